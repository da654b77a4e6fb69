"""Reduced-model stage: quadratic modes g^{mn} and the precomputed floating-frame arrays.

From the prestressed structure and its modes (``u^k`` mass-normalised, force basis
``f^k = K u^k``) this module forms

* the quadratic modes ``g^{mn}``: ``K g = −B(u^m, u^n)`` with inertia relief and the frame
  conditions (centre of mass and mean axes) for a free body — one factorisation of the bordered
  matrix ``[[K, MΨ], [ΨᵀM, 0]]`` for all ``N(N+1)/2`` right-hand sides — or a plain solve on the
  free DOFs of a clamped body;
* the arrays of theory.md §3.2, all mass-weighted bilinear forms ``P(a, b) = aᵀ M_s b``.

The result is a :class:`ReducedModel`, a frozen set of arrays with units, saved and loaded as a
self-describing NetCDF file by :mod:`quadmodes.rom.artifact`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.model import (
    Structure,
    centre_of_mass,
    internal_force,
    mass_matrix,
    rigid_body_modes,
    second_order_force,
    tangent_low_rank,
    tangent_stiffness,
    total_mass,
)
from quadmodes.fe.pressure import PressureSet
from quadmodes.rom.quartic_closed import cubic_force_tensor_closed, symmetrise
from quadmodes.structure.bordered import bordered_solver
from quadmodes.structure.modes import remove_rigid_part
from quadmodes.structure.spinning import centrifugal_softening


@dataclass(frozen=True)
class ReducedModel:
    """Precomputed arrays of the method of quadratic modes (SI units; N modes, n vector DOFs).

    mass: total mass m (kg). free: True for a free-floating body (X about the centre of mass),
    False for a body clamped to a hub (X measured from the hub point on the rotation axis).
    frequencies_hz (N,), damping_ratio (N,), labels (N,): the retained modes.
    J0 (3,3) kg m²: reference inertia 𝒥(X,X). J1 (N,3,3): 2𝒥(X,u^k). J2u (N,N,3,3): 𝒥(u^m,u^n).
    J2g (N,N,3,3): 2𝒥(X,g^{mn}). c (N,3): 𝒞(X,u^k). Cuu (N,N,3): 𝒞(u^m,u^n). Cxg (N,N,3):
    𝒞(X,g^{mn}). S1 (N,3): Σ w u^k, S2 (N,N,3): Σ w g^{mn} (kg m; vanish for a free body).
    mu (N,N): ΦᵀMΦ (= I). Lam (N,N): ΦᵀKΦ (= diag ω², 1/s²). C (N,N): modal damping (1/s).
    X (n,3) m: reference vector DOFs (prestressed, about the CoM for a free body).
    translational (n,) bool. weights (n,) kg: w = M_s t. Phi (N,n,3): modes (1/√kg).
    G (N,N,n,3): quadratic modes g^{mn} (1/kg).
    V3 (N,N,N) J/(√kg·m)³, V4 (N,N,N,N) J/(√kg·m)⁴: fully symmetric cubic and quartic
    coefficients of the manifold potential (:func:`manifold_potential_tensors`), the strain
    energy of ``x0 + Φs + Σ s_m s_n g^{mn}`` truncated at fourth order in s:
    ``V(s) = ½ sᵀΛs + V3_mnp s_m s_n s_p + V4_mnpq s_m s_n s_p s_q``. They default to zeros;
    ``manifold_potential`` is True only when they were computed (formulation "Q4" needs it).
    Mode coordinates s are in √kg·m, so that T = ½ ṡᵀ μ ṡ and V = ½ sᵀ Λ s (J) to second order.

    Expanded about a spinning state (``reference_spin`` ≠ 0 rad/s about ``reference_axis`` (3,),
    body frame): X is the full order's centrifugal relative equilibrium at that spin
    (:func:`quadmodes.structure.spinning.relative_equilibrium`), the modes are those of the
    rotating-frame stiffness ``K_T − Ω²MP̂`` on the frame conditions, and the potential gets the
    linear term ``F1·s`` (F1 (N,) J/(√kg·m) = Φᵀ f(X), the internal force that balances the
    centrifugal load there) and ``Λ = ΦᵀK_TΦ + 2 f·g^{mn}``: ``V(s) = F1·s + ½ sᵀΛs (+ V3, V4)``
    is then the strain energy of the manifold about that state to second (fourth) order, and at
    the reference spin s = 0 is a relative equilibrium of the reduced equations. F1 is zero for
    a model about the state at rest.
    """

    mass: float
    free: bool
    frequencies_hz: np.ndarray
    damping_ratio: np.ndarray
    labels: tuple[str, ...]
    J0: np.ndarray
    J1: np.ndarray
    J2u: np.ndarray
    J2g: np.ndarray
    c: np.ndarray
    Cuu: np.ndarray
    Cxg: np.ndarray
    S1: np.ndarray
    S2: np.ndarray
    mu: np.ndarray
    Lam: np.ndarray
    C: np.ndarray
    X: np.ndarray
    translational: np.ndarray
    weights: np.ndarray
    Phi: np.ndarray
    G: np.ndarray
    V3: np.ndarray | None = None
    V4: np.ndarray | None = None
    manifold_potential: bool = False
    provenance: dict = field(default_factory=dict)
    F1: np.ndarray | None = None
    reference_spin: float = 0.0
    reference_axis: np.ndarray | None = None

    def __post_init__(self):
        n = len(self.frequencies_hz)
        if self.F1 is None:
            object.__setattr__(self, "F1", np.zeros(n))
        if self.reference_axis is None:
            object.__setattr__(self, "reference_axis", np.array([0.0, 0.0, 1.0]))
        if self.V3 is None:
            object.__setattr__(self, "V3", np.zeros((n, n, n)))
        if self.V4 is None:
            object.__setattr__(self, "V4", np.zeros((n, n, n, n)))

    @property
    def n_modes(self) -> int:
        return len(self.frequencies_hz)

    @property
    def J2(self) -> np.ndarray:
        """Second-order inertia coefficients ``J2u + J2g`` (N,N,3,3)."""
        return self.J2u + self.J2g

    @property
    def D(self) -> np.ndarray:
        """Rotation–deformation coupling ``Cuu + 2 Cxg`` (N,N,3)."""
        return self.Cuu + 2.0 * self.Cxg

    def rigid(self) -> ReducedModel:
        """The same body with no elastic modes (N = 0)."""
        n = self.X.shape[0]
        z = np.zeros
        return ReducedModel(
            self.mass,
            self.free,
            z(0),
            z(0),
            (),
            self.J0,
            z((0, 3, 3)),
            z((0, 0, 3, 3)),
            z((0, 0, 3, 3)),
            z((0, 3)),
            z((0, 0, 3)),
            z((0, 0, 3)),
            z((0, 3)),
            z((0, 0, 3)),
            z((0, 0)),
            z((0, 0)),
            z((0, 0)),
            self.X,
            self.translational,
            self.weights,
            z((0, n, 3)),
            z((0, 0, n, 3)),
            provenance=dict(self.provenance),
            reference_spin=self.reference_spin,
            reference_axis=self.reference_axis,
        )

    def select(self, modes: np.ndarray) -> ReducedModel:
        """The model restricted to the modes with indices ``modes``."""
        i = np.asarray(modes, int)
        ii = np.ix_(i, i)
        return ReducedModel(
            self.mass,
            self.free,
            self.frequencies_hz[i],
            self.damping_ratio[i],
            tuple(self.labels[k] for k in i),
            self.J0,
            self.J1[i],
            self.J2u[ii],
            self.J2g[ii],
            self.c[i],
            self.Cuu[ii],
            self.Cxg[ii],
            self.S1[i],
            self.S2[ii],
            self.mu[ii],
            self.Lam[ii],
            self.C[ii],
            self.X,
            self.translational,
            self.weights,
            self.Phi[i],
            self.G[ii],
            self.V3[np.ix_(i, i, i)],
            self.V4[np.ix_(i, i, i, i)],
            self.manifold_potential,
            dict(self.provenance),
            self.F1[i],
            self.reference_spin,
            self.reference_axis,
        )


def mass_product(ms: sp.spmatrix, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``P(a, b) = aᵀ M_s b`` ``(..., 3, 3)`` for fields ``a`` ``(..., n, 3)``, ``b`` ``(n, 3)``."""
    mb = ms @ b
    return np.einsum("...ia,ib->...ab", a, mb)


