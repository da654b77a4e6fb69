"""A free rigid hub with 3-D beams clamped to it (a spinning spacecraft with booms).

The hub is a rigid body on four vector DOFs: its centre ``c`` (m, translational) and its body
axes ``a₁, a₂, a₃`` (dimensionless; the unit axes in the stress-free state). A material point at
body coordinates ξ is at ``c + Σ ξ_i a_i``, so the hub's mass is isotropic and constant,
``M_s = diag(m, S₁, S₂, S₃)`` with the second moments of mass ``S_i = ∫ρ ξ_i² dV =
½ tr I − I_ii`` (about the centre, body axes principal). The axes are held orthonormal by the
quadratic strains ``½(a_i·a_i − 1)`` and ``a_i·a_j`` (a stiff triad, :func:`triad_stiffness`:
its strain a small fraction of the roots' under any load, spin-stiffened blades included; its six
distortion modes far above the booms'). A boom's root node is not a node of its own: its DOFs
are the linear images of the hub's, ``r = c + Σ ρ_i a_i``, ``t = Σ t_i a_i``, ``d₂ = Σ d₂ᵢ a_i``,
``d₃ = Σ d₃ᵢ a_i`` (ρ the root point, ``t, d₂, d₃`` the boom frame, in hub coordinates), so the
clamp is exact and stays exact for finite rotations. The root slope keeps unit length, i.e. zero
axial strain at the root node (as a clamped cable).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.fe.assembly import assemble_scalar_matrix
from quadmodes.fe.beam import (
    DOFS_PER_NODE,
    BeamSection,
    beam_frame,
    beam_sets,
    chain_connectivity,
    straight_beam_nodes,
)
from quadmodes.fe.model import Structure
from quadmodes.fe.quadratic_strain import QuadraticStrainSet

#: Vector DOFs of the hub: c, a₁, a₂, a₃.
HUB_DOFS = 4


@dataclass(frozen=True)
class HubSpec:
    """A rigid hub (SI): mass (kg), principal moments of inertia about its centre along the
    case axes x, y, z ``(3,)`` (kg m²), centre ``(3,)`` (m)."""

    mass: float
    inertia: tuple[float, float, float]
    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class BoomSpec:
    """A straight boom clamped to the hub (SI): root point relative to the hub centre ``(3,)``
    (m), direction ``(3,)``, optional section direction d₂ ``(3,)``, length (m), elements and
    section."""

    name: str
    root: tuple[float, float, float]
    direction: tuple[float, float, float]
    length: float
    elements: int
    section: BeamSection
    director2: tuple[float, float, float] | None = None


def second_moments_of_mass(inertia: np.ndarray, name: str = "hub") -> np.ndarray:
    """``S_i = ½ tr I − I_ii`` ``(3,)`` (kg m²) of principal moments ``I`` ``(3,)``; raises
    ValueError if a moment exceeds the sum of the other two (no physical body has that)."""
    i = np.asarray(inertia, float)
    s = 0.5 * i.sum() - i
    if np.any(s < -1e-12 * i.sum()):
        raise ValueError(
            f"{name}.inertia: each principal moment must not exceed the sum of the other two; "
            f"got {', '.join(f'{v:.4g}' for v in i)} kg m^2"
        )
    return np.clip(s, 0.0, None)


def hub_rigidity_set(stiffness: float) -> QuadraticStrainSet:
    """The triad's six orthonormality strains on DOFs ``[c, a₁, a₂, a₃]`` = 0..3, modulus
    ``stiffness`` (N m: moment per radian of distortion)."""
    e = np.eye(HUB_DOFS)
    ops, offsets = [], []
    for i in range(1, 4):
        ops.append(np.outer(e[i], e[i]))
        offsets.append(0.5)
    for i, j in ((1, 2), (1, 3), (2, 3)):
        ops.append(np.outer(e[i], e[j]) + np.outer(e[j], e[i]))
        offsets.append(0.0)
    return QuadraticStrainSet(
        conn=np.arange(HUB_DOFS)[None, :],
        operators=np.array(ops)[None, None],
        offsets=np.array(offsets)[None, None],
        moduli=np.full((1, 1, 6), float(stiffness)),
        weights=np.ones((1, 1)),
    )


def clamp_transform(root: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """``P`` ``(8, 8)``: from ``[c, a₁, a₂, a₃, r_b, t_b, d2_b, d3_b]`` to the root element's
    ``[r_a, t_a, d2_a, d3_a, r_b, …]`` for a root at ``root`` ``(3,)`` with frame rows
    ``[t, d₂, d₃]`` ``(3, 3)`` (hub coordinates)."""
    p = np.zeros((8, 8))
    p[0, 0] = 1.0
    p[0, 1:4] = root
    p[1:4, 1:4] = frame
    p[4:, 4:] = np.eye(4)
    return p


def attached_axes_stiffness(sets, x: np.ndarray) -> float:
    """The largest diagonal entry (N m) of the tangent stiffness of the element sets ``sets``
    (those attached to the hub) at the state ``x`` ``(n, 3)`` on the hub's axis DOFs a₁, a₂, a₃
    (rows 1–3): the stiffness with which the attached structure resists a distortion of the
    triad. At the stress-free state it is the material stiffness of the roots (axial and
    section terms, EA-like); it never vanishes, unlike a bending stiffness 4EI/ℓ of a
    spin-stiffened blade, and it bounds the geometric stiffness N/ℓ = EA ε/ℓ of every state of
    small strain ε, whatever the spin."""
    diag = np.zeros((x.shape[0], 3))
    for e in sets:
        k = e.stiffness(x)  # (ne, 3k, 3k)
        ne, nk = e.conn.shape
        np.add.at(diag, e.conn, np.einsum("eii->ei", k).reshape(ne, nk, 3))
    return float(np.abs(diag[1:HUB_DOFS]).max(initial=0.0))


def triad_stiffness(
    rigidity: float, root_stiffness: float, moments: np.ndarray, floor_omega2: float
) -> float:
    """Distortion stiffness (N m) of the hub's triad: ``rigidity`` × ``root_stiffness``, the
    attached structure's stiffness on the hub's axes at rest (:func:`attached_axes_stiffness`),
    and at least enough to put the triad's modes ``√(k/S_i)`` (``moments`` S_i (3,) kg m²) above
    ``√floor_omega2`` (rad/s, :func:`boom_floor_omega2`: a heavy hub must not become
    dynamically soft).

    Why this scale: a load on the hub (the centrifugal pull of the blades, at any spin) strains
    the triad ``1/rigidity`` as much as it strains the roots, so the hub stays rigid relative to
    the structure whatever carries the load, bending or the centrifugal tension of a blade with
    no bending stiffness. (Scaled to the booms' bending stiffness at rest, as before issue 26,
    the hub of a spin-stiffened blade was as soft as the blade: its stretch then changed the
    blade's root tension and every string frequency.) The default 100 puts the triad's strain at
    1 % of the roots': frequencies within 2e-4 of the rigid limit; far stiffer penalties (1e4)
    only add round-off to the eigensolutions."""
    dynamic = float(np.max(moments)) * floor_omega2
    return max(rigidity * root_stiffness, dynamic, 1.0)


def boom_floor_omega2(section: BeamSection, length: float) -> float:
    """The square (rad²/s²) of the frequency the triad's modes must exceed for a boom of
    ``length`` (m): 100 × its first clamped bending frequency ``(1.875²)²EI/(ρA L⁴)``, and its
    first axial frequency ``(π/2)² EA/(ρA L²)``, which never vanishes: a spin that stiffens a
    blade of no bending stiffness strains it by ε ≈ (Ω/ω_axial)², so every spin-stiffened
    frequency stays a factor ~1/√ε below it."""
    ei = max(section.EI2, section.EI3)
    bending = 12.36 * ei / (section.rho_A * length**4)
    axial = (0.5 * np.pi) ** 2 * section.EA / (section.rho_A * length**2)
    return max(1e4 * bending, axial)


def build_hub_structure(hub: HubSpec, booms: list[BoomSpec], rigidity: float = 1e2) -> Structure:
    """The structure of a rigid hub with booms. ``rigidity``: see :func:`triad_stiffness`."""
    centre = np.asarray(hub.centre, float)
    reference = [centre[None], np.eye(3)]
    translational = [np.array([True, False, False, False])]
    sets, mass_parts, groups, first = [], [], {}, HUB_DOFS
    floor_omega2 = 0.0
    for b in booms:
        frame = beam_frame(b.direction, b.director2)
        root = np.asarray(b.root, float)
        end = root + b.length * frame[0]
        ref, tr = straight_beam_nodes(centre + root, centre + end, b.elements, frame[1])
        reference.append(ref[DOFS_PER_NODE:])
        translational.append(tr[DOFS_PER_NODE:])
        conn = chain_connectivity(first - DOFS_PER_NODE, b.elements)
        conn[0, :DOFS_PER_NODE] = np.arange(HUB_DOFS)
        transform = np.broadcast_to(np.eye(8), (b.elements, 8, 8)).copy()
        transform[0] = clamp_transform(root, frame)
        boom_sets = beam_sets(conn, b.length / b.elements, b.section, transform)
        sets.extend(boom_sets)
        mass_parts.append((conn, boom_sets[0].mass()))
        groups[f"boom:{b.name}"] = first + DOFS_PER_NODE * np.arange(b.elements)
        first += DOFS_PER_NODE * b.elements
        floor_omega2 = max(floor_omega2, boom_floor_omega2(b.section, b.length))
    n = first
    moments = second_moments_of_mass(np.asarray(hub.inertia))
    root_stiffness = attached_axes_stiffness(sets, np.concatenate(reference))
    hub_set = hub_rigidity_set(triad_stiffness(rigidity, root_stiffness, moments, floor_omega2))
    ms = assemble_scalar_matrix(np.arange(HUB_DOFS)[None, :], np.diag(
        np.concatenate([[hub.mass], moments]))[None], n)
    for conn, blocks in mass_parts:
        ms = ms + assemble_scalar_matrix(conn, blocks, n)
    trans = np.concatenate(translational)
    groups["hub"] = np.array([0])
    groups["beam"] = np.flatnonzero(trans)
    return Structure(
        reference=np.concatenate(reference),
        translational=trans,
        elements=(hub_set, *sets),
        mass_scalar=ms.tocsr(),
        fixed=np.zeros((n, 3), bool),
        groups=groups,
    )
