"""Mesh study of the end-body attachment (issue 14): the paper model's rocking, axial and bending
frequencies with the end-body masses fixed, on meshes refined by the factors ``--factors``.

Each refinement factor f divides ``mesh.edge_length`` by f and multiplies
``mesh.elements_per_attach_radius`` (the grading at the patch rims and flange edges) by f, as
``quadmodes validate``'s mesh-convergence table does; a case without rim grading is refined
uniformly (``--rim-grading N`` gives it N elements per attach radius first). Modes are picked by
their labels (:func:`quadmodes.structure.labels.label_modes`): the rear-mass rocking pair, the
rear-mass axial mode, the bending pair and the front-mass rocking pair. Differences are relative to
the finest mesh (pair means).

Usage::

    nice -n 5 python -m benchmarks.studies.bench_end_body_mesh --quick          # coarse meshes, ~1 min
    nice -n 5 python -m benchmarks.studies.bench_end_body_mesh                  # factors 1, 1.41, 2, 2.83
    nice -n 5 python -m benchmarks.studies.bench_end_body_mesh --factors 1,2,4  # ~65k nodes at f = 4
    python -m benchmarks.studies.bench_end_body_mesh --case paper-membrane-rim --rim-grading 8
    python -m benchmarks.studies.bench_end_body_mesh --table run1.txt run2.txt   # tables of saved rows

Each row is also printed as one JSON line (frequencies in Hz, time in s), so the outputs of
several runs (say, the f = 4 mesh alone) can be joined into one table with ``--table``.

Results in docs/calibration.md ("Mesh-objective end bodies"). Nothing here asserts anything.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from quadmodes.case import Case, load_case
from quadmodes.structure.pipeline import build_modal_model

#: family -> (label, number of modes)
FAMILIES = {
    "rocking_rear": ("rocking (rear mass)", 2),
    "axial_rear": ("axial (rear mass)", 1),
    "bending": ("bending", 2),
    "rocking_front": ("rocking (front mass)", 2),
}
DEFAULT_CASES = ("paper-membrane", "paper-membrane-rim")


def refined(case: Case, factor: float, rim_grading: float | None) -> Case:
    """``case`` with its mesh length scales refined by ``factor`` (see the module docstring)."""
    m = case.mesh
    per_attach = m.elements_per_attach_radius or rim_grading
    mesh = m.model_copy(
        update={
            "edge_length": m.edge_length / factor,
            "elements_per_attach_radius": per_attach * factor if per_attach else None,
        }
    )
    return case.model_copy(update={"mesh": mesh, "modes": case.modes.model_copy(update={"count": 12})})


def family_frequencies(frequencies_hz: np.ndarray, labels: list[str]) -> dict[str, list[float]]:
    """family -> the frequencies (Hz) of its first modes by label (fewer if not found)."""
    out = {}
    for fam, (label, count) in FAMILIES.items():
        out[fam] = [float(f) for f, lab in zip(frequencies_hz, labels, strict=True) if lab == label][
            :count
        ]
    return out


def study(case_name: str, factors: list[float], rim_grading: float | None) -> list[dict]:
    """One row per factor: edge (in), nodes, build time (s) and family frequencies (Hz)."""
    base = load_case(case_name)
    rows = []
    for f in factors:
        case = refined(base, f, rim_grading)
        t0 = time.perf_counter()
        model = build_modal_model(case)
        row = {
            "case": case_name,
            "factor": f,
            "edge_in": case.mesh.edge_length / 0.0254,
            "elements_per_attach_radius": case.mesh.elements_per_attach_radius,
            "nodes": int(model.structure.n),
            "time_s": time.perf_counter() - t0,
            **family_frequencies(model.modes.frequencies_hz, model.labels),
        }
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def markdown(rows: list[dict]) -> str:
    """The study as a markdown table; (±x %) is the pair mean against the finest mesh."""
    finest = rows[-1]

    def cell(row: dict, fam: str) -> str:
        vals = row[fam]
        if not vals:
            return "—"
        text = "/".join(f"{v:.2f}" for v in vals)
        if finest[fam] and row is not finest:
            text += f" ({100 * (np.mean(vals) / np.mean(finest[fam]) - 1):+.2f} %)"
        return text

    head = (
        "| case | f | edge (in) | per attach r | nodes | rocking rear (Hz) | axial rear (Hz) "
        "| bending (Hz) | rocking front (Hz) |\n|---|---|---|---|---|---|---|---|---|"
    )
    lines = [head]
    for row in rows:
        per = row["elements_per_attach_radius"]
        lines.append(
            f"| {row['case']} | {row['factor']:g} | {row['edge_in']:.3g} | "
            f"{'—' if per is None else f'{per:.3g}'} | {row['nodes']} | "
            + " | ".join(cell(row, fam) for fam in FAMILIES)
            + " |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", action="append", help="case name or TOML (repeatable)")
    parser.add_argument("--factors", default="1,1.41,2,2.83", help="refinement factors, ascending")
    parser.add_argument("--rim-grading", type=float, default=None,
                        help="elements per attach radius for a case without rim grading")
    parser.add_argument("--quick", action="store_true", help="factors 0.5, 0.71, 1 (coarse)")
    parser.add_argument("--table", nargs="+", metavar="FILE",
                        help="print the tables of the JSON rows in these outputs; build nothing")
    args = parser.parse_args()
    if args.table:
        rows = [json.loads(line) for path in args.table for line in open(path)
                if line.startswith("{")]  # fmt: skip
        for name in dict.fromkeys(r["case"] for r in rows):
            mine = sorted((r for r in rows if r["case"] == name), key=lambda r: r["factor"])
            print(markdown(mine))
        return
    factors = [0.5, 0.71, 1.0] if args.quick else [float(f) for f in args.factors.split(",")]
    for name in args.case or DEFAULT_CASES:
        rows = study(name, factors, args.rim_grading)
        print(markdown(rows), flush=True)


if __name__ == "__main__":
    main()
