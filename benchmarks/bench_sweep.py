"""Sweep throughput (issue 12): a spin sweep on a LocalCluster of 1 and of 2 workers, the
speed-up, and the per-point overhead of the dask path against a plain in-process loop over the
same points (:func:`quadmodes.sweeps.points.run_point`).

The points share one reduced model (``reduced.reference = "rest"`` and a fixed mode count), so
what is timed is the per-point work (time run, linearisations, energy-sink estimate) and the
machinery around it, not model builds. Each cluster first runs one warm-up point (worker start,
imports, the compiled integrator); the timed sweep then starts from an empty output folder.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_sweep.py                 # 64 points, 1 s runs
    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_sweep.py --points 8 --duration "0.2 s"

The speed-up is bounded by the cores that are free: on a loaded machine it is below 2.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

from quadmodes.case import load_run_case
from quadmodes.sweeps import engine
from quadmodes.sweeps.params import parse_param
from quadmodes.sweeps.points import model_for_group, run_point


def _plan(case: str, points: int, duration: str, modes: int):
    run = load_run_case(case)
    model_case = run.model_case()
    params = [parse_param(f"initial.spin_rate=5 Hz:40 Hz:{points}", model_case),
              parse_param(f"integration.duration={duration}", model_case),
              parse_param("reduced.reference=rest", model_case),
              parse_param(f"reduced.modes={modes}", model_case)]  # fmt: skip
    return engine.plan_sweep(run, params)


def _loop(plan) -> float:
    """Wall time (s) of the plain loop (model built before the clock starts)."""
    cases = [p.case for p in plan.points]
    model, counts = model_for_group(cases)
    run_point(cases[0], model, counts[0])  # warm-up: the compiled integrator
    start = time.perf_counter()
    for case, n in zip(cases, counts, strict=True):
        run_point(case, model, n)
    return time.perf_counter() - start


def _points_held(dask_worker) -> int:
    return sum(1 for key in dask_worker.data if "_point_task" in str(key))


def _dask(plan, warm, workers: int) -> tuple[float, list[int]]:
    """Wall time (s) of the sweep on a fresh LocalCluster of ``workers`` (after a warm-up) and
    how many of its points each worker ran."""
    with engine.dask_client(workers) as client, tempfile.TemporaryDirectory() as tmp:
        engine.execute(warm, Path(tmp) / "warm", client)
        before = client.run(_points_held)
        start = time.perf_counter()
        engine.execute(plan, Path(tmp) / "timed", client)
        wall = time.perf_counter() - start
        after = client.run(_points_held)
        return wall, [after[w] - before.get(w, 0) for w in sorted(after)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="paper-41hz-coarse")
    ap.add_argument("--points", type=int, default=64)
    ap.add_argument("--duration", default="1 s")
    ap.add_argument("--modes", type=int, default=8)
    args = ap.parse_args()
    plan = _plan(args.case, args.points, args.duration, args.modes)
    warm = _plan(args.case, 2, "0.01 s", args.modes)
    load = os.getloadavg()[0]
    loop = _loop(plan)
    one, _ = _dask(plan, warm, 1)
    two, split = _dask(plan, warm, 2)
    n = len(plan.points)
    print(f"{args.case}: {n} points, {args.duration} time runs, {args.modes} modes about rest")
    print("| run | wall (s) | per point (s) |\n|---|---|---|")
    for name, wall in (("plain loop", loop), ("dask, 1 worker", one), ("dask, 2 workers", two)):
        print(f"| {name} | {wall:.2f} | {wall / n:.3f} |")
    print(f"speed-up 1 -> 2 workers: {one / two:.2f}x (points per worker {split}); dask overhead "
          f"per point (1 worker vs loop): {(one - loop) / n * 1e3:.1f} ms "
          f"({(one / loop - 1) * 100:.0f} %); load average at the start {load:.1f} on "
          f"{os.cpu_count()} cores")
    if not math.isfinite(one / two):
        raise SystemExit("no timing")


if __name__ == "__main__":
    main()
