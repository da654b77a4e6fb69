"""Static gate for candidate reduced potentials (issue 9): each candidate against the FE model's
own statically condensed energy W_c along random rays of the modal coordinates (a plain script,
not a test; see docs/potentials.md).

For a run case (default ``paper-41hz-coarse``) and its model with ``--modes`` modes:

1. the largest modal amplitude of the run: a Q4 run of the case over ``--duration`` (compiled
   kernel when numba is installed), ``r41 = max_t |D s(t)|`` with ``D = diag(largest nodal
   displacement of each mode per unit s)`` (m); the 2 in bending case has ``r = 2 in`` in the
   same units (``runs.initial``: s_bend = amplitude / D_bend);
2. ``--rays`` random unit directions ``d`` (uniform on the sphere) of the scaled coordinates,
   ``s = r D⁻¹ d``, at ``--amplitudes`` amplitudes ``r = j/n · r_max``, ``r_max = max(2 r41,
   --bending)``, in increasing order (continuation: W_c starts from the best of the
   quadratic-manifold point, the W_red point, the previous minimiser and its linear
   extrapolation);
3. Q, Q4, QE, W_red (:mod:`quadmodes.experimental.candidate_potentials`) and W_c at every point;
   relative errors ``(V − W_c)/W_c`` by amplitude band (0, r41], (r41, 2 r41], (2 r41, r_max];
   the Q4 barrier (``rom.dynamics.potential_barrier``, and per sampled ray the first maximum of
   V_Q4 along it) in the same units; negative values; the ordering W_c ≤ W_red ≤ QE.

Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_potentials --rays 100 \\
        --markdown /tmp/gate.md --figure docs/figures/potentials-gate-coarse-N5.png
    python -m benchmarks.studies.bench_potentials --rays 1 --amplitudes 12        # time one ray
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.common import compressed_fraction, modal_scale, one_ray, run_case_with_modes
from quadmodes.experimental import candidate_potentials as cand
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import manifold_energy as me
from quadmodes.runs import simulate as sim
from quadmodes.structure import pipeline

NAMES = ("Q", "Q4", "QE", "W_red")
INCH = 0.0254


def run_amplitude(run, model, scale) -> tuple[float, float]:
    """``(max_t |D s(t)|, wall s)`` of the run (its own model)."""
    t0 = time.perf_counter()
    result = sim.simulate(run, model)
    s = result.solution.y[:, 7 : 7 + model.n_modes]
    return float(np.max(np.linalg.norm(s * scale, axis=1))), time.perf_counter() - t0


def ray_barriers(model, scale, dirs) -> np.ndarray:
    """Per direction d (k, N) the amplitude r (m) of the first maximum of V_Q4 along
    ``s = r D⁻¹ d`` (inf if V_Q4 rises for all r): smaller positive root of
    ``4 c4 r² + 3 c3 r + 2 c2``."""
    e = dirs / scale
    c2 = 0.5 * np.einsum("km,mn,kn->k", e, model.Lam, e)
    c3 = np.einsum("mnp,km,kn,kp->k", model.V3, e, e, e)
    c4 = np.einsum("mnpq,km,kn,kp,kq->k", model.V4, e, e, e, e)
    roots = np.full(len(e), np.inf)
    for i in range(len(e)):
        rr = np.roots([4 * c4[i], 3 * c3[i], 2 * c2[i]])
        rr = rr[(np.abs(rr.imag) < 1e-12 * np.abs(rr).max()) & (rr.real > 0)].real
        if rr.size:
            roots[i] = rr.min()
    return roots


def band_table(radii, energies, r41, r_max) -> list[tuple[str, list[str]]]:
    """Rows (band, [median / 90th percentile / max of |rel. error| per candidate]) of
    ``energies`` (rays, amplitudes, 5)."""
    edges = [(0.0, r41), (r41, 2 * r41), (2 * r41, r_max * (1 + 1e-12))]
    wc = energies[..., 4]
    rows = []
    for lo, hi in edges:
        sel = (radii > lo) & (radii <= hi)
        if not sel.any():
            continue
        cells = []
        for c in range(4):
            err = np.abs(energies[:, sel, c] - wc[:, sel]) / np.abs(wc[:, sel])
            cells.append(
                f"{100 * np.median(err):.3g} / {100 * np.percentile(err, 90):.3g} / "
                f"{100 * err.max():.3g} %"
            )
        rows.append((f"({1e3 * lo:.1f}, {1e3 * min(hi, r_max):.1f}] mm", cells))
    return rows


def figure(path, radii, energies, r41, r_b):
    """Median and max relative error vs amplitude for each candidate (PNG)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    wc = energies[..., 4]
    for c, name in enumerate(NAMES):
        err = np.abs(energies[..., c] - wc) / np.abs(wc)
        (line,) = ax.semilogy(1e3 * radii, np.median(err, 0), label=f"{name} median")
        ax.semilogy(1e3 * radii, err.max(0), ls="--", color=line.get_color())
    for x, lab in [(r41, "41 Hz max"), (2 * r41, "2× 41 Hz"), (r_b, "Q4 barrier (min)")]:
        if np.isfinite(x) and x <= 1.05 * radii.max():
            ax.axvline(1e3 * x, color="0.5", lw=0.8)
            ax.text(1e3 * x, ax.get_ylim()[1], lab, rotation=90, va="top", fontsize=7)
    ax.set_xlabel("amplitude r = |D s| (mm, nominal largest nodal displacement)")
    ax.set_ylabel("|V − W_c| / W_c (median solid, max dashed)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def projected_chart(structure, model):
    """``model`` with ``g⊥ = g − Φ ΦᵀM g`` (the M-projection of x − x0 on Φ is then s) and the
    Q4 tensors of :func:`quadmodes.rom.reduced.manifold_potential_tensors` for g⊥."""
    from dataclasses import replace

    from quadmodes.fe.model import mass_matrix
    from quadmodes.rom.reduced import manifold_potential_tensors

    n = model.n_modes
    phi = model.Phi.reshape(n, -1)
    g = model.G.reshape(n * n, -1)
    a = (mass_matrix(structure) @ g.T).T @ phi.T  # (N², N): ΦᵀMg
    g_perp = (g - a @ phi).reshape(model.G.shape)
    v3, v4 = manifold_potential_tensors(structure, model.X, model.Phi, g_perp)
    return replace(model, G=g_perp, V3=v3, V4=v4)


def named_rays(ctx, model, q4, scale, radii, structure) -> None:
    """Energies along ``±e_k`` (each mode alone, both signs) at every 3rd amplitude, with the
    compressed membrane fraction at the quadratic-manifold point and at the W_c minimiser."""
    print("| ray | r (mm) | Q | Q4 | QE | W_red | W_c | compressed: QM / W_c |")
    print("|---|---|---|---|---|---|---|---|")
    _, s_b = dyn.potential_barrier(q4)
    rays = [(f"{'+-'[sign < 0]}{model.labels[k]} ({k})", sign * np.eye(model.n_modes)[k])
            for k in range(model.n_modes) for sign in (1.0, -1.0)]
    if np.any(s_b):
        r_b = float(np.linalg.norm(s_b * scale))
        rays.append((f"Q4 barrier direction (r_b = {1e3 * r_b:.2f} mm)", s_b * scale / r_b))
    for name, d in rays:
        ys = []
        e, _ = one_ray(ctx, model, q4, scale, d, radii, ys)
        for j in range(2, len(radii), 3):
            u = me.manifold_displacement(ctx, radii[j] * d / scale)
            y = ys[j]
            cf = [compressed_fraction(structure, ctx.x0 + v.reshape(-1, 3)) for v in (u, u + y)]
            cells = " | ".join(f"{v:.4g}" for v in e[j])
            print(f"| {name} | {1e3 * radii[j]:.1f} | {cells} "
                  f"| {cf[0]:.2f} / {cf[1]:.2f} |", flush=True)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", default="paper-41hz-coarse", help="run case")
    p.add_argument("--modes", type=int, default=5)
    p.add_argument("--duration", default="120 s", help="duration of the Q4 run for r41")
    p.add_argument("--r41", type=float, help="skip the run: largest amplitude |D s| (m)")
    p.add_argument("--bending", type=float, default=2 * INCH, help="bending amplitude (m)")
    p.add_argument("--rays", type=int, default=100)
    p.add_argument("--amplitudes", type=int, default=12)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--markdown", help="write the table to this file")
    p.add_argument("--figure", help="write the error figure (PNG)")
    p.add_argument("--npz", help="save the raw energies")
    p.add_argument("--from-npz", help="no computation: report the energies saved by --npz")
    p.add_argument(
        "--chart", choices=("manifold", "projected"), default="manifold",
        help="projected: quadratic modes with their retained-mode part removed (g⊥ = g − Φ ΦᵀMg, "
        "so s is the M-projection) and Q4 recomputed for them (a what-if, not the project's model)",
    )
    p.add_argument(
        "--named", action="store_true",
        help="instead: the rays ±(each mode) with the wrinkled (compressed) membrane fraction",
    )
    return p.parse_args()


def main() -> None:
    args = parse_args()
    run = run_case_with_modes(args.case, args.modes, args.duration)
    model_case = run.model_case()
    model = reduced_model_for(model_case, args.modes)
    scale = modal_scale(model)
    if args.from_npz:
        z = np.load(args.from_npz)
        finish(args, model, float(z["r41"]), float(z["radii"][-1]), z["radii"], z["energies"],
               z["info"], float("nan"), cand.quartic_system(model), scale, z["dirs"], final=True)
        return
    if args.r41 is None:
        r41, wall = run_amplitude(run, model, scale)
        print(f"Q4 run {args.case} N={args.modes} over {args.duration}: r41 = {r41:.5g} m "
              f"({wall:.1f} s)")
    else:
        r41 = args.r41
    r_max = max(2.0 * r41, args.bending)
    radii = r_max * np.arange(1, args.amplitudes + 1) / args.amplitudes
    structure = pipeline.with_gas_law(
        model_case, pipeline.structure_for_case(model_case), model.X
    )
    if args.chart == "projected":
        model = projected_chart(structure, model)
    ctx = me.energy_context(structure, model.X, model)
    q4 = cand.quartic_system(model)
    if args.named:
        named_rays(ctx, model, q4, scale, radii, structure)
        return
    rng = np.random.default_rng(args.seed)
    dirs = rng.standard_normal((args.rays, args.modes))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    energies = np.zeros((args.rays, len(radii), 5))
    info = np.zeros((args.rays, len(radii), 2))
    t0 = time.perf_counter()
    for i, d in enumerate(dirs):
        energies[i], info[i] = one_ray(ctx, model, q4, scale, d, radii)
        if i == 0 or (i + 1) % 10 == 0 or i + 1 == args.rays:
            wall = time.perf_counter() - t0
            print(f"ray {i + 1}/{args.rays}: {wall:.1f} s", flush=True)
            finish(args, model, r41, r_max, radii, energies[: i + 1], info[: i + 1], wall,
                   q4, scale, dirs[: i + 1], final=i + 1 == args.rays)


def finish(args, model, r41, r_max, radii, energies, info, wall, q4, scale, dirs, final):
    """Report (printed at the end; files rewritten after every 10 rays, so an interrupted run
    leaves the rays done so far), raw arrays and figure."""
    v_b, s_b = dyn.potential_barrier(q4)
    r_b_rays = ray_barriers(model, scale, dirs)
    report(args, model, r41, r_max, radii, energies, info, wall, v_b, s_b, scale, r_b_rays,
           final)
    if args.npz and not args.from_npz:
        np.savez(args.npz, radii=radii, energies=energies, info=info, dirs=dirs, r41=r41)
    if args.figure:
        figure(args.figure, radii, energies, r41, float(np.min(r_b_rays)))


def report(args, model, r41, r_max, radii, energies, info, wall, v_b, s_b, scale, r_b_rays,
           final=True):
    """Print (and write as markdown) the gate table and the side figures."""
    wc = energies[..., 4]
    tol = 1e-9 * np.abs(wc) + 1e-12
    lines = [
        f"case {args.case}, N = {args.modes} ({', '.join(model.labels)}), {len(energies)} rays × "
        f"{len(radii)} amplitudes r = {1e3 * radii[0]:.2f} … {1e3 * r_max:.2f} mm, seed "
        f"{args.seed}; r41 = {1e3 * r41:.2f} mm; wall {wall:.0f} s "
        f"({wall / len(energies):.1f} s per ray)",
        "",
        "|V − W_c|/W_c, median / 90th percentile / max over the samples of each band:",
        "",
        "| band of r | " + " | ".join(NAMES) + " |",
        "|---|" + "---|" * len(NAMES),
    ]
    for band, cells in band_table(radii, energies, r41, r_max):
        lines.append(f"| {band} | " + " | ".join(cells) + " |")
    neg = {n: int(np.sum(energies[..., c] < 0)) for c, n in enumerate(NAMES + ("W_c",))}
    r_b = float(np.linalg.norm(s_b * scale)) if np.isfinite(v_b) else np.inf
    peak_pe = float(np.max(wc[:, radii <= r41 * (1 + 1e-12)], initial=0.0))
    lines += [
        "",
        f"- samples below zero: {neg}",
        f"- ordering violations W_c > W_red + tol: {int(np.sum(wc > energies[..., 3] + tol))}, "
        f"W_red > QE + tol: {int(np.sum(energies[..., 3] > energies[..., 2] + tol))}",
        f"- W_c / W_red Newton not converged: {int(np.sum(info[..., 0] == 0))} of {info[..., 0].size}"
        f" points; W_c iterations median {np.median(info[..., 1]):.0f}, max {info[..., 1].max():.0f}",
        f"- Q4 barrier (potential_barrier, 4000 directions): V_b = {v_b:.4g} J at r = "
        f"{1e3 * r_b:.2f} mm; over the sampled rays the first maximum of V_Q4 lies at r ≥ "
        f"{1e3 * np.min(r_b_rays):.2f} mm (median {1e3 * np.median(r_b_rays):.1f} mm; "
        f"{int(np.sum(r_b_rays <= r_max))} of {len(r_b_rays)} rays within r_max)",
        f"- W_c at the 41 Hz amplitude band's top sample: max {peak_pe:.4g} J",
    ]
    text = "\n".join(lines)
    if final:
        print(text)
    if args.markdown:
        from quadmodes.io.atomic import write_text

        write_text(args.markdown, text + "\n")


if __name__ == "__main__":
    main()
