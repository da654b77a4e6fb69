"""The FE model's condensed energy along the +bending ray against the reduced potentials.

For a run case (its model, 5 modes about the state at rest), at initial bending amplitudes
r = 1/8 … 2 in (largest nodal displacement of the first bending mode): Q, Q4, W_red and W_c
(docs/potentials.md for the definitions), W_c/Q, whether W_c's Newton converged and the
fraction of membrane elements in compression at the W_c minimiser. Used for the large
amplitude study in docs/full-order.md (with the built-in ``paper-0.5hz`` and with its model
switched to ``[material] wrinkling = "tension-field"``).

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_bending_ray [RUN_CASE] [--steps 16]

Several minutes on the default mesh (each W_c is a bordered Newton on the whole model).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.common import compressed_fraction, modal_scale, one_ray, run_case_with_modes
from quadmodes.experimental import candidate_potentials as cand
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import manifold_energy as me
from quadmodes.structure import pipeline

INCH = 0.0254


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", nargs="?", default="paper-0.5hz")
    ap.add_argument("--steps", type=int, default=16, help="amplitudes 2 in × k/steps")
    args = ap.parse_args()
    run = run_case_with_modes(args.case, 5, "1 s")
    mc = run.model_case()
    model = reduced_model_for(mc, 5)
    scale = modal_scale(model)
    structure = pipeline.with_gas_law(mc, pipeline.structure_for_case(mc), model.X)
    ctx = me.energy_context(structure, model.X, model)
    kb = next(i for i, label in enumerate(model.labels) if "bend" in label)
    radii = 2 * INCH * np.arange(1, args.steps + 1) / args.steps
    minimisers: list = []
    t0 = time.perf_counter()
    e, info = one_ray(ctx, model, cand.quartic_system(model), scale, np.eye(5)[kb], radii,
                      minimisers)  # fmt: skip
    print(f"{args.case}, mode {kb} ({model.labels[kb]}), {time.perf_counter() - t0:.0f} s")
    print("| r (in) | Q (J) | Q4 (J) | W_red (J) | W_c (J) | W_c/Q | W_c converged | compressed |")
    print("|---|---|---|---|---|---|---|---|")
    for j, r in enumerate(radii):
        u = me.manifold_displacement(ctx, r * np.eye(5)[kb] / scale[kb]) + minimisers[j]
        cf = compressed_fraction(structure, ctx.x0 + u.reshape(-1, 3))
        print(f"| {r / INCH:.3f} | {e[j, 0]:.5g} | {e[j, 1]:.5g} | {e[j, 3]:.5g} | {e[j, 4]:.5g} "
              f"| {e[j, 4] / e[j, 0]:.4f} | {'yes' if info[j, 0] else 'no'} | {cf:.3f} |")


if __name__ == "__main__":
    main()
