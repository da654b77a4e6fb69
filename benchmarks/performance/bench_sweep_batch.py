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
states from the single runs' (and whether they are equal bit for bit). Before each N's rows, a
comment line gives the contractions' cost per single step, each timed on its own in a tight
loop and counted per step (a lower bound of their part of a step: inside the step they sit on
its chain of dependent operations, which a tight loop of independent calls overlaps). Then (``--sweep``) the same points as a sweep (``quadmodes.sweeps.engine``) on a
LocalCluster of 2 workers, one task per point, and in a plain loop of
:func:`quadmodes.sweeps.points.run_point` in this process: a point's whole work (the time run
with its diagnostics and secular fits, the rotating-frame roots, the energy-sink estimate), the
part of it the integration loop takes, and the loop projected with the best batched/single
ratio of that N applied to all of each point's integration time (generous: the per-chunk Python
work included), with the bound of an integration that costs nothing.

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
def _repeat(which, mass, z, v, g, out_m, out_p, out_w, reps):
    """``reps`` evaluations of one contraction of the single kernel (0: 𝕄(s), 1: P_E(s, ν),
    2: P(s, ν), 3: W(ν)), nudging s each time."""
    for _ in range(reps):
        z[1] += 1e-15
        if which == 0:
            K._block_mass_matrix(mass, z, g, out_m)
        elif which == 1:
            K._block_products(mass, True, z, v, g, out_p)
        elif which == 2:
            K._block_products(mass, False, z, v, g, out_p)
        else:
            K._block_second(mass[3], v, out_w)


def contraction_share(sys, y0, dt, n_steps: int, repeat: int) -> str:
    """The contractions' cost per single compiled step (the work a batch shares), each timed
    alone (a lower bound, see the module docstring) and counted from the step's own counts: per Newton iteration one 𝕄 and one P_E (the
    residual), per step one P and one W (the Jacobian) and one 𝕄 (the advance)."""
    n = sys.n_modes
    mass = K._arrays(sys)[0]
    z, v = np.r_[1.0, y0[7:7 + n]], np.r_[y0[4:7], y0[7 + n:]]
    work = (np.empty((n + 3) ** 2), np.empty((n + 3, n + 3)), np.empty((n, n + 3)), np.empty((n, n)))
    for which in range(4):
        _repeat(which, mass, z, v, *work, 2)
    reps = 10 * n_steps
    idx = np.array([0, n_steps], np.int64)
    best, best_s = [np.inf] * 4, np.inf
    for _ in range(repeat):
        for which in range(4):
            t = time.perf_counter()
            _repeat(which, mass, z, v, *work, reps)
            best[which] = min(best[which], (time.perf_counter() - t) / reps)
        t = time.perf_counter()
        _, _, _, stats, _, _ = K.fixed_run(sys, y0, n_steps, dt, idx, *NEWTON, 0.0)
        best_s = min(best_s, (time.perf_counter() - t) / n_steps)
    its = stats["n_newton"] / stats["n_steps"]
    per_step = (its + 1) * best[0] + its * best[1] + best[2] + best[3]
    share = per_step / best_s
    return (f"N = {n}: single step {best_s * 1e6:.1f} us ({its:.2f} Newton iterations); the "
            f"contractions, timed one at a time, {per_step * 1e6:.1f} us per step ({share:.0%})")


def compare(n_modes: int, batches, n_steps: int, repeat: int) -> dict[int, float]:
    """Print the rows of the prototype table at N = ``n_modes``; returns {B: batched/single}."""
    ratios = {}
    sys, y_all, dt = initial_states(n_modes, np.linspace(1.0, 10.0, max(batches)))
    print("<!-- " + contraction_share(sys, y_all[0], dt, n_steps, repeat) + " -->", flush=True)
    single_runs(sys, y_all[:1], 2, dt)  # compile / load both kernels first
    batch_run(sys, y_all[:2], 2, dt)
    for b in batches:
        y0s = y_all[np.linspace(0, len(y_all) - 1, b).round().astype(int)]
        best = {"single": np.inf, "batched": np.inf}
        for _ in range(repeat):
            t = time.perf_counter()
            ref = single_runs(sys, y0s, n_steps, dt)
            best["single"] = min(best["single"], time.perf_counter() - t)
            t = time.perf_counter()
            got, info, fail = batch_run(sys, y0s, n_steps, dt, *NEWTON)
            best["batched"] = min(best["batched"], time.perf_counter() - t)
            if fail:
                raise RuntimeError(f"batched run failed at step {fail}: {info}")
        diff = float(np.max(np.abs(got - ref) / np.maximum(np.abs(ref).max(axis=0), 1e-300)))
        rate = {k: b * n_steps / v for k, v in best.items()}
        ratios[b] = rate["batched"] / rate["single"]
        print(f"| {n_modes} | {b} | {rate['single']:,.0f} | {rate['batched']:,.0f} | "
                    f"**{rate['batched'] / rate['single']:.2f}** | {diff:.1e} | "
                    f"{'yes' if np.array_equal(got, ref) else 'no'} |", flush=True)  # fmt: skip
    return ratios


def sweep_side_by_side(n_modes: int, points: int, duration: str, repeat: int,
                       ratio: float) -> None:  # fmt: skip
    """The same ``points`` cone angles as a sweep on 2 local workers and as a plain loop of
    run_point, the integration's share of a point, and what the kernel ratio ``ratio``
    (batched/single) would make of the loop: each point's integration time divided by it (all
    of it, the per-chunk Python work included: generous), the rest of the point unchanged."""
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
    print(f"| loop with the batched integration (projected, kernel ratio {ratio:.2f}) | "
          f"{best_loop / gain:.2f} | {points * steps * gain / best_loop:,.0f} | "
          f"{best_loop / gain / points * 1e3:.0f} |")
    print(f"integration loop (run_wall_s) / whole point: median {np.median(share):.2f} "
          f"(range {min(share):.2f}-{max(share):.2f}); sweep on 2 workers / loop: "
          f"{best_loop / best_sweep:.2f}x; batched integration / loop: {gain:.2f}x "
          f"(bound with an integration of no cost: {bound:.2f}x)", flush=True)


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
          "max rel. diff | bit for bit |\n|---|---|---|---|---|---|---|")
    ratios = {n: compare(n, batches, args.steps, args.repeat) for n in modes}
    if args.sweep:
        for n in modes:
            best = max(ratios[n].values())
            sweep_side_by_side(n, args.sweep_points, args.sweep_duration, args.repeat, best)
    print(f"load average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
