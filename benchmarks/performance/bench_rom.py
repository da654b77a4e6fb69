"""Reduced-order-model (ROM) integration benchmark for quadmodes (a plain script, not a test).

Three parts:

1. Integration throughput (steps/s) of the paper model's reduced model (N = 5 modes, from the
   reduced-model cache; built once if missing) for ``midpoint`` with each backend (``numpy``:
   the Python steppers; ``numba``: the compiled kernel of :mod:`quadmodes.rom.midpoint_kernel`),
   ``backward-euler`` and ``adaptive``, from the paper-41hz initial state (41 Hz spin, 6 deg
   cone), formulation Q, one :func:`quadmodes.rom.integrators.integrate` call per row over
   ``--window`` seconds (``--numba-window`` for the compiled kernel, which is ~30× faster), best
   of ``--repeat`` calls. Compilation is excluded (the kernel is warmed up first).
2. The numba kernel's first-call cost, in fresh processes: with an empty cache directory
   (``NUMBA_CACHE_DIR``; this is the one-off compilation) and again with that cache filled (what
   every later process pays).
3. The wall time of ``quadmodes run paper-41hz`` split by stage, running the same functions as the
   command in-process: load + validate the run case, ``simulate.prepare`` (reduced model from the
   cache, initial state, validity scan), ``simulate.execute`` (chunked integration +
   diagnostics), ``results.write_outputs`` (results.nc, summary.json, PNGs).

Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_rom          # everything (120 s run)
    python -m benchmarks.performance.bench_rom --duration "10 s"               # shorter paper-41hz run
    python -m benchmarks.performance.bench_rom --skip-run --window 2

Needs numba (a core dependency) for the numba rows; where it cannot be imported they are skipped.
Nothing here asserts on timings.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from quadmodes.case import load_run_case
from quadmodes.rom import integrators
from quadmodes.runs import simulate
from quadmodes.runs.results import write_outputs

CASE = "paper-41hz"
#: (method, backend) rows of the throughput table.
ROWS = (
    ("midpoint", "numpy"),
    ("midpoint", "numba"),
    ("backward-euler", "numpy"),
    ("adaptive", "numpy"),
)


def throughput(window: float, numba_window: float, dt: float, rtol: float, repeat: int):
    run = load_run_case(CASE)
    t0 = time.perf_counter()
    setup = simulate.prepare(run)
    load_s = time.perf_counter() - t0
    print(
        f"reduced model: {setup.model.n_modes} modes "
        f"({', '.join(setup.model.labels)}), prepared in {load_s:.2f} s"
    )
    have_numba = integrators.numba_kernel() is not None
    first_call = None
    if have_numba:  # compile, or load from the cache: excluded from the rates below
        t0 = time.perf_counter()
        integrators.integrate(
            setup.system, setup.initial.y0, (0.0, 20 * dt), "midpoint", dt=dt, backend="numba"
        )
        first_call = time.perf_counter() - t0
    rows = []
    for method, backend in ROWS:
        if backend == "numba" and not have_numba:
            continue
        span = numba_window if backend == "numba" else window
        best = None
        for _ in range(max(1, repeat)):
            start = time.perf_counter()
            sol = integrators.integrate(
                setup.system, setup.initial.y0, (0.0, span), method, dt=dt, rtol=rtol,
                backend=backend, save_every=4,
            )  # fmt: skip
            wall = time.perf_counter() - start
            best = wall if best is None else min(best, wall)
        steps = int(sol.stats.get("n_steps", 0))
        rows.append(
            {
                "method": method,
                "backend": sol.stats.get("backend", backend),
                "window_s": span,
                "steps": steps,
                "wall_s": best,
                "steps_per_s": steps / best,
                "simulated_s_per_wall_s": span / best,
                "n_rhs": int(sol.stats.get("n_rhs", 0)),
                "n_newton": int(sol.stats.get("n_newton", 0)),
                "status": sol.status,
            }
        )
    return rows, first_call


def compile_times() -> dict | None:
    """First-call wall time (s) of the numba kernel in fresh processes: ``cold`` with an empty
    ``NUMBA_CACHE_DIR`` (compilation), ``warm`` with that cache filled; ``import`` of numba."""
    if integrators.numba_kernel() is None:
        return None
    code = (
        "import time; t = time.perf_counter(); import numba; i = time.perf_counter() - t; "
        "from quadmodes.rom import midpoint_kernel as k; print(i, k.warm_up())"
    )
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
        for key in ("cold", "warm"):
            res = subprocess.run(
                [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
            )
            imp, first = map(float, res.stdout.split())
            out[key] = first
            out["import"] = imp
    return out


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
    parser.add_argument("--window", type=float, default=2.0, help="simulated s per numpy row")
    parser.add_argument(
        "--numba-window", type=float, default=20.0, help="simulated s for the numba row"
    )
    parser.add_argument("--repeat", type=int, default=3, help="calls per row (best is kept)")
    parser.add_argument("--dt", type=float, default=0.5e-3, help="fixed step (s)")
    parser.add_argument("--rtol", type=float, default=1e-9, help="adaptive rtol")
    parser.add_argument("--duration", default=None, help='paper-41hz duration, e.g. "10 s"')
    parser.add_argument("--skip-run", action="store_true", help="throughput only")
    args = parser.parse_args()

    try:
        import numba

        jit = f"numba {numba.__version__}"
    except ImportError:
        jit = "no numba"
    print(
        f"python {platform.python_version()}, numpy {np.__version__}, {jit}, "
        f"{os.cpu_count()} CPUs, {platform.processor() or platform.machine()}, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    rows, first_call = throughput(args.window, args.numba_window, args.dt, args.rtol, args.repeat)
    print(f"\nROM throughput, {CASE} model, N = 5, dt = {args.dt:g} s, best of {args.repeat}")
    print(
        f"{'method':<16}{'backend':<8}{'window':>8}{'steps':>8}{'wall (s)':>10}"
        f"{'steps/s':>10}{'sim s/wall s':>14}"
    )
    for r in rows:
        print(
            f"{r['method']:<16}{r['backend']:<8}{r['window_s']:>8g}{r['steps']:>8d}"
            f"{r['wall_s']:>10.3f}{r['steps_per_s']:>10.0f}{r['simulated_s_per_wall_s']:>14.3f}"
        )
    rate = {(r["method"], r["backend"]): r["steps_per_s"] for r in rows}
    if ("midpoint", "numba") in rate:
        ratio = rate[("midpoint", "numba")] / rate[("midpoint", "numpy")]
        print(f"midpoint numba / numpy: {ratio:.1f}x")
        print(f"first numba call in this process (cache load or compile): {first_call:.2f} s")
        ct = compile_times()
        print(
            f"fresh process: import numba {ct['import']:.2f} s; first kernel call "
            f"{ct['cold']:.1f} s with an empty cache (compilation), {ct['warm']:.2f} s cached"
        )
    print(f"load average after: {os.getloadavg()[0]:.2f}")
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
