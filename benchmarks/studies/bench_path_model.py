"""Which reduced model stays valid along the secular path of paper-41hz-coarse (issue 29 item 2)?

Candidates are scored two ways at points of a saved reduced path (a ``results.nc`` of
``benchmarks/cases/path-41hz-coarse.toml``):

* **static**: at the sample of largest ‖s‖ in the 2 s after each cone mark, the candidate's
  potential against the FE model's statically condensed energy W_c
  (:func:`quadmodes.rom.manifold_energy.condensed_energy_along_ray`, the reference of the path's
  amplitude check, docs/path-validity.md): Q (½sᵀΛs), Q3 (Q + V3·sss), Q4 (+ V4·ssss), and
  "B", the quadratic re-expansion about the window's mean deformation s̄ (the Taylor polynomial
  of degree 2 of Q4 ≈ W_c about s̄: what a model re-expanded about the mean deformed state
  carries, up to its own basis);
* **dynamic**: the candidate integrated from the path's state at the point over the window of a
  stored ``quadmodes compare --at`` (its ``comparison.nc``: the independent full order started
  from the same point), scored as ``compare`` scores (envelope, secular cone growth, dissipated
  power and spin change over the quasi-steady part). A candidate with more modes starts with
  the extra coordinates at rest and its envelope is taken over the first N of them.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_path_model PATH/results.nc \
        --points "12:CMP12/comparison.nc,15:CMP15/comparison.nc,20:CMP20/comparison.nc" \
        --candidates "Q,Q4,Q:20" [--static]

A candidate is ``FORMULATION[:MODES]`` (default the path's modes). Prints one JSON line a row.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np
import xarray as xr

from quadmodes.analysis import compare as cmp
from quadmodes.analysis.path_point import point_on_samples, reduced_run_from
from quadmodes.case import run_case_from_toml
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import manifold_energy as me
from quadmodes.rom import system as rsys
from quadmodes.runs import deformation_check as dc
from quadmodes.runs import secular
from quadmodes.runs import simulate as sim


def path_samples(path: str):
    """(run case, t (n,), y (n, 7+2N), E_d (n,), spin axis (3,)) of a saved path."""
    ds = xr.open_dataset(path)
    run = run_case_from_toml(str(ds.attrs["case_toml"]))
    y = np.concatenate([ds.quaternion.values, ds.omega_body.values,
                        ds.modal_coordinates.values, ds.modal_velocities.values], axis=1)  # fmt: skip
    return run, ds.time.values, y, ds.dissipated_energy.values, np.asarray(ds.attrs["spin_axis_body"])


def quadratic_about(system, s_bar: np.ndarray, s: np.ndarray) -> float:
    """Degree-2 Taylor polynomial of the Q4 potential (J) about ``s_bar`` evaluated at ``s``."""
    def grad(x):
        return (system.F1 + system.Lam @ x + 3 * np.einsum("mnp,n,p->m", system.V3, x, x)
                + 4 * np.einsum("mnpq,n,p,q->m", system.V4, x, x, x))  # fmt: skip
    hess = (system.Lam + 6 * np.einsum("mnp,p->mn", system.V3, s_bar)
            + 12 * np.einsum("mnpq,p,q->mn", system.V4, s_bar, s_bar))  # fmt: skip
    y = np.zeros(system.n_state)
    y[0] = 1.0
    y[7 : 7 + len(s)] = s_bar
    d = s - s_bar
    return float(dyn.potential_energy(system, y) + grad(s_bar) @ d + 0.5 * d @ hess @ d)


def static_rows(path: str, marks, window_s: float = 2.0):
    """Potential errors against W_c at the path's largest amplitude after each cone mark."""
    run, t, y, _, axis = path_samples(path)
    setup = sim.prepare(run, allow_coarse_step=True)
    model, n = setup.model, setup.system.n_modes
    systems = {f: rsys.reduced_system(model, f) for f in ("Q", "Q4")}
    ctx = me.energy_context(dc.deformation_structure(setup), model.X, model)
    from quadmodes.rom.diagnostics import diagnostics
    from quadmodes.rom.solution import Solution

    d = diagnostics(setup.system, Solution(t, y, "midpoint", {}, 0, "ok", np.zeros(len(t))),
                    spin_axis=axis)  # fmt: skip
    cone = np.degrees(d.cone_angle)
    s_all = y[:, 7 : 7 + n]
    amp = np.linalg.norm(s_all, axis=1)
    per = int(round(window_s / (t[1] - t[0])))
    for mark in marks:
        i0 = int(np.argmax(cone >= mark))
        j = i0 + int(np.argmax(amp[i0 : i0 + per]))
        s = s_all[j]
        c = me.condensed_energy_along_ray(ctx, s, None)
        work = float(ctx.f0 @ me.manifold_displacement(ctx, s))
        yq = y[j]
        v = {f: float(dyn.potential_energy(systems[f], yq)) - work for f in systems}
        s4 = systems["Q4"]
        v["Q3"] = v["Q"] + float(np.einsum("mnp,m,n,p->", s4.V3, s, s, s))
        v["B"] = quadratic_about(s4, s_all[i0 : i0 + per].mean(axis=0), s) - work
        rel = {k: (val - c.value) / c.value for k, val in v.items()}
        print(json.dumps({"static": mark, "t_s": float(t[j]), "amplitude": float(amp[j]),
                          "mean_amplitude": float(np.linalg.norm(s_all[i0:i0 + per].mean(0))),
                          "W_c_J": c.value, "converged": bool(c.converged),
                          **{f"error_{k}": r for k, r in rel.items()}}), flush=True)  # fmt: skip



