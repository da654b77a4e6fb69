"""A flat membrane clamped to a free rigid hub (a sail or an annulus on a spacecraft), with
point masses on it (tip masses).

The hub is the rigid body of :mod:`quadmodes.fe.hub`: vector DOFs ``c, a₁, a₂, a₃`` (centre and
body axes, the unit axes in the stress-free state), mass ``diag(m, S₁, S₂, S₃)``, the axes held
orthonormal by the triad's quadratic strains. The membrane nodes on the hub's edge are not nodes
of their own: as a boom's root, each is the linear image ``x = c + Σ ρ_i a_i`` of the hub's DOFs
(ρ its point in hub coordinates), so the clamp is exact and stays exact for finite rotations.

A membrane triangle with ``j`` nodes on the hub is an element on the vector DOFs ``[c, a₁, a₂,
a₃, its 3 − j free nodes]`` through the per-element map ``P`` ``(3, 4 + 3 − j)``: its node
positions are ``x_e = P X_e``. :class:`ImageSet` wraps an ordinary element set written for the
node positions (the CST membrane, every law and step of it) and transforms its force ``Pᵀ f``,
tangent ``(P ⊗ I₃)ᵀ K (P ⊗ I₃)``, second-order force, mass ``Pᵀ M_e P`` and energy–momentum
step; the triangles free of the hub stay one plain membrane set (its compiled kernels).

Point masses (a tip mass bonded to a corner patch of the sail) are spread over the patch's nodes
with the smooth density ``∝ (1 − (d/p)²)²`` (d the distance from the mass's point, p the patch
radius) times each node's share of the membrane's area: a single loaded node would give a
mesh-dependent point-force singularity, a uniform patch a kink of the stress at its rim; with a
smooth load the stress field is smooth and its largest value converges as the mesh is refined.

Units: m, kg, Pa, N.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.assembly import assemble_scalar_matrix
from quadmodes.fe.build import MembraneSpec
from quadmodes.fe.elements import ElementSet
from quadmodes.fe.hub import HUB_DOFS, HubSpec, hub_rigidity_set, second_moments_of_mass
from quadmodes.fe.membrane import membrane_set
from quadmodes.fe.model import Structure

__all__ = [
    "ImageSet",
    "PointMassSpec",
    "build_hub_membrane_structure",
    "membrane_triad_stiffness",
]


def _expand(p: np.ndarray) -> np.ndarray:
    """``P ⊗ I₃`` ``(ne, 3k, 3kk)`` of per-element maps ``P`` ``(ne, k, kk)``."""
    ne, k, kk = p.shape
    return np.einsum("eab,ij->eaibj", p, np.eye(3)).reshape(ne, 3 * k, 3 * kk)


@dataclass(frozen=True)
class ImageSet(ElementSet):
    """The elements of ``inner`` (a set over virtual nodes: its ``conn`` is ``arange(ne k)
    .reshape(ne, k)``) whose node positions are ``P X[conn]``: ``conn`` ``(ne, kk)`` global
    vector DOFs, ``images`` ``P`` ``(ne, k, kk)`` (module docstring)."""

    inner: ElementSet
    conn: np.ndarray
    images: np.ndarray

    def _virtual(self, x: np.ndarray) -> np.ndarray:
        """Virtual node positions ``(ne k, 3)`` of the global state ``x`` (n, 3)."""
        return np.einsum("eab,ebi->eai", self.images, x[self.conn]).reshape(-1, 3)

    def _pull(self, f: np.ndarray) -> np.ndarray:
        """``Pᵀ f`` ``(ne, kk, 3)`` of element forces ``(ne, k, 3)``."""
        return np.einsum("eab,eai->ebi", self.images, f)

    def _pull_matrix(self, k: np.ndarray) -> np.ndarray:
        p = _expand(self.images)
        return np.einsum("eab,eac,ecd->ebd", p, k, p)

    def energy(self, x: np.ndarray) -> float:
        return self.inner.energy(self._virtual(x))

    def force(self, x: np.ndarray) -> np.ndarray:
        return self._pull(self.inner.force(self._virtual(x)))

    def stiffness(self, x: np.ndarray) -> np.ndarray:
        return self._pull_matrix(self.inner.stiffness(self._virtual(x)))

    def second_order(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        b = self.inner.second_order(self._virtual(x), self._virtual(u), self._virtual(v))
        return self._pull(b)

    def mass(self) -> np.ndarray | None:
        m = self.inner.mass()
        return None if m is None else np.einsum("eab,eac,ecd->ebd", self.images, m, self.images)

    def step_start(self, x0: np.ndarray):
        return self.inner.step_start(self._virtual(x0))

    def step_force(self, x0: np.ndarray, x1: np.ndarray, start=None) -> np.ndarray:
        return self._pull(self.inner.step_force(self._virtual(x0), self._virtual(x1), start))

    def step_block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        return self._pull_matrix(self.inner.step_block(self._virtual(x0), self._virtual(x1)))

    def principal_stress_resultants(self, x: np.ndarray) -> np.ndarray:
        """The inner membrane's principal stress resultants ``(ne, 2)`` (N/m) at ``x``."""
        return self.inner.principal_stress_resultants(self._virtual(x))


