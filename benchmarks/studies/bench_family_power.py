"""Why the spin-family member's dissipated power falls behind the full order's as the cone opens
(issue 29, docs/path-validity.md "Why the reduced power falls behind"): measurements from the
states and series that ``bench_path_family`` saves in its working folder
(``family-member-<C>deg.npz``: the point's state ``y0`` and the member's spin; ``family-full-<C>deg.npz``:
the full order's series), each from the same state:

* ``candidates``: reduced candidates (``bench_path_model.candidate_run``: Q, Q4, Q4c, B, Bc; and
  ``Qfine``, Q at a fixed 0.125 ms) scored against the saved full order (envelope, its 1–2 s
  part, rates, the mean envelope ratio over 1–2 s);
* ``damping``: the reduced motion's field under the full order's damping operator against the
  reduced ṡᵀCṡ (with and without the quadratic modes' velocity), and the path check's amplitude
  error at the window's largest ‖s‖;
* ``modes``: the full order again (2 s) with its modal coordinates kept and, with
  ``--retained``, once more with its damping on the member's modes only; per mode the mean and
  oscillating parts, R / F, and the share of the damped power; the rear mass's mean axial
  deformation, F − R, against what the third-order terms Q leaves out (strain V3, centrifugal
  cubic, kinetic T3) would add.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_family_power candidates DIR \\
        --points 10,45,60 --candidates Q,Qfine,B,Bc,Q4,Q4c
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_family_power damping DIR --points 10,60
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_family_power modes DIR --points 10,60 --retained

* ``exact``: the consistent fourth-order Lagrangian (``quadmodes.experimental.manifold_lagrangian``)
  from the same states (≈ 30 s a window);
* ``midpoint``: the same Lagrangian as formulation QM (``quadmodes.rom.manifold_midpoint``) by the
  numpy implicit midpoint at ``--dt`` (``--damping independent|retained``: the damping modes on
  the manifold velocity), beside Q4 and Q by the same numpy midpoint (cost per step).

``DIR``: the folder ``bench_path_family`` ran in. One JSON line a row.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from benchmarks.studies.bench_path_model import candidate_run
from quadmodes.analysis import compare as cmp
from quadmodes.analysis.comparison_run import prepare_comparison
from quadmodes.analysis.full_order_runs import full_order_for_run
from quadmodes.analysis.path_point import PathPoint, full_order_setup_at, reduced_run_from
from quadmodes.case import load_run_case
from quadmodes.rom import system as rsys
from quadmodes.runs import secular
from quadmodes.runs.family_samples import member_run
from quadmodes.runs.mode_choice import resolve_modes

CASE = "benchmarks/cases/path-41hz-coarse-family-60.toml"
WINDOW = 2.0


def saved(folder: Path, deg: float, kind: str) -> dict:
    """The arrays of ``family-<kind>-<deg>deg.npz`` (kind "member" or "full")."""
    with np.load(folder / f"family-{kind}-{deg:g}deg.npz") as z:
        return {k: z[k] for k in z.files}


def series(name: str, d: dict) -> cmp.Series:
    """A :class:`~quadmodes.analysis.compare.Series` of saved arrays (no energy: not scored)."""
    return cmp.Series(name=name, t=d["t"], amplitude=d["amplitude"], cone_angle=d["cone"],
                      spin_rate=d["spin"], H_norm=d["H"], E=np.zeros_like(d["t"]), E_d=d["E_d"],
                      wall_s=1.0)  # fmt: skip


def member_window(run, member: dict):
    """``(run_w, setup)``: the member's run cut to the window (a sample every 2 steps) and the
    full order's setup at t = 0 of that run."""
    run_m = member_run(run, float(member["member_spin"]))
    integ = run_m.integration.model_copy(update={"save_every": 2})
    return prepare_comparison(run_m.model_copy(update={"integration": integ}), WINDOW)


