"""The condensed potential W_B on a snapshot-augmented basis (experimental.condensed_potential)
against the FE model's statically condensed energy W_c, on the tension-field (wrinkling) coarse
membrane (a plain script, not a test).

For a run case (default ``benchmarks/cases/paper-0.5hz-coarse-tf.toml``: paper-membrane-coarse
with ``wrinkling = "tension-field"``, 5 modes about the 0.5 Hz relative equilibrium):

1. training points ``s = r D⁻¹ d`` (``cp.training_points``): ``--train-dirs`` random unit
   directions and ± each bending mode alone, at ``--train-amplitudes`` (in, the largest nodal
   displacement, the ``initial.bending_amplitude`` convention); W_c there (continuation along
   each ray), the minimisers' POD;
2. held-out test points: ``--test-dirs`` other random directions at ``--test-amplitudes``;
   W_c, W_red and the run's own reduced potential (formulation Q, ``½ sᵀΛs`` less the work of
   the reference state's force, as ``runs.deformation_check``) there;
3. for bases B = [G⊥, first p POD vectors], p in ``--pod``: W_B/W_c at every test point (and at
   the training points), and the cost of one energy + gradient evaluation (warm start from a
   point 0.1 % away on the same ray, and cold).

Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_condensed_potential
    python -m benchmarks.studies.bench_condensed_potential --train-dirs 2 --test-dirs 2   # quicker
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.common import CASES
from quadmodes.case import load_run_case
from quadmodes.experimental import candidate_potentials as cand
from quadmodes.experimental import condensed_potential as cp
from quadmodes.fe import wrinkling as wr
from quadmodes.fe.membrane import MembraneSet, green_strain
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import manifold_energy as me
from quadmodes.runs import simulate as sim
from quadmodes.runs.deformation_check import deformation_structure

INCH = 0.0254
CASE = CASES / "paper-0.5hz-coarse-tf.toml"


def floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",")]


def reduced_q(ctx, system, s) -> float:
    """The run's reduced potential at s (J) less the work of f(x_ref) (deformation_check)."""
    y = np.zeros(7 + 2 * system.n_modes)
    y[0] = 1.0
    y[7 : 7 + system.n_modes] = s
    work = float(ctx.f0 @ me.manifold_displacement(ctx, s))
    return float(dyn.potential_energy(system, y)) - work


def not_taut(structure, x) -> float:
    """Fraction of membrane elements wrinkled or slack at ``x`` ``(n, 3)``."""
    count, total = 0, 0
    for e in structure.elements:
        if isinstance(e, MembraneSet):
            _, strain = green_strain(e.gradients, x[e.conn])
            e1, e2, _, _ = wr.principal_strains(strain)
            wrinkled, slack = wr.states(e1, e2, e.poisson_ratio)
            count, total = count + int(np.sum(wrinkled | slack)), total + len(e1)
    return count / max(total, 1)


def condensed(ctx, points, label):
    """W_c results at ``points`` (k, N), with a progress line per point."""
    t0 = time.perf_counter()

    def step(i, r):
        print(f"  {label} {i + 1}/{len(points)}: W_c = {r.value:.6g} J, converged {r.converged}, "
              f"{r.iterations} it, {time.perf_counter() - t0:.0f} s", flush=True)  # fmt: skip

    return cp.condensed_snapshots(ctx, points, step)


def rays(points) -> list[bool]:
    """True where a point starts a new ray (the warm start is dropped there)."""
    out = [True]
    for a, b in zip(points[:-1], points[1:], strict=True):
        out.append(not cp._same_ray(a, b))
    return out


def w_b(pot, points) -> tuple[np.ndarray, np.ndarray]:
    """W_B (J) and Newton iterations at ``points`` (k, N), the warm start kept along rays."""
    vals, its = np.zeros(len(points)), np.zeros(len(points), int)
    for j, (s, new) in enumerate(zip(points, rays(points), strict=True)):
        if new:
            pot.clear()
        m = pot.minimum(s)
        vals[j], its[j] = m.value if m.converged else np.nan, m.iterations
    return vals, its


