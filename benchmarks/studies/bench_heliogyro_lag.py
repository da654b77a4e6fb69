"""The heliogyro blades' lag (in-plane bending) against the mesh across their width
(docs/sails.md, "A spin-rate change: heliogyro-spinup").

For each edge length of ``heliogyro-blade`` (the structured grid puts ceil(0.5 m / h) cells
across each blade): the model of ``heliogyro-spinup`` (the lowest mode the hub's torque drives,
about 1 rad/s), its lag frequency, the peak tip lag of the 1 → 1.5 rad/s change in 30 s, the
FE model's free DOFs and the build's wall time; against the beam-string quasi-static tip lag
(``tests/reference/blade_lag.py``, Ω = 1.25 rad/s, α = 1/30 rad/s² at T/2). Nothing is
asserted. Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_heliogyro_lag --edges 0.25,0.125
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from quadmodes.case import load_case  # noqa: E402
from quadmodes.case.editing import edit  # noqa: E402
from quadmodes.runs.spin_change import spin_change, spin_change_model  # noqa: E402
from quadmodes.structure.pipeline import structure_for_case  # noqa: E402


def beam_reference(case) -> float:
    """The beam-string quasi-static tip lag (m) at the ramp's middle."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
    from reference.blade_lag import beam_string_tip_lag

    g, m = case.geometry, case.material
    b = 0.5 * g.inner_diameter
    mu = m.density * m.thickness * g.width
    ei = m.youngs_modulus * m.thickness * g.width**3 / 12.0
    return beam_string_tip_lag(1.0 / 30.0, 1.25, b, b + g.length, mu, ei)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--edges", default="0.25,0.125", help="mesh edge lengths (m)")
    args = ap.parse_args()
    base = load_case("heliogyro-blade")
    ref = beam_reference(base)
    print(f"beam-string reference tip lag {ref * 1e3:.3f} mm")
    print("| edge (m) | across | free DOFs | build (s) | lag (rad/s) | peak tip lag (mm) | vs beam |")
    print("|---|---|---|---|---|---|---|")
    for h in (float(e) for e in args.edges.split(",")):
        case = edit(base, {"mesh.edge_length": f"{h} m"}, "--edges")
        n_dof = int(structure_for_case(case).free_dofs.size)
        t0 = time.perf_counter()
        model = spin_change_model(case, 1, 1.0)
        build = time.perf_counter() - t0
        r = spin_change(model, 1.0, 1.5, 30.0, 60.0, n_out=601)
        lag = 2.0 * math.pi * float(model.frequencies_hz[0])
        across = math.ceil(base.geometry.width / h - 1e-9)
        print(f"| {h:g} | {across} | {n_dof} | {build:.1f} | {lag:.4f} | "
              f"{r.peak_deflection * 1e3:.3f} | {r.peak_deflection / ref - 1:+.1%} |", flush=True)


if __name__ == "__main__":
    main()