def scored(red: cmp.Series, full: cmp.Series, model, n: int) -> dict:
    """Envelope (whole window and 1–2 s), mean envelope ratio over 1–2 s, the secular ratios."""
    period = 1.0 / float(np.min(model.frequencies_hz[:n]))
    tau = secular.decay_time(model.frequencies_hz[:n], model.damping_ratio[:n])
    row = cmp.errors(red, full, period)
    sc = secular.score(full, {red.name: red}, secular.quasi_steady_interval(WINDOW, tau)).row(red.name)
    te, ef = cmp.envelope(full, period)
    tr, er = cmp.envelope(red, period)
    late = te >= 1.0
    on = np.interp(te[late], tr, er)
    return {"envelope": row["envelope_error"],
            "envelope_late": float(np.max(np.abs(on - ef[late])) / np.max(ef)),
            "envelope_mean_ratio": float(np.mean(on) / np.mean(ef[late])),
            **{k: sc.get(k) for k in ("cone_growth_ratio", "dissipated_power_ratio",
                                      "spin_rate_change_ratio")}}  # fmt: skip


def candidates(run, folder: Path, points, names) -> None:
    for deg in points:
        member, full = saved(folder, deg, "member"), series("full", saved(folder, deg, "full"))
        run_w, setup = member_window(run, member)
        model, n = setup.model, run_w.reduced.modes
        for name in names:
            if name == "Qfine":  # the member at a fixed 0.125 ms instead of its controlled step
                integ = run_w.integration.model_copy(update={"step_tolerance": None,
                                                             "dt": 0.125e-3, "save_every": 8})
                res = reduced_run_from(run_w.model_copy(update={"integration": integ}), model,
                                       member["y0"])  # fmt: skip
            else:
                res, _ = candidate_run(run_w, name, member["y0"], WINDOW)
            row = scored(cmp.series_from_run(name, res), full, model, n)
            print(json.dumps({"point_deg": deg, "candidate": name, **row}), flush=True)


def damping(run, folder: Path, points) -> None:
    from quadmodes.fe.model import centre_of_mass
    from quadmodes.fullorder import kinematics as kin
    from quadmodes.fullorder.step import damping_force
    from quadmodes.runs import path_validity as pv
    from quadmodes.runs import simulate
    from quadmodes.runs.deformation_check import deformation_structure

    for deg in points:
        member = saved(folder, deg, "member")
        run_w, setup = member_window(run, member)
        model, st, modes = setup.model, setup.structure, setup.damping
        res = reduced_run_from(run_w, model, member["y0"])
        t, y = res.solution.t, res.solution.y
        body = kin.make_body(st.mass_scalar, st.translational, np.asarray(model.X), model, False)
        mphi = np.stack([st.mass_scalar @ p for p in modes.shapes])
        centre = centre_of_mass(st, setup.x_rest if setup.x_rest is not None else setup.x_ref)
        p_full, p_lin, p_red = [], [], []
        for i in np.flatnonzero(t >= 1.0)[::5]:  # every 5 samples of the window's second half
            s, sd = rsys.split_state(res.system, y[i])[2:]
            x, v = kin.initial_state_from_reduced(model, y[i], p=centre)
            v_g = (2.0 * np.einsum("m,n,mnia->ia", s, sd, model.G)) @ kin.rotation_matrix(y[i, :4]).T
            p_full.append(float(np.sum(v * damping_force(body, modes.C, x, v, mphi=mphi))))
            v_l = v - v_g
            p_lin.append(float(np.sum(v_l * damping_force(body, modes.C, x, v_l, mphi=mphi))))
            p_red.append(float(sd @ model.C @ sd))
        s_all = rsys.split_state(res.system, y)[2]
        j = int(np.argmax(np.linalg.norm(s_all, axis=1)))
        prepared = simulate.prepare(run_w, model)
        err, _ = pv._amplitude_error(prepared, y[j], deformation_structure(prepared))
        print(json.dumps({"point_deg": deg, "full_operator_over_reduced": np.mean(p_full) / np.mean(p_red),
                          "without_quadratic_velocity": np.mean(p_lin) / np.mean(p_red),
                          "damping_modes": modes.n_modes, "largest_s": float(np.linalg.norm(s_all[j])),
                          "amplitude_check_error": err}), flush=True)  # fmt: skip


