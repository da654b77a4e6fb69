"""The spin-family path (``reduced.path_model = "spin-family"``) against the independent full
order started from it (issue 29 item 2): the path integrated by its members, and at each cone
angle asked the full order started from the path's state there, mapped by the seed's kinematics
with the **member's** model (the one that integrated that sample), over a window; the member
integrated from the same state beside it; scored as ``quadmodes compare`` scores.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_path_family \\
        benchmarks/cases/path-41hz-coarse-family.toml --points 15,20 --window 2 --full-dt 0.25e-3

The point is located to the step in the chart of its member, as ``quadmodes compare RUN --at``
locates it (:mod:`quadmodes.analysis.family_point`; until that command read family paths, the
first saved sample at or past the cone angle). Prints the path's summary, its switches, then one
JSON line a point.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from quadmodes.analysis import compare as cmp
from quadmodes.analysis.comparison_run import prepare_comparison
from quadmodes.analysis.family_point import family_point_on_samples
from quadmodes.analysis.full_order_runs import full_order_for_run
from quadmodes.analysis.path_point import full_order_setup_at, reduced_run_from
from quadmodes.case import load_run_case
from quadmodes.runs import secular
from quadmodes.runs import simulate as sim
from quadmodes.runs.family_samples import Members, member_run, sample_member_spins


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


def point_row(result, cone_deg: float, window: float, full_dt: float) -> dict:
    """The full order and the member from the family path's point at ``cone_deg``: the point
    located to the step in its member's chart, the member's run and full-order setup, as
    ``quadmodes compare --at`` makes them (quadmodes.analysis.family_point)."""
    d = result.diagnostics
    spins = sample_member_spins(d.t, float(result.model.reference_spin), result.family)
    point = family_point_on_samples(Members(result.run, result.model_case), result.run.integration,
                                    f"cone {cone_deg:g} deg", d.t, result.solution.y, d.E_d, spins,
                                    result.initial.spin_axis, "family path")  # fmt: skip
    run_m = member_run(result.run, point.member_spin)
    run_m = run_m.model_copy(update={"integration": run_m.integration.model_copy(update={"save_every": 2})})
    run_w, setup0 = prepare_comparison(run_m, window)
    start = time.perf_counter()
    full_sol = full_order_for_run(run_w, dt=full_dt, setup=full_order_setup_at(setup0, point))
    full_wall = time.perf_counter() - start
    full = cmp.series_from_full_order(full_sol)
    red = cmp.series_from_run("member", reduced_run_from(run_w, setup0.model, point.y))
    model, n = setup0.model, run_w.reduced.modes
    f_low = float(np.min(model.frequencies_hz[:n]))
    tau = secular.decay_time(model.frequencies_hz[:n], model.damping_ratio[:n])
    row = cmp.errors(red, full, 1.0 / f_low)
    row.update(secular.score(full, {"member": red}, secular.quasi_steady_interval(window, tau)).row("member"))
    np.savez(f"family-full-{cone_deg:g}deg.npz", t=full.t, amplitude=full.amplitude, cone=full.cone_angle,
             spin=full.spin_rate, E_d=full.E_d, H=full.H_norm)  # fmt: skip
    np.savez(f"family-member-{cone_deg:g}deg.npz", t=red.t, amplitude=red.amplitude, cone=red.cone_angle,
             spin=red.spin_rate, E_d=red.E_d, H=red.H_norm, y0=point.y, member_spin=point.member_spin)  # fmt: skip
    return {"point_deg": cone_deg, "t_s": point.time, "step": point.step,
            "cone_deg": math.degrees(point.cone_angle), "path_spin_hz": point.spin_rate / (2 * math.pi),
            "member_hz": point.member_spin / (2 * math.pi),
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
        print(json.dumps(point_row(result, c, args.window, args.full_dt), default=float), flush=True)


if __name__ == "__main__":
    main()
