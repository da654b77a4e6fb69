"""Does stepping many sweep points of one reduced model at once pay (issue 27, item 3)?

Points of a sweep that share one reduced model (only the initial state differs: here the
initial cone angle of ``paper-41hz-coarse``, B values between 1° and 10°) integrated

* **single**: one compiled kernel call per point (``midpoint_kernel.fixed_run``), one after
  the other in this process (what one sweep worker does today, point after point);
* **batched**: the lock-step prototype (:mod:`benchmarks.performance.batch_step_prototype`):
  one compiled call steps the B states together, the contractions with the quadratic-mode
  tensors (𝕄(s) and ½(∂𝕄/∂s_k)ν by blocks) evaluated for all B at once with the batch index
  innermost, the Newton solve per point;

alternating, best of ``--repeat``, for B = 1, 4, 16, 64 at N = 8, 16, 31: point-steps per
second and the ratio batched/single, and the largest relative difference of the batched final
states from the single runs' (and whether they are equal bit for bit). The column "bound" is
the same batch with every contraction skipped (``batch_run(..., free=True)``: two chord rounds
per step, as the real steps here make, on stale arrays; its states mean nothing): the rate of
the per-point work alone, hence the most that any faster form of the shared contractions (BLAS
products included) could give this design. The "BLAS batch" is the same prototype with the
contractions as matrix products (``batch_run(..., use_blas=True)``; equal to the single runs to
round-off only). A comment line after each N's rows gives the rate
of BLAS (GFMA/s) on the largest of the batched contractions, for the arithmetic of what a BLAS
form could reach.

Then (``--sweep``) the same points as a sweep (``quadmodes.sweeps.engine``) on a LocalCluster
of 2 workers, one task per point, and in a plain loop of
:func:`quadmodes.sweeps.points.run_point` in this process: a point's whole work (the time run
with its diagnostics and secular fits, the rotating-frame roots, the energy-sink estimate), the
part of it the integration loop takes, and the loop projected with the best batched/single
ratio of that N applied to all of each point's integration time (generous: the per-chunk Python
work included); the same with the bound's ratio, and with an integration that costs nothing.

    OPENBLAS_NUM_THREADS=1 nice -n 10 python -m benchmarks.performance.bench_sweep_batch
    OPENBLAS_NUM_THREADS=1 nice -n 10 python -m benchmarks.performance.bench_sweep_batch --modes 16 --batches 16 --sweep

Ratios measured side by side in one run are robust to the machine's load; absolute figures
are not. The reduced models come from the model cache (built once if missing: minutes for N =
31). Nothing here asserts on timings.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numba as nb
import numpy as np

from benchmarks.performance.batch_step_prototype import batch_run
from quadmodes.case import load_run_case
from quadmodes.rom import midpoint_kernel as K
from quadmodes.runs import simulate

CASE = "paper-41hz-coarse"
NEWTON = (1e-13, 25)


def _run(n_modes: int, duration: str | None = None, reference: str = "spinning"):
    run = load_run_case(CASE)
    red = run.reduced.model_copy(update={"modes": n_modes, "reference": reference})
    update = {"reduced": red}
    if duration is not None:
        from quadmodes.case.editing import edit

        run = edit(run, [("integration.duration", duration)], "benchmark")
    return run.model_copy(update=update)


def initial_states(n_modes: int, cones_deg) -> tuple:
    """(system, y0s (B, 7+2N), dt) of ``paper-41hz-coarse`` with N modes at the cone angles."""
    from quadmodes.runs.initial import initial_state

    run = _run(n_modes)
    setup = simulate.prepare(run)
    y0s = []
    for c in cones_deg:
        ini = run.initial.model_copy(update={"cone_angle": float(np.radians(c))})
        y0s.append(initial_state(setup.system, setup.model, run.model_copy(update={"initial": ini})).y0)
    return setup.system, np.array(y0s), float(run.integration.dt)


def single_runs(sys, y0s, n_steps, dt):
    """Final states (B, 7+2N) of one compiled call per point."""
    idx = np.array([0, n_steps], np.int64)
    out = []
    for y0 in y0s:
        ys, _, done, _, status, msg = K.fixed_run(sys, y0, n_steps, dt, idx, *NEWTON, 0.0)
        if status:
            raise RuntimeError(msg)
        out.append(ys[-1])
    return np.array(out)


@nb.njit
def _gemm_repeat(s, j, out, reps):
    for _ in range(reps):
        s[0, 0] += 1e-15
        np.dot(s, j, out)


def gemm_rate(n_modes: int, batch: int = 16, repeat: int = 3) -> float:
    """GFMA/s of BLAS (numba's np.dot) on the largest contraction of a batch, G = S·J2 with S
    (B, N) and J2 laid out (N, 9N): the rate a BLAS form of the batched contractions could hope
    for at these shapes."""
    rng = np.random.default_rng(1)
    s, j = rng.random((batch, n_modes)), rng.random((n_modes, 9 * n_modes))
    out = np.empty((batch, 9 * n_modes))
    _gemm_repeat(s, j, out, 2)
    reps, best = 5000, np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        _gemm_repeat(s, j, out, reps)
        best = min(best, (time.perf_counter() - t) / reps)
    return batch * n_modes * 9 * n_modes / best / 1e9


def compare(n_modes: int, batches, n_steps: int, repeat: int) -> dict[int, tuple]:
    """Print the rows of the prototype table at N = ``n_modes``; returns {B: (batched/single,
    bound/single)}."""
    ratios = {}
    sys, y_all, dt = initial_states(n_modes, np.linspace(1.0, 10.0, max(batches)))
    single_runs(sys, y_all[:1], 2, dt)  # compile / load both kernels first
    batch_run(sys, y_all[:2], 2, dt)
    batch_run(sys, y_all[:2], 2, dt, free=True)
    batch_run(sys, y_all[:2], 2, dt, use_blas=True)
    for b in batches:
        y0s = y_all[np.linspace(0, len(y_all) - 1, b).round().astype(int)]
        best = {"single": np.inf, "batched": np.inf, "blas": np.inf, "free": np.inf}
        for _ in range(repeat):
            t = time.perf_counter()
            ref = single_runs(sys, y0s, n_steps, dt)
            best["single"] = min(best["single"], time.perf_counter() - t)
            t = time.perf_counter()
            got, info, fail = batch_run(sys, y0s, n_steps, dt, *NEWTON)
            best["batched"] = min(best["batched"], time.perf_counter() - t)
            if fail:
                raise RuntimeError(f"batched run failed at step {fail}: {info}")
            t = time.perf_counter()
            got_blas, _, fail = batch_run(sys, y0s, n_steps, dt, *NEWTON, use_blas=True)
            best["blas"] = min(best["blas"], time.perf_counter() - t)
            if fail:
                raise RuntimeError(f"BLAS batch failed at step {fail}")
            t = time.perf_counter()
            batch_run(sys, y0s, n_steps, dt, *NEWTON, free=True)
            best["free"] = min(best["free"], time.perf_counter() - t)
        scale = np.maximum(np.abs(ref).max(axis=0), 1e-300)
        diff = float(np.max(np.abs(got - ref) / scale))
        diff_blas = float(np.max(np.abs(got_blas - ref) / scale))
        rate = {k: b * n_steps / v for k, v in best.items()}
        ratios[b] = (rate["batched"] / rate["single"], rate["free"] / rate["single"],
                     rate["blas"] / rate["single"])
        print(f"| {n_modes} | {b} | {rate['single']:,.0f} | {rate['batched']:,.0f} | "
                    f"**{rate['batched'] / rate['single']:.2f}** | {rate['blas']:,.0f} | "
              f"**{rate['blas'] / rate['single']:.2f}** | {rate['free'] / rate['single']:.2f} | "
              f"{diff:.1e} | {diff_blas:.1e} | "
                    f"{'yes' if np.array_equal(got, ref) else 'no'} |", flush=True)  # fmt: skip
    print(f"<!-- N = {n_modes}: BLAS on the largest contraction, (16 x {n_modes}) . "
          f"({n_modes} x {9 * n_modes}): {gemm_rate(n_modes):.1f} GFMA/s -->", flush=True)
    return ratios


def sweep_side_by_side(n_modes: int, points: int, duration: str, repeat: int,
                       ratio: float, bound_ratio: float, blas_ratio: float) -> None:  # fmt: skip
    """The same ``points`` cone angles as a sweep on 2 local workers and as a plain loop of
    run_point, the integration's share of a point, and what the kernel ratio ``ratio``
    (batched/single) would make of the loop: each point's integration time divided by it (all
    of it, the per-chunk Python work included: generous), the rest of the point unchanged; the
    same with ``bound_ratio`` (the batch with its contractions free)."""
    from quadmodes.sweeps import engine
    from quadmodes.sweeps.params import parse_param
    from quadmodes.sweeps.points import model_for_group, run_point

    run = _run(n_modes)
    mc = run.model_case()
    cones = ", ".join(f"{c:.4g} deg" for c in np.linspace(1.0, 10.0, points))
    params = [parse_param(f"initial.cone_angle={cones}", mc),
              parse_param(f"integration.duration={duration}", mc),
              parse_param(f"reduced.modes={n_modes}", mc)]  # fmt: skip
    plan = engine.plan_sweep(run, params)
    cases = [p.case for p in plan.points]
    model, counts = model_for_group(cases)
    run_point(cases[0], model, counts[0])  # warm-up
    best_loop, share, walls = np.inf, [], []
    with engine.dask_client(2) as client, tempfile.TemporaryDirectory() as tmp:
        engine.execute(plan, Path(tmp) / "warm", client)
        best_sweep = np.inf
        for r in range(repeat):
            t = time.perf_counter()
            results = [run_point(c, model, n) for c, n in zip(cases, counts, strict=True)]
            wall = time.perf_counter() - t
            if wall < best_loop:
                best_loop = wall
                share = [res["run_wall_s"] / res["wall_s"] for res in results]
                walls = [(res["wall_s"], res["run_wall_s"]) for res in results]
            t = time.perf_counter()
            engine.execute(plan, Path(tmp) / f"sweep-{r}", client)
            best_sweep = min(best_sweep, time.perf_counter() - t)
    steps = round(float(plan.points[0].case.run.integration.duration) / float(run.integration.dt))
    print(f"\nN = {n_modes}, {points} points of {duration} ({steps} steps each):")
    print("| run | wall (s) | point-steps/s | per point (ms) |\n|---|---|---|---|")
    for name, w in (("plain loop of run_point, 1 process", best_loop),
                    ("sweep, 2 local workers", best_sweep)):  # fmt: skip
        print(f"| {name} | {w:.2f} | {points * steps / w:,.0f} | {w / points * 1e3:.0f} |")
    whole = sum(w for w, _ in walls)
    gain = whole / sum(w - r + r / ratio for w, r in walls)
    bound = whole / sum(w - r for w, r in walls)
    free = whole / sum(w - r + r / bound_ratio for w, r in walls)
    blas = whole / sum(w - r + r / blas_ratio for w, r in walls)
    print(f"| loop with the batched integration (projected, kernel ratio {ratio:.2f}) | "
          f"{best_loop / gain:.2f} | {points * steps * gain / best_loop:,.0f} | "
          f"{best_loop / gain / points * 1e3:.0f} |")
    print(f"integration loop (run_wall_s) / whole point: median {np.median(share):.2f} "
          f"(range {min(share):.2f}-{max(share):.2f}); sweep on 2 workers / loop: "
          f"{best_loop / best_sweep:.2f}x; batched integration / loop: {gain:.2f}x; BLAS batch "
          f"({blas_ratio:.2f}x): {blas:.2f}x; with the "
          f"contractions free ({bound_ratio:.2f}x): {free:.2f}x; with an integration of no cost: "
          f"{bound:.2f}x", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", default="8,16,31")
    ap.add_argument("--batches", default="1,4,16,64")
    ap.add_argument("--steps", type=int, default=1000, help="steps per point of the kernel table")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sweep", action="store_true", help="also the sweep on 2 local workers")
    ap.add_argument("--sweep-points", type=int, default=16)
    ap.add_argument("--sweep-duration", default="2 s")
    args = ap.parse_args()
    modes = [int(m) for m in args.modes.split(",")]
    batches = [int(b) for b in args.batches.split(",")]
    load0 = os.getloadavg()[0]
    print(f"{CASE}: cone angles 1-10 deg, {args.steps} steps per point, best of {args.repeat}")
    print("| N | B | single, point-steps/s | batched, point-steps/s | **batched/single** | "
          "BLAS batch, point-steps/s | **BLAS/single** | bound: contractions free / single | "
          "max rel. diff, batched | max rel. diff, BLAS | batched bit for bit |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|")
    ratios = {n: compare(n, batches, args.steps, args.repeat) for n in modes}
    if args.sweep:
        for n in modes:
            best = max(r[0] for r in ratios[n].values())
            bound = max(r[1] for r in ratios[n].values())
            blas = max(r[2] for r in ratios[n].values())
            sweep_side_by_side(n, args.sweep_points, args.sweep_duration, args.repeat, best, bound,
                               blas)
    print(f"load average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