def inertia_form(p: np.ndarray) -> np.ndarray:
    """``𝒥 = tr P I − ½(P + Pᵀ)`` for ``P`` ``(..., 3, 3)``."""
    tr = np.trace(p, axis1=-2, axis2=-1)[..., None, None]
    return tr * np.eye(3) - 0.5 * (p + np.swapaxes(p, -1, -2))


def cross_form(p: np.ndarray) -> np.ndarray:
    """``𝒞 = (P23 − P32, P31 − P13, P12 − P21)`` for ``P`` ``(..., 3, 3)``."""
    return np.stack(
        [p[..., 1, 2] - p[..., 2, 1], p[..., 2, 0] - p[..., 0, 2], p[..., 0, 1] - p[..., 1, 0]], -1
    )


def quadratic_modes(
    structure: Structure, x: np.ndarray, shapes: np.ndarray, progress=None, softening=None
):
    """Quadratic modes ``g^{mn}`` ``(N, N, n, 3)`` (symmetric in m, n) about state ``x``.

    Free body: bordered solve ``[[K, MΨ], [ΨᵀM, 0]]`` (inertia relief + CoM/mean-axis frame);
    clamped body: ``K_ff g_f = −B_f``. ``K`` is the tangent, minus ``softening`` (3n, 3n) N/m if
    given (the centrifugal softening ``Ω²MP̂`` of a spinning reference state: the second-order
    static response in the rotating frame).
    """
    n_modes = shapes.shape[0]
    free = structure.free_dofs
    k = tangent_stiffness(structure, x)
    if softening is not None:
        k = (k - softening).tocsr()
    k = k[free][:, free]
    low_rank = [(c, v[free]) for c, v in tangent_low_rank(structure, x)]
    if structure.is_free:
        constraint = (mass_matrix(structure) @ rigid_body_modes(structure, x))[free]
        # drop rigid motions that carry no mass (line beams about their axis)
        gram = constraint.T @ rigid_body_modes(structure, x)[free]
        lam, vec = np.linalg.eigh(0.5 * (gram + gram.T))
        constraint = constraint @ vec[:, lam > 1e-10 * lam.max()]
    else:
        constraint = None
    solve = bordered_solver(k, constraint, low_rank)
    g = np.zeros((n_modes, n_modes, structure.n, 3))
    pairs = [(m, q) for m in range(n_modes) for q in range(m, n_modes)]
    for j, (m, q) in enumerate(pairs):
        b = second_order_force(structure, x, shapes[m], shapes[q]).ravel()[free]
        full = np.zeros(3 * structure.n)
        full[free] = solve(-b)
        g[m, q] = g[q, m] = full.reshape(-1, 3)
        if progress:
            progress("quadratic modes", (j + 1) / len(pairs))
    if structure.is_free:
        # polish the frame conditions (S2 = 0, C_xg = 0) to round-off: the removed part is a
        # rigid motion, in the kernel of K, so K g = −ΠᵀB still holds
        flat = g.reshape(n_modes * n_modes, -1).T
        g = remove_rigid_part(structure, x, flat).T.reshape(g.shape)
    return g


