"""What-if (not a model option): Q and Q4 with the quadratic modes in the projected chart,
g⊥ = g − ΦΦᵀMg, against the model's own chart, over a 4 s window of paper-41hz-coarse; the
secular cone-growth rate and mean dissipated power over the quasi-steady part (the rule of
``quadmodes compare``) as ratios to the full-order values passed on the command line (from
``quadmodes compare paper-41hz-coarse --window "4 s" --full-dt "0.25 ms"``).

    python -m benchmarks.studies.whatif_projected_chart --modes 5 --full-cone 0.010648 --full-power 0.010795
    python -m benchmarks.studies.whatif_projected_chart --modes 11 --full-cone 0.010515 --full-power 0.010516

The projected chart is made by swapping ``rom.reduced.quadratic_modes`` for the length of one
``reduce`` call; nothing in the package changes.
"""

import argparse

import numpy as np

from quadmodes.analysis.compare import series_from_run
from quadmodes.case import load_run_case
from quadmodes.fe.model import mass_matrix
from quadmodes.rom import reduced as red
from quadmodes.runs import secular, simulate
from quadmodes.structure import pipeline


def projected_quadratic_modes(structure, x, shapes, progress=None):
    """``g − ΦΦᵀMg`` (N, N, n, 3) of :func:`quadmodes.rom.reduced.quadratic_modes`."""
    g = ORIGINAL(structure, x, shapes, progress)
    phi = shapes.reshape(shapes.shape[0], -1).T
    flat = g.reshape(-1, phi.shape[0]).T
    flat = flat - phi @ (phi.T @ (mass_matrix(structure) @ flat))
    return flat.T.reshape(g.shape)


ORIGINAL = red.quadratic_modes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", type=int, default=5)
    ap.add_argument("--full-cone", type=float, required=True, help="full order, deg/s")
    ap.add_argument("--full-power", type=float, required=True, help="full order, W")
    args = ap.parse_args()
    run = simulate.apply_overrides(load_run_case("paper-41hz-coarse"), duration="4 s")
    run = run.model_copy(update={"reduced": run.reduced.model_copy(update={"modes": args.modes})})
    case = run.model_case()
    mm = pipeline.build_modal_model(case)
    n, zeta = args.modes, case.material.damping_ratio
    parts = (mm.structure, mm.x, mm.modes.frequencies_hz[:n], mm.modes.shapes[:n], mm.labels[:n], zeta)
    models = {"model's chart": red.reduce(*parts)}
    red.quadratic_modes = projected_quadratic_modes
    try:
        models["projected"] = red.reduce(*parts)
    finally:
        red.quadratic_modes = ORIGINAL
    tau = secular.decay_time(mm.modes.frequencies_hz[:n], np.full(n, zeta))
    interval = secular.quasi_steady_interval(4.0, tau)
    print(f"N = {n}, fits over {interval.start_s:g}-{interval.end_s:g} s, reduced / full")
    print("| chart | formulation | cone-growth rate | dissipated power |\n|---|---|---|---|")
    for chart, model in models.items():
        for f in ("Q", "Q4"):
            r = run.model_copy(update={"reduced": run.reduced.model_copy(update={"formulation": f})})
            fits = secular.secular_fits(series_from_run(f, simulate.execute(
                simulate.prepare(r, model, model_case=case))), interval)  # fmt: skip
            cone = np.degrees(fits["cone_growth"].slope) / args.full_cone
            power = fits["dissipated_power"].slope / args.full_power
            print(f"| {chart} | {f} | × {cone:.3f} | × {power:.3f} |", flush=True)


if __name__ == "__main__":
    main()
