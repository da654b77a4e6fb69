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
from dataclasses import dataclass, field, replace

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
from quadmodes.fe.hub_membrane import PointMassSpec, build_hub_membrane_structure
from quadmodes.fe.model import (
    Structure,
    centre_of_mass,
    inertia_tensor,
    total_mass,
)
from quadmodes.fe.pressure import PressureSet
from quadmodes.mesh.flat import disc_surface
from quadmodes.mesh.hub_flat import (
    annulus_surface,
    hub_ring_nodes,
    square_surface,
    strip_root_nodes,
    strip_surface,
)
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
from quadmodes.structure.damping import SolvedModes
from quadmodes.structure.flat_spin import flat_spinning_equilibrium
from quadmodes.structure.labels import label_modes
from quadmodes.structure.modes import ModalResult, compute_modes
from quadmodes.structure.prestress import PrestressedState, inflate
from quadmodes.structure.spinning import (
    SpinningEquilibrium,
    centrifugal_softening,
    neutral_modes,
)

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
    g, h = case.geometry, case.mesh.edge_length
    if g.shape == "disc":
        surface = disc_surface(0.5 * g.diameter, h)
    elif g.shape == "annulus":
        surface = annulus_surface(0.5 * g.diameter, 0.5 * g.inner_diameter, h)
    elif g.shape == "square":
        surface = square_surface(g.side_length, 0.5 * g.inner_diameter, h)
    elif g.shape == "strip":
        surface = strip_surface(0.5 * g.inner_diameter, g.length, g.width, g.blades or 4, h)
    elif revolution is not None:
        profile, refine = revolution
        surface = mesh_revolution(profile, case.mesh.edge_length, case.mesh.elements_per_radius,
                                  refine)  # fmt: skip
    else:
        surface = read_surface(case.geometry.file, case.geometry.file_scale())
        if case.spin is not None:
            check_flat_file(surface)
    if case.pressure is not None and case.pressure.value > 0.0:
        check_closed_surface(surface)
    if min_angle_deg(surface.points, surface.triangles) < 5.0:
        raise ValueError("mesh: triangles with angles below 5° found; remesh or change edge_length")
    check_surface_plausibility(case, surface)
    return surface


def check_flat_file(surface: TriangleSurface) -> None:
    """A mesh file with ``[spin]`` (a membrane without pressure) must be flat in a plane normal
    to z, the spin axis of a flat membrane; ValueError naming ``geometry.file`` otherwise."""
    z = surface.points[:, 2]
    extent = float(np.ptp(surface.points, axis=0).max())
    if np.ptp(z) > 1e-9 * extent:
        raise ValueError(
            f"geometry.file: a membrane without pressure ([spin]) must be flat in a plane normal "
            f"to z, its spin axis; this surface spans {np.ptp(z):.3g} m in z; rotate the mesh "
            "into an x-y plane"
        )


def file_hub_nodes(surface: TriangleSurface, inner_radius: float) -> np.ndarray:
    """The boundary nodes of a flat mesh file within ``inner_radius`` (m) of the z axis: those
    clamped to its hub (``geometry.inner_diameter``); ValueError if fewer than 3."""
    from quadmodes.mesh.surface import boundary_edges

    rim = np.unique(boundary_edges(surface.triangles))
    r = np.hypot(surface.points[rim, 0], surface.points[rim, 1])
    nodes = rim[r <= inner_radius * (1.0 + 1e-6)]
    if len(nodes) < 3:
        raise ValueError(
            f"geometry.inner_diameter: only {len(nodes)} boundary nodes of the mesh file lie "
            f"within {inner_radius:.4g} m of the z axis; the hub needs the edge of a hole around "
            "the axis: check the diameter or the mesh"
        )
    return nodes


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
        pressure=case.pressure.value if case.pressure is not None else 0.0,
        gas_law_exponent=case.pressure.gas_law_exponent if case.pressure is not None else 0.0,
        lumped_mass=case.mesh.mass_matrix == "lumped",
        tension_field=m.wrinkling == "tension-field",
    )
    if case.hub is not None:
        return hub_membrane_structure(case, surface, spec)
    return build_membrane_structure(surface.points, surface.triangles, spec, end_body_specs(case))


