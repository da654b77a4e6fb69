"""The spinning membrane disc against the full order in time with the full order's independent
damping (docs/sails.md, "Downstream on spin-stiffened bodies").

Writes two case files to a scratch folder — ``spinning-disc`` with ``damping_ratio`` ζ on the
membrane, and ``spinning-disc-nutation`` on it with a 5° cone and ``--amplitude`` on its lowest
mode (0: the nutation alone) — runs ``quadmodes compare`` (Q only) over ``--window`` and prints
the comparison's envelope error and rate ratios, and per model the decay rate of the modal
amplitude envelope (a log-linear fit through the local maxima of ‖s‖) and the dissipated
energy. Nothing is asserted. Usage (12 s with the defaults; the full order of 331 nodes runs
0.1 s per simulated second)::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_disc_damping
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_disc_damping --amplitude 0 --window 60
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import quadmodes as qm  # noqa: E402
from quadmodes.case import load_case  # noqa: E402
from quadmodes.case.editing import edit  # noqa: E402


def envelope_decay(t: np.ndarray, a: np.ndarray) -> float:
    """Decay rate (1/s) of the envelope of ``a`` (ns,) at times ``t`` (ns,) s: minus the slope of
    log a through its local maxima (NaN with fewer than 3)."""
    k = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
    if k.size < 3:
        return float("nan")
    return float(-np.polyfit(t[k], np.log(a[k]), 1)[0])


def write_cases(folder: Path, zeta: float, amplitude_m: float) -> Path:
    """The damped model case and its run case in ``folder``; returns the run case's path."""
    case = edit(load_case("spinning-disc"), {"material.damping_ratio": zeta}, "--zeta")
    model = case.to_toml().replace('name = "spinning-disc"', 'name = "spinning-disc-damped"')
    (folder / "spinning-disc-damped.toml").write_text(model, encoding="utf-8")
    bend = f'bending_amplitude = "{amplitude_m!r} m"\n' if amplitude_m > 0 else ""
    run = (
        'name = "disc-damped-run"\nkind = "run"\nmodel = "spinning-disc-damped.toml"\n'
        '[reduced]\nmodes = "auto"\nformulation = "Q"\nreference = "spinning"\n'
        f'[initial]\nspin_rate = "1 rad/s"\ncone_angle = "5 deg"\nspin_axis = "major"\n{bend}'
        '[integration]\nmethod = "midpoint"\ndt = "0.05 s"\nduration = "60 s"\nsave_every = 2\n'
    )
    path = folder / "disc-damped-run.toml"
    path.write_text(run, encoding="utf-8")
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--zeta", type=float, default=0.02, help="membrane damping ratio")
    ap.add_argument("--amplitude", type=float, default=5e-3, help="m on the lowest mode")
    ap.add_argument("--window", type=float, default=40.0, help="simulated window (s)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        run = write_cases(Path(tmp), args.zeta, args.amplitude)
        cmp = qm.compare(str(run), f"{args.window} s", formulations=("Q",),
                         output_dir=Path(tmp) / "out", plots=False)  # fmt: skip
        summary = cmp.as_json()
        import xarray as xr

        with xr.open_dataset(Path(tmp) / "out" / "comparison.nc") as ds:
            t = ds.time.values
            for i, name in enumerate(ds.model_label.values):
                a = ds.modal_amplitude.values[i]
                print(f"{name}: envelope decay {envelope_decay(t, a):.5g} 1/s, largest ‖s‖ "
                      f"{np.nanmax(a):.4g} √kg m, dissipated {ds.dissipated_energy.values[i, -1]:.5g} J")  # fmt: skip
    q = summary["formulations"]["Q"]
    print(f"envelope error {q['envelope_error']:.4g}, dissipated power ratio "
          f"{q['dissipated_power_ratio']}, cone growth ratio {q['cone_growth_ratio']}, "
          f"speed-up {q['speedup']:.4g}")  # fmt: skip
    for note in summary.get("notes", []):
        print("note:", note)


if __name__ == "__main__":
    main()
