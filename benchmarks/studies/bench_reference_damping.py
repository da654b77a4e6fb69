"""Convergence of the full-order reference's independent damping in its cutoff frequency.

On a run case (default ``paper-41hz-coarse``: 41 Hz spin, 6° cone) over a short window, the
full-order transient (``quadmodes.analysis.full_order_runs.full_order_for_run``) with modal damping (ζ of the
case) on every FE mode below the cutoff c, 1.5c, 2c (c the default,
:func:`quadmodes.fullorder.damping.default_cutoff`: 3 × max(spin, highest retained mode)), and
with the old retained-mode damping (the reduced model's 5 modes). For each it prints the number
of damped modes, the dissipated energy E_d(T), the cone-angle change Δθ(T) = θ(T) − θ(0), the
mean dissipated power P and cone-growth rate θ̇ (straight-line fits of E_d and θ over the
second half of the window, past the start-up), and their ratios to the largest cutoff's run; ``--half-dt`` adds the default cutoff at half
the step (the reference's convergence in Δt). Nothing is asserted. Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_reference_damping --window 0.5
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_reference_damping --window 0.02  # timing
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from quadmodes.analysis.full_order_runs import full_order_for_run, setup_for_run  # noqa: E402
from quadmodes.fullorder.damping import default_cutoff  # noqa: E402


def run_one(base, window: float, dt: float, damping: str, cutoff: float | None) -> dict:
    """One full-order run from the shared setup; its damping basis, E_d(T), Δθ(T), wall time."""
    start = time.perf_counter()
    sol = full_order_for_run(
        base.run, window=window, dt=dt, setup=base, damping=damping, damping_cutoff=cutoff
    )
    late = sol.t >= 0.5 * sol.t[-1]
    return {
        "power": float(np.polyfit(sol.t[late], sol.E_d[late], 1)[0]),
        "rate": float(np.polyfit(sol.t[late], sol.cone_angle[late], 1)[0]),
        "label": damping if cutoff is None else f"{cutoff:.4g} Hz",
        "dt_ms": 1e3 * sol.dt,
        "modes": int(sol.stats["damped_modes"]),
        "E_d": float(sol.E_d[-1]),
        "dtheta": float(sol.cone_angle[-1] - sol.cone_angle[0]),
        "wall": time.perf_counter() - start,
        "complete": sol.status == 0,
        "note": sol.damping,
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", default="paper-41hz-coarse")
    p.add_argument("--window", type=float, default=0.5, help="simulated window (s)")
    p.add_argument("--dt", type=float, default=None, help="full-order step (s; default run's)")
    p.add_argument("--factors", default="1,1.5,2", help="cutoffs as multiples of the default")
    p.add_argument("--half-dt", action="store_true", help="also the default cutoff at dt/2")
    args = p.parse_args()
    base = setup_for_run(args.case, damping="none")
    dt = float(args.dt or base.run.integration.dt)
    spin = float(base.run.initial.spin_rate) / (2 * math.pi)
    c = default_cutoff(spin, base.model.frequencies_hz)
    print(f"{args.case}: window {args.window:g} s, dt {dt * 1e3:g} ms, default cutoff {c:.4g} Hz "
          f"(spin {spin:.4g} Hz, highest retained {max(base.model.frequencies_hz):.4g} Hz)")  # fmt: skip
    rows = [run_one(base, args.window, dt, "independent", f * c)
            for f in (float(s) for s in args.factors.split(","))]  # fmt: skip
    rows.append(run_one(base, args.window, dt, "retained", None))
    if args.half_dt:
        rows.append(run_one(base, args.window, 0.5 * dt, "independent", c))
        rows[-1]["label"] += " (dt/2)"
    ref = max((r for r in rows if r["label"].endswith("Hz")), key=lambda r: r["modes"])
    print(f"ratios to the {ref['label']} run ({ref['modes']} damped modes)")
    print(f"{'damping':>16} {'dt ms':>6} {'modes':>5} {'E_d(T) J':>10} {'ratio':>7} "
          f"{'dθ(T) deg':>10} {'ratio':>7} {'P W':>9} {'ratio':>7} {'θ̇ deg/s':>9} {'ratio':>7} "
          f"{'wall s':>7}")  # fmt: skip
    for r in rows:
        print(f"{r['label']:>16} {r['dt_ms']:6.3g} {r['modes']:5d} {r['E_d']:10.5g} "
              f"{r['E_d'] / ref['E_d']:7.4f} {math.degrees(r['dtheta']):10.5f} "
              f"{r['dtheta'] / ref['dtheta']:7.4f} {r['power']:9.5g} "
              f"{r['power'] / ref['power']:7.4f} {math.degrees(r['rate']):9.5f} "
              f"{r['rate'] / ref['rate']:7.4f} {r['wall']:7.1f}"
              + ("" if r["complete"] else "  (stopped early)"), flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
