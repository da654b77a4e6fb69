"""The structure stage's pipeline from a validated case to a modal model: mesh -> structure ->
prestress -> modes -> labels.

Each step is a small function: :func:`structure_for_case` (mesh and stress-free finite-element
structure), :func:`reference_state` (inflation), :func:`with_gas_law` (pressure for vibrations
about the inflated state), :func:`build_modal_model` (all of them plus modes and labels, as a
:class:`ModalModel`) and :func:`modes_summary` (its JSON summary). The CLI, the calibration, the
reduction and the full-order runs call them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from quadmodes.case import Case
from quadmodes.case.plausibility import check_mass, check_strain_scale, volume_change_warning
from quadmodes.fe.beam import BeamSection, solid_section
from quadmodes.fe.build import (
    EndBodySpec,
    MembraneSpec,
    build_beam_structure,
    build_membrane_structure,
)
from quadmodes.fe.hub import BoomSpec, HubSpec, build_hub_structure
from quadmodes.fe.model import (
    Structure,
    centre_of_mass,
    inertia_tensor,
    total_mass,
    with_tension_field,
)
from quadmodes.fe.pressure import PressureSet
from quadmodes.mesh.io import read_surface
from quadmodes.mesh.revolution import (
    capsule_profile,
    flat_cylinder_profile,
    mesh_revolution,
    ring_arc_length,
    sphere_cone_profile,
    sphere_profile,
    with_ring_at_radius,
)
from quadmodes.mesh.surface import (
    TriangleSurface,
    check_closed_surface,
    enclosed_volume,
    min_angle_deg,
    surface_area,
)
from quadmodes.structure.boom_labels import boom_labels
from quadmodes.structure.labels import label_modes
from quadmodes.structure.modes import ModalResult, compute_modes
from quadmodes.structure.prestress import PrestressedState, inflate

Progress = Callable[[str, float], None]


def revolution_profile(case: Case):
    """``(profile, refinements)`` of a membrane of revolution: its meridian profile with a ring
    at each end body's attach radius and the mesh refinements there (for
    :func:`quadmodes.mesh.revolution.mesh_revolution`); None for a mesh-file geometry."""
    g = case.geometry
    profiles = {
        "sphere-cone": lambda: sphere_cone_profile(
            g.length, 0.5 * g.front_cap_diameter, 0.5 * g.rear_cap_diameter
        ),
        "sphere": lambda: sphere_profile(0.5 * g.diameter),
        "capsule": lambda: capsule_profile(0.5 * g.diameter, g.length),
        "flat-cylinder": lambda: flat_cylinder_profile(0.5 * g.diameter, g.length),
    }
    if g.shape not in profiles:
        return None
    profile = profiles[g.shape]()
    # a ring at each attach radius gives every end body a sharp, mesh-independent patch edge;
    # the membrane stress is singular at that rim, so the mesh is refined there
    # (a flange adds a ring, and the same refinement, at its outer edge: the thickness jumps there)
    refine = []
    for body in case.end_body:
        radii = [body.attach_radius] + ([body.flange_radius] if body.flange_radius else [])
        for radius in radii:
            profile = with_ring_at_radius(profile, body.pole, radius)
            if case.mesh.elements_per_attach_radius:
                s_ring = ring_arc_length(profile, body.pole, radius)
                refine.append((s_ring, body.attach_radius / case.mesh.elements_per_attach_radius))
    return profile, tuple(refine)


def surface_for_case(case: Case) -> TriangleSurface:
    """The stress-free membrane surface of a membrane case (m)."""
    revolution = revolution_profile(case)
    if revolution is not None:
        profile, refine = revolution
        surface = mesh_revolution(profile, case.mesh.edge_length, case.mesh.elements_per_radius,
                                  refine)  # fmt: skip
    else:
        surface = read_surface(case.geometry.file, case.geometry.file_scale())
    if case.pressure is not None and case.pressure.value > 0.0:
        check_closed_surface(surface)
    if min_angle_deg(surface.points, surface.triangles) < 5.0:
        raise ValueError("mesh: triangles with angles below 5° found; remesh or change edge_length")
    check_surface_plausibility(case, surface)
    return surface


def check_surface_plausibility(case: Case, surface: TriangleSurface) -> None:
    """Strain scale and mass of a membrane case on its surface
    (:mod:`quadmodes.case.plausibility`): R is the largest cap radius of a body of revolution,
    or the radius of the sphere of a mesh file's volume."""
    g = case.geometry
    if g.shape == "file":
        volume = abs(enclosed_volume(surface.points, surface.triangles))
        radius = (3.0 * volume / (4.0 * np.pi)) ** (1.0 / 3.0)
    else:
        radius = max(g.cap_radius("front") or 0.0, g.cap_radius("rear") or 0.0)
    if case.pressure is not None:
        check_strain_scale(case, radius)
    check_mass(case, surface_area(surface.points, surface.triangles))


