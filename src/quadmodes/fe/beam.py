"""Geometrically nonlinear 3-D beam with torsion and section rotary inertia, on vector DOFs.

Each beam node carries four vector DOFs of the global state ``x`` ``(n, 3)``: its position ``r``
(m, translational), its slope ``t = ∂r/∂x`` and two section directors ``d₂, d₃`` (dimensionless,
non-translational; in the stress-free state ``t, d₂, d₃`` are the orthonormal beam frame). In an
element of reference length ``L`` (``ξ = x/L``) the centreline is the cubic Hermite interpolant
of ``r, t`` (as :mod:`quadmodes.fe.cable`), the directors are linear, and a material point of
the section at ``(y, z)`` is at ``X = r + y d₂ + z d₃``. So the mass is isotropic and constant,
``M_s = ∫ρA S Sᵀ + ∫ρI₂ N Nᵀ + ∫ρI₃ N Nᵀ`` (``I₂ = ∫y² dA``, ``I₃ = ∫z² dA``), which carries the
section's rotary inertia (torsion ``ρ(I₂ + I₃)``, and the Rayleigh term in bending).

Strains (all quadratic forms of the DOFs, see :mod:`quadmodes.fe.quadratic_strain`), per length:

* along the element (5-point Gauss, exact): axial Green strain ``ε = ½(r'·r' − 1)`` (EA),
  curvatures ``κ₂ = r''·d₂`` (E I₂, bending towards d₂), ``κ₃ = r''·d₃`` (E I₃), twist
  ``κ₁ = ½(d₂'·d₃ − d₃'·d₂)`` (GJ; ``= φ'`` for a section twisted by φ);
* at the nodes (trapezoidal rule, weight L/2 per element end): the section's tie to the slope,
  ``γ₂ = t·d₂``, ``γ₃ = t·d₃`` (κGA, a transverse-shear spring), and its rigidity,
  ``½(d₂·d₂ − 1)``, ``½(d₃·d₃ − 1)`` (EA) and ``d₂·d₃`` (GA) — the section strains of a ν = 0
  St Venant–Kirchhoff continuum. Evaluating the tie only at the nodes, where ``t`` is a DOF,
  avoids the shear locking a pointwise tie of a linear director to a quadratic slope would cause.

The energy is a quartic polynomial, exactly invariant under rigid motions (translations move
only ``r``; rotations turn every vector), so a free beam has exactly six rigid-body modes. Bending
is Euler–Bernoulli (curvature of the centreline) with rotary inertia; twist is St Venant's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.fe.cable import hermite_shape
from quadmodes.fe.quadratic_strain import QuadraticStrainSet

#: Vector DOFs per beam node: r, t, d₂, d₃.
DOFS_PER_NODE = 4
N_GAUSS = 5
_GP, _GW = np.polynomial.legendre.leggauss(N_GAUSS)
_XI, _WXI = 0.5 * (_GP + 1.0), 0.5 * _GW


@dataclass(frozen=True)
class BeamSection:
    """Section properties (SI): axial EA (N), bending E I₂ / E I₃ (N m², towards d₂ / d₃),
    torsion GJ (N m²), shear κGA and in-plane shear GA (N), mass per length ρA (kg/m) and the
    section's second moments of mass ρI₂, ρI₃ (kg m)."""

    EA: float
    EI2: float
    EI3: float
    GJ: float
    kGA: float
    GA: float
    rho_A: float
    rho_I2: float
    rho_I3: float


def solid_section(
    area: float,
    second_moment: float,
    youngs_modulus: float,
    density: float,
    shear_modulus: float | None = None,
    torsion_constant: float | None = None,
    shear_factor: float = 5.0 / 6.0,
) -> BeamSection:
    """A doubly symmetric section (I₂ = I₃ = ``second_moment``, m⁴) of ``area`` (m²); shear
    modulus (Pa) defaults to E/2.6 (ν = 0.3) and the torsion constant (m⁴) to 2I (circular)."""
    g = youngs_modulus / 2.6 if shear_modulus is None else shear_modulus
    j = 2.0 * second_moment if torsion_constant is None else torsion_constant
    e = youngs_modulus
    return BeamSection(
        EA=e * area, EI2=e * second_moment, EI3=e * second_moment, GJ=g * j,
        kGA=shear_factor * g * area, GA=g * area, rho_A=density * area,
        rho_I2=density * second_moment, rho_I3=density * second_moment,
    )  # fmt: skip