def per_mode(sol, res, model) -> list[dict]:
    """Per retained mode over 1–2 s: mean and oscillating parts of s (F and R) and the share of
    the retained-mode damped power ṡᵀCṡ (velocities by central differences of the samples)."""
    t_f, s_f = sol.t, np.asarray(sol.modal_coordinates, float)
    s_r = rsys.split_state(res.system, res.solution.y)[2]
    s_r = np.stack([np.interp(t_f, res.solution.t, s_r[:, k]) for k in range(s_r.shape[1])], 1)
    late = t_f >= 1.0
    v_f, v_r = (np.gradient(s, t_f, axis=0)[late] for s in (s_f, s_r))
    c = np.diag(model.C)
    total = float(np.mean(v_f**2 @ c))
    rows = []
    for k, label in enumerate(model.labels):
        pf, pr = float(np.mean(v_f[:, k] ** 2) * c[k]), float(np.mean(v_r[:, k] ** 2) * c[k])
        rows.append({"mode": k, "label": str(label), "mean_F": float(s_f[late, k].mean()),
                     "mean_R": float(s_r[late, k].mean()), "osc_F": float(s_f[late, k].std()),
                     "osc_R": float(s_r[late, k].std()), "power_share_F": pf / total,
                     "power_R_over_F": pr / pf if pf > 0 else math.nan})  # fmt: skip
    return rows


def cubic_axial(model, structure, res, sol) -> dict:
    """The mean axial deformation of the rear mass (the model's "axial" mode) over 1–2 s, F and R,
    and what the third-order terms Q leaves out would add to R's, each from R's own motion
    divided by that mode's stiffness Λ_aa: the strain energy's V3 (−3 V3_amn s_m s_n), the
    centrifugal potential's cubic at the reference spin (``bench_path_model.centrifugal_higher_order``)
    and the kinetic energy's ``T3 = 2 (Φᵀ M g^{mn})_k ṡ_k s_m ṡ_n`` (Q's modal mass μ is constant:
    ``∂T3/∂s_a = 2 Σ (ΦᵀM g^{an})_k ṡ_k ṡ_n``)."""
    from benchmarks.studies.bench_path_model import centrifugal_higher_order

    a = next(i for i, label in enumerate(model.labels) if str(label).startswith("axial"))
    late_r, late_f = res.solution.t >= 1.0, sol.t >= 1.0
    _, _, s, sd = rsys.split_state(res.system, res.solution.y)
    s, sd = s[late_r], sd[late_r]
    mphi = np.stack([structure.mass_scalar @ p for p in model.Phi])
    gm = np.einsum("mnia,kia->kmn", model.G, mphi)  # (Φ_kᵀ M g^{mn})
    v3c, _ = centrifugal_higher_order(model, structure.mass_scalar)
    lam = float(model.Lam[a, a])
    terms = {
        "V3": -3 * np.einsum("mn,tm,tn->t", np.asarray(model.V3)[a], s, s).mean() / lam,
        "centrifugal_cubic": -3 * np.einsum("mn,tm,tn->t", v3c[a], s, s).mean() / lam,
        "kinetic_T3": 2 * np.einsum("kn,tk,tn->t", gm[:, a, :], sd, sd).mean() / lam,
    }
    s_f = np.asarray(sol.modal_coordinates, float)[late_f, a]
    return {"mode": a, "mean_F": float(s_f.mean()), "mean_R": float(s[:, a].mean()),
            "F_minus_R": float(s_f.mean() - s[:, a].mean()),
            **{k: float(v) for k, v in terms.items()}, "sum": float(sum(terms.values()))}