def end_body_specs(case: Case) -> list[EndBodySpec]:
    """SI end-body descriptions of a case."""
    return [
        EndBodySpec(
            b.name,
            b.pole,
            b.mass,
            *b.inertias(),
            b.attach_radius,
            b.offset,
            b.cluster_arm(),
            b.flange_radius,
            b.flange_thickness_factor or 1.0,
        )
        for b in case.end_body
    ]


def beam_section(beam) -> BeamSection:
    """The 3-D beam section of a case's ``[beam]`` table (SI)."""
    return solid_section(
        beam.area, beam.second_moment, beam.youngs_modulus, beam.density,
        beam.shear_modulus, beam.torsion_constant,
    )  # fmt: skip


def spacecraft_structure(case: Case) -> Structure:
    """The hub-and-booms structure of a spacecraft case (booms radial at their azimuth and
    elevation, section director d₂ in the boom's vertical plane)."""
    h = case.hub
    booms = []
    for b in case.boom:
        radial = np.array([np.cos(b.azimuth), np.sin(b.azimuth), 0.0])
        direction = np.cos(b.elevation) * radial + np.array([0.0, 0.0, np.sin(b.elevation)])
        normal = np.cross(direction, np.array([-radial[1], radial[0], 0.0]))
        section = solid_section(b.area, b.second_moment, b.youngs_modulus, b.density,
                                b.shear_modulus, b.torsion_constant)  # fmt: skip
        root = b.root_radius * radial + np.array([0.0, 0.0, b.root_height])
        booms.append(BoomSpec(b.name, tuple(root), tuple(direction), b.length, b.elements,
                              section, tuple(normal)))  # fmt: skip
    hub = HubSpec(h.mass, (h.inertia_x, h.inertia_y, h.inertia_z))
    return build_hub_structure(hub, booms, rigidity=h.rigidity)


def structure_for_case(case: Case, surface: TriangleSurface | None = None) -> Structure:
    """The finite-element structure of a case (stress-free)."""
    if case.kind == "spacecraft":
        return spacecraft_structure(case)
    if case.kind == "beam":
        b = case.beam
        return build_beam_structure(
            b.length,
            b.elements,
            b.youngs_modulus * b.area,
            b.youngs_modulus * b.second_moment,
            b.density * b.area,
            clamped=b.support == "clamped",
            section=beam_section(b) if b.element == "beam3d" else None,
        )
    surface = surface if surface is not None else surface_for_case(case)
    m = case.material
    spec = MembraneSpec(
        thickness=m.thickness,
        youngs_modulus=m.youngs_modulus,
        poisson_ratio=m.poisson_ratio,
        density=m.density,
        pressure=case.pressure.value,
        gas_law_exponent=case.pressure.gas_law_exponent,
        lumped_mass=case.mesh.mass_matrix == "lumped",
        tension_field=m.wrinkling == "tension-field",
    )
    return build_membrane_structure(surface.points, surface.triangles, spec, end_body_specs(case))


@dataclass(frozen=True)
class ModalModel:
    """Everything the modal stage produced for a case."""

    case: Case
    structure: Structure
    prestress: PrestressedState | None
    x: np.ndarray
    modes: ModalResult
    labels: list[str]


