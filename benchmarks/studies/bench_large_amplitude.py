"""Large amplitude: ``paper-0.5hz`` with 0.5, 1 and 2 in initial bending against the full order
over 1 s — the bending frequency (mean period of the first bending coordinate's zero crossings,
over the first three periods and over the window)
and the modal-amplitude envelope error of each reduced formulation (issue 9, "Large
amplitude"). Each amplitude runs one full-order transient (independent damping, its own step)
and every formulation against it.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_large_amplitude \
        [--case paper-0.5hz] [--amplitudes 0.5,1,2] [--window "1 s"] [--full-dt "0.5 ms"] \
        [--reference spinning] [--modes 5] [--formulations Q,Q4]

Prints one markdown table (figures in docs/validation.md). Several minutes per amplitude on the
default mesh (3006 nodes).
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.common import EARLY_PERIODS, crossing_frequency, variant
from quadmodes.analysis import compare as cmp
from quadmodes.analysis.full_order_runs import full_order_for_run
from quadmodes.case import load_run_case
from quadmodes.case.units import parse_quantity
from quadmodes.runs import simulate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="paper-0.5hz")
    ap.add_argument("--amplitudes", default="0.5,1,2", help="initial bending, in")
    ap.add_argument("--window", default="1 s")
    ap.add_argument("--full-dt", default="0.5 ms")
    ap.add_argument("--reference", default="spinning", choices=("rest", "spinning"))
    ap.add_argument("--modes", default="5")
    ap.add_argument("--formulations", default="Q,Q4")
    args = ap.parse_args()
    window = parse_quantity(args.window, "time", "--window")
    full_dt = parse_quantity(args.full_dt, "time", "--full-dt")
    modes = args.modes if args.modes == "auto" else int(args.modes)
    forms = tuple(args.formulations.split(","))
    print(f"{args.case}, {args.reference} reference, modes = {modes}, window {args.window}, "
          f"full order at {args.full_dt}")  # fmt: skip
    print("| bending (in) | model | bending frequency, first 3 periods (Hz) | vs full "
          "| over the window (Hz) | vs full | envelope error |")
    print("|---|---|---|---|---|---|---|")
    for amp in (float(a) for a in args.amplitudes.split(",")):
        run = cmp.window_run(variant(load_run_case(args.case), amp, args.reference, modes), window)
        held = {}

        def full(r, dt, held=held):
            held["sol"] = full_order_for_run(r, dt=dt)
            return held["sol"]

        c = cmp.compare(run, window, formulations=forms, full_order_dt=full_dt, full_order=full)
        setup = simulate.prepare(c.run)
        k = setup.initial.bending_modes[0]
        sol = held["sol"]
        t_full, y_full = np.asarray(sol.t), np.asarray(sol.modal_coordinates)[:, k]
        f_full = crossing_frequency(t_full, y_full)
        f3_full = crossing_frequency(t_full, y_full, EARLY_PERIODS)
        print(f"| {amp:g} | full order | {f3_full:.3f} | — | {f_full:.3f} | — | — |", flush=True)
        for name in forms:
            r = simulate.execute(simulate.prepare(cmp.window_run(c.run, window, name)))
            s = r.solution.y[:, 7 + k]
            f = crossing_frequency(r.solution.t, s)
            f3 = crossing_frequency(r.solution.t, s, EARLY_PERIODS)
            err = c.table[name]["envelope_error"]
            print(f"| {amp:g} | {name} | {f3:.3f} | {100 * (f3 / f3_full - 1):+.1f} % | {f:.3f} "
                  f"| {100 * (f / f_full - 1):+.2f} % | {err:.4f} |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