def modes(run, folder: Path, points, retained: bool) -> None:
    for deg in points:
        member = saved(folder, deg, "member")
        run_w, setup = member_window(run, member)
        point = PathPoint(f"cone {deg:g} deg", "cone", 0.0, 0, member["y0"], 0.0, 0.0, 0.0,
                          str(folder), member_spin=float(member["member_spin"]))  # fmt: skip
        start = full_order_setup_at(setup, point)
        res = reduced_run_from(run_w, setup.model, member["y0"])
        sol = full_order_for_run(run_w, dt=0.25e-3, setup=start)
        for row in per_mode(sol, res, setup.model):
            print(json.dumps({"point_deg": deg, **row}), flush=True)
        axial = cubic_axial(setup.model, setup.structure, res, sol)
        print(json.dumps({"point_deg": deg, "axial_mean": axial}), flush=True)
        if retained:  # the full order's damping on the member's own modes only
            ret = full_order_for_run(run_w, dt=0.25e-3, setup=start, damping="retained")
            renamed = dataclasses.replace(cmp.series_from_full_order(ret), name="retained")
            ratio = scored(renamed, cmp.series_from_full_order(sol), setup.model,
                           run_w.reduced.modes)  # fmt: skip
            print(json.dumps({"point_deg": deg, "retained_over_independent": ratio}), flush=True)


def exact(run, folder: Path, points) -> None:
    """The consistent fourth-order Lagrangian (:mod:`quadmodes.experimental.manifold_lagrangian`,
    the full order's damping on the manifold velocity) from each saved state, scored as the
    candidates are; its cone angle and spin from Q's diagnostics of its (q, ω, s, ṡ)."""
    import time

    from quadmodes.experimental import manifold_lagrangian as ml
    from quadmodes.rom import diagnostics as rdiag
    from quadmodes.rom.solution import Solution

    for deg in points:
        member, full = saved(folder, deg, "member"), series("full", saved(folder, deg, "full"))
        run_w, setup = member_window(run, member)
        model, mass = setup.model, setup.structure.mass_scalar
        lag = ml.ManifoldLagrangian(model, mass).with_damping(setup.damping, mass, model)
        start = time.perf_counter()
        t, ys = ml.run(lag, member["y0"], WINDOW)
        wall = time.perf_counter() - start
        states = lag.reduced_states(ys)
        d = rdiag.diagnostics(rsys.reduced_system(model, "Q"),
                              Solution(t=t, y=states, method="DOP853", stats={}, status=0,
                                       message="", dissipated=ys[:, -1]))  # fmt: skip
        h = np.linalg.norm(ys[:, 4:7], axis=1)
        red = cmp.Series(name="exact", t=t, amplitude=np.linalg.norm(states[:, 7 : 7 + model.n_modes], axis=1),
                         cone_angle=d.cone_angle, spin_rate=d.spin_rate, H_norm=h,
                         E=np.zeros_like(t), E_d=ys[:, -1], wall_s=wall)  # fmt: skip
        balance = np.array([lag.energy(y) + y[-1] for y in ys[::100]])
        print(json.dumps({"point_deg": deg, "candidate": "exact-T, Q4, C(s)", "wall_s": wall,
                          "H_drift": float(np.max(np.abs(h - h[0])) / h[0]),
                          "energy_balance": float(np.max(np.abs(balance - balance[0])) / abs(balance[0])),
                          **scored(red, full, model, run_w.reduced.modes)}), flush=True)  # fmt: skip


def _series(name, model, t, states, e_d, wall) -> cmp.Series:
    """A scored :class:`~quadmodes.analysis.compare.Series` of reduced states [q, ω, s, ṡ]: cone
    angle and spin from Q's diagnostics, |H| from Q's momenta (diagnostic only)."""
    from quadmodes.rom import diagnostics as rdiag
    from quadmodes.rom.solution import Solution

    d = rdiag.diagnostics(rsys.reduced_system(model, "Q"),
                          Solution(t=t, y=states, method="midpoint", stats={}, status=0,
                                   message="", dissipated=e_d))  # fmt: skip
    return cmp.Series(name=name, t=t, amplitude=np.linalg.norm(states[:, 7 : 7 + model.n_modes], axis=1),
                      cone_angle=d.cone_angle, spin_rate=d.spin_rate, H_norm=np.ones_like(t),
                      E=np.zeros_like(t), E_d=e_d, wall_s=wall)  # fmt: skip


