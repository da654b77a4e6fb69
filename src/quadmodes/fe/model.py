"""The assembled finite-element structure and its global operators.

A :class:`Structure` is the whole discrete body: stress-free vector-DOF values, which of them are
positions (translate with the body) rather than slopes, the element sets, the scalar mass matrix
``M_s`` (``M = M_s ⊗ I_3``), clamped components and named node groups. Every operator here is a
pure function of a structure and a state ``x`` ``(n, 3)`` (m).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.assembly import (
    CsrPattern,
    assemble_csr,
    assemble_vector,
    csr_pattern,
    expand_scalar_matrix,
)
from quadmodes.fe.elements import ElementSet
from quadmodes.fe.membrane import MembraneSet
from quadmodes.fe.pressure import PressureSet, gas_rank_one, gas_second_order


@dataclass(frozen=True)
class Structure:
    """A discrete body.

    reference: ``(n, 3)`` stress-free vector DOFs (m; slopes dimensionless).
    translational: ``(n,)`` bool, True where the vector DOF is a position.
    elements: element sets obeying :class:`quadmodes.fe.elements.ElementSet`.
    mass_scalar: ``(n, n)`` sparse scalar mass ``M_s`` (kg), including point masses.
    fixed: ``(n, 3)`` bool, clamped components (all False for a free body).
    groups: named index arrays (e.g. ``"membrane"``, ``"body:rear"``, ``"attach:rear"``).
    """

    reference: np.ndarray
    translational: np.ndarray
    elements: tuple[ElementSet, ...]
    mass_scalar: sp.csr_matrix
    fixed: np.ndarray
    groups: Mapping[str, np.ndarray] = field(default_factory=dict)
    # Stiffness patterns by connectivity (see stiffness_pattern); shared by the copies that
    # dataclasses.replace makes (load stepping, gas law), whose sets keep their connectivity.
    pattern_cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def n(self) -> int:
        return self.reference.shape[0]

    @property
    def is_free(self) -> bool:
        return not bool(self.fixed.any())

    @property
    def free_dofs(self) -> np.ndarray:
        """Indices of unconstrained scalar DOFs, ``(n_free,)``."""
        return np.flatnonzero(~self.fixed.ravel())


def with_load_factor(structure: Structure, factor: float) -> Structure:
    """The structure with every pressure set scaled by ``factor`` (load stepping)."""
    sets = tuple(
        replace(e, load_factor=factor) if isinstance(e, PressureSet) else e
        for e in structure.elements
    )
    return replace(structure, elements=sets)


def with_tension_field(structure: Structure, on: bool) -> Structure:
    """The structure with the membranes' wrinkling relaxation switched on or off."""
    sets = [
        replace(e, tension_field=on) if isinstance(e, MembraneSet) else e
        for e in structure.elements
    ]
    return replace(structure, elements=sets)


def strain_energy(structure: Structure, x: np.ndarray) -> float:
    """Total potential energy (J), elastic plus pressure potential."""
    return float(sum(e.energy(x) for e in structure.elements))


def internal_force(structure: Structure, x: np.ndarray) -> np.ndarray:
    """Internal force ``f(x)`` ``(n, 3)`` (N), the gradient of :func:`strain_energy`."""
    out = np.zeros((structure.n, 3))
    for e in structure.elements:
        out += assemble_vector(e.conn, e.force(x), structure.n)
    return out


def tangent_stiffness(structure: Structure, x: np.ndarray) -> sp.csr_matrix:
    """Sparse tangent stiffness ``K(x)`` ``(3n, 3n)`` (N/m): material + geometric + pressure load.

    A gas-law pressure adds a global rank-one term given by :func:`tangent_low_rank`.
    """
    pattern, groups = _stiffness_assembly(structure)
    summed: list = [None] * (max(groups) + 1 if groups else 0)
    fresh = [False] * len(summed)  # summed[g] is our own sum (a kernel's array is never written)
    for e, g in zip(structure.elements, groups, strict=True):
        k = e.stiffness(x)
        if summed[g] is None:
            summed[g] = k
        elif fresh[g]:
            summed[g] += k
        else:
            summed[g], fresh[g] = summed[g] + k, True
    return assemble_csr(pattern, summed)


