"""The spin range's two measures at given spins: the rotating-frame frequencies and the
energy-sink coning rate of a run's model against the model rebuilt about each spin
(:mod:`quadmodes.runs.spin_check`), the spins about the model's reference axis.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_spin_sense paper-41hz-coarse \\
        --at 40.8325:8,40.6:10,40.35:11.8,40.33:12,39.82:15,38.74:20,37.717:23.8

(``--at`` spin Hz:cone deg, the cone angle the path has at that spin; each new spin builds a
model, 15–60 s on the coarse mesh, then cached.)
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from quadmodes.case.run_loading import load_run_case
from quadmodes.runs import simulate as sim
from quadmodes.runs.spin_check import measured_error, sink_error


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--at", required=True, help="spin Hz:cone deg, comma separated")
    args = ap.parse_args()
    setup = sim.prepare(load_run_case(args.case), allow_coarse_step=True)
    e = np.asarray(setup.model.reference_axis, float)
    f_ref = setup.model.reference_spin / (2 * math.pi)
    for item in args.at.split(","):
        hz, cone = (float(x) for x in item.split(":"))
        start = time.perf_counter()
        w = 2 * math.pi * hz * e
        print(json.dumps({
            "spin_hz": hz, "cone_deg": cone, "spin_departure": 1 - hz / f_ref,
            "delta": abs((hz / f_ref) ** 2 - 1), "frequency_error": measured_error(setup, w)[1],
            "coning_rate_error": sink_error(setup, w, math.radians(cone)),
            "wall_s": round(time.perf_counter() - start, 2)}), flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
