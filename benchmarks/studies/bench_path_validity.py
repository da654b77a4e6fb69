"""The model's validity along the path of a saved run, from its ``results.nc`` (no integration):
the checks of :mod:`quadmodes.runs.path_validity` as ``quadmodes run`` makes them (the FE model's
condensed energy at the path's modal amplitudes, the spin range measured against a rebuilt
model), printed with the path's cone angles and spins.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_path_validity DIR/<case>/results.nc

The run case is read back from the file (``case_toml``, with its model); the path is the file's
saved samples.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time

import numpy as np

from quadmodes.case import run_case_from_toml
from quadmodes.rom.diagnostics import diagnostics
from quadmodes.rom.solution import Solution
from quadmodes.runs import results
from quadmodes.runs import simulate as sim
from quadmodes.runs.path_validity import run_path_validity


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results")
    args = ap.parse_args()
    ds = results.load_results(args.results)
    run = run_case_from_toml(str(ds.attrs["case_toml"]))
    setup = dataclasses.replace(sim.prepare(run, allow_coarse_step=True), fe_checks=True)
    t = np.asarray(ds["time"].values, float)
    y = np.concatenate([ds["quaternion"].values, ds["omega_body"].values,
                        ds["modal_coordinates"].values, ds["modal_velocities"].values], axis=1)  # fmt: skip
    sol = Solution(t, y, run.integration.method, {}, 0, "ok", ds["dissipated_energy"].values)
    diag = diagnostics(setup.system, sol, spin_axis=setup.initial.spin_axis)
    start = time.perf_counter()
    path = run_path_validity(setup, sol, diag)
    print(f"{run.name}: t = 0 … {t[-1]:.6g} s, spin {diag.spin_rate[0] / (2 * math.pi):.5g} → "
          f"{diag.spin_rate[-1] / (2 * math.pi):.5g} Hz, cone {math.degrees(diag.cone_angle[0]):.4g}"
          f" → {math.degrees(diag.cone_angle[-1]):.4g} deg; checks {time.perf_counter() - start:.1f} s")  # fmt: skip
    out = {f.name: getattr(path, f.name) for f in dataclasses.fields(path)
           if f.name != "tension_samples"}  # (arrays)
    out["spin_range_hz"] = [v / (2 * math.pi) for v in path.spin_range]
    out["measured_spin_hz"] = path.measured_spin / (2 * math.pi)
    out["measured_sink_spin_hz"] = path.measured_sink_spin / (2 * math.pi)
    k = int(np.argmax(t >= path.left_at)) if path.left_at is not None else -1
    out["left_cone_deg"] = math.degrees(diag.cone_angle[k]) if k >= 0 else None
    print(json.dumps(out, indent=1, default=float))
    print("valid:", path.valid, "|", path.message())


if __name__ == "__main__":
    main()
