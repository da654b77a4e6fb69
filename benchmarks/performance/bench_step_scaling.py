"""Cost of one reduced midpoint step against the number of modes N: the mass matrix by blocks
(:mod:`quadmodes.rom.structured_mass`, O(N²) per product, the default) against the dense mass
tensor (O(N⁴) per product, the evaluation before issue 27, kept as the reference behind
``dense=True``), side by side in one process, on both back ends (a plain script, not a test).

For each N (pairs whole) the reduced model of ``--case`` (default ``paper-41hz-coarse``, from
the model cache; built once if missing, which takes minutes for N ≳ 30) is integrated from the
case's initial state (41 Hz spin, 6 deg cone) with the case's Δt (0.5 ms):

* throughput: steps per second of the compiled kernel (``midpoint_kernel.fixed_run``) over
  ``--steps`` steps and of the numpy stepper (``fixed_step.run_fixed(MidpointStep(...))``) over
  ``--numpy-steps`` steps, old (dense) and new (the default: blocks; the numpy stepper keeps
  the dense tensor below ``structured_mass.NUMPY_BLOCKS_FROM`` modes, so there new = old;
  the column "blocks" forces blocks), best of ``--repeat``, alternating; the ratio new/old;
* agreement, on each back end, over ``--check-steps`` steps (sampled every 10): the max over
  samples and components of ``|y_blocks − y_dense| / max_t |y_dense|`` (per component: strict,
  a barely excited mode's velocity counts as much as the spin), the same normwise per part of
  the state (q, ω, s, ṡ: ``|Δ part| / max_t |part|``), and whether the two took the same
  Newton iterations; and, when both back ends ran the same check, how far the compiled and
  the numpy runs of one evaluation differ (dense against dense, blocks against blocks): the
  round-off floor of the comparison.

Usage (from the repository root)::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_step_scaling
    python -m benchmarks.performance.bench_step_scaling --modes 8,16 --check-steps 2000

The first call compiles the kernel (or loads it from numba's cache); it is excluded. Nothing
here asserts on timings; tests/test_structured_mass.py checks the agreement.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from quadmodes.case import load_run_case
from quadmodes.rom import integrators
from quadmodes.rom.fixed_step import run_fixed
from quadmodes.rom.midpoint import MidpointStep
from quadmodes.runs import simulate

NEWTON = (1e-13, 25)  # the defaults of integrators.integrate


def setup_for(case: str, n_modes: int):
    """(system, y0, dt (s)) of ``case`` with ``n_modes`` modes (model from the cache)."""
    run = load_run_case(case)
    run = run.model_copy(update={"reduced": run.reduced.model_copy(update={"modes": n_modes})})
    setup = simulate.prepare(run)
    return setup.system, setup.initial.y0, float(run.integration.dt)


def one_run(kernel, sys, y0, dt, n_steps, dense, every=None):
    """(ys, stats) of ``n_steps`` midpoint steps; ``kernel`` the compiled module or None."""
    idx = np.arange(0, n_steps + 1, every or n_steps, dtype=np.int64)
    if idx[-1] != n_steps:
        idx = np.append(idx, n_steps)
    if kernel is not None:
        out = kernel.fixed_run(sys, y0, n_steps, dt, idx, *NEWTON, 0.0, "midpoint", dense)
    else:
        step = MidpointStep(sys, dt, dense=dense)
        out = run_fixed(step, sys, y0, n_steps, dt, idx, *NEWTON, 0.0, "midpoint")
    ys, _, done, stats, status, msg = out
    if status:
        raise RuntimeError(msg)
    return ys, stats


def steps_per_second(kernel, sys, y0, dt, n_steps, repeat):
    """{dense: best steps/s} (dense True: old, None: the default, False: blocks) over
    ``repeat`` alternating runs of ``n_steps`` (the kernel's default is blocks)."""
    modes = (True, False) if kernel is not None else (True, None, False)
    best = dict.fromkeys(modes, 0.0)
    for _ in range(max(1, repeat)):
        for dense in modes:
            start = time.perf_counter()
            one_run(kernel, sys, y0, dt, n_steps, dense)
            best[dense] = max(best[dense], n_steps / (time.perf_counter() - start))
    best.setdefault(None, best[False])
    return best


def trajectories(kernel, sys, y0, dt, n_steps):
    """{dense: (ys sampled every 10 steps, stats)} of ``n_steps`` with the dense tensor (True)
    and by blocks (False)."""
    return {
        dense: one_run(kernel, sys, y0, dt, n_steps, dense, every=10) for dense in (True, False)
    }


def rel_diff(a, b, n):
    """(max_t,i |a − b| / max_t |a| per component i, the same normwise per part q, ω, s, ṡ)."""
    scale = np.abs(a).max(axis=0)
    scale[scale == 0.0] = 1.0
    parts = (slice(0, 4), slice(4, 7), slice(7, 7 + n), slice(7 + n, 7 + 2 * n))
    norm = max(float(np.linalg.norm(a[:, p] - b[:, p], axis=1).max()
                     / max(np.linalg.norm(a[:, p], axis=1).max(), 1e-300))
               for p in parts if p.stop > p.start)  # fmt: skip
    return float((np.abs(a - b) / scale).max()), norm


def measure(k, sys, y0, dt, steps, check, repeat):
    """(table row cells after N and back end, trajectories) of one back end."""
    for dense in (True, False):  # first-call costs (dense tensors, buffers) out of the timing
        one_run(k, sys, y0, dt, 2, dense)
    rate = steps_per_second(k, sys, y0, dt, steps, repeat)
    traj = trajectories(k, sys, y0, dt, check)
    diff, norm = rel_diff(traj[True][0], traj[False][0], sys.n_modes)
    same = traj[True][1]["n_newton"] == traj[False][1]["n_newton"]
    cells = (f"{rate[True]:,.0f} | {rate[None]:,.0f} | {rate[None] / rate[True]:.2f} | "
             f"{rate[False]:,.0f} | {diff:.1e} | {norm:.1e} | {check} | {same}")  # fmt: skip
    return cells, traj


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="paper-41hz-coarse")
    ap.add_argument("--modes", default="8,16,31,46", help="mode counts (pairs whole)")
    ap.add_argument("--steps", type=int, default=2000, help="compiled steps per timing")
    ap.add_argument("--numpy-steps", type=int, default=300, help="numpy steps per timing")
    ap.add_argument("--check-steps", type=int, default=10_000, help="steps of the agreement check")
    ap.add_argument("--numpy-check-steps", type=int, default=None,
                    help="numpy steps of the agreement check (default: --check-steps)")  # fmt: skip
    ap.add_argument("--backends", default="numba,numpy")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    kernel = integrators.numba_kernel()
    backends = [b for b in args.backends.split(",") if b != "numba" or kernel is not None]
    if kernel is not None and "numba" in backends:
        t0 = time.perf_counter()
        kernel.warm_up()
        print(f"numba kernel compiled or loaded in {time.perf_counter() - t0:.1f} s")
    print(f"{args.case}, {platform.processor() or platform.machine()}, python "
          f"{platform.python_version()}, numpy {np.__version__}")  # fmt: skip
    print("| N | back end | old (dense) steps/s | new steps/s | new/old | blocks steps/s "
          "| max rel. diff blocks/dense, per component | normwise | steps "
          "| same Newton its |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|")
    floor = []
    for n in (int(v) for v in args.modes.split(",")):
        sys, y0, dt = setup_for(args.case, n)
        traj = {}
        for backend in backends:
            k = kernel if backend == "numba" else None
            steps = args.steps if k is not None else args.numpy_steps
            check = args.check_steps if k is not None else (args.numpy_check_steps
                                                             or args.check_steps)  # fmt: skip
            cells, traj[backend] = measure(k, sys, y0, dt, steps, check, args.repeat)
            print(f"| {n} | {backend} | {cells} |", flush=True)
        a, b = traj.get("numba"), traj.get("numpy")
        if a and b and a[True][0].shape == b[True][0].shape:
            old, new = (rel_diff(a[d][0], b[d][0], n) for d in (True, False))
            floor.append(f"| {n} | {old[0]:.1e} | {old[1]:.1e} | {new[0]:.1e} | {new[1]:.1e} |")
    if floor:  # how far the two back ends of one evaluation already differ: round-off floor
        print("\ncompiled against numpy, the same evaluation (the round-off floor):")
        print("| N | dense, per component | dense, normwise | blocks, per component | "
              "blocks, normwise |\n|---|---|---|---|---|")  # fmt: skip
        print("\n".join(floor))


if __name__ == "__main__":
    main()
