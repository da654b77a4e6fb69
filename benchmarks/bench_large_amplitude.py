"""Large amplitude: ``paper-0.5hz`` with 0.5, 1 and 2 in initial bending against the full order
over 1 s — the bending frequency (mean period of the first bending coordinate's zero crossings,
over the first three periods and over the window)
and the modal-amplitude envelope error of each reduced formulation (issue 9, "Large
amplitude"). Each amplitude runs one full-order transient (independent damping, its own step)
and every formulation against it.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_large_amplitude.py \
        [--case paper-0.5hz] [--amplitudes 0.5,1,2] [--window "1 s"] [--full-dt "0.5 ms"] \
        [--reference spinning] [--modes 5] [--formulations Q,Q4]

Prints one markdown table (figures in docs/validation.md). Several minutes per amplitude on the
default mesh (3006 nodes).
"""

from __future__ import annotations

import argparse

import numpy as np

from quadmodes.analysis import compare as cmp
from quadmodes.analysis.full_order_runs import full_order_for_run
from quadmodes.case import load_run_case
from quadmodes.case.units import parse_quantity
from quadmodes.runs import simulate

#: Periods of the large-amplitude part of a decaying transient over which the early frequency is
#: taken (at 0.5 in on the coarse tension-field mesh the bending amplitude falls below a tenth of
#: its initial value within about three periods).
EARLY_PERIODS = 3


def upward_crossings(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times (s) of the upward zero crossings of ``y(t)`` (linear interpolation between samples).

    About zero, the coordinate's value at the relative equilibrium, not about the signal's mean:
    a wrinkling transient leaves a mean offset of the order of the late amplitude, and crossings
    of ``y - mean`` stop once the decaying signal no longer reaches it (before session 10 the
    0.5 in tension-field figure, 31.94 Hz, so averaged only over 0–0.55 s)."""
    i = np.flatnonzero((y[:-1] < 0.0) & (y[1:] >= 0.0))
    return t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])


def crossing_frequency(t: np.ndarray, y: np.ndarray, periods: int | None = None) -> float:
    """Frequency (Hz) from the mean spacing of the upward zero crossings of ``y(t)``
    (:func:`upward_crossings`), over the first ``periods`` periods only if given (the
    large-amplitude part of a decaying transient); NaN with fewer than two crossings."""
    tc = upward_crossings(np.asarray(t, float), np.asarray(y, float))
    if periods is not None:
        tc = tc[: periods + 1]
    if len(tc) < 2:
        return float("nan")
    return float((len(tc) - 1) / (tc[-1] - tc[0]))


def variant(run, amplitude_in: float, reference: str, modes):
    """``run`` with the initial bending amplitude (in) and the reduced-model choice."""
    red = run.reduced.model_copy(update={"reference": reference, "modes": modes})
    ini = run.initial.model_copy(update={"bending_amplitude": amplitude_in * 0.0254})
    return run.model_copy(update={"reduced": red, "initial": ini,
                                  "name": f"{run.name}-{amplitude_in:g}in"})  # fmt: skip


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
