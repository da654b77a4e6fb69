"""Offline build (inflation + modes) with SuperLU's two orderings, side by side in one run.

``old``: COLAMD with partial pivoting for every factorisation (the ordering before
:mod:`quadmodes.linalg.factor`); ``new``: minimum degree on A + Aᵀ with diagonal pivots for the
symmetric tangents (the default now). Rows alternate old/new ``--repeat`` times; the table gives
the best wall time of each, their ratio, and how far the results differ (inflated state, elastic
frequencies), which must be at the solver tolerance.

    python benchmarks/bench_factor.py --edges "1 in,0.39 in" --modes 10 --repeat 1
"""

import argparse
import time

import numpy as np

from quadmodes.case import load_case, parse_quantity
from quadmodes.linalg import factor
from quadmodes.structure import modes as qmodes
from quadmodes.structure import pipeline


def build(case, n_modes: int):
    """(inflated x (n,3) m, elastic frequencies (n_modes,) Hz, wall s) of the offline build."""
    start = time.perf_counter()
    structure = pipeline.structure_for_case(case)
    x, _ = pipeline.reference_state(case, structure)
    loaded = pipeline.with_gas_law(case, structure, x)
    result = qmodes.compute_modes(loaded, x, n_modes)
    return x, np.asarray(result.frequencies_hz), time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="paper-membrane")
    ap.add_argument("--edges", default="1 in,0.39 in", help="mesh edge lengths (quantities)")
    ap.add_argument("--modes", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    new_options = dict(factor.SYMMETRIC_OPTIONS)
    print("| edge | nodes | old (s) | new (s) | old / new | max Δx / extent | max Δf / f |")
    print("|---|---|---|---|---|---|---|")
    for edge in args.edges.split(","):
        base = load_case(args.case)
        h = parse_quantity(edge.strip(), "length", "--edges")
        case = base.model_copy(update={"mesh": base.mesh.model_copy(update={"edge_length": h})})
        times = {"old": [], "new": []}
        out = {}
        for _ in range(args.repeat):
            for label, options in (("old", factor.GENERAL_OPTIONS), ("new", new_options)):
                factor.SYMMETRIC_OPTIONS = options  # the benchmark's switch between orderings
                out[label] = build(case, args.modes)
                times[label].append(out[label][2])
        factor.SYMMETRIC_OPTIONS = new_options
        (x_old, f_old, _), (x_new, f_new, _) = out["old"], out["new"]
        extent = float(np.ptp(x_old, axis=0).max())
        dx = float(np.abs(x_new - x_old).max()) / extent
        df = float(np.max(np.abs(f_new - f_old) / f_old))
        t_old, t_new = min(times["old"]), min(times["new"])
        print(f"| {edge.strip()} | {x_old.shape[0]} | {t_old:.1f} | {t_new:.1f} | "
              f"{t_old / t_new:.2f} | {dx:.1e} | {df:.1e} |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
