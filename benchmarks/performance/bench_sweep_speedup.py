"""Sweep speed-up (issue 12): one spin sweep on a LocalCluster of 1 worker and on one of 2
workers, side by side in one run, the ratio of their wall times, and the per-point overhead of
the dask path against a plain in-process loop over the same points
(:func:`quadmodes.sweeps.points.run_point`).

The points share one reduced model (``reduced.reference = "rest"`` and a fixed mode count), so
what is timed is the per-point work (time run, linearisations, energy-sink estimate) and the
machinery around it, not model builds. Both clusters are started and warmed up (worker start,
imports, the compiled integrator) before any clock starts; then the three runs (loop, 1 worker,
2 workers) are timed in turn, ``--repeats`` rounds, each sweep from an empty output folder, so
that a change of the machine's load hits all three alike. The best round of each is reported
(and the median).

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_sweep_speedup              # 64 points, 5 s runs
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_sweep_speedup --points 8 --duration "0.2 s"

Before timing it prints how long the whole benchmark should take (from the warm-up point).
The speed-up is bounded by the cores that are free: on a loaded machine it is below 2 (the load
average at the start and at the end is printed).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
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


class _Loop:
    """The plain loop: model built and the integrator compiled before any clock starts."""

    def __init__(self, plan):
        self.cases = [p.case for p in plan.points]
        self.model, self.counts = model_for_group(self.cases)
        start = time.perf_counter()
        run_point(self.cases[0], self.model, self.counts[0])  # warm-up: the compiled integrator
        self.first_s = time.perf_counter() - start

    def per_point_s(self) -> float:
        """Wall time of one warm point (s), for the estimate."""
        start = time.perf_counter()
        run_point(self.cases[-1], self.model, self.counts[-1])
        return time.perf_counter() - start

    def __call__(self) -> float:
        start = time.perf_counter()
        for case, n in zip(self.cases, self.counts, strict=True):
            run_point(case, self.model, n)
        return time.perf_counter() - start


def _points_held(dask_worker) -> int:
    return sum(1 for key in dask_worker.data if "_point_task" in str(key))


def _timed_sweep(client, plan, folder: Path) -> tuple[float, list[int]]:
    """Wall time (s) of the sweep on ``client`` into the empty ``folder`` and how many of its
    points each worker ran."""
    before = client.run(_points_held)
    start = time.perf_counter()
    engine.execute(plan, folder, client)
    wall = time.perf_counter() - start
    after = client.run(_points_held)
    return wall, [after[w] - before.get(w, 0) for w in sorted(after)]


def _row(name: str, walls: list[float], n: int) -> str:
    best = min(walls)
    return (f"| {name} | {best:.2f} | {statistics.median(walls):.2f} | {best / n * 1e3:.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="paper-41hz-coarse")
    ap.add_argument("--points", type=int, default=64, help="spin values of the sweep")
    ap.add_argument("--duration", default="5 s", help="time run of each point")
    ap.add_argument("--modes", type=int, default=8)
    ap.add_argument("--repeats", type=int, default=2, help="timed rounds (loop, 1, 2 workers)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    load0 = os.getloadavg()[0]
    plan = _plan(args.case, args.points, args.duration, args.modes)
    warm = _plan(args.case, 2, "0.01 s", args.modes)
    n = len(plan.points)
    loop = _Loop(plan)
    point_s = loop.per_point_s()
    # loop + 1 worker + 2 workers (half the time on an idle machine), per round
    estimate = args.repeats * n * point_s * 2.5 + 30.0
    print(f"{args.case}: {n} points, {args.duration} time runs, {args.modes} modes about rest; "
          f"one point {point_s:.2f} s -> about {estimate / 60:.1f} min for the benchmark "
          f"(idle machine; longer when loaded)", flush=True)  # fmt: skip
    walls: dict[str, list[float]] = {"plain loop": [], "dask, 1 worker": [], "dask, 2 workers": []}
    split: list[int] = []
    with contextlib.ExitStack() as stack, tempfile.TemporaryDirectory() as tmp:
        one = stack.enter_context(engine.dask_client(1))
        two = stack.enter_context(engine.dask_client(2))
        for k, client in enumerate((one, two)):
            engine.execute(warm, Path(tmp) / f"warm-{k}", client)
        for r in range(args.repeats):
            walls["plain loop"].append(loop())
            walls["dask, 1 worker"].append(_timed_sweep(one, plan, Path(tmp) / f"one-{r}")[0])
            wall, split = _timed_sweep(two, plan, Path(tmp) / f"two-{r}")
            walls["dask, 2 workers"].append(wall)
    best = {name: min(w) for name, w in walls.items()}
    print("| run | best wall (s) | median wall (s) | per point (ms) |\n|---|---|---|---|")
    for name, w in walls.items():
        print(_row(name, w, n))
    overhead = (best["dask, 1 worker"] - best["plain loop"]) / n
    print(f"speed-up 1 -> 2 workers: {best['dask, 1 worker'] / best['dask, 2 workers']:.2f}x "
          f"(points per worker in the last 2-worker round {split}); dask overhead per point "
          f"(1 worker vs loop): {overhead * 1e3:.1f} ms "
          f"({(best['dask, 1 worker'] / best['plain loop'] - 1) * 100:.0f} %)")  # fmt: skip
    print(f"load average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end, on "
          f"{os.cpu_count()} cores; benchmark wall {time.perf_counter() - t0:.0f} s "
          f"(estimated {estimate:.0f} s)")  # fmt: skip


if __name__ == "__main__":
    main()
