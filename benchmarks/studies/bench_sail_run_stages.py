"""What the reduced run of the IKAROS-like sail spends once its model is loaded (issue 26; docs/
performance.md, "The reduced run of the IKAROS-like sail, per simulated second"): for each
window, the median of ``--repeats`` of its chunked integration (``integrate_run``), of the
path's FE checks (``run_path_validity`` with the checks ``quadmodes run`` makes) and of the
whole ``simulate.execute`` (integration, diagnostics, path checks). Run it with two trees in
alternation to compare them side by side (``PYTHONPATH=<tree>/src``). Nothing is asserted::

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=src python -m benchmarks.studies.bench_sail_run_stages
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from quadmodes.case import load_run_case  # noqa: E402
from quadmodes.case.editing import edit  # noqa: E402
from quadmodes.runs import simulate  # noqa: E402
from quadmodes.runs.path_validity import run_path_validity  # noqa: E402
from quadmodes.runs.step_chunks import integrate_run  # noqa: E402


def _median_ms(call, repeats: int) -> float:
    walls = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        walls.append(time.perf_counter() - start)
    return 1e3 * float(np.median(walls))


def stages(case: str, window: float, repeats: int) -> tuple[int, float, float, float]:
    """(steps, integration ms, path FE checks ms, execute ms) of ``case`` over ``window`` (s)."""
    run = edit(load_run_case(case), {"integration.duration": f"{window} s"}, "--windows")
    setup = simulate.prepare(run, check_deformation=True)
    result = simulate.execute(setup)  # also loads the compiled kernel
    integ = _median_ms(lambda: integrate_run(setup.system, setup.initial.y0, run.integration),
                       repeats)  # fmt: skip
    path = _median_ms(lambda: run_path_validity(setup, result.solution, result.diagnostics),
                      repeats)  # fmt: skip
    whole = _median_ms(lambda: simulate.execute(setup), repeats)
    return int(result.solution.stats["n_steps"]), integ, path, whole


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="ikaros-sail-nutation", help="run case")
    ap.add_argument("--windows", default="60,600", help="simulated windows (s), comma-separated")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--label", default=os.environ.get("PYTHONPATH", "this tree"))
    args = ap.parse_args()
    for window in (float(w) for w in args.windows.split(",")):
        steps, integ, path, whole = stages(args.case, window, args.repeats)
        print(f"{args.label} {window:g} s ({steps} steps): integration {integ:.1f} ms, path FE "
              f"checks {path:.0f} ms, execute {whole:.0f} ms (medians of {args.repeats})")


if __name__ == "__main__":
    main()