def stored_full(path: str) -> tuple[cmp.Series, dict]:
    """The full-order :class:`~quadmodes.analysis.compare.Series` of a comparison.nc and its
    start attributes."""
    ds = xr.open_dataset(path)
    i = [str(v) for v in ds.model_label.values].index("full")
    g = {k: ds[v].values[i] for k, v in (("amplitude", "modal_amplitude"), ("cone_angle", "cone_angle"),
         ("spin_rate", "spin_rate"), ("H_norm", "angular_momentum_norm"), ("E", "total_energy"),
         ("E_d", "dissipated_energy"))}  # fmt: skip
    return cmp.Series(name="full", t=ds.time.values, wall_s=float("nan"), **g), dict(ds.attrs)


def centrifugal_higher_order(model, mass_scalar) -> tuple[np.ndarray, np.ndarray]:
    """Cubic and quartic terms (V3c (N,N,N), V4c (N,N,N,N), fully symmetric) of the centrifugal
    potential −½Ω² xᵀ M P̂ x at the model's reference spin on the manifold x = X + Φs + Σss g:
    the s³ and s⁴ terms the second-order inertia J̃(s) = J0 + J1 s + J2 ss leaves out."""
    from quadmodes.rom.reduced import symmetrise

    om = float(model.reference_spin)
    e = np.asarray(model.reference_axis, float)
    e = e / np.linalg.norm(e)
    n = model.n_modes

    def proj(v):  # (…, nodes, 3) → M_s ⊗ P̂ applied
        v = v - np.einsum("...a,a,b->...b", v, e, e)
        lead, nodes = v.shape[:-2], v.shape[-2]
        flat = np.moveaxis(v.reshape(-1, nodes, 3), 1, 0).reshape(nodes, -1)
        out = np.asarray(mass_scalar @ flat).reshape(nodes, -1, 3)
        return np.moveaxis(out, 0, 1).reshape(*lead, nodes, 3)

    phi = np.asarray(model.Phi, float)
    g = np.asarray(model.G, float)
    pg = proj(g)  # (N,N,nodes,3)
    v3 = -om**2 * np.einsum("kia,mnia->kmn", phi, pg)
    v4 = -0.5 * om**2 * np.einsum("mnia,pqia->mnpq", g.reshape(n, n, -1, 3), pg)
    return symmetrise(v3), symmetrise(v4)


def reexpanded(model, s_bar: np.ndarray, v3: np.ndarray, v4: np.ndarray):
    """``model`` with its quadratic potential re-expanded about the deformation ``s_bar`` (N,):
    F1, Λ the gradient and Hessian there of F1·s + ½sᵀΛs + V3·sss + V4·ssss, written about
    s = 0 (a constant dropped): candidate B, the mean deformed state in the reference."""
    import dataclasses

    grad = (model.F1 + model.Lam @ s_bar + 3 * np.einsum("mnp,n,p->m", v3, s_bar, s_bar)
            + 4 * np.einsum("mnpq,n,p,q->m", v4, s_bar, s_bar, s_bar))  # fmt: skip
    hess = (model.Lam + 6 * np.einsum("mnp,p->mn", v3, s_bar)
            + 12 * np.einsum("mnpq,p,q->mn", v4, s_bar, s_bar))  # fmt: skip
    hess = 0.5 * (hess + hess.T)
    return dataclasses.replace(model, F1=grad - hess @ s_bar, Lam=hess)


