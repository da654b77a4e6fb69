"""Cost of one step of formulation QM (docs/manifold-formulation.md, "Compiled step"): the numpy
step (:class:`~quadmodes.rom.manifold_midpoint.ManifoldMidpointStep`), the compiled loop
(:mod:`quadmodes.rom.manifold_kernel`) and, beside them, the compiled Q and Q4 steps
(:mod:`quadmodes.rom.midpoint_kernel`), all by :func:`quadmodes.rom.integrators.integrate` in one
process from the same state: a point of the coarse spin-family path saved by
``bench_path_family`` (``family-member-<C>deg.npz``: the state ``y0`` and the member's spin; the
member model is the one the family case uses there, ``bench_family_power.member_window``), its
own modes as damping modes (what a run case uses). Then the agreement of the numpy and compiled
QM over the numpy steps (the velocities in the Newton test's energy weights, E_d, |R h|), the
chord iterations a step, and, with ``--pieces``, the cost of each piece of the compiled step.

    OPENBLAS_NUM_THREADS=1 QUADMODES_CACHE=/work/wt/family60-cache \\
        python -m benchmarks.performance.bench_qm_step /work/wt/bigcone-out/bench7 --point 45 \\
        --dt 0.25e-3 --steps 4000 --numpy-steps 200 --pieces

Nothing here asserts on timings. One JSON line a row.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from quadmodes.rom import integrators
from quadmodes.rom import manifold_kernel as mkk
from quadmodes.rom import manifold_kinetics as mk
from quadmodes.rom import manifold_midpoint as mm
from quadmodes.rom import midpoint_kernel as qk
from quadmodes.rom.fixed_step import newton_weights
from quadmodes.rom.system import reduced_system

CASE = "benchmarks/cases/path-41hz-coarse-family-60.toml"


def member_systems(folder: Path, deg: float, case: str):
    """``({"QM", "Q4", "Q": ReducedSystem}, y0)`` of the member at the saved point ``deg``."""
    from benchmarks.studies.bench_family_power import member_window, saved
    from quadmodes.case import load_run_case
    from quadmodes.runs.mode_choice import resolve_modes

    run, _ = resolve_modes(load_run_case(case))
    member = saved(folder, deg, "member")
    _, setup = member_window(run, member)
    model = setup.model
    arrays = mk.manifold_arrays(model, setup.structure.mass_scalar, mk.retained_damping(model))
    systems = {"QM": mk.manifold_system(model, arrays), "Q4": reduced_system(model, "Q4"),
               "Q": reduced_system(model, "Q")}  # fmt: skip
    return systems, np.asarray(member["y0"], float)


def timed(sys, y0, dt, steps, backend, repeat):
    """(µs a step, Solution) of ``steps`` midpoint steps, best of ``repeat``."""
    best, sol = np.inf, None
    for _ in range(repeat):
        sol = integrators.integrate(sys, y0, (0.0, steps * dt), dt=dt, save_every=1,
                                    newton_tol=1e-13, backend=backend)  # fmt: skip
        best = min(best, sol.stats["wall_s"])
    return 1e6 * best / steps, sol


def agreement(sys, ref, sol, n_cmp) -> dict:
    """The compiled QM against the numpy one over the first ``n_cmp`` steps."""
    n = sys.n_modes
    idx = np.r_[4:7, 7 + n : 7 + 2 * n]
    wt = newton_weights(sys)
    a, b = ref.y[: n_cmp + 1], sol.y[: n_cmp + 1]
    wa, wb = a[:, idx] * wt, b[:, idx] * wt
    rel = np.abs(b - a).max(axis=0) / np.maximum(np.abs(a).max(axis=0), 1e-300)
    h = np.array([np.linalg.norm(mm.angular_momentum(sys.manifold, y)) for y in sol.y])
    return {"steps": n_cmp, "velocities_weighted": float(np.abs(wb - wa).max() / np.abs(wa).max()),
            "component_max": float(rel.max()),
            "E_d": float(abs(sol.dissipated[n_cmp] - ref.dissipated[-1]) / ref.dissipated[-1]),
            "H_drift_compiled": float(np.abs(h - h[0]).max() / h[0])}  # fmt: skip


def same_iterations(sys, y0, dt, steps):
    """The compiled QM with the numpy step's predictor (2ν₀ − ν₋₁) and one Newton matrix a
    step: the numpy step's iterations, as a Solution-like object for :func:`agreement`."""
    from types import SimpleNamespace

    y0 = y0.copy()
    y0[:4] /= np.linalg.norm(y0[:4])  # as integrate does
    y, ed, *_ = mkk.fixed_run(sys, y0, steps, dt, np.arange(steps + 1), 1e-13, 25, 0.0,
                              refresh=1, order=1)  # fmt: skip
    return SimpleNamespace(y=y, dissipated=ed)


