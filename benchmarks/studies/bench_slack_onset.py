"""Where and at what amplitude the inflated membrane first loses tension, per mode, and how much
softer the FE model's condensed energy becomes beyond that (issue 9, large amplitude).

For each model: the linearised onset of wrinkling along each of the lowest modes (the largest
nodal displacement of ``s u^k`` at which a membrane element off the bonded end-body patches
first has a non-positive principal stress, :mod:`quadmodes.structure.tension_margin`), where
that element is, its minor principal stress resultant at rest, and the fraction of the membrane
(by area) that the linearised stress puts out of tension at 1/16, 1/4 and 1/2 in. With ``--backbone``
also the FE model's statically condensed energy W_c along the +bending ray over ½ sᵀΛs, for the
St Venant–Kirchhoff membrane and for the tension-field (wrinkling) membrane of the same model
(continuation from the smaller amplitude; each point a bordered Newton on the whole model).

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_slack_onset \\
        [--models paper-membrane,paper-membrane-rim,paper-membrane-coarse] [--modes 5] \\
        [--backbone "0.015625,0.0625,0.25,0.5,1,2"]

The onset table takes about a minute per model once the models are cached; the backbone on the
6,085-node default model about 5 min per material up to 2 in.
"""

from __future__ import annotations

import argparse
import time
import tomllib

import numpy as np

from quadmodes.case import case_from_dict, load_case
from quadmodes.experimental import candidate_potentials as cand
from quadmodes.fe.membrane import MembraneSet
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import manifold_energy as me
from quadmodes.structure import pipeline
from quadmodes.structure.tension_margin import bonded_elements, element_slack_onset

INCH = 0.0254


def with_wrinkling(case):
    """The model case with the tension-field membrane (same mesh, modes of the taut state)."""
    data = tomllib.loads(case.to_toml())
    data["material"]["wrinkling"] = "tension-field"
    data["name"] = f"{case.name}-tension-field"
    return case_from_dict(data, source="bench_slack_onset")


def model_and_structure(case, modes: int):
    model = reduced_model_for(case, modes)
    structure = pipeline.with_gas_law(case, pipeline.structure_for_case(case), model.X)
    return model, structure


def onset_rows(name: str, modes: int) -> list[str]:
    """Markdown rows: one per mode of the model ``name`` (about its state at rest)."""
    model, structure = model_and_structure(load_case(name), modes)
    x0 = np.asarray(model.X, float)
    membrane = next(e for e in structure.elements if isinstance(e, MembraneSet))
    off_patch = ~bonded_elements(structure, membrane)
    rest_minor = membrane.principal_stress_resultants(x0)[:, 0]
    centroid = x0[membrane.conn].mean(axis=1)
    z_mid = 0.5 * (x0[:, 2].min() + x0[:, 2].max())
    rows = []
    for k in range(model.n_modes):
        u = np.asarray(model.Phi[k], float)
        u = u / np.max(np.linalg.norm(u, axis=1))  # unit largest nodal displacement (m)
        onset = np.where(off_patch, element_slack_onset(membrane, x0, u), np.inf)
        first = int(np.argmin(onset))
        c = centroid[first]
        end = "front" if c[2] < z_mid else "rear"
        area = membrane.area0[off_patch]
        slack = [float(np.average(onset[off_patch] <= a * INCH, weights=area))
                 for a in (1 / 16, 0.25, 0.5)]  # fmt: skip
        rows.append(f"| {name} | {k + 1} {model.labels[k]} | {onset[first] / INCH:.4f} | {end}, "
                    f"r = {np.hypot(c[0], c[1]) / INCH:.3f} in | {rest_minor[first]:.1f} | "
                    + " | ".join(f"{100 * f:.1f} %" for f in slack) + " |")  # fmt: skip
    return rows


def backbone(name: str, modes: int, radii_in: list[float], wrinkling: bool) -> list[str]:
    """Markdown rows of W_c/Q along the +bending ray of model ``name``."""
    case = load_case(name)
    if wrinkling:
        case = with_wrinkling(case)
    model, structure = model_and_structure(case, modes)
    ctx = me.energy_context(structure, model.X, model)
    kb = next(i for i, label in enumerate(model.labels) if "bend" in label)
    scale = np.max(np.linalg.norm(np.asarray(model.Phi[kb]), axis=1))
    rows, y = [], None
    for r in radii_in:
        s = r * INCH * np.eye(model.n_modes)[kb] / scale
        t0 = time.perf_counter()
        wc = me.condensed_energy(ctx, s, cand.best_start(ctx, s, [y]))
        if not wc.converged:
            wc = me.condensed_energy_along_ray(ctx, s)
        q = cand.quadratic_potential(model, s)
        rows.append(f"| {name} | {'tension field' if wrinkling else 'SVK'} | {r:g} | {q:.5g} | "
                    f"{wc.value:.5g} | {wc.value / q:.4f} | {'yes' if wc.converged else 'no'} | "
                    f"{time.perf_counter() - t0:.0f} |")  # fmt: skip
        print(rows[-1], flush=True)
        y = wc.unknowns if wc.converged else None
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", default="paper-membrane,paper-membrane-rim,paper-membrane-coarse")
    ap.add_argument("--modes", type=int, default=5)
    ap.add_argument("--backbone", default="", help="bending amplitudes (in), comma-separated")
    ap.add_argument("--backbone-model", default="paper-membrane")
    args = ap.parse_args()
    print("| model | mode | onset (in) | first element | its minor stress at rest (N/m) "
          "| slack at 1/16 in | at 1/4 in | at 1/2 in |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.models.split(","):
        print("\n".join(onset_rows(name.strip(), args.modes)), flush=True)
    if args.backbone:
        radii = [float(a) for a in args.backbone.split(",")]
        print("\n| model | membrane | r (in) | Q (J) | W_c (J) | W_c/Q | converged | wall (s) |")
        print("|---|---|---|---|---|---|---|---|")
        for wrinkling in (False, True):
            backbone(args.backbone_model, args.modes, radii, wrinkling)


if __name__ == "__main__":
    main()
