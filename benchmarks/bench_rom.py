"""Reduced-order-model (ROM) integration benchmark for quadmodes (a plain script, not a test).

Two parts:

1. Integration throughput (steps/s) of the paper model's reduced model (N = 5 modes, from the
   reduced-model cache; built once if missing) for ``midpoint``, ``backward-euler`` and
   ``adaptive``, from the paper-41hz initial state (41 Hz spin, 6 deg cone), formulation Q, one
   :func:`quadmodes.integrators.integrate` call per method over ``--window`` seconds.
2. The wall time of ``quadmodes run paper-41hz`` split by stage, running the same functions as the
   command in-process: load + validate the run case, ``simulate.prepare`` (reduced model from the
   cache, initial state, validity scan), ``simulate.execute`` (chunked integration +
   diagnostics), ``results.write_outputs`` (results.nc, summary.json, PNGs).

Usage::

    python benchmarks/bench_rom.py                       # throughput + paper-41hz (120 s run)
    python benchmarks/bench_rom.py --duration "10 s"     # shorter paper-41hz run
    python benchmarks/bench_rom.py --skip-run --window 2

Pure numpy (no numba). Nothing here asserts on timings.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from quadmodes import integrators, simulate
from quadmodes.config import load_run_case
from quadmodes.results import write_outputs

CASE = "paper-41hz"
METHODS = ("midpoint", "backward-euler", "adaptive")


def throughput(window: float, dt: float, rtol: float) -> list[dict]:
    run = load_run_case(CASE)
    t0 = time.perf_counter()
    setup = simulate.prepare(run)
    load_s = time.perf_counter() - t0
    print(
        f"reduced model: {setup.model.n_modes} modes "
        f"({', '.join(setup.model.labels)}), prepared in {load_s:.2f} s"
    )
    integrators.integrate(setup.system, setup.initial.y0, (0.0, 20 * dt), "midpoint", dt=dt)
    rows = []
    for method in METHODS:
        start = time.perf_counter()
        sol = integrators.integrate(
            setup.system, setup.initial.y0, (0.0, window), method, dt=dt, rtol=rtol
        )
        wall = time.perf_counter() - start
        steps = int(sol.stats.get("n_steps", 0))
        rows.append(
            {
                "method": method,
                "steps": steps,
                "wall_s": wall,
                "steps_per_s": steps / wall,
                "simulated_s_per_wall_s": window / wall,
                "n_rhs": int(sol.stats.get("n_rhs", 0)),
                "n_newton": int(sol.stats.get("n_newton", 0)),
                "status": sol.status,
            }
        )
    return rows


def staged_run(duration: str | None) -> dict:
    stages: dict[str, float] = {}
    t0 = time.perf_counter()
    run = simulate.apply_overrides(load_run_case(CASE), duration=duration)
    stages["load case"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    setup = simulate.prepare(run)
    stages["prepare (cached ROM, initial state, validity)"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = simulate.execute(setup)
    stages["integrate + diagnostics"] = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        write_outputs(result, Path(tmp), plots=True)
        stages["write results.nc, summary.json, PNGs"] = time.perf_counter() - t0
    stages["total"] = sum(stages.values())
    return {
        "duration_s": run.integration.duration,
        "steps": int(result.solution.stats.get("n_steps", 0)),
        "integration_wall_s": result.wall_s,
        "stages": stages,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--window", type=float, default=2.0, help="simulated s per method")
    parser.add_argument("--dt", type=float, default=0.5e-3, help="fixed step (s)")
    parser.add_argument("--rtol", type=float, default=1e-9, help="adaptive rtol")
    parser.add_argument("--duration", default=None, help='paper-41hz duration, e.g. "10 s"')
    parser.add_argument("--skip-run", action="store_true", help="throughput only")
    args = parser.parse_args()

    print(
        f"python {platform.python_version()}, numpy {np.__version__}, "
        f"{os.cpu_count()} CPUs, {platform.processor() or platform.machine()}"
    )
    rows = throughput(args.window, args.dt, args.rtol)
    print(f"\nROM throughput, {CASE} model, N = 5, window {args.window:g} s, dt = {args.dt:g} s")
    print(f"{'method':<16}{'steps':>8}{'wall (s)':>10}{'steps/s':>10}{'sim s/wall s':>14}")
    for r in rows:
        print(
            f"{r['method']:<16}{r['steps']:>8d}{r['wall_s']:>10.3f}{r['steps_per_s']:>10.0f}"
            f"{r['simulated_s_per_wall_s']:>14.3f}"
        )
    if args.skip_run:
        return
    info = staged_run(args.duration)
    print(
        f"\n`quadmodes run {CASE}` stages ({info['duration_s']:g} s simulated, "
        f"{info['steps']} steps)"
    )
    for stage, wall in info["stages"].items():
        print(f"{stage:<48}{wall:>10.2f} s")


if __name__ == "__main__":
    main()
