"""The IKAROS-like square sail (issue 26, second increment): its spinning reference state on a
sequence of meshes (largest displacement, largest principal stress resultant and where, the
hub-rim stress, the area not taut), the rotating-frame ω/Ω at two spins, and their convergence.

    OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg python -m benchmarks.studies.bench_ikaros_sail \\
        [--meshes 0.7,0.5,0.35,0.25,0.177,0.125] [--modal-meshes 0.7,0.5,0.35] [--spins 2.5,1]

The model is the built-in ``ikaros-sail`` with its edge length (m) and spin (rpm) set; about a
minute on one core for the defaults (0.125 m: 17 952 DOFs, reference state only).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from quadmodes.case import load_case
from quadmodes.case.editing import edit
from quadmodes.structure.pipeline import (
    build_modal_model,
    modes_summary,
    reference_state,
    structure_for_case,
)


def case_at(edge: float, spin_rpm: float | None = None, count: int | None = None):
    """ikaros-sail with edge ``edge`` (m), spin (rpm) and mode count changed."""
    changes = {"mesh.edge_length": f"{edge} m"}
    if spin_rpm is not None:
        changes["spin.rate"] = f"{spin_rpm} rpm"
    if count is not None:
        changes["modes.count"] = count
    return edit(load_case("ikaros-sail"), changes, "bench")


def state_figures(edge: float) -> dict:
    """Reference-state figures of ikaros-sail at edge ``edge`` (m)."""
    case = case_at(edge)
    t0 = time.perf_counter()
    st = structure_for_case(case)
    x, _ = reference_state(case, st)
    sets = [e for e in st.elements if hasattr(e, "principal_stress_resultants")]
    res = np.concatenate([e.principal_stress_resultants(x) for e in sets])
    centres = np.concatenate([
        e._virtual(st.reference).reshape(len(e.conn), -1, 3).mean(axis=1)
        if hasattr(e, "inner") else st.reference[e.conn].mean(axis=1) for e in sets
    ])  # fmt: skip
    area = np.concatenate([e.inner.area0 if hasattr(e, "inner") else e.area0 for e in sets])
    k = int(np.argmax(res[:, 1]))
    rim = np.hypot(*centres[:, :2].T) < 0.8 + 2 * edge
    disp = np.linalg.norm((x - st.reference)[st.translational], axis=1)
    return {
        "edge": edge, "dofs": st.n, "seconds": time.perf_counter() - t0,
        "max_displacement": float(disp.max()),
        "max_stress": float(res[k, 1]), "max_stress_at": centres[k, :2],
        "hub_rim_stress": float(res[rim, 1].max()),
        "not_taut": float(area[res[:, 0] <= 0].sum() / area.sum()),
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", default="0.7,0.5,0.35,0.25,0.177,0.125")
    ap.add_argument("--modal-meshes", default="0.7,0.5,0.35")
    ap.add_argument("--spins", default="2.5,1")
    a = ap.parse_args()
    print("| edge (m) | DOFs | build (s) | largest displacement (µm) | largest principal "
          "resultant (N/m) at (x, y) m | hub-rim resultant (N/m) | area not taut |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    rows = [state_figures(float(h)) for h in a.meshes.split(",")]
    for r in rows:
        x, y = r["max_stress_at"]
        print(f"| {r['edge']:g} | {r['dofs']} | {r['seconds']:.1f} | "
              f"{1e6 * r['max_displacement']:.3f} | {r['max_stress']:.4f} at ({x:.2f}, {y:.2f}) | "
              f"{r['hub_rim_stress']:.5f} | {100 * r['not_taut']:.2f} % |")  # fmt: skip
    last, prev = rows[-1], rows[-2]
    for key in ("max_displacement", "max_stress", "hub_rim_stress"):
        print(f"{key}: {100 * (last[key] / prev[key] - 1):+.2f} % between the two finest meshes")
    spins = [float(v) for v in a.spins.split(",")]
    ratios = {}
    for h in (float(v) for v in a.modal_meshes.split(",")):
        for spin in spins:
            model = build_modal_model(case_at(h, spin, 12))
            ratios[h, spin] = np.array(modes_summary(model)["spinning_reference"]["frequency_ratios"])
            print(f"edge {h:g} m, {spin:g} rpm: ω/Ω = " + ", ".join(f"{r:.4f}" for r in ratios[h, spin])
                  + f"   ({', '.join(model.labels[:4])}, …)")  # fmt: skip
    spread = max(np.abs(ratios[h, spins[-1]] / ratios[h, spins[0]] - 1).max()
                 for h in {k[0] for k in ratios})  # fmt: skip
    print(f"ω/Ω at {spins[-1]:g} vs {spins[0]:g} rpm: largest relative difference {spread:.1e}")


if __name__ == "__main__":
    main()
