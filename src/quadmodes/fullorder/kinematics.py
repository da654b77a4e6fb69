"""Frames, the reduced → full-order state map and per-sample diagnostics of the full-order model.

All functions are pure functions of arrays: a state is ``x`` ``(n, 3)`` (m; slope rows of a cable
are dimensionless) and ``v`` ``(n, 3)`` (m/s), with the scalar mass ``M_s`` ``(n, n)`` (kg) of
:class:`~quadmodes.fe.model.Structure`, ``t`` the translational indicator (1 for position rows,
0 for slope rows). Mass-weighted forms follow theory.md §1: ``𝒞(a, b) = Σ_ij M_ij a_i × b_j``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.fe import model as fem
from quadmodes.rom.reduced import ReducedModel, cross_form
from quadmodes.rotations import axis_rotation, polar_rotation, rotation_matrix, skew
from quadmodes.structure.bordered import bordered_solver

# ---------------------------------------------------------------------------------------------
# rotations
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class HubDrive:
    """Prescribed hub rotation: the clamped vector DOFs follow ``x_c(t) = point + R(t) X_c``.

    angle: ``t (s) -> (θ (rad), θ̇ (rad/s))``; the hub frame coincides with the reference frame
    at θ = 0. axis (3,): hub axis (inertial, unit after normalisation). point (3,) m: a point on
    the axis (the origin of the clamped body's reference X)."""

    angle: Callable[[float], tuple[float, float]]
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def rotation(self, t: float) -> np.ndarray:
        """Hub rotation R(t) (3,3), hub frame → inertial."""
        return axis_rotation(np.asarray(self.axis, float), self.angle(t)[0])

    def angular_velocity(self, t: float) -> np.ndarray:
        """Hub angular velocity (3,) rad/s, inertial (= hub frame: the axis is fixed)."""
        a = np.asarray(self.axis, float)
        return self.angle(t)[1] * a / np.linalg.norm(a)


def kane_angle(t: float, omega_s: float, t_ramp: float) -> tuple[float, float]:
    """Hub angle θ (rad) and rate Ω (rad/s) of the Kane spin-up (:func:`quadmodes.runs.spinup.kane_rate`
    integrated): θ = (Ωs/T)[t²/2 + (T/2π)²(cos(2πt/T) − 1)] for t ≤ T, then θ(T) + Ωs (t − T)."""
    if t <= t_ramp:
        a = 2.0 * np.pi / t_ramp
        theta = (omega_s / t_ramp) * (0.5 * t * t + (np.cos(a * t) - 1.0) / (a * a))
        rate = (omega_s / t_ramp) * (t - np.sin(a * t) / a)
        return float(theta), float(rate)
    return float(0.5 * omega_s * t_ramp + omega_s * (t - t_ramp)), float(omega_s)


def kane_hub(omega_s: float, t_ramp: float) -> HubDrive:
    """:class:`HubDrive` of the Kane profile about the z axis through the origin."""
    return HubDrive(angle=lambda t: kane_angle(t, omega_s, t_ramp))


# ---------------------------------------------------------------------------------------------
# body frame of a deformed state
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Body:
    """Constant data of the body for frames and diagnostics.

    ms (n,n) kg: scalar mass. t (n,) float: translational indicator. w (n,) kg: ``M_s t``.
    mass kg. X (n,3): reference about the CoM (free body) or the hub point (clamped).
    MX (n,3) = ``M_s X``. Phi (N,n,3), G (N,N,n,3): retained modes and quadratic modes (may be
    N = 0). MPhi (N,n,3) = ``M_s Φ``. tip: index of the tip position row (clamped) or None.
    GM (N,N,N) √kg·m⁻¹: ``Φ_kᵀ M g^{mn}`` (indexed k, m, n) for :func:`modal_coordinates`, or
    None (computed there)."""

    ms: sp.csr_matrix
    t: np.ndarray
    w: np.ndarray
    mass: float
    X: np.ndarray
    MX: np.ndarray
    Phi: np.ndarray
    G: np.ndarray
    MPhi: np.ndarray
    tip: int | None = None
    GM: np.ndarray | None = None

    @property
    def n_modes(self) -> int:
        return self.Phi.shape[0]


def make_body(ms, translational, X, model: ReducedModel | None, hub: bool) -> Body:
    """:class:`Body` from the scalar mass, translational mask, reference X and optional model."""
    ms = sp.csr_matrix(ms)
    t = np.asarray(translational, float)
    w = ms @ t
    n = X.shape[0]
    phi = np.zeros((0, n, 3)) if model is None else np.asarray(model.Phi, float)
    g = np.zeros((0, 0, n, 3)) if model is None else np.asarray(model.G, float)
    mphi = np.stack([ms @ p for p in phi]) if len(phi) else np.zeros((0, n, 3))
    tip = None
    if hub:
        r = np.where(t > 0, np.linalg.norm(X, axis=1), -np.inf)
        tip = int(np.argmax(r))
    gm = np.einsum("mnia,kia->kmn", g, mphi)  # Φᵀ M g^{mn}, once instead of per sample
    return Body(ms, t, w, float(w.sum()), X, ms @ X, phi, g, mphi, tip, gm)


def centre(body: Body, x: np.ndarray) -> np.ndarray:
    """Centre of mass (3,) m of state x."""
    return (body.w @ x) / body.mass


def best_fit_rotation(body: Body, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Mass-weighted best-fit (Kabsch) rotation R (3,3) of ``x`` about ``p`` onto the reference:
    the polar factor of ``Σ M_ij (x_i − t_i p) X_jᵀ``. It is the mean-axes (Buckens) frame,
    ``𝒞(X, Rᵀ(x − p)) = 0`` (theory.md §2)."""
    r = x - body.t[:, None] * p
    return polar_rotation(r.T @ body.MX)


def mean_axes_omega(body: Body, rb: np.ndarray, vb: np.ndarray) -> np.ndarray:
    """Body-frame angular velocity (3,) rad/s of the mean-axes frame: the ω with
    ``𝒞(X, vb − ω × rb) = 0`` (the time derivative of the frame condition), for body-frame
    positions ``rb = Rᵀ(x − p)`` and velocities ``vb = Rᵀ(v − ṗ)`` (n,3)."""
    p = body.MX.T @ rb  # P_ab = Σ M X_a rb_b
    a = np.trace(p) * np.eye(3) - p.T
    return np.linalg.solve(a, cross_form(body.MX.T @ vb))


def modal_coordinates(
    body: Body, u: np.ndarray, quadratic: bool = True, iterations: int = 12
) -> np.ndarray:
    """Modal coordinates s (N,) √kg·m of a body-frame displacement ``u`` (n,3) m: the
    M-projection ``s = Φᵀ M_s u`` (μ = I), corrected with ``quadratic`` for the quadratic modes:
    the root of ``s + Φᵀ M_s Σ s_m s_n g^{mn} = Φᵀ M_s u`` nearest the projection, by Newton
    (at most ``iterations``, to round-off).

    Why Newton, not the fixed point ``s ← Φᵀ M_s (u − Σ s s g)`` it replaces: Φᵀ M g is not
    zero for a spinning model, and the fixed point contracts by ‖2 Φᵀ M g s‖ per iteration
    (0.23 at the 45° point of the coarse spin-family path, docs/path-validity.md), so eight
    iterations left 2e-8 of s; Newton reaches round-off in three or four. For a manifold field
    R(X + Φs + Σ s s g) + p the best-fit frame is R exactly (Φ and g satisfy the mean-axes
    conditions) and this returns s: the full order's instrument reads a reduced state's own
    field as that state's s (``tests/test_family_point.py``)."""
    if body.n_modes == 0:
        return np.zeros(0)
    lin = np.einsum("kia,ia->k", body.MPhi, u)
    s = lin
    if quadratic:
        gm = body.GM if body.GM is not None else np.einsum("mnia,kia->kmn", body.G, body.MPhi)
        gm = 0.5 * (gm + gm.transpose(0, 2, 1))  # g^{mn} = g^{nm}: the Jacobian is 2 gm s
        eye = np.eye(len(lin))
        for _ in range(iterations):
            r = s + np.einsum("kmn,m,n->k", gm, s, s) - lin
            step = np.linalg.solve(eye + 2.0 * np.einsum("kmn,n->km", gm, s), r)
            s = s - step
            if np.linalg.norm(step) <= 1e-15 * np.linalg.norm(s):
                break
    return s


# ---------------------------------------------------------------------------------------------
# reduced state -> full-order state
# ---------------------------------------------------------------------------------------------


def initial_state_from_reduced(
    model: ReducedModel,
    y0: np.ndarray,
    p: np.ndarray | None = None,
    p_dot: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Full-order ``(x0, v0)`` (n,3) of a reduced state ``y0 = [q, ω, s, ṡ]`` (7+2N,).

    ``x = p + R (X + Σ s_k u^k + Σ s_m s_n g^{mn})`` and
    ``v = ṗ + R (ω × r + Σ ṡ_k u^k + 2 Σ s_m ṡ_n g^{mn})``, r = X + U, with R = R(q) (body →
    inertial), ω the body angular velocity (rad/s), p (3,) m the centre of mass (free model) or
    the hub point (clamped; default the origin) and ṗ (3,) m/s (default 0). Position rows
    translate (p, ṗ added), slope rows only rotate (``model.translational``)."""
    n_modes = model.n_modes
    y0 = np.asarray(y0, float)
    if y0.shape != (7 + 2 * n_modes,):
        raise ValueError(f"y0 must have shape ({7 + 2 * n_modes},), got {y0.shape}")
    q, w = y0[:4], y0[4:7]
    s, sd = y0[7 : 7 + n_modes], y0[7 + n_modes :]
    phi, g = np.asarray(model.Phi, float), np.asarray(model.G, float)
    u = np.einsum("k,kia->ia", s, phi) + np.einsum("m,n,mnia->ia", s, s, g)
    ud = np.einsum("k,kia->ia", sd, phi) + 2.0 * np.einsum("m,n,mnia->ia", s, sd, g)
    r = np.asarray(model.X, float) + u
    rot = rotation_matrix(q)
    t = np.asarray(model.translational, float)
    p = np.zeros(3) if p is None else np.asarray(p, float)
    pd = np.zeros(3) if p_dot is None else np.asarray(p_dot, float)
    x0 = np.outer(t, p) + r @ rot.T
    v0 = np.outer(t, pd) + (np.cross(w, r) + ud) @ rot.T
    return x0, v0


# ---------------------------------------------------------------------------------------------
# diagnostics of one state
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Sample:
    """Diagnostics of one state (SI): H (3) inertial angular momentum about the CoM (kg m²/s);
    T (J) kinetic energy without the CoM translation; inertia (3,3) inertial, about the CoM
    (kg m²); omega (3,) inertial mean-axes angular velocity (rad/s); s (N,) modal coordinates;
    tip (3,) hub-frame tip displacement (m) or None."""

    H: np.ndarray
    T: float
    inertia: np.ndarray
    omega: np.ndarray
    s: np.ndarray
    tip: np.ndarray | None


def sample(
    body: Body, x: np.ndarray, v: np.ndarray, frame: np.ndarray | None, origin, omega=None
) -> Sample:
    """:class:`Sample` of state (x, v). ``frame`` (3,3): the body frame (the hub rotation of a
    clamped body), or None for the best-fit frame of a free body; ``origin`` (3,): the hub point
    (clamped) or None (the centre of mass); ``omega`` (3,) inertial: the hub angular velocity
    (clamped; else the mean-axes ω is computed)."""
    p = centre(body, x)
    pd = (body.w @ v) / body.mass
    r = x - body.t[:, None] * p
    mv = body.ms @ v
    h = cross_form(r.T @ mv)
    t_kin = 0.5 * float(np.sum(v * mv)) - 0.5 * body.mass * float(pd @ pd)
    pm = r.T @ (body.ms @ r)
    inertia = np.trace(pm) * np.eye(3) - pm
    o = p if origin is None else np.asarray(origin, float)
    rot = best_fit_rotation(body, x, o) if frame is None else frame
    rb = (x - body.t[:, None] * o) @ rot
    if omega is None:
        vb = (v - body.t[:, None] * pd) @ rot
        w_in = rot @ mean_axes_omega(body, rb, vb)
    else:
        w_in = np.asarray(omega, float)
    u = rb - body.X
    s = modal_coordinates(body, u)
    tip = u[body.tip].copy() if body.tip is not None else None
    return Sample(h, t_kin, 0.5 * (inertia + inertia.T), w_in, s, tip)


def track(inertia: np.ndarray, previous: np.ndarray) -> np.ndarray:
    """The unit eigenvector (3,) of ``inertia`` (3,3) nearest ``previous`` (3,), sign continuous
    (as :func:`quadmodes.rom.diagnostics.track_axis`)."""
    _, vec = np.linalg.eigh(inertia)
    d = previous @ vec
    j = int(np.argmax(np.abs(d)))
    return vec[:, j] * (1.0 if d[j] >= 0.0 else -1.0)


def minor_axis(inertia: np.ndarray) -> np.ndarray:
    """Minor principal axis (3,) of ``inertia``, sign: largest component positive."""
    _, vec = np.linalg.eigh(inertia)
    v = vec[:, 0]
    return v * np.sign(v[np.argmax(np.abs(v))])


# ---------------------------------------------------------------------------------------------
# centrifugal pre-stretch of the initial state
# ---------------------------------------------------------------------------------------------


def bordered_correction(
    structure: fem.Structure,
    x: np.ndarray,
    stiffness: sp.spmatrix,
    constraints: np.ndarray | None,
    residual: np.ndarray,
) -> np.ndarray:
    """Newton correction Δx (n,3) m of a static residual on the free DOFs of ``structure``:
    ``(K + Σ c v vᵀ) Δx = −r`` subject to ``Cᵀ Δx = 0`` (bordered solve), with ``stiffness`` K
    (n_free, n_free) N/m, the rank-one gas-law terms of
    :func:`~quadmodes.fe.model.tangent_low_rank` at x (n,3), ``constraints`` C (n_free, k) or
    None and ``residual`` r (n_free,) N. Zero on clamped components."""
    free = structure.free_dofs
    low = [(c, v[free]) for c, v in fem.tangent_low_rank(structure, x)]
    solve = bordered_solver(stiffness, constraints, low)
    dx = np.zeros(3 * structure.n)
    dx[free] = -solve(residual)
    return dx.reshape(-1, 3)


def centrifugal_stretch(
    structure: fem.Structure,
    x_ref: np.ndarray,
    omega: np.ndarray,
    model: ReducedModel | None = None,
    rtol: float = 1e-10,
    max_iterations: int = 30,
) -> np.ndarray:
    """Quasi-static centrifugal displacement ``u_c`` (n,3) m of the free body in its reference
    frame under steady rotation ω (3,) rad/s (body frame): ``f(X + u_c) = −M ω × (ω × r)`` with
    inertia relief and the CoM / mean-axes conditions (bordered Newton, as the prestress stage),
    minus its content in the retained modes of ``model``: the quadratic-manifold point
    ``Φs + Σ s_m s_n g^{mn}`` with ``Φᵀ M (u_c − Φs − Σ s s g) = 0``.

    Why: a state taken from the reduced model spins without the centrifugal stretch of the
    membrane (at 41 Hz it is of the order of the inflation strain). The full order then starts
    with a violent breathing transient in modes the reduced model does not have, which also
    defeats the midpoint at Δt = 0.5 ms (ωΔt ≫ 1 on those modes). Adding ``R u_c`` puts the
    non-retained modes at their quasi-static state (which is what a reduced model assumes) and
    leaves the retained ones where the reduced state has them."""
    w = np.asarray(omega, float)
    lmat = np.outer(w, w) - (w @ w) * np.eye(3)  # ω × (ω × r) = L r
    tr = structure.translational.astype(float)
    ms = structure.mass_scalar
    free = structure.free_dofs
    x = np.asarray(x_ref, float).copy()
    scale = float(np.max(np.abs(x_ref))) or 1.0
    m_l = sp.kron(ms, lmat, format="csr")
    for _ in range(max_iterations):
        r = x - np.outer(tr, fem.centre_of_mass(structure, x))
        res = fem.internal_force(structure, x) + ms @ (r @ lmat)
        k = (fem.tangent_stiffness(structure, x) + m_l)[free][:, free]
        cons = (fem.mass_matrix(structure) @ fem.rigid_body_modes(structure, x))[free]
        dx = bordered_correction(structure, x, k, cons, res.ravel()[free])
        x = x + dx
        if np.max(np.abs(dx)) <= rtol * scale:
            break
    else:
        raise ValueError(
            "centrifugal stretch: Newton did not converge; the spin may exceed the body's "
            "stability (rotating stiffness K − Mω² not positive definite)"
        )
    u = x - x_ref
    if model is not None and model.n_modes:
        phi = np.asarray(model.Phi, float)
        # The retained content is the manifold point Φs + Σ s s g, not Φs: with the linear part
        # alone, the second-order part of a beam section's rotation (|d|² = 1 − θ², …) would
        # stay behind in its stiff section strains. s solves Φᵀ M (u − Φs − Σ s s g) = 0, so
        # the remainder has no linear content in the retained modes either.
        g = np.asarray(getattr(model, "G", np.zeros((0, 0, *u.shape))), float)
        quad = np.zeros_like(u)
        for _ in range(20 if g.size else 1):
            s = np.einsum("kia,ia->k", phi, ms @ (u - quad))
            new = np.einsum("m,n,mnia->ia", s, s, g) if g.size else quad
            if np.max(np.abs(new - quad), initial=0.0) <= rtol * scale:
                quad = new
                break
            quad = new
        u = u - np.einsum("k,kia->ia", s, phi) - quad
    return u


# ---------------------------------------------------------------------------------------------
# steady rotation under the inertial-frame midpoint
# ---------------------------------------------------------------------------------------------


def _rotation_parts(body: Body, x: np.ndarray, v: np.ndarray):
    """``(c, ṗ, r, ω)``: CoM (3,), its velocity (3,), r = x − t c (n,3) and the inertial
    mean-axes angular velocity ω (3,) rad/s of state (x, v)."""
    c = centre(body, x)
    pd = (body.w @ v) / body.mass
    r = x - body.t[:, None] * c
    rot = best_fit_rotation(body, x, c)
    w = rot @ mean_axes_omega(body, r @ rot, (v - body.t[:, None] * pd) @ rot)
    return c, pd, r, w


def _rescale(body: Body, c, pd, r, w_from, w_to, radial: float, v_el) -> tuple:
    """State with ``r⊥`` (normal to ω) scaled by ``radial`` and the rigid velocity ω_to × r."""
    a = w_to / np.linalg.norm(w_to)
    r_new = r + (radial - 1.0) * (r - np.outer(r @ a, a))
    return body.t[:, None] * c + r_new, body.t[:, None] * pd + r_new @ skew(w_to).T + v_el


def to_discrete_rotation(body: Body, x: np.ndarray, v: np.ndarray, h: float, expand: bool = True):
    """Map a physical state (x, v) (n,3) to the state the implicit midpoint needs for the same
    steady rotation at step h (s).

    For a rigid rotation at Ω (angle φ = |Ω|h per step) the midpoint's exact discrete solution
    has its *midpoint* configuration ``x½`` equal to the physical one, the end configurations
    expanded normal to Ω by ``1/cos(φ/2)`` and the end velocities ``κ Ω × r`` with
    ``κ = tan(φ/2)/(φ/2)``. Starting from the physical state instead puts a sudden strain of
    φ²/8 (2e-3 at 41 Hz, 0.5 ms) into every element: stiff parts (end-body ties) then ring at the
    Nyquist frequency with large amplitude. Elastic velocities are kept. With the energy–momentum
    stress average (``expand`` False) the end configurations of a steady rotation are the
    physical ones (x½ is shrunk instead) and only the velocities are scaled by κ."""
    c, pd, r, w = _rotation_parts(body, x, v)
    phi = float(np.linalg.norm(w)) * h
    if phi == 0.0:
        return x.copy(), v.copy()
    v_el = v - body.t[:, None] * pd - r @ skew(w).T  # − ω × r
    kappa = np.tan(0.5 * phi) / (0.5 * phi)
    radial = 1.0 / np.cos(0.5 * phi) if expand else 1.0
    return _rescale(body, c, pd, r, w, kappa * w, radial, v_el)


def to_physical_rotation(body: Body, x: np.ndarray, v: np.ndarray, h: float, expand: bool = True):
    """Inverse of :func:`to_discrete_rotation`: the physical state (x, v) (n,3) of a midpoint
    end state at step h (s), with Ω from the end state's mean-axes ω = κ Ω
    (φ = 2 atan(|ω| h / 2))."""
    c, pd, r, w = _rotation_parts(body, x, v)
    phi_d = float(np.linalg.norm(w)) * h
    if phi_d == 0.0:
        return x.copy(), v.copy()
    phi = 2.0 * np.arctan(0.5 * phi_d)
    v_el = v - body.t[:, None] * pd - r @ skew(w).T  # − ω × r
    radial = np.cos(0.5 * phi) if expand else 1.0
    return _rescale(body, c, pd, r, w, w * (phi / phi_d), radial, v_el)