def _coefficients(length0: np.ndarray, xi: np.ndarray) -> dict[str, np.ndarray]:
    """Coefficient vectors ``(ne, nξ, 8)`` over the element DOFs
    ``[r_a, t_a, d2_a, d3_a, r_b, t_b, d2_b, d3_b]`` of r, r', r'', d₂, d₂', d₃, d₃' at ``xi``."""
    n, dn, ddn = hermite_shape(xi)
    L = length0[:, None, None]
    ne, nx = length0.size, xi.size
    scale = np.ones((ne, 1, 4))
    scale[:, 0, 1] = scale[:, 0, 3] = length0
    out = {k: np.zeros((ne, nx, 8)) for k in ("r", "r1", "r2", "d2", "d2x", "d3", "d3x")}
    for key, shape, power in (("r", n, 0), ("r1", dn, 1), ("r2", ddn, 2)):
        out[key][..., [0, 1, 4, 5]] = shape[None] * scale / L**power
    lin = np.stack([1.0 - xi, xi], -1)[None]
    for key, slots in (("d2", [2, 6]), ("d3", [3, 7])):
        out[key][..., slots] = lin
        out[key + "x"][..., slots] = np.array([-1.0, 1.0]) / L
    return out


def _bilinear(alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Operator ``a = αβᵀ + βαᵀ`` with ``½ qᵀ a q = (αq)·(βq)``."""
    return np.einsum("...j,...l->...jl", alpha, beta) + np.einsum("...j,...l->...jl", beta, alpha)


def _distributed_operators(length0: np.ndarray) -> np.ndarray:
    """``a`` ``(ne, 5, 4, 8, 8)``: axial, κ₂, κ₃, κ₁ at the Gauss points."""
    c = _coefficients(length0, _XI)
    axial = np.einsum("...j,...l->...jl", c["r1"], c["r1"])
    twist = 0.5 * (_bilinear(c["d2x"], c["d3"]) - _bilinear(c["d3x"], c["d2"]))
    return np.stack(
        [axial, _bilinear(c["r2"], c["d2"]), _bilinear(c["r2"], c["d3"]), twist], axis=2
    )


def _nodal_operators(ne: int) -> np.ndarray:
    """``a`` ``(ne, 2, 5, 8, 8)``: t·d₂, t·d₃, ½|d₂|², ½|d₃|², d₂·d₃ at both element ends."""
    a = np.zeros((2, 5, 8, 8))
    for p, base in enumerate((0, 4)):
        e = np.eye(8)[base : base + 4]  # r, t, d2, d3 of this end
        a[p, 0] = _bilinear(e[1], e[2])
        a[p, 1] = _bilinear(e[1], e[3])
        a[p, 2] = np.outer(e[2], e[2])
        a[p, 3] = np.outer(e[3], e[3])
        a[p, 4] = _bilinear(e[2], e[3])
    return np.broadcast_to(a, (ne, 2, 5, 8, 8)).copy()


def _mass_blocks(length0: np.ndarray, section: BeamSection) -> np.ndarray:
    """Scalar consistent mass ``(ne, 8, 8)``."""
    c = _coefficients(length0, _XI)
    dx = _WXI[None, :] * length0[:, None]
    m = section.rho_A * np.einsum("eg,egj,egl->ejl", dx, c["r"], c["r"])
    m += section.rho_I2 * np.einsum("eg,egj,egl->ejl", dx, c["d2"], c["d2"])
    m += section.rho_I3 * np.einsum("eg,egj,egl->ejl", dx, c["d3"], c["d3"])
    return m


def _transformed(a: np.ndarray, transform: np.ndarray | None) -> np.ndarray:
    """``Pᵀ a P`` over the last two axes, P ``(ne, 8, 8)`` per element (None: identity)."""
    if transform is None:
        return a
    extra = a.ndim - 3
    p = transform.reshape(transform.shape[0], *([1] * extra), 8, 8)
    return np.swapaxes(p, -1, -2) @ a @ p


@dataclass(frozen=True, eq=False)
class BeamSectionSet(QuadraticStrainSet):
    """The nodal section strains of a beam (:func:`_nodal_operators`), with ``triads``
    ``(k, 3)``: the rows ``[t, d₂, d₃]`` of its nodes whose slope and directors are DOFs of
    their own (not images of a hub's) — what the full order's Newton turns as a frame
    (:func:`quadmodes.fullorder.newton.advanced`)."""

    triads: np.ndarray | None = None


def beam_sets(
    conn: np.ndarray,
    length0: np.ndarray,
    section: BeamSection,
    transform: np.ndarray | None = None,
) -> tuple[QuadraticStrainSet, BeamSectionSet]:
    """The beam's two element sets (distributed strains with the mass; nodal section strains)
    for elements ``conn`` ``(ne, 8)`` of reference lengths ``length0`` ``(ne,)`` (m).

    ``transform`` ``(ne, 8, 8)``: per element the linear map from the DOFs in ``conn`` to the
    element's ``[r_a, t_a, d2_a, d3_a, r_b, …]`` (a root clamped to a rigid body), or None.
    """
    conn = np.asarray(conn, dtype=np.intp)
    length0 = np.broadcast_to(np.asarray(length0, float), (conn.shape[0],)).copy()
    ne = conn.shape[0]
    s = section
    dist = QuadraticStrainSet(
        conn=conn,
        operators=_transformed(_distributed_operators(length0), transform),
        offsets=np.broadcast_to([0.5, 0.0, 0.0, 0.0], (ne, N_GAUSS, 4)).copy(),
        moduli=np.broadcast_to([s.EA, s.EI2, s.EI3, s.GJ], (ne, N_GAUSS, 4)).copy(),
        weights=_WXI[None, :] * length0[:, None],
        mass_blocks=_transformed(_mass_blocks(length0, s), transform),
    )
    nodal = BeamSectionSet(
        conn=conn,
        operators=_transformed(_nodal_operators(ne), transform),
        offsets=np.broadcast_to([0.0, 0.0, 0.5, 0.5, 0.0], (ne, 2, 5)).copy(),
        moduli=np.broadcast_to([s.kGA, s.kGA, s.EA, s.EA, s.GA], (ne, 2, 5)).copy(),
        weights=np.repeat(0.5 * length0[:, None], 2, axis=1),
        triads=_own_triads(conn, transform),
    )
    return dist, nodal


def _own_triads(conn: np.ndarray, transform: np.ndarray | None) -> np.ndarray:
    """Rows ``[t, d₂, d₃]`` ``(k, 3)`` of the element ends of ``conn`` ``(ne, 8)`` whose DOFs are
    their own (the end's block of ``transform`` is the identity), each node once."""
    ends = []
    for base in (0, 4):
        own = np.ones(conn.shape[0], bool)
        if transform is not None:
            block = transform[:, base : base + 4, base : base + 4]
            own = np.all(np.isclose(block, np.eye(4)), axis=(1, 2))
        ends.append(conn[own, base + 1 : base + 4])
    return np.unique(np.concatenate(ends), axis=0)


def beam_frame(tangent: np.ndarray, director2: np.ndarray | None = None) -> np.ndarray:
    """Orthonormal rows ``(3, 3)`` ``[t, d₂, d₃]``: ``d₂`` is ``director2`` made normal to
    ``t`` (default: the global axis least aligned with t), ``d₃ = t × d₂``."""
    t = np.asarray(tangent, float) / np.linalg.norm(tangent)
    if director2 is None:
        director2 = np.eye(3)[int(np.argmin(np.abs(t)))]
    d2 = np.asarray(director2, float) - np.dot(director2, t) * t
    norm = np.linalg.norm(d2)
    if norm < 1e-9:
        raise ValueError("beam director: must not be parallel to the beam axis; choose another")
    d2 /= norm
    return np.stack([t, d2, np.cross(t, d2)])


def straight_beam_nodes(
    start: np.ndarray, end: np.ndarray, n_elements: int, director2: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Stress-free vector DOFs ``(4 (n_elements + 1), 3)`` ``[r_0, t, d₂, d₃, r_1, …]`` of a
    straight beam and its translational flags."""
    if n_elements < 1:
        raise ValueError("beam elements: must be >= 1")
    start, end = np.asarray(start, float), np.asarray(end, float)
    frame = beam_frame(end - start, director2)
    nn = n_elements + 1
    ref = np.empty((nn, DOFS_PER_NODE, 3))
    ref[:, 0] = start + np.linspace(0.0, 1.0, nn)[:, None] * (end - start)
    ref[:, 1:] = frame[None]
    translational = np.zeros((nn, DOFS_PER_NODE), bool)
    translational[:, 0] = True
    return ref.reshape(-1, 3), translational.ravel()


def chain_connectivity(first_dof: int, n_elements: int) -> np.ndarray:
    """``(n_elements, 8)`` connectivity of a chain of beam nodes numbered from ``first_dof``."""
    e = first_dof + DOFS_PER_NODE * np.arange(n_elements)[:, None]
    return e + np.arange(2 * DOFS_PER_NODE)[None, :]
