"""Reduced equations of motion of a free-floating (or hub-driven) flexible body, body frame: the
Lagrangian quantities (energies, momenta), the mass matrix, the right-hand side and the
prescribed-rotation form. The arrays of a formulation, the formulations themselves and the
state vector are in :mod:`quadmodes.rom.system`; the rotating-frame linearisation in
:mod:`quadmodes.rom.rotating_frame`.

Euler–Poincaré equations (τ, Q external torque and modal force, both zero here)::

    ḣ + ω × h = τ,                 h   = ∂L̃/∂ω = J̃ ω + Aᵀ ṡ
    ṗ_s − ∂L̃/∂s = −C ṡ + Q,        p_s = ∂L̃/∂ṡ = A ω + μ ṡ

written as ``𝕄(s) ν̇ = b`` with ``ν = (ω, ṡ)``, ``𝕄 = [[J̃, Aᵀ], [A, μ]]`` and::

    b_ω = τ − ω × h − J̃̇ ω − Ȧᵀ ṡ,     J̃̇ = Σ_k ṡ_k ∂J̃/∂s_k,   Ȧᵀṡ = Σ_mn ṡ_m ṡ_n D_mn
    b_k = Q_k − (Λs)_k − (Cṡ)_k + ωᵀ(½ J1_k + Σ_m s_m J2_km) ω + Σ_m ṡ_m ω·(D_km − D_mk)

(``D_km − D_mk = 2 Cuu_km`` because Cuu is antisymmetric and Cxg symmetric in (m, n).)

Implementation: T = ½ νᵀ𝕄(s)ν with 𝕄(s) evaluated by blocks (:mod:`quadmodes.rom.structured_mass`,
O(N²)), so that with P[k] = ½ (∂𝕄/∂s_k) ν ``b = [−ω × h, P·ν − Λs − Cṡ] − 2 ṡ·P`` (the last
term is −𝕄̇ν). No loops over modes.

Formulation "Q4": the modal force is ``−∂V/∂s = −Λs − 3 V3·ss − 4 V4·sss`` in place of ``−Λs``,
its Jacobian ``−(Λ + 6 V3·s + 12 V4·ss)``; E (with this V) and H are conserved by the continuous
equations.

Prescribed rotation (hub-clamped body, ``model.free is False``): ``prescribed_rhs`` integrates
``μ s̈ + (Γ(ω) + C) ṡ + (Λ − ωᵀJ2ω) s = ½ ωᵀJ1ω − A(s) ω̇`` for given ω(t), ω̇(t).

SI units; the state vector ``y = [q, ω, s, ṡ]`` (7+2N) of :mod:`quadmodes.rom.system`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from quadmodes.rom import structured_mass as sm
from quadmodes.rom.system import ReducedSystem, split_state, sym_tensor
from quadmodes.rotations import quat_rate, rotation_matrix

# ---------------------------------------------------------------------------------------------
# Lagrangian quantities (batched over leading axes of y)
# ---------------------------------------------------------------------------------------------


def inertia_tensor(sys: ReducedSystem, s: np.ndarray, row: str = "energy") -> np.ndarray:
    """J̃(s) (..., 3, 3) kg m² for s (..., N). ``row="rot"`` uses the rotational-row arrays."""
    j2 = sys.J2_rot if row == "rot" else sys.J2
    return (
        sys.J0
        + np.einsum("...k,kab->...ab", s, sys.J1)
        + np.einsum("...m,...n,mnab->...ab", s, s, j2)
    )


def coupling_rows(sys: ReducedSystem, s: np.ndarray, row: str = "energy") -> np.ndarray:
    """A(s) as rows a_n (..., N, 3) √kg·m: ``a_n = c_n + Σ_m s_m D_mn``."""
    d = sys.D_rot if row == "rot" else sys.D
    return sys.c + np.einsum("...m,mna->...na", s, d)


def kinetic_energy(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """Kinetic energy T = ½ ωᵀJ̃ω + ω·(Aᵀṡ) + ½ ṡᵀμṡ (…) J (energy/modal-row arrays; "QM":
    ½ νᵀ𝕄(s)ν of the manifold)."""
    _, w, s, sd = split_state(sys, y)
    if sys.manifold is not None:
        return 0.5 * np.einsum("...i,...i->...", np.concatenate([w, sd], -1), _qm_momenta(sys, y))
    jt = inertia_tensor(sys, s)
    a = coupling_rows(sys, s)
    return (
        0.5 * np.einsum("...a,...ab,...b->...", w, jt, w)
        + np.einsum("...a,...n,...na->...", w, sd, a)
        + 0.5 * np.einsum("...m,mn,...n->...", sd, sys.mu, sd)
    )


def potential_energy(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """V = F1·s + ½ sᵀΛs (…) J; for "Q4" plus ``V3_mnp s_m s_n s_p + V4_mnpq s_m s_n s_p s_q``."""
    s = split_state(sys, y)[2]
    v = 0.5 * np.einsum("...m,mn,...n->...", s, sys.Lam, s) + s @ sys.F1
    if sys.quartic:
        ss = np.einsum("...m,...n->...mn", s, s)
        v = v + np.einsum("...mn,...p,mnp->...", ss, s, sys.V3)
        v = v + np.einsum("...mn,...pq,mnpq->...", ss, ss, sys.V4)
    if sys.nonlinear_potential is not None:  # one evaluation per sample (a static solve each)
        extra = sys.nonlinear_potential.nonlinear_energy
        flat = s.reshape(-1, sys.n_modes)
        v = v + np.array([extra(si) for si in flat]).reshape(s.shape[:-1])
    return v


def effective_potential(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """``V(s) − ½ωᵀ(J̃(s) − J0)ω`` (…) J at modal coordinates ``s`` (…, N), ω the system's
    ``reference_omega``: the potential in the frame turning with the reference state (for a
    model about the state at rest, ω = 0: V itself)."""
    s = np.asarray(s, float)
    y = np.zeros(s.shape[:-1] + (7 + 2 * sys.n_modes,))
    y[..., 7 : 7 + sys.n_modes] = s
    w = sys.reference_omega
    jt = inertia_tensor(sys, s) - sys.J0
    return potential_energy(sys, y) - 0.5 * np.einsum("a,...ab,b->...", w, jt, w)


def potential_gradient(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """∂V/∂s (N,) J/(√kg·m) at one s (N,): ``F1 + Λs`` (+ ``3 V3·ss + 4 V4·sss`` for "Q4")."""
    g = sys.Lam @ s + sys.F1
    return g + potential_nonlinear_force(sys, s) if sys.nonlinear else g


def potential_nonlinear_force(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """``∂V/∂s − Λs − F1 = 3 V3·ss + 4 V4·sss (+ ∂N/∂s)`` (N,) J/(√kg·m) at one s (N,) (zeros
    for Q, P, L; N the system's ``nonlinear_potential``)."""
    if sys.quartic:
        ss = np.outer(s, s).ravel()
        out = sys.flat.V3g @ ss + sys.flat.V4g @ np.outer(ss, s).ravel()
    else:  # no V3, V4 (their flat forms are (N, 0))
        out = np.zeros(sys.n_modes)
    if sys.nonlinear_potential is not None:
        out = out + sys.nonlinear_potential.nonlinear_force(s)
    return out


def potential_hessian(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """∂²V/∂s² (N,N) 1/s² at one s (N,): ``Λ`` (+ ``6 V3·s + 12 V4·ss`` for "Q4")."""
    if not sys.nonlinear:
        return sys.Lam
    n = sys.n_modes
    h = sys.Lam
    if sys.quartic:
        ss = np.outer(s, s).ravel()
        h3 = (sys.flat.V3g.reshape(n * n, n) @ s).reshape(n, n)  # 3 V3·s
        h4 = (sys.flat.V4g.reshape(n * n, n * n) @ ss).reshape(n, n)  # 4 V4·ss
        h = h + 2.0 * h3 + 3.0 * h4
    if sys.nonlinear_potential is not None:
        h = h + sys.nonlinear_potential.nonlinear_hessian(s)
    return h


def potential_nonlinear_energy(sys: ReducedSystem, s: np.ndarray) -> float:
    """``V − F1·s − ½ sᵀΛs`` (J) at one s (N,): the cubic and quartic terms of "Q4" plus the
    system's ``nonlinear_potential`` (zero for Q, P, L)."""
    v = 0.0
    if sys.quartic:
        ss = np.outer(s, s)
        v = float(np.einsum("mn,p,mnp->", ss, s, sys.V3) + np.einsum("mn,pq,mnpq->", ss, ss, sys.V4))
    if sys.nonlinear_potential is not None:
        v += float(sys.nonlinear_potential.nonlinear_energy(s))
    return v


def potential_barrier(
    sys: ReducedSystem, n_directions: int = 4000, seed: int = 0
) -> tuple[float, np.ndarray]:
    """Lowest barrier of the "Q4" potential: ``(V_b (J), s_b (N,))``.

    For a model expanded about a spinning state the potential is the effective one at its
    reference angular velocity ω, ``V − ½ωᵀJ̃(s)ω`` (Λ → Λ − ωᵀJ2ω, whose linear term vanishes
    there). Along a ray ``s = r d`` (d scaled so that ½ dᵀΛd = ½) ``V(r) = r²/2 + c3 r³ + c4 r⁴``; where
    the quartic turns V down, its first maximum (the smaller positive root of
    ``4c4 r² + 3c3 r + 1 = 0``) is the energy a motion needs to escape along d. ``V_b`` is the
    smallest such maximum over ``n_directions`` random directions (a sampled estimate from above;
    ``inf`` when V rises along every sampled ray, e.g. for Q), ``s_b`` the point where it is
    reached. Why: V4 truncates the manifold energy and can be negative definite, so V is unbounded
    below; a state whose modal energy exceeds V_b may run off to where Q4 has no meaning."""
    n = sys.n_modes
    if not sys.quartic or n == 0:
        return math.inf, np.zeros(n)
    lam, f1 = _effective_quadratic(sys)
    d = np.random.default_rng(seed).standard_normal((n_directions, n))
    d /= np.sqrt(np.einsum("km,mn,kn->k", d, lam, d))[:, None]
    c3 = np.einsum("mnp,km,kn,kp->k", sys.V3, d, d, d)
    c4 = np.einsum("mnpq,km,kn,kp,kq->k", sys.V4, d, d, d, d)
    c1 = d @ f1
    c1[np.abs(c1) <= 1e-9 * np.abs(f1 @ f1) ** 0.5 + 1e-300] = 0.0  # cancelled: F1 balances
    if np.any(c1):  # a linear term (spinning reference): maxima of c1 r + r²/2 + c3 r³ + c4 r⁴
        r = np.array([_first_maximum(*c) for c in zip(c1, c3, c4, strict=True)])
    else:
        a, b = 4.0 * c4, 3.0 * c3
        disc = b * b - 4.0 * a  # roots of a r² + b r + 1
        with np.errstate(invalid="ignore", divide="ignore"):
            sq = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
            roots = np.stack([(-b - sq) / (2 * a), (-b + sq) / (2 * a)], 1)
        roots = np.where((roots > 0.0) & np.isfinite(roots), roots, np.inf)
        r = roots.min(axis=1)
    with np.errstate(invalid="ignore"):
        v = np.where(np.isfinite(r), c1 * r + 0.5 * r * r + c3 * r**3 + c4 * r**4, np.inf)
    k = int(np.argmin(v))
    return float(v[k]), (r[k] * d[k] if np.isfinite(v[k]) else np.zeros(n))


def _effective_quadratic(sys: ReducedSystem) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness (N,N) and linear force (N,) of the effective potential V − ½ωᵀJ̃(s)ω at the
    system's reference spin ω (Λ − ωᵀJ2ω, F1 − ½ωᵀJ1ω)."""
    n, w = sys.n_modes, sys.reference_omega
    lam = sys.Lam - (sys.flat.J2w @ np.outer(w, w).ravel()).reshape(n, n)
    return lam, sys.F1 - 0.5 * np.einsum("kab,a,b->k", sys.J1, w, w)


def beyond_ray_maximum(sys: ReducedSystem, s0: np.ndarray) -> bool:
    """Q4: whether the modal state ``s0`` (N,) lies beyond the first maximum of the effective
    potential along its own ray ``r s0/|s0|`` (False at s0 = 0 or for a potential rising along it)."""
    n = sys.n_modes
    s0 = np.asarray(s0, float)
    if not sys.quartic or n == 0 or not np.any(s0):
        return False
    lam, f1 = _effective_quadratic(sys)
    r0 = float(np.sqrt(s0 @ lam @ s0))
    if not r0 > 0.0:
        return False
    d = s0 / r0
    c1 = float(d @ f1)
    if abs(c1) <= 1e-9 * float(np.sqrt(f1 @ f1)) + 1e-300:
        c1 = 0.0
    c3 = float(np.einsum("mnp,m,n,p->", sys.V3, d, d, d))
    c4 = float(np.einsum("mnpq,m,n,p,q->", sys.V4, d, d, d, d))
    return r0 > _first_maximum(c1, c3, c4)


def _first_maximum(c1: float, c3: float, c4: float) -> float:
    """Smallest r > 0 where ``V(r) = c1 r + r²/2 + c3 r³ + c4 r⁴`` has a maximum (inf if none)."""
    roots = np.roots([4.0 * c4, 3.0 * c3, 1.0, c1])
    real = roots[np.abs(roots.imag) <= 1e-12 * np.abs(roots).max(initial=1.0)].real
    maxima = [x for x in real if x > 0.0 and 1.0 + 6.0 * c3 * x + 12.0 * c4 * x * x < 0.0]
    return min(maxima, default=math.inf)


def energy(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """Total mechanical energy E = T + V (…) J of the rotational + elastic motion.

    For "P" the same (Q) formula is used; P does not conserve it."""
    return kinetic_energy(sys, y) + potential_energy(sys, y)


def lagrangian(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """L̃ = T − V (…) J (the Q Lagrangian for Q and P, the linear-mode one for L)."""
    return kinetic_energy(sys, y) - potential_energy(sys, y)


def body_momentum(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """Body-frame angular momentum h = J̃ω + Aᵀṡ (..., 3) kg m²/s of the rotational row
    (h_P for "P", the quantity that formulation conserves as R h)."""
    if sys.manifold is not None:
        return _qm_momenta(sys, y)[..., :3]
    _, w, s, sd = split_state(sys, y)
    jt = inertia_tensor(sys, s, "rot")
    a = coupling_rows(sys, s, "rot")
    return np.einsum("...ab,...b->...a", jt, w) + np.einsum("...n,...na->...a", sd, a)


def momentum_inertial(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """Inertial angular momentum about the centre of mass H = R(q) h (..., 3) kg m²/s."""
    r = rotation_matrix(y[..., 0:4])
    return np.einsum("...ab,...b->...a", r, body_momentum(sys, y))


def modal_momentum(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """Modal momentum p_s = Aω + μṡ (..., N) √kg·m/s (energy/modal-row arrays)."""
    if sys.manifold is not None:
        return _qm_momenta(sys, y)[..., 3:]
    _, w, s, sd = split_state(sys, y)
    a = coupling_rows(sys, s)
    return np.einsum("...na,...a->...n", a, w) + np.einsum("mn,...n->...m", sys.mu, sd)


def dissipation_rate(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """Power dissipated by modal damping P_d = ṡᵀCṡ (…) W ("QM": ṡᵀC(s)ṡ)."""
    if sys.manifold is not None:
        from quadmodes.rom.manifold_kinetics import state_dissipation

        return state_dissipation(sys.manifold, y)
    sd = split_state(sys, y)[3]
    return np.einsum("...m,mn,...n->...", sd, sys.C, sd)


def _qm_momenta(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """(h, p) (..., 3+N) of formulation "QM" (the manifold's 𝕄(s)ν)."""
    from quadmodes.rom.manifold_kinetics import state_momenta

    return state_momenta(sys.manifold, np.asarray(y, float))


# ---------------------------------------------------------------------------------------------
# equations of motion (single state, lean)
# ---------------------------------------------------------------------------------------------


def mass_matrix(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """Generalised mass matrix 𝕄(s) (3+N, 3+N) = [[J̃, Aᵀ], [A, μ]] at s (N,).

    For "P" the rotational rows use the P arrays and the modal rows the Q arrays (unsymmetric);
    "QM": the manifold's."""
    if sys.manifold is not None:
        from quadmodes.rom.manifold_kinetics import mass_matrix as qm_mass

        return qm_mass(sys.manifold, np.asarray(s, float))
    return sm.mass_matrix(sys.mass_blocks, np.asarray(s, float))


def generalised_system(sys: ReducedSystem, s, w, sd, torque=None, force=None):
    """``(𝕄, b)`` of ``𝕄(s) ν̇ = b``, ν = (ω, ṡ), at one state (s (N,), ω (3,), ṡ (N,)).

    With T = ½ νᵀ𝕄(s)ν (Q) the Euler–Poincaré equations read
    ``𝕄ν̇ = [−ω × h, ∂T/∂s − Λs − Cṡ] − 𝕄̇ν``, h = (𝕄ν)[:3], 𝕄̇ = Σ_k ṡ_k ∂𝕄/∂s_k.
    Optional external body-frame torque τ (3,) N m and modal force Q (N,) √kg·m/s²."""
    if sys.manifold is not None:
        raise ValueError('formulation "QM" has no explicit equations of motion here; integrate '
                         'it with method "midpoint"')  # fmt: skip
    mb = sys.mass_blocks
    nu = np.concatenate([w, sd])
    m = sm.mass_matrix(mb, s)
    p = sm.half_derivative_products(mb, s, nu, energy=False)  # P[k] = ½ ∂𝕄/∂s_k ν (N, 3+N)
    b = -2.0 * (sd @ p)  # −𝕄̇ν
    hx, hy, hz = (m[:3] @ nu).tolist()
    wx, wy, wz = w.tolist()
    b[0] -= wy * hz - wz * hy
    b[1] -= wz * hx - wx * hz
    b[2] -= wx * hy - wy * hx
    pe = p if sys.same_rows else sm.half_derivative_products(mb, s, nu)
    b[3:] += pe @ nu - sys.Lam @ s - sys.F1 - sys.C @ sd  # ∂T/∂s_k = νᵀ (½∂𝕄/∂s_k) ν
    if sys.nonlinear:
        b[3:] -= potential_nonlinear_force(sys, s)
    if torque is not None:
        b[:3] += torque
    if force is not None:
        b[3:] += force
    return m, b


def rhs(sys: ReducedSystem, t: float, y: np.ndarray) -> np.ndarray:
    """dy/dt (7+2N,) of the free body (torque-free), for scipy's ``solve_ivp``.

    ``t`` is unused (autonomous) but kept for the scipy signature."""
    n = sys.n_modes
    w = y[4:7]
    s = y[7 : 7 + n]
    sd = y[7 + n :]
    m, b = generalised_system(sys, s, w, sd)
    dnu = np.linalg.solve(m, b)
    dy = np.empty_like(y)
    dy[0:4] = quat_rate(y[0:4], w, sys.quat_gain)
    dy[4:7] = dnu[:3]
    dy[7 : 7 + n] = sd
    dy[7 + n :] = dnu[3:]
    return dy


# ---------------------------------------------------------------------------------------------
# prescribed rotation and initial conditions
# ---------------------------------------------------------------------------------------------


def prescribed_rhs(
    sys: ReducedSystem,
    t: float,
    y: np.ndarray,
    omega: Callable[[float], np.ndarray],
    omega_dot: Callable[[float], np.ndarray],
    force: Callable[[float], np.ndarray] | None = None,
) -> np.ndarray:
    """d/dt [s, ṡ] (2N,) for a prescribed body rotation (hub-clamped body, theory §4)::

        μ s̈ = −(Γ(ω) + C) ṡ − (Λ − ωᵀJ2ω) s + ½ ωᵀJ1ω − A(s) ω̇ + Q(t)

    with Γ_km = ω·(D_mk − D_km) (= 2ω·Cuu_mk). ``omega(t)`` and ``omega_dot(t)`` return body-frame
    (3,) rad/s and rad/s²; ``force(t)`` an optional modal force (N,). Use the "Q" (or "P", same
    modal row) or "L" system of a model with ``free=False``."""
    n = sys.n_modes
    s = y[:n]
    sd = y[n:]
    w = np.asarray(omega(t), float)
    wd = np.asarray(omega_dot(t), float)
    g = (s @ sys.flat.J2s).reshape(n, 9)
    a = sys.c + (s @ sys.flat.Ds).reshape(n, 3)
    ww = np.outer(w, w).ravel()
    f = (
        (0.5 * sys.flat.J1f + g) @ ww
        + (sys.flat.Dsk @ w).reshape(n, n) @ sd
        - potential_gradient(sys, s)
        - sys.C @ sd
        - a @ wd
    )
    if force is not None:
        f = f + force(t)
    return np.concatenate([sd, np.linalg.solve(sys.mu, f)])


def coning_omega(J: np.ndarray, spin: float, cone_angle: float, axis: int | None = None):
    """Body angular velocity (3,) rad/s of a rigid body with inertia J (3,3) spinning at ``spin``
    about principal axis ``axis`` (index into ascending eigenvalues; default 0 = minor axis)
    with cone angle ``cone_angle`` (rad) between H and that axis (tan θ = I_t ω⊥ / (I_a ω_a)).
    The transverse component is put along the next principal axis."""
    lam, vec = np.linalg.eigh(sym_tensor(np.asarray(J, float)))
    a = 0 if axis is None else axis
    t = (a + 1) % 3
    ea, et = vec[:, a], vec[:, t]
    k = int(np.argmax(np.abs(ea)))
    ea = ea * np.sign(ea[k])
    w_perp = math.tan(cone_angle) * lam[a] * spin / lam[t]
    return spin * ea + w_perp * et