def chart_fit(model, x: np.ndarray, w: np.ndarray, s: np.ndarray, iterations: int = 8) -> np.ndarray:
    """Modal coordinates s (N,) whose manifold field X + Φs + Σss g is nearest ``x`` (n,3) in
    the lumped mass norm (weights ``w`` (n,) kg), Gauss–Newton from ``s``."""
    phi, g = np.asarray(model.Phi), np.asarray(model.G)
    for _ in range(iterations):
        r = x - (model.X + np.einsum("k,kia->ia", s, phi) + np.einsum("m,n,mnia->ia", s, s, g))
        jac = phi + 2 * np.einsum("n,mnia->mia", s, g)
        a = np.einsum("mia,i,nia->mn", jac, w, jac)
        s = s + np.linalg.solve(a, np.einsum("mia,i,ia->m", jac, w, r))
    return s


def in_chart_of(model0, model1, s1: np.ndarray) -> np.ndarray:
    """Samples s1 (n, N1) of ``model1`` in the modal coordinates of ``model0`` (n, N0)."""
    w = np.asarray(model0.weights, float)
    out = np.zeros((len(s1), model0.n_modes))
    s = np.zeros(model0.n_modes)
    for i, si in enumerate(s1):
        x = model1.X + np.einsum("k,kia->ia", si, model1.Phi) + np.einsum("m,n,mnia->ia", si, si, model1.G)
        s = out[i] = chart_fit(model0, x, w, s, 3 if i else 8)
    return out


def mapped_state(sys0, model0, sys1, model1, y: np.ndarray) -> np.ndarray:
    """State of ``model1`` matching ``y`` of ``model0`` (candidate A): s1 with the displacement
    field X1 + Φ1 s1 + Σ s1 s1 g1 nearest X0 + Φ0 s + Σ ss g0 in the mass norm (Gauss–Newton),
    ṡ1 the least-squares fit of the deformation velocity, ω1 such that the body-frame angular
    momentum is the same (so H is exact), the attitude kept."""
    from quadmodes.fe.model import expand_scalar_matrix  # noqa: F401  (documentation only)

    n0, n1 = model0.n_modes, model1.n_modes
    s, sd = y[7 : 7 + n0], y[7 + n0 :]
    w = np.asarray(model0.weights, float)  # lumped mass per node (kg): M ≈ diag(w)
    x = model0.X + np.einsum("k,kia->ia", s, model0.Phi) + np.einsum("m,n,mnia->ia", s, s, model0.G)
    v = np.einsum("k,kia->ia", sd, model0.Phi) + 2 * np.einsum("m,n,mnia->ia", s, sd, model0.G)
    phi1, g1 = np.asarray(model1.Phi), np.asarray(model1.G)
    s1 = chart_fit(model1, x, w, np.zeros(n1))
    jac = phi1 + 2 * np.einsum("n,mnia->mia", s1, g1)
    a = np.einsum("mia,i,nia->mn", jac, w, jac)
    sd1 = np.linalg.solve(a, np.einsum("mia,i,ia->m", jac, w, v))
    h = dyn.body_momentum(sys0, y)
    y1 = np.concatenate([y[:7], s1, sd1])
    jt = dyn.inertia_tensor(sys1, s1, "rot")
    a_rows = dyn.coupling_rows(sys1, s1, "rot")
    y1[4:7] = np.linalg.solve(jt, h - sd1 @ a_rows)
    return y1


def candidate_run(run, candidate: str, y_start: np.ndarray, window: float):
    """RunResult of ``candidate`` (``FORMULATION[:MODES]``) from the path state ``y_start``."""
    from quadmodes.models.build import reduced_model_for

    form, _, modes = candidate.partition(":")
    n0 = (len(y_start) - 7) // 2
    if form == "A":  # the model about another spin (Hz), the state mapped onto it
        return spin_family_run(run, float(modes), y_start, window), n0
    n = int(modes) if modes else n0
    sub = cmp.window_run(run, window, {"Q4c": "Q4", "B": "Q", "Bc": "Q"}.get(form, form))
    sub = sub.model_copy(update={"reduced": sub.reduced.model_copy(update={"modes": n})})
    model = reduced_model_for(sub.model_case(), n, None, spin=sub.reference_spin,
                              axis=sub.reference_axis)  # fmt: skip
    if form == "Q4c":  # Q4 with the centrifugal cubic/quartic terms at the reference spin
        import dataclasses

        from quadmodes.structure import pipeline

        structure = pipeline.structure_for_case(sub.model_case())
        v3c, v4c = centrifugal_higher_order(model, structure.mass_scalar)
        model = dataclasses.replace(model, V3=model.V3 + v3c, V4=model.V4 + v4c)
        sub = cmp.window_run(sub, window, "Q4")
    if form in ("B", "Bc"):  # re-expanded about the mean deformation over the first second
        q = reduced_run_from(cmp.window_run(sub, 1.0, "Q"), model, y_start)
        s_q = rsys.split_state(q.system, q.solution.y)[2]
        v3, v4 = model.V3, model.V4
        if form == "Bc":
            from quadmodes.structure import pipeline

            c3, c4 = centrifugal_higher_order(model, pipeline.structure_for_case(sub.model_case()).mass_scalar)
            v3, v4 = v3 + c3, v4 + c4
        model = reexpanded(model, s_q.mean(axis=0), v3, v4)
        sub = cmp.window_run(sub, window, "Q")
    y = np.zeros(7 + 2 * n)
    y[:7] = y_start[:7]
    m = min(n, n0)
    y[7 : 7 + m] = y_start[7 : 7 + m]
    y[7 + n : 7 + n + m] = y_start[7 + n0 : 7 + n0 + m]
    return reduced_run_from(sub, model, y), n0


