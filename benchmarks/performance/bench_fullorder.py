"""Reduced model versus full order: cost per simulated second at 41 Hz spin, by mesh size.

For the paper model spinning at 41 Hz with a 6° cone (the paper-41hz initial state) on three
meshes (3 in, 2 in and 1 in elements; the 2 in mesh is ``paper-membrane-coarse``, the 1 in mesh
the default ``paper-membrane``), this measures

* the full-order transient (``quadmodes.fullorder``): wall time per step over ``--probe`` steps
  after the first, at the full order's step (default 0.25 ms, the step at which its cone-angle
  change is converged to a few %: docs/full-order.md), extrapolated to one simulated second;
* the reduced model (Q, 5 modes, midpoint at 0.5 ms, compiled kernel if numba is installed):
  integration of a whole simulated second, and the one-off precomputation (inflate, modes,
  quadratic modes) it needs;

and prints the speed-up of the reduced integration over the full order and the break-even
window including the precomputation. Nothing here asserts on timings. Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_fullorder
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_fullorder --edges 2,1 --probe 20
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from quadmodes.analysis.full_order_runs import estimate_for_run  # noqa: E402
from quadmodes.case import case_to_toml, load_case, load_run_case  # noqa: E402
from quadmodes.models import build as model_build  # noqa: E402
from quadmodes.runs import simulate  # noqa: E402


def run_for_mesh(edge_in: float, folder: Path):
    """paper-41hz-coarse's run on the coarse model re-meshed at ``edge_in`` inches."""
    base = load_case("paper-membrane-coarse")
    mesh = base.mesh.model_copy(update={"edge_length": edge_in * 0.0254})
    case = base.model_copy(update={"mesh": mesh, "name": f"paper-membrane-{edge_in:g}in"})
    path = folder / f"model-{edge_in:g}in.toml"
    path.write_text(case_to_toml(case))
    run = load_run_case("paper-41hz-coarse")
    return run.model_copy(update={"model": str(path), "name": f"paper-41hz-{edge_in:g}in"})


def measure(edge_in: float, full_dt: float, probe: int, folder: Path) -> dict:
    run = run_for_mesh(edge_in, folder)
    start = time.perf_counter()
    model = model_build.build_reduced_model(run.model_case(), run.reduced.modes)
    reduce_s = time.perf_counter() - start
    one_second = run.model_copy(
        update={"integration": run.integration.model_copy(update={"duration": 1.0})}
    )
    simulate.simulate(  # warm-up (kernel load), not timed
        one_second.model_copy(update={"integration": one_second.integration.model_copy(
            update={"duration": 0.01})}), model=model)  # fmt: skip
    rom = simulate.simulate(one_second, model=model)
    est = estimate_for_run(run, dt=full_dt, window=1.0, n_probe=probe)
    n = int(model.X.shape[0])
    full_s = est["estimate_s"]
    return {
        "edge_in": edge_in,
        "nodes": n,
        "reduce_s": reduce_s,
        "rom_s_per_sim_s": rom.wall_s,
        "rom_steps_per_s": rom.solution.stats["n_steps"] / rom.wall_s,
        "full_s_per_step": est["per_step_s"],
        "full_newton_per_step": est.get("newton_per_step", float("nan")),
        "full_s_per_sim_s": full_s,
        "speedup": full_s / rom.wall_s,
        "break_even_s": reduce_s / max(full_s - rom.wall_s, 1e-12),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--edges", default="3,2,1", help="element edge lengths (in)")
    ap.add_argument("--full-dt", type=float, default=2.5e-4, help="full-order step (s)")
    ap.add_argument("--probe", type=int, default=12, help="full-order steps timed")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for e in (float(v) for v in args.edges.split(",")):
            rows.append(measure(e, args.full_dt, args.probe, Path(tmp)))
            r = rows[-1]
            print(
                f"{r['edge_in']:g} in, {r['nodes']} nodes: full order {r['full_s_per_step'] * 1e3:.1f} "
                f"ms/step ({r['full_newton_per_step']:.1f} Newton/step) = {r['full_s_per_sim_s']:.0f} s "
                f"per simulated s; reduced {r['rom_s_per_sim_s']:.3f} s per simulated s "
                f"({r['rom_steps_per_s']:.3g} steps/s); speed-up {r['speedup']:.3g}; "
                f"precomputation {r['reduce_s']:.1f} s (break-even after {r['break_even_s']:.2g} "
                "simulated s)",
                flush=True,
            )
    print("\n| edge (in) | nodes | full order (ms/step) | full order (s per sim. s) | "
          "reduced (s per sim. s) | speed-up | precomputation (s) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['edge_in']:g} | {r['nodes']} | {r['full_s_per_step'] * 1e3:.1f} | "
            f"{r['full_s_per_sim_s']:.0f} | {r['rom_s_per_sim_s']:.3f} | {r['speedup']:.3g} | "
            f"{r['reduce_s']:.1f} |"
        )
    if len(rows) > 1:
        import math

        a, b = rows[0], rows[-1]
        k = math.log(b["full_s_per_step"] / a["full_s_per_step"]) / math.log(b["nodes"] / a["nodes"])
        print(f"\nfull-order time per step grows as nodes^{k:.2f} between {a['nodes']} and "
              f"{b['nodes']} nodes")  # fmt: skip


if __name__ == "__main__":
    main()
