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
    spin = member_at(result, float(d.t[j]))
    run = load_run_case(case)
    n = result.system.n_modes
    reduced = run.reduced.model_copy(update={"modes": n, "path_model": "fixed", "path_switch": None,
                                                "path_tolerance": None})
    init = run.initial.model_copy(update={"spin_rate": spin})
    integ = run.integration.model_copy(update={"until": None, "save_every": 2, "step_tolerance": None})
    run_m = run.model_copy(update={"reduced": reduced, "initial": init, "integration": integ})
    run_w, setup0 = prepare_comparison(run_m, window)
    y = np.asarray(result.solution.y[j], float)
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
    args = ap.parse_args()
    points = [float(v) for v in args.points.split(",")]
    result = family_path(args.case, max(points) + 0.01)
    for c in points:
        print(json.dumps(point_row(result, c, args.window, args.full_dt, args.case), default=float), flush=True)


if __name__ == "__main__":
    main()