def reference_state(
    case: Case, structure: Structure, progress: Progress | None = None
) -> tuple[np.ndarray, PrestressedState | None]:
    """Prestressed equilibrium of a membrane case, or the stress-free state of a beam or a
    spacecraft."""
    if case.kind != "membrane":
        return structure.reference, None
    # Membrane strain scale p R / (E t): below ~1e-8 the prestress is lost in round-off and the
    # membrane has no meaningful stiffness out of its plane.
    m = case.material
    radius = np.max(np.linalg.norm(structure.reference[:, :2], axis=1))
    strain = case.pressure.value * radius / (m.youngs_modulus * m.thickness)
    if strain < 1e-8:
        raise ValueError(
            f"pressure.value: {case.pressure.value:.3g} Pa is too low to tension the membrane "
            f"(strain scale {strain:.1e}); raise the pressure above "
            f"{1e-8 * m.youngs_modulus * m.thickness / radius:.2g} Pa"
        )
    # Inflated from the stress-free (slack) state under SVK; the taut equilibrium is the same
    # with the wrinkling relaxation (the two laws agree wherever the membrane is taut).
    state = inflate(with_tension_field(structure, False), progress=progress)
    compressed = float(np.mean(state.stress_resultants[:, 0] <= 0.0))
    if compressed > 0.05:
        raise ValueError(
            f"pressure.value: {100 * compressed:.0f} % of the membrane is in compression after "
            "inflation (the pressure is too low to tension it); raise the pressure"
        )
    return state.x, state


def with_gas_law(case: Case, structure: Structure, x: np.ndarray) -> Structure:
    """The structure for vibrations about the inflated state ``x``: with a gas-law exponent the
    pressure follows ``p V^κ = const`` through (p, V) of the inflated state (inflation itself is
    done at constant pressure)."""
    kappa = case.pressure.gas_law_exponent if case.pressure is not None else 0.0
    if not kappa:
        return structure
    sets = tuple(
        replace(e, gas_law_exponent=kappa, reference_volume=e.volume(x))
        if isinstance(e, PressureSet)
        else e
        for e in structure.elements
    )
    return replace(structure, elements=sets)


def build_modal_model(case: Case, progress: Progress | None = None) -> ModalModel:
    """Mesh, structure, prestress, modes and labels of a case."""
    structure = structure_for_case(case)
    x, state = reference_state(case, structure, progress)
    structure = with_gas_law(case, structure, x)
    if progress:
        progress("modes", 0.0)
    modes = compute_modes(structure, x, case.modes.count)
    if progress:
        progress("modes", 1.0)
    labeller = boom_labels if case.kind == "spacecraft" else label_modes
    return ModalModel(case, structure, state, x, modes, labeller(structure, x, modes.shapes))


def modes_summary(model: ModalModel) -> dict:
    """JSON-ready summary: frequencies (Hz), labels, rigid frequencies (Hz), mass (kg), inertia
    about the centre of mass (kg m²), pressure (Pa), and prestress figures."""
    s, x = model.structure, model.x
    out = {
        "case": model.case.name,
        "frequencies_hz": [float(f) for f in model.modes.frequencies_hz],
        "labels": list(model.labels),
        "rigid_frequencies_hz": [float(f) for f in model.modes.rigid_frequencies_hz],
        "mass_kg": total_mass(s),
        "inertia_kg_m2": inertia_tensor(s, x).tolist(),
        "centre_of_mass_m": centre_of_mass(s, x).tolist(),
        "pressure_pa": float(model.case.pressure.value) if model.case.pressure else 0.0,
        "n_nodes": int(s.n),
        "n_dofs": int(s.free_dofs.size),
    }
    if model.prestress is not None:
        st = model.prestress
        out["prestress"] = {
            "volume_change": st.volume_change,
            "stress_resultant_min_n_per_m": float(st.stress_resultants.min()),
            "stress_resultant_max_n_per_m": float(st.stress_resultants.max()),
            "elements_in_compression": int(np.sum(st.stress_resultants[:, 0] <= 0.0)),
            "relative_residual": st.residual_norm,
        }
        warning = volume_change_warning(st.volume_change)
        if warning:
            out["warnings"] = [warning]
        out["slack_onset_m"] = mode_slack_onsets(s, x, model.modes.shapes)
    return out


def mode_slack_onsets(structure: Structure, x: np.ndarray, shapes: np.ndarray) -> list:
    """Per mode of ``shapes`` ``(N, n, 3)``: the largest nodal displacement (m) of the mode at
    which the membrane first loses tension off the end-body patches (linearised,
    :func:`quadmodes.structure.tension_margin.slack_onset`; None if it never does) — the
    amplitude beyond which the taut model, and any smooth reduced potential, stops holding."""
    from quadmodes.structure.tension_margin import slack_onset

    onsets = []
    for u in shapes:
        unit = u / np.max(np.linalg.norm(u, axis=1))
        first = slack_onset(structure, x, unit)
        ok = first is not None and np.isfinite(first.fraction)
        onsets.append(float(first.fraction) if ok else None)
    return onsets
