"""Validation suite, finite-element part: measured numbers against analytic and published
references (inflated sphere and capsule, rigid-body modes, the paper model's frequencies, the Kane
cantilever) and the paper model's mesh convergence.

Each check is a small function returning :class:`quadmodes.validation.report.Row` values;
``quadmodes validate`` runs the suite and writes the table to ``docs/validation.md``; the tests
run the fast checks directly.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla
from scipy.optimize import brentq

from quadmodes.case import Case, load_case
from quadmodes.fe.build import MembraneSpec, build_membrane_structure
from quadmodes.fe.membrane import MembraneSet
from quadmodes.fe.model import rigid_body_modes, second_order_force, tangent_stiffness
from quadmodes.mesh.revolution import capsule_surface, sphere_surface
from quadmodes.structure.modes import compute_modes
from quadmodes.structure.pipeline import build_modal_model, structure_for_case
from quadmodes.structure.prestress import inflate
from quadmodes.validation.report import Check, Row


def _paper_membrane_spec() -> MembraneSpec:
    m = load_case("paper-membrane")
    return MembraneSpec(
        m.material.thickness,
        m.material.youngs_modulus,
        m.material.poisson_ratio,
        m.material.density,
        m.pressure.value,
    )


def check_sphere() -> list[Row]:
    """Inflated sphere (R = 5 in): mean stress resultant and volume change vs the exact
    finite-strain St Venant–Kirchhoff membrane sphere."""
    spec = _paper_membrane_spec()
    radius = 0.127
    surface = sphere_surface(radius, radius / 12)
    structure = build_membrane_structure(surface.points, surface.triangles, spec)
    state = inflate(structure)
    et = spec.thickness * spec.youngs_modulus / (1 - spec.poisson_ratio)
    stretch = brentq(lambda s: et * (s * s - 1) - spec.pressure * radius * s, 1.0, 1.5)
    membrane = next(e for e in structure.elements if isinstance(e, MembraneSet))
    mean = np.sum(state.stress_resultants.mean(1) * membrane.area0) / membrane.area0.sum()
    src = "references §7: sphere pr/2 (finite-strain SVK)"
    return [
        Row(
            "sphere: mean stress resultant",
            mean,
            spec.pressure * radius * stretch / 2,
            0.01,
            "N/m",
            source=src,
        ),
        Row("sphere: volume change", state.volume_change, stretch**3 - 1, 0.01, source=src),
        Row(
            "sphere: element scatter of resultant (max/min - 1)",
            state.stress_resultants.max() / state.stress_resultants.min() - 1,
            0.0,
            0.25,
            absolute=True,
            source="facet-discretisation scatter, reported",
        ),
    ]


def check_capsule() -> list[Row]:
    """Closed cylinder with hemispherical ends: hoop pr and axial pr/2 at mid-length."""
    spec = _paper_membrane_spec()
    radius, length = 0.127, 0.762
    surface = capsule_surface(radius, length, radius / 8)
    structure = build_membrane_structure(surface.points, surface.triangles, spec)
    state = inflate(structure)
    tri = surface.triangles
    mid = np.abs(state.x[tri].mean(1)[:, 2] - length / 2) < 0.15 * length
    r_def = np.mean(np.linalg.norm(state.x[np.unique(tri[mid]), :2], axis=1))
    p = spec.pressure
    src = "references §7: closed cylinder"
    return [
        Row(
            "cylinder: hoop resultant",
            state.stress_resultants[mid, 1].mean(),
            p * r_def,
            0.01,
            "N/m",
            source=src,
        ),
        Row(
            "cylinder: axial resultant",
            state.stress_resultants[mid, 0].mean(),
            p * r_def / 2,
            0.01,
            "N/m",
            source=src,
        ),
    ]


def check_rigid_modes(case: Case | None = None) -> list[Row]:
    """Free-free prestressed paper model: rigid-body frequencies and ‖KΨ‖."""
    model = build_modal_model(case or load_case("paper-membrane"))
    k = tangent_stiffness(model.structure, model.x)
    psi = rigid_body_modes(model.structure, model.x)
    scale = abs(k).sum(axis=1).max() * np.linalg.norm(psi, axis=0)
    ratio = np.max(np.abs(model.modes.rigid_frequencies_hz)) / model.modes.frequencies_hz[0]
    return [
        Row(
            "paper: max |rigid frequency| / first elastic",
            ratio,
            0.0,
            1e-3,
            absolute=True,
            source="issue: below 1e-3",
        ),
        Row(
            "paper: max ‖KΨ‖ / (‖K‖‖Ψ‖)",
            float(np.max(np.linalg.norm(k @ psi, axis=0) / scale)),
            0.0,
            1e-10,
            absolute=True,
            source="theory §9 step 1",
        ),
    ]


def paper_frequency_rows(model) -> list[Row]:
    f, labels = model.modes.frequencies_hz, model.labels

    def pair(label: str) -> float:
        return float(np.mean([fk for fk, lab in zip(f, labels, strict=True) if lab == label][:2]))

    axial = [fk for fk, lab in zip(f, labels, strict=True) if lab == "axial (rear mass)"]
    return [
        Row(
            "paper: rear-mass rocking pair",
            pair("rocking (rear mass)"),
            31.2,
            0.01,
            "Hz",
            source="seed Fig. 3",
        ),
        Row("paper: bending pair", pair("bending"), 38.0, 0.01, "Hz", source="seed Fig. 5"),
        Row(
            "paper: rear-mass axial mode (calibration target, geometric mean)",
            float(axial[0]) if axial else float("nan"),
            float(np.sqrt(31.2 * 38.0)),
            0.01,
            "Hz",
            source="seed Fig. 4 (order only)",
        ),
    ]


def check_paper_frequencies() -> list[Row]:
    return paper_frequency_rows(build_modal_model(load_case("paper-membrane")))


def check_cantilever() -> list[Row]:
    """Kane beam as a clamped ANCF cable: ω̄ = ω√(ρA L⁴/EI) and the foreshortening of g¹¹."""
    case = load_case("kane-beam")
    b = case.beam
    model = build_modal_model(case)
    ei, rho_a = b.youngs_modulus * b.second_moment, b.density * b.area
    scale = np.sqrt(rho_a * b.length**4 / ei)
    omega_bar = model.modes.omega[::2][:3] * scale
    src = "references §8"
    rows = [
        Row(f"cantilever: ω̄{k + 1}", float(w), ref, 0.005, source=src)
        for k, (w, ref) in enumerate(zip(omega_bar, (3.5160, 22.0345, 61.6972), strict=True))
    ]
    rows.append(
        Row(
            "cantilever: foreshortening of g¹¹ (× L/a²)",
            foreshortening(case),
            -0.58097,
            0.01,
            source="references §4",
        )
    )
    return rows


def foreshortening(case: Case) -> float:
    """Axial tip displacement of g¹¹ = −½K⁻¹B(w, w) for the first bending mode scaled to unit
    tip deflection in one plane, times L/a² (clamped: plain solve)."""
    structure = structure_for_case(case)
    x = structure.reference
    modes = compute_modes(structure, x, 2)
    tip = np.flatnonzero(structure.translational)[-1]
    pair = modes.shapes[:2]
    # combine the degenerate pair into the bending mode with no tip motion along z
    a, b = pair[0][tip, 2], pair[1][tip, 2]
    w = b * pair[0] - a * pair[1]
    w = w / w[tip, 1]
    free = structure.free_dofs
    k = tangent_stiffness(structure, x)[free][:, free].tocsc()
    rhs = -second_order_force(structure, x, w, w).ravel()[free]
    g = np.zeros(3 * structure.n)
    g[free] = spla.spsolve(k, rhs)
    return float(g.reshape(-1, 3)[tip, 0] * case.beam.length)


def mesh_convergence(factors: tuple[float, ...] = (1.0, 1.41, 2.0)) -> list[dict]:
    """First five elastic frequencies of the paper model, refining every mesh length scale of the
    default case (edge length, curvature grading, attachment-rim refinement) by ``factors``."""
    base = load_case("paper-membrane")
    out = []
    for f in factors:
        m = base.mesh
        mesh = m.model_copy(
            update={
                "edge_length": m.edge_length / f,
                "elements_per_radius": (m.elements_per_radius or 0) * f or None,
                "elements_per_attach_radius": (m.elements_per_attach_radius or 0) * f or None,
            }
        )
        model = build_modal_model(base.model_copy(update={"mesh": mesh}))
        out.append(
            {
                "refinement": f,
                "edge_in": round(mesh.edge_length / 0.0254, 3),
                "nodes": int(model.structure.n),
                "frequencies_hz": [float(v) for v in model.modes.frequencies_hz[:5]],
                "labels": model.labels[:5],
            }
        )
    return out


FE_CHECKS: dict[str, Check] = {
    "sphere": check_sphere,
    "capsule": check_capsule,
    "rigid": check_rigid_modes,
    "paper-frequencies": check_paper_frequencies,
    "cantilever": check_cantilever,
}
