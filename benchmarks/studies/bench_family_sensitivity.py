"""The coning-rate sensitivity σ a spin family measured between its members (issue 29, the
adaptive spacing of ``reduced.path_tolerance``, :mod:`quadmodes.runs.family_spacing`), recomputed
from a family run's results.nc: the members named in its notes (rebuilt from the model cache:
no build when the run's cache is used), at each switch the cone angle of the path there.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_family_sensitivity \\
        out/path-41hz-coarse-family-60/results.nc benchmarks/cases/path-41hz-coarse-family-60.toml

Prints one line a pair: the spins (Hz), the cone angle (deg), σ (relative change of θ̇/θ per
unit of ln Ω), the departure tol/σ it allows, and the departure used (ln of the spin step over
1 + 1/HYSTERESIS of the spacing rule).
"""

from __future__ import annotations

import argparse
import math
import re

import numpy as np
import xarray as xr

from quadmodes.case import load_run_case
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import system as rsys
from quadmodes.runs.family_spacing import HYSTERESIS, sensitivity


def member_spins(notes: str, prefix: str) -> list[float]:
    """The members' spins (Hz) named in a family run's notes, made exact (1e-4 Hz) from the
    model cache's file names ``prefix``-spin<Hz>Hz-*.nc (the notes may print 5 digits)."""
    from quadmodes.models.cache import cache_dir

    found = re.search(r"members about ([0-9., ]+) Hz", notes)
    named = [float(v) for v in found.group(1).split(",")] if found else []
    cached = [float(m.group(1).replace("p", "."))
              for p in cache_dir().glob(f"{prefix}-spin*Hz-*.nc")
              if (m := re.search(r"-spin([0-9p]+)Hz-", p.name))]  # fmt: skip
    out = []
    for hz in named:
        near = min(cached, key=lambda c: abs(c - hz), default=hz)
        out.append(near if abs(near - hz) < 0.006 else hz)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results")
    ap.add_argument("case")
    args = ap.parse_args()
    run = load_run_case(args.case)
    ds = xr.open_dataset(args.results)
    n_modes = int(ds.sizes.get("mode", 16))
    spin_path = np.asarray(ds["spin_rate_hz"].values, float)
    cone = np.asarray(ds["cone_angle_deg"].values, float)
    from quadmodes.case import load_case

    case = load_case(run.model)
    spins = member_spins(str(ds.attrs.get("notes", "")), f"{case.name}-N{n_modes}")
    tol = run.reduced.path_tolerance or math.nan
    systems = []
    for hz in spins:
        model = reduced_model_for(case, n_modes, spin=2 * math.pi * hz,
                                  axis=run.reference_axis)  # fmt: skip
        systems.append(rsys.reduced_system(model, run.reduced.formulation))
    for k in range(1, len(spins)):
        j = int(np.argmin(np.abs(spin_path - spins[k])))
        sigma = sensitivity(systems[k - 1], systems[k], math.radians(cone[j]))
        step = math.log(spins[k - 1] / spins[k])
        print(f"{spins[k - 1]:8.4f} -> {spins[k]:8.4f} Hz  cone {cone[j]:6.2f} deg  sigma {sigma:.3f}"
              f"  tol/sigma {100 * tol / sigma:.3f} %  step {100 * step:.3f} %"
              f"  (d ≈ {100 * step / (1 + 1 / HYSTERESIS):.3f} %)", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