def has_polynomial_potential(structure: Structure) -> bool:
    """True if the internal force is an exact polynomial of degree ≤ 3 in the DOFs (membrane,
    bar, cable, constant pressure); False with a gas-law pressure (``p V^κ = const``)."""
    return not any(isinstance(e, PressureSet) and e.gas_law_exponent for e in structure.elements)


def pair_forces(structure: Structure, x: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """``B_x(u^m, u^n)`` ``(N, N, n, 3)`` (N per unit² of the shapes), symmetric in (m, n), for
    shapes ``(N, n, 3)`` about state ``x`` ``(n, 3)`` (m)."""
    n_modes = shapes.shape[0]
    out = np.zeros((n_modes, n_modes) + shapes.shape[1:])
    for m in range(n_modes):
        for q in range(m, n_modes):
            out[m, q] = out[q, m] = second_order_force(structure, x, shapes[m], shapes[q])
    return out


def cubic_force_tensor(structure, x, shapes, b=None, progress=None) -> np.ndarray:
    """``E_mnpq = u^q · C(u^m, u^n, u^p)`` ``(N, N, N, N)`` (J per unit⁴ of the shapes).

    ``C`` is the symmetric trilinear cubic term of ``f(x + U) = f(x) + KU + B(U,U) + C(U,U,U)``.
    For a cubic f, ``D²f`` is affine in the state, so exactly (no truncation error)
    ``C(u, v, w) = (B_{x+αw}(u, v) − B_x(u, v)) / (3α)`` for any α; α is chosen so that
    ``α w`` spans the body (round-off). ``b``: ``pair_forces(structure, x, shapes)`` if known."""
    n_modes = shapes.shape[0]
    phi = shapes.reshape(n_modes, -1)
    b = pair_forces(structure, x, shapes) if b is None else b
    size = float(np.ptp(x[structure.translational], axis=0).max(initial=0.0)) or 1.0
    e = np.zeros((n_modes,) * 4)
    for p in range(n_modes):
        alpha = size / max(float(np.abs(shapes[p]).max()), 1e-300)
        bp = pair_forces(structure, x + alpha * shapes[p], shapes)
        e[:, :, p, :] = np.einsum("mni,qi->mnq", (bp - b).reshape(n_modes, n_modes, -1), phi)
        e[:, :, p, :] /= 3.0 * alpha
        if progress:
            progress("manifold potential", (p + 1) / n_modes)
    return e


def manifold_potential_tensors(
    structure: Structure, x: np.ndarray, shapes: np.ndarray, g: np.ndarray, progress=None
) -> tuple[np.ndarray, np.ndarray]:
    """Cubic and quartic coefficients ``(V3 (N,N,N), V4 (N,N,N,N))``, fully symmetric, of the
    strain energy on the quadratic-mode manifold ``U(s) = a + b``, ``a = Φs``, ``b = Σ s_m s_n
    g^{mn}``, about the equilibrium ``x`` (``f(x) = 0`` on the free DOFs).

    With ``W(x+U) − W(x) = ½UᵀKU + ⅓UᵀB(U,U) + ¼UᵀC(U,U,U)`` (exact for a cubic force)::

        cubic:   aᵀK b + ⅓ aᵀB(a,a)
        quartic: ½ bᵀK b + bᵀB(a,a) + ¼ aᵀC(a,a,a)

    (the terms of U·B(U,U) with one b combine as ⅓(bᵀB(a,a) + 2aᵀB(a,b)) = bᵀB(a,a) since
    ``wᵀB(u,v)`` is the symmetric form ½D³W). K g is not replaced by −B: for a free body the
    quadratic modes include inertia relief. Units: J per (√kg·m)³ and (√kg·m)⁴."""
    n_modes = shapes.shape[0]
    k = tangent_stiffness(structure, x)
    phi = shapes.reshape(n_modes, -1)
    gf = g.reshape(n_modes, n_modes, -1)
    kg = (k @ gf.reshape(n_modes * n_modes, -1).T).T.reshape(gf.shape)
    b = pair_forces(structure, x, shapes)
    bf = b.reshape(n_modes, n_modes, -1)
    t3 = np.einsum("pi,mni->mnp", phi, kg) + np.einsum("pi,mni->mnp", phi, bf) / 3.0
    e = cubic_force_tensor_closed(structure, shapes)  # the membrane's, 10³ × faster
    if e is None:
        e = cubic_force_tensor(structure, x, shapes, b, progress)
    t4 = 0.5 * np.einsum("mni,pqi->mnpq", gf, kg) + np.einsum("mni,pqi->mnpq", gf, bf) + 0.25 * e
    return symmetrise(t3), symmetrise(t4)


def reduce(
    structure: Structure,
    x: np.ndarray,
    frequencies_hz: np.ndarray,
    shapes: np.ndarray,
    labels,
    damping_ratio: float | np.ndarray,
    progress=None,
    provenance: dict | None = None,
    *,
    spinning: SpinningReference | None = None,
    damping_matrix: np.ndarray | None = None,
) -> ReducedModel:
    """Build the :class:`ReducedModel` from the prestressed state ``x`` and retained modes.

    ``spinning``: the model is expanded about a spinning state (``x`` its relative equilibrium,
    ``shapes`` modes of its rotating-frame stiffness; :class:`ReducedModel`). ``damping_matrix``
    (N, N) 1/s: the modal damping (default ``diag(2ζω)``)."""
    n_modes = shapes.shape[0]
    ms = structure.mass_scalar
    t = structure.translational.astype(float)
    if structure.is_free:
        xr = x - np.outer(t, centre_of_mass(structure, x))
    else:
        xr = x.copy()
    softening = None if spinning is None else spinning.softening(structure)
    g = quadratic_modes(structure, x, shapes, progress, softening)
    w = ms @ t
    p_xx = mass_product(ms, xr, xr)
    p_xu = mass_product(ms, shapes, xr)  # P(u, X): (N,3,3); transpose for P(X, u)
    p_x_u = np.swapaxes(p_xu, -1, -2)
    p_uu = np.einsum("mia,nib->mnab", shapes, np.stack([ms @ s for s in shapes]))
    p_xg = np.swapaxes(mass_product(ms, g, xr), -1, -2)  # P(X, g)
    phi = shapes.reshape(n_modes, -1).T
    mu = phi.T @ (mass_matrix(structure) @ phi)
    lam, f1 = potential_quadratic_part(structure, x, shapes, g, spinning is not None)
    omega = 2.0 * np.pi * np.asarray(frequencies_hz)
    zeta = np.broadcast_to(np.asarray(damping_ratio, float), omega.shape).copy()
    if damping_matrix is None:
        damping_matrix = np.diag(2.0 * zeta * omega * np.diag(mu))
    polynomial = has_polynomial_potential(structure)
    if polynomial:
        v3, v4 = manifold_potential_tensors(structure, x, shapes, g, progress)
    else:  # gas law: the potential is not a polynomial; Q4 refuses such a model
        v3, v4 = None, None
    return ReducedModel(
        mass=total_mass(structure),
        free=structure.is_free,
        frequencies_hz=np.asarray(frequencies_hz, float),
        damping_ratio=zeta,
        labels=tuple(labels),
        J0=inertia_form(p_xx),
        J1=2.0 * inertia_form(p_x_u),
        J2u=inertia_form(p_uu),
        J2g=2.0 * inertia_form(p_xg),
        c=cross_form(p_x_u),
        Cuu=cross_form(p_uu),
        Cxg=cross_form(p_xg),
        S1=np.einsum("i,kia->ka", w, shapes),
        S2=np.einsum("i,mnia->mna", w, g),
        mu=mu,
        Lam=lam,
        C=np.asarray(damping_matrix, float),
        X=xr,
        translational=structure.translational.copy(),
        weights=w,
        Phi=shapes.copy(),
        G=g,
        V3=v3,
        V4=v4,
        manifold_potential=polynomial,
        provenance=dict(provenance or {}),
        F1=f1,
        reference_spin=0.0 if spinning is None else float(spinning.spin),
        reference_axis=None if spinning is None else np.asarray(spinning.axis, float),
    )


def potential_quadratic_part(
    structure: Structure, x: np.ndarray, shapes: np.ndarray, g: np.ndarray, loaded: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """``(Λ (N,N) 1/s², F1 (N,) J/(√kg·m))``: the second- and first-order coefficients of the
    strain energy on the manifold ``x + Φs + Σ s_m s_n g^{mn}`` about ``x`` (n,3),
    ``Λ = ΦᵀK_TΦ + 2 f·g^{mn}`` and ``F1 = Φᵀf`` with ``f`` the internal force at ``x`` on the
    free DOFs (pressure included): zero at an equilibrium at rest, the centrifugal load at a
    spinning relative equilibrium. ``loaded=False``: ``x`` is an equilibrium at rest, f is taken
    as zero (its Newton residual is not kept) and F1 = 0."""
    n_modes = shapes.shape[0]
    phi = shapes.reshape(n_modes, -1).T
    lam = phi.T @ (tangent_stiffness(structure, x) @ phi)
    for coef, vec in tangent_low_rank(structure, x):
        lam += coef * np.outer(phi.T @ vec, phi.T @ vec)
    if not loaded:
        return 0.5 * (lam + lam.T), np.zeros(n_modes)
    force = internal_force(structure, x)
    force[structure.fixed] = 0.0
    f = force.ravel()
    if np.abs(f).max(initial=0.0) > 0.0:
        lam += 2.0 * (g.reshape(n_modes, n_modes, -1) @ f)
    f1 = phi.T @ f
    return 0.5 * (lam + lam.T), f1


@dataclass(frozen=True)
class SpinningReference:
    """The spinning state a reduced model is expanded about: ``spin`` (rad/s) about the unit
    ``axis`` (3,) through the centre of mass (free body) or the hub point (clamped)."""

    spin: float
    axis: np.ndarray

    def softening(self, structure: Structure) -> sp.csr_matrix:
        """Centrifugal softening ``Ω² M_s ⊗ (I − e eᵀ)`` (3n, 3n) N/m."""
        return centrifugal_softening(structure, self.spin, self.axis)