def spin_family_run(run, spin_hz: float, y_start: np.ndarray, window: float):
    """Candidate A: the model of the run's case about ``spin_hz``, from ``y_start`` mapped."""
    from quadmodes.models.build import reduced_model_for

    n = (len(y_start) - 7) // 2
    sub = cmp.window_run(run, window, "Q")
    model0 = reduced_model_for(sub.model_case(), n, None, spin=sub.reference_spin,
                               axis=sub.reference_axis)  # fmt: skip
    init = sub.initial.model_copy(update={"spin_rate": 2 * math.pi * spin_hz})
    sub = sub.model_copy(update={"initial": init})
    model1 = reduced_model_for(sub.model_case(), n, None, spin=sub.reference_spin,
                               axis=sub.reference_axis)  # fmt: skip
    sys0, sys1 = rsys.reduced_system(model0, "Q"), rsys.reduced_system(model1, "Q")
    y1 = mapped_state(sys0, model0, sys1, model1, np.asarray(y_start, float))
    h0, h1 = dyn.momentum_inertial(sys0, y_start), dyn.momentum_inertial(sys1, y1)
    e0 = float(dyn.kinetic_energy(sys0, y_start) + dyn.potential_energy(sys0, y_start))
    e1 = float(dyn.kinetic_energy(sys1, y1) + dyn.potential_energy(sys1, y1))
    print(json.dumps({"switch_to_hz": spin_hz, "H_jump": float(np.linalg.norm(h1 - h0) / np.linalg.norm(h0)),
                      "energy_jump_J": e1 - e0, "energy": e0}), flush=True)  # fmt: skip
    result = reduced_run_from(sub, model1, y1)
    s0 = in_chart_of(model0, model1, rsys.split_state(result.system, result.solution.y)[2])
    return result, s0


def dynamic_rows(path: str, points: dict[float, str], candidates, case: str):
    path_run, t, y, e_d, axis = path_samples(path)
    setup = sim.prepare(path_run, allow_coarse_step=True)
    # the comparison's own run case (its sampling, every step's 2 × dt): the path case samples
    # every 50 ms, too coarse for the envelope
    from quadmodes.case.run_loading import load_run_case

    run = load_run_case(case)
    run = run.model_copy(update={"reduced": run.reduced.model_copy(update={"modes": setup.system.n_modes})})
    for mark, nc in points.items():
        full, attrs = stored_full(nc)
        point = point_on_samples(setup.system, run.integration, f"cone {mark:g} deg", t, y, e_d,
                                 axis, path)  # fmt: skip
        assert abs(point.time - float(attrs["start_time"])) < 1e-9, (point.time, attrs["start_time"])
        window = float(full.t[-1])
        for cand in candidates:
            start = time.perf_counter()
            result, n0 = candidate_run(run, cand, point.y, window)
            chart = None
            if isinstance(result, tuple):  # candidate A: its samples in the path model's chart
                result, chart = result
            ser = cmp.series_from_run(cand, result)
            if chart is not None:
                ser = cmp.Series(**{**ser.__dict__, "amplitude": np.linalg.norm(chart, axis=1)})
            elif result.system.n_modes != n0:  # envelope over the path model's modes
                s = rsys.split_state(result.system, result.solution.y)[2][:, :n0]
                ser = cmp.Series(**{**ser.__dict__, "amplitude": np.linalg.norm(s, axis=1)})
            model = result.model
            f_low = float(np.min(model.frequencies_hz[:n0]))
            tau = secular.decay_time(model.frequencies_hz[:n0], model.damping_ratio[:n0])
            row = cmp.errors(ser, full, 1.0 / f_low)
            te, ef = cmp.envelope(full, 1.0 / f_low)
            tr, er = cmp.envelope(ser, 1.0 / f_low)
            late = te >= window / 2  # past the start-up of the window (the transient of the start)
            row["envelope_error_late"] = float(np.max(np.abs(np.interp(te[late], tr, er) - ef[late])) / np.max(ef))
            row["envelope_ratio_late"] = float(np.mean(np.interp(te[late], tr, er) / ef[late]))
            scores = secular.score(full, {cand: ser}, secular.quasi_steady_interval(window, tau))
            row.update(scores.row(cand))
            h = ser.H_norm
            e_tot = ser.E + ser.E_d
            print(json.dumps({"point": mark, "candidate": cand, "wall_s": time.perf_counter() - start,
                              "integration_wall_s": ser.wall_s,
                              "H_drift": float(np.max(np.abs(h - h[0])) / h[0]),
                              "energy_balance": float(np.max(np.abs(e_tot - e_tot[0])) / abs(e_tot[0])),
                              **{k: row.get(k) for k in ("envelope_error", "envelope_error_late", "envelope_ratio_late", "cone_growth_ratio",
                                 "dissipated_power_ratio", "spin_rate_change_ratio")}},
                             default=float), flush=True)  # fmt: skip