def evaluation_cost(pot, s, repeats: int = 5) -> tuple[float, float, float]:
    """(warm s, cold s, warm iterations) of one energy + gradient at ``s``: warm from the
    minimiser at 0.999 s."""
    warm, cold, its = [], [], []
    for _ in range(repeats):
        pot.clear()
        pot.minimum(0.999 * s)
        t0 = time.perf_counter()
        pot.energy(s), pot.gradient(s)
        warm.append(time.perf_counter() - t0)
        its.append(pot.minimum(s).iterations)
        pot.clear()
        t0 = time.perf_counter()
        pot.energy(s), pot.gradient(s)
        cold.append(time.perf_counter() - t0)
    return float(np.median(warm)), float(np.median(cold)), float(np.median(its))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default=str(CASE))
    ap.add_argument("--train-dirs", type=int, default=4)
    ap.add_argument("--train-amplitudes", default="0.25,0.5,0.75,1.0", help="in")
    ap.add_argument("--test-dirs", type=int, default=4)
    ap.add_argument("--test-amplitudes", default="0.25,0.5,0.75,1.0", help="in")
    ap.add_argument("--pod", default="0,1,2,4,6,8,12,16,24,32,all")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    setup = sim.prepare(load_run_case(args.case))
    model, system = setup.model, setup.system
    structure = deformation_structure(setup)
    ctx = me.energy_context(structure, model.X, model)
    print(f"{args.case}: N = {model.n_modes} ({', '.join(model.labels)}), "
          f"{structure.n} nodes, G⊥ {ctx.g_perp.shape[1]} vectors")  # fmt: skip

    train = cp.training_points(model, INCH * np.array(floats(args.train_amplitudes)),
                               args.train_dirs, seed=args.seed)  # fmt: skip
    test = cp.training_points(model, INCH * np.array(floats(args.test_amplitudes)),
                              args.test_dirs, seed=args.seed + 1000, bending=False)  # fmt: skip
    t0 = time.perf_counter()
    snaps = condensed(ctx, train, "train")
    t_train = time.perf_counter() - t0
    ref = condensed(ctx, test, "test")
    ys = np.array([r.unknowns for r in snaps if r.converged])
    wc_train = np.array([r.value if r.converged else np.nan for r in snaps])
    wc = np.array([r.value if r.converged else np.nan for r in ref])
    print(f"W_c: {len(train)} training points in {t_train:.0f} s "
          f"({t_train / len(train):.1f} s each), {np.sum(np.isnan(wc))} test points not converged")  # fmt: skip

    bend = [j for j, s in enumerate(train) if np.count_nonzero(s) == 1]
    print("\ntraining points in a bending mode alone (the runs' initial deformations):")
    print(f"{'amp in':>7} {'mode':>4} {'W_c J':>11} {'W_red/W_c':>10} {'Q/W_c':>8}")
    for j in bend:
        s = train[j]
        k = int(np.flatnonzero(s)[0])
        sign = "-" if s[k] < 0 else "+"
        amp = abs(s[k]) * cp.modal_scale(model)[k] / INCH
        wr_j = cand.condensed_quadratic_mode_energy(ctx, s).value
        print(f"{amp:7.3f} {sign}{k:3d} {wc_train[j]:11.5g} {wr_j / wc_train[j]:10.4f} "
              f"{reduced_q(ctx, system, s) / wc_train[j]:8.4f}")  # fmt: skip

    amp_test = np.linalg.norm(test * cp.modal_scale(model), axis=1) / INCH
    x_c = [model.X + (me.manifold_displacement(ctx, s) + r.unknowns).reshape(-1, 3)
           for s, r in zip(test, ref, strict=True)]  # fmt: skip
    wred = np.array([cand.condensed_quadratic_mode_energy(ctx, s).value for s in test])
    q = np.array([reduced_q(ctx, system, s) for s in test])
    print("\nheld-out test points (W_c minimiser's share of membrane elements not taut):")
    print(f"{'amp in':>7} {'not taut':>9} {'W_c J':>11} {'W_red/W_c':>10} {'Q/W_c':>8}")
    for j in range(len(test)):
        print(f"{amp_test[j]:7.3f} {not_taut(structure, x_c[j]):9.3f} {wc[j]:11.5g} "
              f"{wred[j] / wc[j]:10.4f} {q[j] / wc[j]:8.4f}")  # fmt: skip

    _, lam, _ = cp.pod_basis(ctx, ys, tol=0.0)
    print("\nPOD eigenvalues (kg m²), relative:", np.array2string(lam[:12] / lam[0], precision=2))
    n_max = int(np.sum(lam > 1e-12 * lam[0]))
    print(f"\n{'POD p':>5} {'q':>4} {'test W_B/W_c: median':>21} {'max':>8} {'train max':>10} "
          f"{'Newton it':>9} {'E+grad warm ms':>14}")  # fmt: skip
    needed, results = None, {}
    for tag in args.pod.split(","):
        p = n_max if tag == "all" else min(int(tag), n_max)
        if p in results:
            continue
        b, _, _ = cp.pod_basis(ctx, ys, tol=0.0, max_vectors=p)
        pot = cp.CondensedPotential(ctx, b)
        wb, its = w_b(pot, test)
        wb_train, _ = w_b(pot, train)
        err = wb / wc - 1.0
        results[p] = pot
        warm = evaluation_cost(pot, test[int(np.argmax(amp_test))], repeats=3)[0]
        print(f"{p:5d} {b.shape[1]:4d} {1 + np.nanmedian(err):21.4f} {1 + np.nanmax(np.abs(err)):8.4f} "
              f"{np.nanmax(wb_train / wc_train):10.4f} {np.median(its):9.0f} {1e3 * warm:14.1f}")  # fmt: skip
        if needed is None and np.nanmax(np.abs(err)) <= 0.02:
            needed = (p, b.shape[1])
    if needed:
        print(f"\nW_B within 2 % of W_c at every held-out point from p = {needed[0]} POD vectors "
              f"(B: {needed[1]} columns)")  # fmt: skip
    else:
        print("\nno basis tried puts W_B within 2 % of W_c at every held-out point")

    pot = results[max(results)]
    lam_model = np.asarray(model.Lam, float)
    h0 = pot.hessian0
    print(f"\nH0 (W_B's Hessian at 0) against the model's Λ: |H0 − Λ| / |Λ| = "
          f"{np.linalg.norm(h0 - lam_model) / np.linalg.norm(lam_model):.2e}; "
          f"sqrt(diag H0)/2π = {np.array2string(np.sqrt(np.diag(h0)) / 2 / np.pi, precision=3)} Hz, "
          f"sqrt(diag Λ)/2π = {np.array2string(np.sqrt(np.diag(lam_model)) / 2 / np.pi, precision=3)} Hz")  # fmt: skip
    warm_wb, _ = w_b(pot, test)
    cold_wb = np.array([cold_energy(pot, s) for s in test])
    print(f"\nlargest basis: W_B from a cold start (η = 0) / along the ray "
          f"- 1: max {np.nanmax(np.abs(cold_wb / warm_wb - 1)):.2e}")  # fmt: skip
    worst = int(np.nanargmax(amp_test))
    warm, cold, its = evaluation_cost(pot, test[worst])
    print(f"\none energy + gradient at {amp_test[worst]:.2f} in, q = {pot.basis.shape[1]}: "
          f"warm {1e3 * warm:.1f} ms ({its:.0f} Newton it), cold {1e3 * cold:.1f} ms; "
          f"Hessian adds {1e3 * hessian_cost(pot, test[worst]):.1f} ms")  # fmt: skip


def cold_energy(pot, s) -> float:
    pot.clear()
    m = pot.minimum(s)
    return m.value if m.converged else np.nan


def hessian_cost(pot, s) -> float:
    pot.minimum(s)
    t0 = time.perf_counter()
    pot.hessian(s)
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