def stiffness_pattern(structure: Structure) -> CsrPattern:
    """CSR pattern of the tangent of ``structure``'s element sets, computed once per set of
    connectivities (keyed by their contents) and kept in ``structure.pattern_cache``. Its
    slots are those of the distinct connectivities (:func:`connectivity_groups`): sets on one
    connectivity (a membrane and the pressure on it) are summed before the scatter."""
    return _stiffness_assembly(structure)[0]


def connectivity_groups(conns: list[np.ndarray]) -> tuple[list[np.ndarray], tuple[int, ...]]:
    """The distinct connectivities among ``conns`` (each ``(ne, k)``) in order of first
    appearance, and for each of ``conns`` the index of its own among them."""
    distinct: list[np.ndarray] = []
    groups = []
    for c in conns:
        same = [i for i, d in enumerate(distinct) if d.shape == c.shape and np.array_equal(d, c)]
        if not same:
            distinct.append(c)
        groups.append(same[0] if same else len(distinct) - 1)
    return distinct, tuple(groups)


def _stiffness_assembly(structure: Structure) -> tuple[CsrPattern, tuple[int, ...]]:
    """``(pattern, groups)`` of :func:`stiffness_pattern` and :func:`connectivity_groups`."""
    conns = [np.asarray(e.conn) for e in structure.elements]
    key = (structure.n, *((c.shape, hash(c.tobytes())) for c in conns))
    if key not in structure.pattern_cache:
        distinct, groups = connectivity_groups(conns)
        structure.pattern_cache[key] = (csr_pattern(distinct, structure.n), groups)
    return structure.pattern_cache[key]


def tangent_low_rank(structure: Structure, x: np.ndarray) -> list[tuple[float, np.ndarray]]:
    """Rank-one stiffness terms ``c v vᵀ`` as ``(c, v)`` pairs (gas-law pressure)."""
    terms = [gas_rank_one(e, x) for e in structure.elements if isinstance(e, PressureSet)]
    return [t for t in terms if t is not None]


def second_order_force(
    structure: Structure, x: np.ndarray, u: np.ndarray, v: np.ndarray
) -> np.ndarray:
    """``B(u, v) = ½ D²f(x)[u, v]`` ``(n, 3)`` (N per unit² of u, v), symmetric in ``u, v``."""
    out = np.zeros((structure.n, 3))
    for e in structure.elements:
        out += assemble_vector(e.conn, e.second_order(x, u, v), structure.n)
        if isinstance(e, PressureSet):
            out += gas_second_order(e, x, u, v)
    return out


def mass_matrix(structure: Structure) -> sp.csr_matrix:
    """Isotropic mass ``M = M_s ⊗ I_3`` ``(3n, 3n)`` (kg)."""
    return expand_scalar_matrix(structure.mass_scalar)


def total_mass(structure: Structure) -> float:
    """Total mass ``m = tᵀ M_s t`` (kg), ``t`` the translational indicator."""
    t = structure.translational.astype(float)
    return float(t @ (structure.mass_scalar @ t))


def centre_of_mass(structure: Structure, x: np.ndarray) -> np.ndarray:
    """Centre of mass ``(3,)`` (m) of state ``x``."""
    w = structure.mass_scalar @ structure.translational.astype(float)
    return (w @ x) / w.sum()


def inertia_tensor(
    structure: Structure, x: np.ndarray, about: np.ndarray | None = None
) -> np.ndarray:
    """Inertia tensor ``(3, 3)`` (kg m²) of state ``x`` about ``about`` (default: centre of mass)."""
    c = centre_of_mass(structure, x) if about is None else about
    r = x - np.outer(structure.translational, c)
    p = r.T @ (structure.mass_scalar @ r)
    return np.trace(p) * np.eye(3) - p


def rigid_body_modes(structure: Structure, x: np.ndarray) -> np.ndarray:
    """Rigid-body motions ``Ψ`` ``(3n, 6)`` of state ``x``: translations (positions only), then
    infinitesimal rotations ``e_a × (x − c)`` about the centre of mass."""
    n = structure.n
    t = structure.translational.astype(float)
    c = centre_of_mass(structure, x)
    r = x - np.outer(t, c)
    psi = np.zeros((n, 3, 6))
    for a in range(3):
        psi[:, a, a] = t
        e = np.zeros(3)
        e[a] = 1.0
        psi[:, :, 3 + a] = np.cross(e, r)
    return psi.reshape(3 * n, 6)
