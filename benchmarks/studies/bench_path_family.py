"""The spin-family path (``reduced.path_model = "spin-family"``) against the independent full
order started from it (issue 29 item 2): the path integrated by its members, and at each cone
angle asked the full order started from the path's state there, mapped by the seed's kinematics
with the **member's** model (the one that integrated that sample), over a window; the member
integrated from the same state beside it; scored as ``quadmodes compare`` scores.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_path_family \\
        benchmarks/cases/path-41hz-coarse-family.toml --points 15,20 --window 2 --full-dt 0.25e-3

The point is the first saved sample of the path at or past the cone angle (a sample every
50 ms: within 0.002° of it). Prints the path's summary, its switches, then one JSON line a point.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from quadmodes.analysis import compare as cmp
from quadmodes.analysis.comparison_run import prepare_comparison
from quadmodes.analysis.full_order_runs import full_order_for_run
from quadmodes.analysis.path_point import PathPoint, full_order_setup_at, reduced_run_from
from quadmodes.case import load_run_case
from quadmodes.runs import secular
from quadmodes.runs import simulate as sim


def family_path(case: str, until_deg: float):
    """The RunResult of the family path of ``case`` to ``until_deg`` degrees of cone."""
    run = load_run_case(case)
    integ = run.integration.model_copy(update={"until": f"cone {until_deg:g} deg"})
    result = sim.simulate(run.model_copy(update={"integration": integ}))
    d = result.diagnostics
    h, eb = d.H_norm, d.E + d.E_d
    print(json.dumps({"path_t_s": float(d.t[-1]), "spin_hz": [d.spin_rate[0] / (2 * math.pi), d.spin_rate[-1] / (2 * math.pi)],
                      "cone_deg": math.degrees(d.cone_angle[-1]), "wall_s": result.wall_s,
                      "H_drift": float(np.max(np.abs(h - h[0])) / h[0]),
                      "energy_balance": float(np.max(np.abs(eb - eb[0])) / abs(eb[0])),
                      "notes": list(result.notes), "path": result.path.message() if result.path else None}),
          flush=True)  # fmt: skip
    for sw in result.family:
        print(sw.describe(), flush=True)
    return result


def member_at(result, t: float) -> float:
    """Spin (rad/s) of the member that integrated the sample at ``t`` (a switch's own sample
    belongs to the member before it)."""
    spin = float(result.model.reference_spin)
    for sw in result.family:
        if sw.time < t - 1e-12:
            spin = sw.spin_to
    return spin


def point_row(result, cone_deg: float, window: float, full_dt: float, case: str) -> dict:
    d = result.diagnostics
    j = int(np.argmax(np.degrees(d.cone_angle) >= cone_deg))
    return window_row(d, np.asarray(result.solution.y[j], float), j, member_at(result, float(d.t[j])),
                      result.system.n_modes, cone_deg, window, full_dt, case)  # fmt: skip


def path_from_results(path: str, n_modes: int):
    """(diagnostics-like namespace: t, cone_angle, spin_rate, E_d; states y (k, 7+2N); the
    members' exact spins, rad/s) of a family run's results.nc, the member spins from the model
    cache's file names (their notes print 7 digits)."""
    import types

    import xarray as xr

    from benchmarks.studies.bench_family_sensitivity import member_spins
    from quadmodes.case import load_case

    ds = xr.open_dataset(path)
    case = load_case(load_run_case_from_ds(ds).model)
    spins = member_spins(str(ds.attrs.get("notes", "")), f"{case.name}-N{n_modes}")
    d = types.SimpleNamespace(t=ds["time"].values, cone_angle=ds["cone_angle"].values,
                              spin_rate=ds["spin_rate"].values, E_d=ds["dissipated_energy"].values)  # fmt: skip
    y = np.concatenate([ds["quaternion"].values, ds["omega_body"].values,
                        ds["modal_coordinates"].values, ds["modal_velocities"].values], axis=1)  # fmt: skip
    return d, y, [2 * math.pi * hz for hz in spins]


def load_run_case_from_ds(ds):
    from quadmodes.case import run_case_from_toml

    return run_case_from_toml(str(ds.attrs["case_toml"]))


def results_point(d, spins, cone_deg: float) -> tuple[int, float]:
    """(sample, member spin rad/s) near ``cone_deg`` where the path's spin is its member's (the
    member that integrated it beyond doubt: the departure there is 0, the switches at ±d)."""
    j0 = int(np.argmax(np.degrees(d.cone_angle) >= cone_deg))
    member = min(spins, key=lambda w: abs(math.log(d.spin_rate[j0] / w)))
    near = slice(max(0, j0 - 5000), j0 + 5000)
    j = near.start + int(np.argmin(np.abs(d.spin_rate[near] - member)))
    return j, member


def window_row(d, y, j: int, spin: float, n: int, cone_deg: float, window: float, full_dt: float,
               case: str) -> dict:  # fmt: skip
    run = load_run_case(case)
    reduced = run.reduced.model_copy(update={"modes": n, "path_model": "fixed", "path_switch": None,
                                                "path_tolerance": None})
    init = run.initial.model_copy(update={"spin_rate": spin})
    integ = run.integration.model_copy(update={"until": None, "save_every": 2, "step_tolerance": None})
    run_m = run.model_copy(update={"reduced": reduced, "initial": init, "integration": integ})
    run_w, setup0 = prepare_comparison(run_m, window)
    dt = float(run.integration.dt)
    point = PathPoint(f"cone {cone_deg:g} deg", "cone", float(d.t[j]), int(round(d.t[j] / dt)), y,  # step: nominal
                      float(d.E_d[j]), float(d.cone_angle[j]), float(d.spin_rate[j]), "family path")  # fmt: skip
    start = time.perf_counter()
    full_sol = full_order_for_run(run_w, dt=full_dt, setup=full_order_setup_at(setup0, point))
    full_wall = time.perf_counter() - start
    full = cmp.series_from_full_order(full_sol)
    red = cmp.series_from_run("member", reduced_run_from(run_w, setup0.model, y))
    model = setup0.model
    f_low = float(np.min(model.frequencies_hz[:n]))
    tau = secular.decay_time(model.frequencies_hz[:n], model.damping_ratio[:n])
    row = cmp.errors(red, full, 1.0 / f_low)
    row.update(secular.score(full, {"member": red}, secular.quasi_steady_interval(window, tau)).row("member"))
    np.savez(f"family-full-{cone_deg:g}deg.npz", t=full.t, amplitude=full.amplitude, cone=full.cone_angle,
             spin=full.spin_rate, E_d=full.E_d, H=full.H_norm)  # fmt: skip
    return {"point_deg": cone_deg, "t_s": float(d.t[j]), "cone_deg": math.degrees(d.cone_angle[j]),
            "path_spin_hz": d.spin_rate[j] / (2 * math.pi), "member_hz": spin / (2 * math.pi),
            "full_wall_s": full_wall, "full_H_drift": float(np.max(np.abs(full.H_norm - full.H_norm[0])) / full.H_norm[0]),
            **{k: row.get(k) for k in ("envelope_error", "cone_growth_ratio", "dissipated_power_ratio",
                                       "spin_rate_change_ratio")}}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--points", default="15,20")
    ap.add_argument("--window", type=float, default=2.0)
    ap.add_argument("--full-dt", type=float, default=0.25e-3)
    ap.add_argument("--results", help="a family run's results.nc: its path, not integrated again "
                    "(each point where the path's spin is its member's, near the cone angle)")
    ap.add_argument("--modes", type=int, default=16, help="with --results: the run's N")
    args = ap.parse_args()
    points = [float(v) for v in args.points.split(",")]
    if args.results:
        d, y, spins = path_from_results(args.results, args.modes)
        for c in points:
            j, member = results_point(d, spins, c)
            print(json.dumps(window_row(d, y[j], j, member, args.modes, c, args.window, args.full_dt,
                                        args.case), default=float), flush=True)  # fmt: skip
        return
    result = family_path(args.case, max(points) + 0.01)
    for c in points:
        print(json.dumps(point_row(result, c, args.window, args.full_dt, args.case), default=float), flush=True)


if __name__ == "__main__":
    main()
