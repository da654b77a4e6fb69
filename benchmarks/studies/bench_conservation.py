"""Conservation of the default reduced model in the time step (issue 9, "Conservation"):
undamped, from the run case's initial state, 10⁵ midpoint steps on the compiled kernel and
2×10⁴ on the numpy stepper; prints the largest relative energy error, its trend (mean of the
last tenth minus mean of the first tenth) and the largest relative |H| error, for Q and Q4.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_conservation [--case paper-41hz-coarse]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from quadmodes.case import load_run_case
from quadmodes.rom import diagnostics as dg
from quadmodes.rom import integrators as it
from quadmodes.rom import system as rsys
from quadmodes.runs import simulate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="paper-41hz-coarse")
    ap.add_argument("--steps", type=int, default=100_000)
    args = ap.parse_args()
    setup = simulate.prepare(load_run_case(args.case))
    model = dataclasses.replace(setup.model, C=0 * setup.model.C)
    dt = setup.run.integration.dt
    print(f"{args.case}: N = {model.n_modes}, reference spin {model.reference_spin:.6g} rad/s, "
          f"dt = {dt * 1e3:g} ms, undamped")  # fmt: skip
    print("| formulation | backend | steps | max abs(dE)/E | trend dE/E | max abs(d abs(H))/abs(H) "
          "| steps/s |\n|---|---|---|---|---|---|---|")  # fmt: skip
    for f in ("Q", "Q4"):
        sys = rsys.reduced_system(model, f)
        for backend, n in (("numba", args.steps), ("numpy", args.steps // 5)):
            if backend == "numba" and it.numba_kernel() is None:
                continue
            start = time.perf_counter()
            sol = it.integrate(sys, setup.initial.y0, (0.0, n * dt), "midpoint", dt=dt,
                               backend=backend, save_every=10)  # fmt: skip
            wall = time.perf_counter() - start
            d = dg.diagnostics(sys, sol)
            de = (d.E - d.E[0]) / abs(d.E[0])
            k = max(len(de) // 10, 1)
            h = np.abs(d.H_norm / d.H_norm[0] - 1.0).max()
            print(f"| {f} | {backend} | {n} | {np.abs(de).max():.2e} | "
                  f"{de[-k:].mean() - de[:k].mean():.2e} | {h:.1e} | {n / wall:.3g} |", flush=True)


if __name__ == "__main__":
    main()