def pieces(sys, y0, dt, reps=3000) -> dict:
    """µs of each piece of the compiled step at the state ``y0`` (a compiled loop each)."""
    import numba as nb

    qm, qarr, wh, _ = mkk._arrays(sys)
    n, rr = sys.n_modes, qm[0].shape[0]
    s, x = y0[7 : 7 + n].copy(), np.concatenate([y0[4:7], y0[7 + n :]])

    @nb.njit
    def loop(reps, which, qm, qarr, wh, s, x):
        e, e2 = np.empty((rr, 3, n)), np.empty((rr, 3, n))
        mkk._tangents2(qm[1], qm[2], s, s, e, e2)
        wk, wkq = mkk._work_arrays(n, rr, qm[7].shape[0], qm[4].shape[0]), qk._work_arrays(n)
        consts = (x.copy(), x[:3].copy(), s.copy(), s.copy(), s.copy(), s.copy(), e2)
        r, piv, jm = np.empty(n + 3), np.empty(n + 3, np.int64), np.empty((n + 3, n + 3))
        lu3, piv3 = np.empty((3, 3)), np.empty(3, np.int64)
        mkk._residual(x, qm, dt, consts, wk, r, False)
        for _ in range(reps):
            if which == 0:
                mkk._tangents(qm[1], qm[2], s, e)
            elif which == 1:
                mkk._tangents2(qm[1], qm[2], s, s, e, e2)
            elif which == 2:
                mkk._residual(x, qm, dt, consts, wk, r, True)
            elif which == 3:
                mkk._residual(x, qm, dt, consts, wk, r, False)
            elif which == 4:
                mkk._newton_matrix(x, qm, qarr, wh, dt, wk, wkq, jm, piv)
            elif which == 5:
                mkk._begin(qm, dt, x, s, consts, wk, False, x)
            else:
                mkk._advance(
                    qm, dt, x, x.copy(), consts, s.copy(), np.empty(3), wk, lu3, piv3, x[3:]
                )

    names = ("sweep E(s)", "sweep E at two points", "residual at the predictor (E, potential given)",
             "residual (sweep included)", "Newton matrix (+ LU)", "begin (p0, potential)",
             "advance (sweep of two, projection, E_d)")  # fmt: skip
    out = {}
    for i, name in enumerate(names):
        loop(1, i, qm, qarr, wh, s, x)
        start = time.perf_counter()
        loop(reps, i, qm, qarr, wh, s, x)
        out[name] = 1e6 * (time.perf_counter() - start) / reps
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path, help="the folder bench_path_family ran in")
    ap.add_argument("--case", default=CASE)
    ap.add_argument("--point", type=float, default=45.0)
    ap.add_argument("--dt", type=float, default=0.25e-3)
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--numpy-steps", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--pieces", action="store_true")
    args = ap.parse_args()
    systems, y0 = member_systems(args.folder, args.point, args.case)
    sys_qm = systems["QM"]
    warm = {"QM": mkk.warm_up(), "Q": qk.warm_up()}
    head = {"point_deg": args.point, "modes": sys_qm.n_modes, "particles": sys_qm.manifold.rank,
            "dt": args.dt, "warm_up_s": warm}  # fmt: skip
    print(json.dumps(head), flush=True)
    us, ref = timed(sys_qm, y0, args.dt, args.numpy_steps, "numpy", 1)
    rows = [("QM", "numpy", args.numpy_steps, us, ref)]
    for name in ("QM", "Q4", "Q"):
        us, sol = timed(systems[name], y0, args.dt, args.steps, "numba", args.repeat)
        rows.append((name, "numba", args.steps, us, sol))
    for name, backend, steps, us, sol in rows:
        st = sol.stats
        print(json.dumps({"formulation": name, "backend": backend, "steps": steps, "us_per_step": us,
                          "chord_iterations_per_step": st["n_newton"] / st["n_steps"],
                          "newton_matrices_per_step": st["n_jac"] / st["n_steps"]}), flush=True)  # fmt: skip
    qm_numba = rows[1][4]
    print(json.dumps({"agreement": agreement(sys_qm, ref, qm_numba, args.numpy_steps)}), flush=True)
    same = same_iterations(sys_qm, y0, args.dt, args.numpy_steps)
    print(json.dumps({"agreement_numpy_predictor": agreement(sys_qm, ref, same, args.numpy_steps)}),
          flush=True)  # fmt: skip
    if args.pieces:
        print(json.dumps({"pieces_us": pieces(sys_qm, y0, args.dt)}), flush=True)


if __name__ == "__main__":
    main()
