"""Assemble a :class:`~quadmodes.fe.model.Structure` from a surface mesh or a beam description.

Inputs are plain SI values; :mod:`quadmodes.structure.pipeline` maps a validated case onto them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.assembly import assemble_scalar_matrix
from quadmodes.fe.bar import bar_set
from quadmodes.fe.beam import BeamSection, beam_sets, chain_connectivity, straight_beam_nodes
from quadmodes.fe.membrane import membrane_set
from quadmodes.fe.model import Structure
from quadmodes.fe.pressure import PressureSet
from quadmodes.fe.rigid import point_mass_cluster, tie_connectivity


@dataclass(frozen=True)
class EndBodySpec:
    """A rigid end body (SI): mass (kg), inertias about its own centre (kg m²), the radius of the
    attached membrane patch around the pole (m), the outward offset of its centre from the pole (m)
    and the half-size of the point-mass cluster (m). With ``flange_radius`` (m) the membrane
    between ``attach_radius`` and ``flange_radius`` is ``flange_thickness_factor`` times as thick
    (a bonded flange, or doubler); without it the rigid patch meets the bare membrane."""

    name: str
    pole: str
    mass: float
    inertia_axial: float
    inertia_transverse: float
    attach_radius: float
    offset: float
    arm: float
    flange_radius: float | None = None
    flange_thickness_factor: float = 1.0


def element_thickness(
    points: np.ndarray,
    triangles: np.ndarray,
    thickness: float,
    end_bodies: Sequence[EndBodySpec],
) -> float | np.ndarray:
    """Membrane thickness (m): ``thickness``, or per triangle ``(nt,)`` with every triangle whose
    nodes all lie within an end body's ``flange_radius`` on its cap made
    ``flange_thickness_factor`` times as thick (the rings at the radii make this exact)."""
    flanges = [b for b in end_bodies if b.flange_radius and b.flange_thickness_factor != 1.0]
    if not flanges:
        return thickness
    t = np.full(len(triangles), float(thickness))
    for body in flanges:
        inside = np.zeros(len(points), bool)
        inside[pole_nodes(points, body.pole, body.flange_radius)] = True
        t[inside[triangles].all(axis=1)] *= body.flange_thickness_factor
    return t


@dataclass(frozen=True)
class MembraneSpec:
    """Membrane material and load (SI): thickness (m), Young's modulus (Pa), Poisson ratio,
    density (kg/m³), pressure (Pa), gas-law exponent (0: constant pressure), wrinkling
    relaxation (``tension_field``)."""

    thickness: float
    youngs_modulus: float
    poisson_ratio: float
    density: float
    pressure: float
    gas_law_exponent: float = 0.0
    lumped_mass: bool = False
    tie_stiffness_factor: float = 1e3
    tension_field: bool = False


def pole_nodes(points: np.ndarray, pole: str, radius: float, axis: int = 2) -> np.ndarray:
    """Indices of surface nodes within ``radius`` (m) of the body axis on the ``pole`` side."""
    z = points[:, axis]
    radial = np.linalg.norm(np.delete(points, axis, axis=1), axis=1)
    mid = 0.5 * (z.min() + z.max())
    side = z < mid if pole == "front" else z > mid
    return np.flatnonzero(side & (radial <= radius * (1.0 + 1e-6)))


def build_membrane_structure(
    points: np.ndarray,
    triangles: np.ndarray,
    spec: MembraneSpec,
    end_bodies: Sequence[EndBodySpec] = (),
) -> Structure:
    """Closed membrane (outward triangles ``(nt, 3)`` on ``points`` ``(n, 3)`` m, body axis z) with
    follower pressure and rigid end bodies. Node order: membrane nodes, then 7 points per body."""
    points = np.asarray(points, float)
    triangles = np.asarray(triangles, np.int64)
    membrane = membrane_set(
        triangles,
        points,
        element_thickness(points, triangles, spec.thickness, end_bodies),
        spec.youngs_modulus,
        spec.poisson_ratio,
        spec.density,
        lumped_mass=spec.lumped_mass,
        tension_field=spec.tension_field,
    )
    all_points = [points]
    point_masses = [np.zeros(len(points))]
    groups: dict[str, np.ndarray] = {"membrane": np.arange(len(points))}
    ties = []
    tie_ea = []
    n = len(points)
    for body in end_bodies:
        attached = pole_nodes(points, body.pole, body.attach_radius)
        if len(attached) < 3:
            raise ValueError(
                f"end_body {body.name}: attach_radius {body.attach_radius:.4g} m reaches only "
                f"{len(attached)} nodes; increase attach_radius or refine the mesh"
            )
        outward = np.array([0.0, 0.0, -1.0 if body.pole == "front" else 1.0])
        pole_point = points[np.argmax(points @ outward)]
        centre = np.array([0.0, 0.0, pole_point[2]]) + body.offset * outward
        cluster_pts, cluster_m = point_mass_cluster(
            centre,
            outward,
            body.mass,
            body.inertia_axial,
            body.inertia_transverse,
            body.arm,
            name=body.name,
        )
        idx = np.arange(n, n + len(cluster_pts))
        n += len(cluster_pts)
        all_points.append(cluster_pts)
        point_masses.append(cluster_m)
        groups[f"body:{body.name}"] = idx
        groups[f"attach:{body.name}"] = attached
        conn = tie_connectivity(idx, attached)
        ties.append(conn)
        tie_ea.append(
            np.full(len(conn), spec.tie_stiffness_factor * spec.youngs_modulus * spec.thickness)
        )
    reference = np.concatenate(all_points)
    if spec.tension_field:  # membrane under a rigid end body: bonded, it cannot wrinkle
        on_patch = np.zeros(len(points), bool)
        for name, nodes in groups.items():
            if name.startswith("attach:"):
                on_patch[nodes] = True
        membrane = replace(membrane, bonded=on_patch[membrane.conn].all(axis=1))
    # EA of a tie scales with its length so that every tie has axial stiffness k = factor·E·t.
    elements: list = [membrane, PressureSet(triangles, spec.pressure)]
    if ties:
        conn = np.concatenate(ties)
        lengths = np.linalg.norm(reference[conn[:, 1]] - reference[conn[:, 0]], axis=1)
        elements.append(bar_set(conn, reference, np.concatenate(tie_ea) * lengths))
    ms = assemble_scalar_matrix(membrane.conn, membrane.mass(), len(reference))
    ms = (ms + sp.diags(np.concatenate(point_masses))).tocsr()
    return Structure(
        reference=reference,
        translational=np.ones(len(reference), bool),
        elements=tuple(elements),
        mass_scalar=ms,
        fixed=np.zeros((len(reference), 3), bool),
        groups=groups,
    )


def build_beam_structure(
    length: float,
    n_elements: int,
    EA: float,
    EI: float,
    rho_A: float,
    clamped: bool = True,
    section: BeamSection | None = None,
) -> Structure:
    """Straight beam along +x from the origin (SI): the ANCF cable (no torsion) when ``section``
    is None, else the 3-D beam of :mod:`quadmodes.fe.beam` with that section (EA, EI, ρA then
    come from it). A clamp at x = 0 fixes the root position and the root tangent direction (and
    the 3-D beam's section directors); the root slope's axial component stays free, because a
    clamp fixes the direction of the centreline, not its stretch."""
    if section is not None:
        return _build_3d_beam(length, n_elements, section, clamped)
    from quadmodes.fe.cable import straight_cable

    reference, translational, cable = straight_cable(
        np.zeros(3), np.array([length, 0.0, 0.0]), n_elements, EA, EI, rho_A
    )
    n = len(reference)
    fixed = np.zeros((n, 3), bool)
    if clamped:
        fixed[0, :] = True
        fixed[1, 1:] = True
    ms = assemble_scalar_matrix(cable.conn, cable.mass(), n)
    positions = np.flatnonzero(translational)
    return Structure(
        reference=reference,
        translational=translational,
        elements=(cable,),
        mass_scalar=ms,
        fixed=fixed,
        groups={"beam": positions},
    )


def _build_3d_beam(length: float, n_elements: int, section: BeamSection, clamped: bool):
    """The 3-D beam case of :func:`build_beam_structure` (d₂ = y, d₃ = z)."""
    reference, translational = straight_beam_nodes(
        np.zeros(3), np.array([length, 0.0, 0.0]), n_elements, np.array([0.0, 1.0, 0.0])
    )
    conn = chain_connectivity(0, n_elements)
    sets = beam_sets(conn, length / n_elements, section)
    n = len(reference)
    fixed = np.zeros((n, 3), bool)
    if clamped:
        fixed[[0, 2, 3], :] = True
        fixed[1, 1:] = True
    return Structure(
        reference=reference,
        translational=translational,
        elements=sets,
        mass_scalar=assemble_scalar_matrix(conn, sets[0].mass(), n),
        fixed=fixed,
        groups={"beam": np.flatnonzero(translational)},
    )