@dataclass(frozen=True)
class PointMassSpec:
    """A point mass (kg) bonded to the membrane nodes within ``patch`` (m) of ``position``
    ``(3,)`` (m, stress-free), spread over them smoothly (module docstring)."""

    name: str
    mass: float
    position: tuple[float, float, float]
    patch: float


def membrane_triad_stiffness(
    rigidity: float, spec: MembraneSpec, hub_radius: float, moments: np.ndarray, extent: float
) -> float:
    """Distortion stiffness (N m) of the hub's triad under a membrane, ``rigidity`` × the
    larger of two stiffnesses that do not vanish at rest:

    * the membrane's in-plane stiffness on a unit stretch of the hub's axes, ``E t b²`` (b the
      hub radius): the hub deforms 1/rigidity as much as the membrane it holds;
    * ``S_max E / (ρ R²)`` (S the hub's second moments of mass, R the membrane's ``extent``):
      spinning at Ω, the hub's own centrifugal load ``Ω² S`` stretches its axes by ``Ω² S / k``,
      while the membrane's centrifugal strain is ``ρ Ω² R² / E``; both grow as Ω², so with
      this k the hub's penalty strain is 1/rigidity of the membrane's at every spin. (A heavy
      hub needs this one: the IKAROS hub's 49 kg m² at 1e4 E t b² would stretch the hub's rim
      by 3 % of the membrane's displacement there.)"""
    in_plane = spec.youngs_modulus * spec.thickness * hub_radius**2
    centrifugal = float(np.max(moments)) * spec.youngs_modulus / (spec.density * extent**2)
    return float(MEMBRANE_TRIAD_FACTOR * rigidity * max(in_plane, centrifugal))


#: Extra factor on ``[hub] rigidity`` under a membrane. The case default (100) is set for booms
#: (fe/hub.py: the roots' axial and section stiffness, rigid to 2e-4 in the blades' roots); the
#: two bounds above are order-of-magnitude scales, and at 100 × them the annulus's hub still
#: strained 2 % of the membrane's rim strain and its hub-coupled (0, 0) branch moved 0.1 %
#: (tests/test_spinning_annulus.py). 100 more (10⁴ × the bounds, as validated) keeps the hub's
#: strain below 1e-8 and every branch at its rigid-hub value.
MEMBRANE_TRIAD_FACTOR = 100.0