#: The one-model path's spins (Hz) at its cone marks (the `compare --at` table of
#: docs/path-validity.md), for rows printed without ``path_spin_hz``.
POINT_SPIN_HZ = {12.0: 40.327, 15.0: 39.824, 20.0: 38.744}


def figure(rows_files: list[str], out: str) -> None:
    """Cone-growth ratio (reduced / full order) by candidate against the cone angle, and that of
    the members (A) against their spin departure from the path's, from printed JSON rows."""
    import matplotlib.pyplot as plt

    rows = [json.loads(line) for f in rows_files for line in open(f) if '"point"' in line]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    names = {"Q": "Q, one model (today)", "Q4": "Q4", "Q4c": "Q4 + centrifugal s³, s⁴",
             "B": "B: re-expanded about s̄", "Bc": "Bc", "Q:20": "Q, 20 modes"}  # fmt: skip
    for cand, label in names.items():
        pts = sorted((r["point"], r["cone_growth_ratio"]) for r in rows if r["candidate"] == cand)
        if pts:
            ax.plot(*zip(*pts, strict=True), "o-", label=label)
    at_spin = []
    for r in rows:
        if not r["candidate"].startswith("A:") and r["candidate"] != "Q":
            continue  # (Q: the member about 41 Hz)
        path_hz = r.get("path_spin_hz", POINT_SPIN_HZ[r["point"]])
        dep = 100 * ((41.0 if r["candidate"] == "Q" else float(r["candidate"][2:])) / path_hz - 1.0)
        bx.plot(dep, r["cone_growth_ratio"], "o", color={12.0: "C0", 15.0: "C1", 20.0: "C2"}[r["point"]])
        if abs(dep) < 0.05:
            at_spin.append((r["point"], r["cone_growth_ratio"]))
    ax.plot(*zip(*sorted(at_spin), strict=True), "k*-", ms=10, label="A: member about the point's spin")
    ax.axhspan(0.95, 1.05, color="0.9", zorder=0)
    ax.set(xlabel="cone angle at the point (deg)", ylabel="cone growth, reduced / full order")
    ax.legend(fontsize=7)
    for p, c in ((12.0, "C0"), (15.0, "C1"), (20.0, "C2")):
        bx.plot([], [], "o", color=c, label=f"{p:g}°")
    bx.axhspan(0.95, 1.05, color="0.9", zorder=0)
    bx.set(xlabel="member's spin above the path's (%)", ylabel="cone growth, reduced / full order")
    bx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="?", default="")
    ap.add_argument("--points", default="")
    ap.add_argument("--candidates", default="Q,Q4")
    ap.add_argument("--case", default="paper-41hz-coarse", help="the comparisons' run case")
    ap.add_argument("--static", default="", help="cone marks (deg), e.g. 8,10,12,15,20")
    ap.add_argument("--figure", default="", help="PNG of the rows in --rows (printed JSON lines)")
    ap.add_argument("--rows", default="", help="comma-separated files of printed rows")
    args = ap.parse_args()
    if args.figure:
        figure(args.rows.split(","), args.figure)
    if args.static:
        static_rows(args.results, [float(v) for v in args.static.split(",")])
    if args.points:
        pts = dict((float(a), b) for a, b in (p.split(":", 1) for p in args.points.split(",")))
        dynamic_rows(args.results, pts, args.candidates.split(","), args.case)


if __name__ == "__main__":
    main()