def midpoint(run, folder: Path, points, dt: float, damping: str = "independent") -> None:
    """Formulation QM (:mod:`quadmodes.rom.manifold_midpoint`, the full order's damping on the
    manifold velocity) by the numpy implicit midpoint at a fixed ``dt`` from each saved state,
    scored as the candidates are; beside it Q4 and Q by the same numpy midpoint and ``dt`` (the
    cost per step side by side, same process); |H| and E + E_d of QM from its own arrays.
    ``damping``: the full order's damping modes on the manifold velocity ("independent", the
    saved series' basis) or the member's own ("retained": the model's Φ and C)."""
    import time

    from quadmodes.rom import manifold_kinetics as mk
    from quadmodes.rom import manifold_midpoint as mm
    from quadmodes.rom.fixed_step import run_fixed
    from quadmodes.rom.midpoint import MidpointStep

    steps, every = int(round(WINDOW / dt)), max(1, int(round(0.25e-3 / dt)))
    for deg in points:
        member, full = saved(folder, deg, "member"), series("full", saved(folder, deg, "full"))
        run_w, setup = member_window(run, member)
        model, n = setup.model, run_w.reduced.modes
        y0 = np.asarray(member["y0"], float)
        modes = setup.damping if damping == "independent" else mk.retained_damping(model)
        arrays = mk.manifold_arrays(model, setup.structure.mass_scalar, modes)
        sys4 = rsys.reduced_system(model, "Q4")
        start = time.perf_counter()
        t, ys, ed = mm.run_manifold(sys4, arrays, y0, dt, steps, save_every=every)
        wall = time.perf_counter() - start
        h = np.array([np.linalg.norm(mm.angular_momentum(arrays, y)) for y in ys])
        e = np.array([mm.energy(sys4, arrays, y) for y in ys]) + ed
        print(json.dumps({"point_deg": deg, "candidate": f"QM midpoint, {damping} C(s)", "dt": dt, "modes": n,
                          "wall_s": wall, "ms_per_step": 1e3 * wall / steps,
                          "H_drift": float(np.max(np.abs(h - h[0])) / h[0]),
                          "energy_balance": float(np.max(np.abs(e - e[0])) / abs(e[0])),
                          **scored(_series("QM", model, t, ys, ed, wall), full, model, n)}), flush=True)  # fmt: skip
        for name in ("Q4", "Q"):
            sys_f = rsys.reduced_system(model, name)
            start = time.perf_counter()
            out = run_fixed(MidpointStep(sys_f, dt), sys_f, y0, steps, dt, np.arange(0, steps + 1, every),
                            1e-12, 20, 0.0, name)  # fmt: skip
            wall = time.perf_counter() - start
            row = scored(_series(name, model, np.arange(len(out[0])) * every * dt, out[0], out[1], wall),
                         full, model, n)  # fmt: skip
            print(json.dumps({"point_deg": deg, "candidate": f"{name} numpy midpoint (C0)", "dt": dt,
                              "wall_s": wall, "ms_per_step": 1e3 * wall / steps, **row}), flush=True)  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("candidates", "damping", "modes", "exact", "midpoint"))
    ap.add_argument("folder", type=Path)
    ap.add_argument("--case", default=CASE)
    ap.add_argument("--points", default="10,45,60")
    ap.add_argument("--candidates", default="Q,Qfine,B,Bc,Q4,Q4c")
    ap.add_argument("--retained", action="store_true")
    ap.add_argument("--dt", type=float, default=0.125e-3)
    ap.add_argument("--damping", choices=("independent", "retained"), default="independent")
    args = ap.parse_args()
    run, _ = resolve_modes(load_run_case(args.case))
    points = [float(v) for v in args.points.split(",")]
    if args.what == "candidates":
        candidates(run, args.folder, points, args.candidates.split(","))
    elif args.what == "damping":
        damping(run, args.folder, points)
    elif args.what == "exact":
        exact(run, args.folder, points)
    elif args.what == "midpoint":
        midpoint(run, args.folder, points, args.dt, args.damping)
    else:
        modes(run, args.folder, points, args.retained)


if __name__ == "__main__":
    main()