def _image_rows(points: np.ndarray, tri: np.ndarray, on_hub: np.ndarray, index: np.ndarray,
                centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """``(conn (ne, kk), P (ne, 3, kk))`` of triangles ``tri`` that all have the same number
    of free nodes: ``index`` maps a surface node to its structure DOF."""
    free = ~on_hub[tri]
    nf = int(free[0].sum())
    kk = HUB_DOFS + nf
    conn = np.zeros((len(tri), kk), np.int64)
    conn[:, :HUB_DOFS] = np.arange(HUB_DOFS)
    p = np.zeros((len(tri), 3, kk))
    slot = np.cumsum(free, axis=1) - 1 + HUB_DOFS  # the free node's column
    for a in range(3):
        hub = ~free[:, a]
        rho = points[tri[:, a]] - centre
        p[hub, a, 0] = 1.0
        p[hub, a, 1:HUB_DOFS] = rho[hub]
        rows = np.flatnonzero(~hub)
        p[rows, a, slot[rows, a]] = 1.0
        conn[rows, slot[rows, a]] = index[tri[rows, a]]
    return conn, p


def _membrane_sets(points, triangles, spec: MembraneSpec, on_hub, index, centre):
    """The plain membrane set of the hub-free triangles and one :class:`ImageSet` per number
    of free nodes (1, 2) of the others; triangles all on the hub (rigid: no strain) give
    their mass to the hub, returned as a ``(4, 4)`` block."""
    args = (spec.thickness, spec.youngs_modulus, spec.poisson_ratio, spec.density)
    kw = {"lumped_mass": spec.lumped_mass, "tension_field": spec.tension_field}
    n_free = (~on_hub[triangles]).sum(axis=1)
    plain = triangles[n_free == 3]
    sets: list = [membrane_set(index[plain], _indexed(points, index), *args, **kw)]
    rigid_mass = np.zeros((HUB_DOFS, HUB_DOFS))
    for nf in (2, 1, 0):
        tri = triangles[n_free == nf]
        if not len(tri):
            continue
        virtual = np.arange(3 * len(tri)).reshape(-1, 3)
        inner = membrane_set(virtual, points[tri].reshape(-1, 3), *args, **kw)
        if nf == 0:
            _, p = _image_rows(points, tri, on_hub, index, centre)
            rigid_mass += np.einsum("eab,eac,ecd->bd", p, inner.mass(), p)
            continue
        conn, p = _image_rows(points, tri, on_hub, index, centre)
        sets.append(ImageSet(inner, conn, p))
    return sets, rigid_mass


def _indexed(points: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Points placed at their structure rows (rows of hub-ring nodes left at zero)."""
    out = np.zeros((int(index.max()) + 1, 3))
    ok = index >= 0
    out[index[ok]] = points[ok]
    return out


def _point_masses(points, triangles, masses: Sequence[PointMassSpec], index, n):
    """Nodal masses ``(n,)`` (kg) of ``masses`` spread over their patches, and their groups."""
    area = np.zeros(len(points))
    p = points[triangles]
    a = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    np.add.at(area, triangles.ravel(), np.repeat(a / 3.0, 3))
    nodal, groups = np.zeros(n), {}
    for m in masses:
        d = np.linalg.norm(points - np.asarray(m.position), axis=1) / m.patch
        near = (d < 1.0) & (index >= 0)
        if not near.any():
            raise ValueError(f"tip_mass {m.name}: no free membrane node within its patch "
                             f"({m.patch:.4g} m); enlarge patch or refine the mesh")  # fmt: skip
        w = area[near] * (1.0 - d[near] ** 2) ** 2
        w /= w.sum()
        nodal[index[near]] += m.mass * w
        groups[f"tip:{m.name}"] = index[near]
    return nodal, groups


def build_hub_membrane_structure(
    points: np.ndarray,
    triangles: np.ndarray,
    spec: MembraneSpec,
    hub: HubSpec,
    hub_nodes: np.ndarray,
    rigidity: float = 100.0,
    point_masses: Sequence[PointMassSpec] = (),
) -> Structure:
    """The structure of a flat membrane (triangles ``(nt, 3)`` on ``points`` ``(n, 3)`` m)
    whose nodes ``hub_nodes`` are clamped to the rigid ``hub`` (module docstring). DOFs: the
    hub's ``c, a₁, a₂, a₃`` (0–3), then the other membrane nodes in their order. ``rigidity``:
    :func:`membrane_triad_stiffness`."""
    points = np.asarray(points, float)
    triangles = np.asarray(triangles, np.int64)
    centre = np.asarray(hub.centre, float)
    on_hub = np.zeros(len(points), bool)
    on_hub[np.asarray(hub_nodes, np.int64)] = True
    index = np.full(len(points), -1, np.int64)
    index[~on_hub] = HUB_DOFS + np.arange(int((~on_hub).sum()))
    n = HUB_DOFS + int((~on_hub).sum())
    sets, rigid_mass = _membrane_sets(points, triangles, spec, on_hub, index, centre)
    hub_radius = float(np.max(np.linalg.norm(points[on_hub] - centre, axis=1)))
    moments = second_moments_of_mass(np.asarray(hub.inertia))
    extent = float(np.max(np.linalg.norm(points - centre, axis=1)))
    triad = hub_rigidity_set(membrane_triad_stiffness(rigidity, spec, hub_radius, moments, extent))
    hub_block = np.diag(np.concatenate([[hub.mass], moments])) + rigid_mass
    ms = assemble_scalar_matrix(np.arange(HUB_DOFS)[None, :], hub_block[None], n)
    for e in sets:
        ms = ms + assemble_scalar_matrix(e.conn, e.mass(), n)
    nodal, tip_groups = _point_masses(points, triangles, point_masses, index, n)
    ms = (ms + sp.diags(nodal)).tocsr()
    reference = np.zeros((n, 3))
    reference[0] = centre
    reference[1:HUB_DOFS] = np.eye(3)
    reference[index[~on_hub]] = points[~on_hub]
    translational = np.ones(n, bool)
    translational[1:HUB_DOFS] = False
    groups = {"hub": np.array([0]), "membrane": index[~on_hub], **tip_groups}
    return Structure(
        reference=reference,
        translational=translational,
        elements=(triad, *sets),
        mass_scalar=ms,
        fixed=np.zeros((n, 3), bool),
        groups=groups,
    )