def hub_membrane_structure(case: Case, surface: TriangleSurface, spec: MembraneSpec) -> Structure:
    """The structure of a flat membrane clamped on its hole's edge to the case's rigid
    ``[hub]`` (centred on the membrane's plane), with its ``[[tip_mass]]`` on the corners
    (:mod:`quadmodes.fe.hub_membrane`)."""
    h, g = case.hub, case.geometry
    half = 0.5 * (g.side_length or 0.0)
    tips = [
        PointMassSpec(t.name, t.mass, (half * float(t.corner[0] + "1"),
                                       half * float(t.corner[2] + "1"), 0.0), t.patch)
        for t in case.tip_mass
    ]  # fmt: skip
    b = 0.5 * g.inner_diameter
    if g.shape == "file":  # the hub at the axis, in the membrane's plane
        ring, centre = file_hub_nodes(surface, b), (0.0, 0.0, float(surface.points[0, 2]))
    elif g.shape == "strip":
        ring, centre = strip_root_nodes(surface.points, b, g.blades or 4), (0.0, 0.0, 0.0)
    else:
        ring, centre = hub_ring_nodes(surface.points, b), (0.0, 0.0, 0.0)
    structure = build_hub_membrane_structure(
        surface.points, surface.triangles, spec,
        HubSpec(h.mass, (h.inertia_x, h.inertia_y, h.inertia_z), centre), ring, h.rigidity, tips,
    )  # fmt: skip
    if g.shape != "strip":
        return structure
    # the blades' nodes (strip_surface meshes them blade by blade), for the mode names
    count = g.blades or 4
    member = np.repeat(np.arange(count), len(surface.points) // count)
    free = np.ones(len(surface.points), bool)
    free[ring] = False
    nodes = structure.groups["membrane"]
    blades = {f"blade:{k}": nodes[member[free] == k] for k in range(count)}
    return replace(structure, groups={**structure.groups, **blades})


#: Spin axis of a flat membrane: its normal, the body axis z of every built-in shape.
FLAT_SPIN_AXIS = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class ModalModel:
    """Everything the modal stage produced for a case. ``spinning``: for a membrane without
    stiffness at rest (a ``disc``), the relative equilibrium at the case's ``[spin]`` that ``x``
    is, about which ``modes`` are those of the rotating-frame stiffness; else None.
    ``solved``: the eigenproblems about its states solved so far (the damping modes at rest of
    the models expanded about its spinning states, solved once for all of them)."""

    case: Case
    structure: Structure
    prestress: PrestressedState | None
    x: np.ndarray
    modes: ModalResult
    labels: list[str]
    spinning: SpinningEquilibrium | None = None
    solved: SolvedModes = field(default_factory=SolvedModes, compare=False, repr=False)


def reference_state(
    case: Case, structure: Structure, progress: Progress | None = None
) -> tuple[np.ndarray, PrestressedState | SpinningEquilibrium | None]:
    """Prestressed equilibrium of a membrane case (inflated, or for a membrane without pressure
    its spinning relative equilibrium at ``spin.rate`` about its normal,
    :func:`quadmodes.structure.flat_spin.flat_spinning_equilibrium`), or the stress-free state
    of a beam or a spacecraft."""
    if case.kind != "membrane":
        return structure.reference, None
    if case.pressure is None:  # a flat membrane: taut only when it spins
        eq = flat_spinning_equilibrium(structure, structure.reference, case.spin.rate,
                                       FLAT_SPIN_AXIS)  # fmt: skip
        return eq.x, eq
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
    # Inflated from the stress-free (slack) state under SVK, then relaxed by the wrinkling law
    # when the case has it (the two laws agree wherever the membrane is taut).
    state = inflate(structure, steps=case.pressure.steps or 1, progress=progress)
    minor, major = state.stress_resultants[:, 0], state.stress_resultants[:, 1]
    compressed = float(np.mean(minor < -1e-9 * np.abs(major).max()))
    if compressed > 0.05:
        raise ValueError(
            f"pressure.value: {100 * compressed:.0f} % of the membrane is in compression after "
            'inflation; set [material] wrinkling = "tension-field" (a membrane wrinkles where '
            "it would be compressed, e.g. at flat ends) or raise the pressure"
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
    spinning = state if isinstance(state, SpinningEquilibrium) else None
    if progress:
        progress("modes", 0.0)
    if spinning is not None:
        modes = rotating_frame_modes(structure, spinning, case.modes.count)
    else:
        modes = compute_modes(structure, x, case.modes.count)
    if progress:
        progress("modes", 1.0)
    labeller = boom_labels if case.kind == "spacecraft" else label_modes
    labels = labeller(structure, x, modes.shapes)
    prestress = None if spinning is not None else state
    return ModalModel(case, structure, prestress, x, modes, labels, spinning)


def rotating_frame_modes(structure: Structure, eq: SpinningEquilibrium, count: int) -> ModalResult:
    """The lowest ``count`` modes of the rotating-frame stiffness ``K_T − Ω² M P̂`` about the
    relative equilibrium ``eq``, with a free body's frame conditions (no Coriolis term)."""
    soft = centrifugal_softening(structure, eq.spin, eq.axis)
    return compute_modes(structure, eq.x, count, softening=soft)


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
            # compressed: a minor resultant below round-off of the largest; wrinkled: none
            # across the wrinkles (tension-field law), tension along them
            "elements_in_compression": int(np.sum(st.stress_resultants[:, 0]
                                                  < -1e-9 * np.abs(st.stress_resultants).max())),
            "elements_wrinkled": int(np.sum(st.wrinkle_state() == 1)),
            "relative_residual": st.residual_norm,
        }
        warning = volume_change_warning(st.volume_change)
        if warning:
            out["warnings"] = [warning]
        out["slack_onset_m"] = mode_slack_onsets(s, x, model.modes.shapes)
    if model.spinning is not None:
        out["spinning_reference"] = spinning_summary(s, model.spinning, model.modes)
    return out


def spinning_summary(structure: Structure, eq: SpinningEquilibrium, modes: ModalResult) -> dict:
    """JSON-ready figures of a spinning reference state: spin (rad/s, Hz), the modes'
    frequency ratios ω/Ω (rotating frame), the principal stress resultants (N/m) and the
    largest displacement from the stress-free state (m)."""
    from quadmodes.structure.stress_recovery import largest_nodal_resultant

    sets = [e for e in structure.elements if hasattr(e, "principal_stress_resultants")]
    resultants = np.concatenate([e.principal_stress_resultants(eq.x) for e in sets])
    area = np.concatenate([e.area0 if hasattr(e, "area0") else e.inner.area0 for e in sets])
    centres = np.concatenate([_centroids(e, eq.x) for e in sets])
    k = int(np.argmin(resultants[:, 0]))
    return {
        "spin_rad_s": float(eq.spin),
        "spin_hz": float(eq.spin) / (2.0 * np.pi),
        "frequency_ratios": [float(2.0 * np.pi * f / eq.spin) for f in modes.frequencies_hz],
        # neutral: kept as coordinates of zero stiffness; the rotation about the spin axis and
        # the translation along it are removed by the frame conditions (docs/sails.md)
        "neutral_modes": [int(i) + 1 for i in np.flatnonzero(neutral_modes(
            modes.frequencies_hz, eq.spin))],
        "stress_resultant_min_n_per_m": float(resultants.min()),
        "stress_resultant_max_n_per_m": float(resultants.max()),
        # the converged measure of the largest (structure.stress_recovery; docs/sails.md)
        "stress_resultant_max_nodal_n_per_m": largest_nodal_resultant(sets, eq.x, resultants, area),
        "elements_in_compression": int(np.sum(resultants[:, 0] <= 0.0)),
        # where the membrane is least taut (the slack-onset check of a flat spinning membrane:
        # its out-of-plane modes change no strain to first order, so it is the state's own)
        "compressed_area_fraction": float(area[resultants[:, 0] <= 0.0].sum() / area.sum()),
        "least_tension_n_per_m": float(resultants[k, 0]),
        "least_tension_position_m": centres[k].tolist(),
        "max_displacement_m": float(np.linalg.norm(
            (eq.x - structure.reference)[structure.translational], axis=1).max()),
        "relative_residual": float(eq.residual),
    }


def _centroids(element_set, x: np.ndarray) -> np.ndarray:
    """Element centroids ``(ne, 3)`` (m) of a membrane set (or an image set's) at ``x``."""
    if hasattr(element_set, "inner"):  # fe.hub_membrane.ImageSet: its virtual node positions
        return element_set._virtual(x).reshape(len(element_set.conn), -1, 3).mean(axis=1)
    return x[element_set.conn].mean(axis=1)


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
