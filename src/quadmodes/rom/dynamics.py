"""Reduced equations of motion of a free-floating (or hub-driven) flexible body, body frame.

Lagrangian of formulation "Q" (theory.md §3, derivation in docs/derivation.md)::

    L̃ = ½ ωᵀ J̃(s) ω + ωᵀ A(s) ṡ + ½ ṡᵀ μ ṡ − ½ sᵀ Λ s
    J̃(s) = J0 + Σ_k s_k J1_k + Σ_mn s_m s_n J2_mn,   J2 = J2u + J2g
    A(s) = [a_1 … a_N],  a_n = c_n + Σ_m s_m D_mn,     D = Cuu + 2 Cxg

In the code ``A`` is stored transposed, as rows ``a_n``: an ``(N, 3)`` array, so that
``h = J̃ ω + Aᵀ ṡ`` reads ``Jt @ w + sd @ A`` and ``p_s = A ω + μ ṡ`` reads ``A @ w + mu @ sd``.

Euler–Poincaré equations (τ, Q external torque and modal force, both zero here)::

    ḣ + ω × h = τ,                 h   = ∂L̃/∂ω = J̃ ω + Aᵀ ṡ
    ṗ_s − ∂L̃/∂s = −C ṡ + Q,        p_s = ∂L̃/∂ṡ = A ω + μ ṡ

written as ``𝕄(s) ν̇ = b`` with ``ν = (ω, ṡ)``, ``𝕄 = [[J̃, Aᵀ], [A, μ]]`` and::

    b_ω = τ − ω × h − J̃̇ ω − Ȧᵀ ṡ,     J̃̇ = Σ_k ṡ_k ∂J̃/∂s_k,   Ȧᵀṡ = Σ_mn ṡ_m ṡ_n D_mn
    b_k = Q_k − (Λs)_k − (Cṡ)_k + ωᵀ(½ J1_k + Σ_m s_m J2_km) ω + Σ_m ṡ_m ω·(D_km − D_mk)

(``D_km − D_mk = 2 Cuu_km`` because Cuu is antisymmetric and Cxg symmetric in (m, n).)

Implementation: T = ½ νᵀ𝕄(s)ν with 𝕄(s) = Σ_ij z_i z_j Mt_ij, z = (1, s), a mass tensor Mt
(N+1, N+1, 3+N, 3+N) precomputed once, so that with P[k] = ½ (∂𝕄/∂s_k) ν (one matrix product)
``b = [−ω × h, P·ν − Λs − Cṡ] − 2 ṡ·P`` (the last term is −𝕄̇ν). No loops over modes.

Formulations (``reduced_system(model, formulation)``):

* ``"Q"``: the above; E and H conserved exactly by the continuous equations.
* ``"P"``: the seed's printed equations. Modal row as Q; rotational row built from
  ``J2u`` and ``Cuu`` only (no g terms): ``h_P = (J0 + sJ1 + ssJ2u) ω + (c + s Cuu)ᵀ ṡ``.
  ``h_P`` is conserved, E (same formula as Q) is not.
* ``"L"``: linear modes: ``J2g = 0`` and ``Cxg = 0`` everywhere (a consistent Lagrangian too).
* ``"rigid"``: N = 0.
* ``"Q4"``: Q kinetics with the manifold potential truncated at fourth order,
  ``V(s) = ½ sᵀΛs + V3_mnp s_m s_n s_p + V4_mnpq s_m s_n s_p s_q`` (tensors of
  :func:`quadmodes.rom.reduced.manifold_potential_tensors`): the modal force is ``−∂V/∂s =
  −Λs − 3 V3·ss − 4 V4·sss`` in place of ``−Λs``, its Jacobian ``−(Λ + 6 V3·s + 12 V4·ss)``.
  E (with this V) and H are conserved by the continuous equations.

State vector ``y = [q (4), ω (3), s (N), ṡ (N)]``, length ``7 + 2N``: q a unit quaternion,
scalar first, rotating body-frame vectors into the inertial frame; ω (rad/s) body-frame angular
velocity; s (√kg·m) modal coordinates; ṡ (√kg·m/s). Translation is decoupled (p = centre of
mass) and not part of y. SI units throughout: J in kg m², h in kg m²/s, energies in J.

Prescribed rotation (hub-clamped body, ``model.free is False``): ``prescribed_rhs`` integrates
``μ s̈ + (Γ(ω) + C) ṡ + (Λ − ωᵀJ2ω) s = ½ ωᵀJ1ω − A(s) ω̇`` for given ω(t), ω̇(t).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from quadmodes.rom.reduced import ReducedModel
from quadmodes.rotations import quat_rate, rotation_matrix

FORMULATIONS = ("Q", "P", "L", "rigid", "Q4")


# ---------------------------------------------------------------------------------------------
# system
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ReducedSystem:
    """Arrays of one formulation of the reduced equations (SI units, N modes).

    J0 (3,3) kg m². J1 (N,3,3) √kg·m. J2 (N,N,3,3) and D (N,N,3), dimensionless, J2 symmetrised:
    second-order inertia and rotation–deformation coupling of the Lagrangian (modal row and
    energy). J2_rot, D_rot: the same arrays as used by the rotational row (differ from J2, D for
    "P" only). c (N,3) √kg·m. mu (N,N) 1, Lam (N,N) 1/s², C (N,N) 1/s. quat_gain (1/s): gain of
    the quaternion norm-drift correction ``k (1 − |q|²) q`` in :func:`rhs`.
    V3 (N,N,N), V4 (N,N,N,N) J/(√kg·m)^k: symmetric cubic and quartic potential coefficients,
    used only when ``quartic`` (formulation "Q4"); None means zeros.
    The private ``_*`` arrays are flattened copies for fast matrix products.
    """

    formulation: str
    free: bool
    J0: np.ndarray
    J1: np.ndarray
    J2: np.ndarray
    D: np.ndarray
    c: np.ndarray
    mu: np.ndarray
    Lam: np.ndarray
    C: np.ndarray
    J2_rot: np.ndarray
    D_rot: np.ndarray
    quat_gain: float = 1.0
    V3: np.ndarray | None = None
    V4: np.ndarray | None = None
    n_modes: int = field(init=False)
    quartic: bool = field(init=False)
    same_rows: bool = field(init=False, repr=False)
    _J1f: np.ndarray = field(init=False, repr=False)
    _J2s: np.ndarray = field(init=False, repr=False)
    _J2w: np.ndarray = field(init=False, repr=False)
    _Ds: np.ndarray = field(init=False, repr=False)
    _Dsk: np.ndarray = field(init=False, repr=False)
    _Mt: np.ndarray = field(init=False, repr=False)
    _Yt: np.ndarray = field(init=False, repr=False)
    _MtE: np.ndarray = field(init=False, repr=False)
    _YtE: np.ndarray = field(init=False, repr=False)
    _WtE: np.ndarray = field(init=False, repr=False)
    _Wt: np.ndarray = field(init=False, repr=False)
    _V3g: np.ndarray = field(init=False, repr=False)
    _V4g: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        n = self.J1.shape[0]
        m3 = 3 + n
        put = object.__setattr__
        put(self, "n_modes", n)
        put(self, "quartic", self.formulation == "Q4")
        v3 = np.zeros((n, n, n)) if self.V3 is None else np.asarray(self.V3, float)
        v4 = np.zeros((n, n, n, n)) if self.V4 is None else np.asarray(self.V4, float)
        put(self, "V3", v3)
        put(self, "V4", v4)
        # ∂V/∂s − Λs = 3 V3·ss + 4 V4·sss = _V3g @ (s⊗s) + _V4g @ (s⊗s⊗s)
        put(self, "_V3g", np.ascontiguousarray(3.0 * v3.reshape(n, n * n)))
        put(self, "_V4g", np.ascontiguousarray(4.0 * v4.reshape(n, n * n * n)))
        same = self.J2_rot is self.J2 and self.D_rot is self.D
        put(self, "same_rows", same)
        c = np.ascontiguousarray
        put(self, "_J1f", c(self.J1.reshape(n, 9)))
        # G(s)_k = Σ_m s_m J2_mk  →  (s @ _J2s).reshape(N, 9)
        put(self, "_J2s", c(self.J2.reshape(n, n * 9)))
        put(self, "_Ds", c(self.D.reshape(n, n * 3)))
        put(self, "_J2w", c(self.J2.reshape(n * n, 9)))
        dsk = self.D - self.D.transpose(1, 0, 2)  # D_km − D_mk
        put(self, "_Dsk", c(dsk.reshape(n * n, 3)))
        # 𝕄(s) = Σ_ij z_i z_j Mt[i, j], z = (1, s): mass tensor (N+1, N+1, 3+N, 3+N), symmetric
        # in (i, j). Rows 0–2 (rotational) from J2_rot/D_rot, rows 3… (modal) from J2/D.
        mom = _mass_tensor(self, self.J2_rot, self.D_rot, self.D)
        en = mom if same else _mass_tensor(self, self.J2, self.D, self.D)
        for tag, mt in (("", mom), ("E", en)):
            put(self, "_Mt" + tag, c(mt.reshape((n + 1) ** 2, m3 * m3)))
            # Y(z)[k] = Σ_j z_j Mt[k+1, j] (k = 0…N−1): (z @ _Yt).reshape(N·m3, m3)
            put(self, "_Yt" + tag, c(mt[:, 1:].reshape(n + 1, n * m3 * m3)))
        # second derivatives ∂²𝕄/∂s_k∂s_j = 2 Mt[k+1, j+1]
        put(self, "_WtE", c(en[1:, 1:].reshape(n * n, m3 * m3)))
        put(self, "_Wt", c(mom[1:, 1:].reshape(n, n * m3 * m3)))

    @property
    def n_state(self) -> int:
        """Length of the state vector, ``7 + 2N``."""
        return 7 + 2 * self.n_modes


def _sym_pair(a: np.ndarray) -> np.ndarray:
    """Symmetrise ``a`` (N,N,...) in its first two indices."""
    return 0.5 * (a + np.swapaxes(a, 0, 1))


def _sym_tensor(a: np.ndarray) -> np.ndarray:
    """Symmetrise ``a`` (...,3,3) in its last two indices."""
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def _mass_tensor(sys: ReducedSystem, j2_rot, d_rot, d_mod) -> np.ndarray:
    """Coefficients Mt (N+1, N+1, 3+N, 3+N) of 𝕄(s) = Σ_ij z_i z_j Mt[i,j], z = (1, s)."""
    n = sys.J1.shape[0]
    m3 = 3 + n
    mt = np.zeros((n + 1, n + 1, m3, m3))
    mt[0, 0, :3, :3] = sys.J0
    mt[0, 0, :3, 3:] = sys.c.T
    mt[0, 0, 3:, :3] = sys.c
    mt[0, 0, 3:, 3:] = sys.mu
    for k in range(n):  # linear terms, split evenly between (0, k) and (k, 0)
        blk = np.zeros((m3, m3))
        blk[:3, :3] = sys.J1[k]
        blk[:3, 3:] = d_rot[k].T  # Aᵀ column n gets s_k D_kn
        blk[3:, :3] = d_mod[k]
        mt[0, k + 1] = mt[k + 1, 0] = 0.5 * blk
    mt[1:, 1:, :3, :3] = j2_rot
    return mt


def reduced_system(
    model: ReducedModel, formulation: str = "Q", quat_gain: float = 1.0
) -> ReducedSystem:
    """The :class:`ReducedSystem` of ``model`` for ``formulation`` in ``FORMULATIONS``.

    J2 is symmetrised in (m, n) and in its 3×3 indices (it is symmetric by construction; this
    removes round-off so that the equations are exactly variational).
    """
    if formulation not in FORMULATIONS:
        raise ValueError(f"unknown formulation {formulation!r}; choose one of {FORMULATIONS}")
    if formulation == "rigid":
        model = model.rigid()
    if formulation == "Q4" and not getattr(model, "manifold_potential", False):
        raise ValueError(
            "formulation Q4 needs the manifold potential (V3, V4) of the reduced model, which this "
            "model does not have (a file of artifact format 1: rebuild it with `quadmodes "
            "reduce`; or a gas-law pressure, which is not polynomial: use Q)"
        )
    f = np.asarray
    j2u = _sym_tensor(_sym_pair(f(model.J2u, float)))
    j2g = _sym_tensor(_sym_pair(f(model.J2g, float)))
    cuu = f(model.Cuu, float)
    cxg = f(model.Cxg, float)
    if formulation == "L":
        j2, d = j2u, cuu.copy()
    else:
        j2, d = j2u + j2g, cuu + 2.0 * cxg
    if formulation == "P":
        j2_rot, d_rot = j2u, cuu.copy()
    else:
        j2_rot, d_rot = j2, d
    return ReducedSystem(
        formulation=formulation,
        free=bool(model.free),
        J0=_sym_tensor(f(model.J0, float)),
        J1=_sym_tensor(f(model.J1, float)),
        J2=j2,
        D=d,
        c=f(model.c, float).copy(),
        mu=_sym_pair(f(model.mu, float)),
        Lam=_sym_pair(f(model.Lam, float)),
        C=f(model.C, float).copy(),
        J2_rot=j2_rot,
        D_rot=d_rot,
        quat_gain=float(quat_gain),
        V3=f(model.V3, float) if formulation == "Q4" else None,
        V4=f(model.V4, float) if formulation == "Q4" else None,
    )


def with_damping(sys: ReducedSystem, C: np.ndarray) -> ReducedSystem:
    """``sys`` with the modal damping matrix replaced by ``C`` (N,N) 1/s."""
    return ReducedSystem(
        sys.formulation, sys.free, sys.J0, sys.J1, sys.J2, sys.D, sys.c, sys.mu, sys.Lam,
        np.asarray(C, float), sys.J2_rot, sys.D_rot, sys.quat_gain, sys.V3, sys.V4,
    )  # fmt: skip


# ---------------------------------------------------------------------------------------------
# state vector and rotations
# ---------------------------------------------------------------------------------------------


def split_state(sys: ReducedSystem, y: np.ndarray):
    """``(q, ω, s, ṡ)`` views of ``y`` (..., 7+2N)."""
    n = sys.n_modes
    return y[..., 0:4], y[..., 4:7], y[..., 7 : 7 + n], y[..., 7 + n : 7 + 2 * n]


def pack_state(sys: ReducedSystem, q=None, omega=None, s=None, sdot=None) -> np.ndarray:
    """State vector ``y`` (7+2N,) from its parts (defaults: identity, zeros); q is normalised."""
    n = sys.n_modes
    q = np.array([1.0, 0.0, 0.0, 0.0]) if q is None else np.asarray(q, float)
    z = np.zeros(n)
    parts = [
        q / np.linalg.norm(q),
        np.zeros(3) if omega is None else np.asarray(omega, float),
        z if s is None else np.asarray(s, float),
        z if sdot is None else np.asarray(sdot, float),
    ]
    return np.concatenate(parts)


def coning_omega(J: np.ndarray, spin: float, cone_angle: float, axis: int | None = None):
    """Body angular velocity (3,) rad/s of a rigid body with inertia J (3,3) spinning at ``spin``
    about principal axis ``axis`` (index into ascending eigenvalues; default 0 = minor axis)
    with cone angle ``cone_angle`` (rad) between H and that axis (tan θ = I_t ω⊥ / (I_a ω_a)).
    The transverse component is put along the next principal axis."""
    lam, vec = np.linalg.eigh(_sym_tensor(np.asarray(J, float)))
    a = 0 if axis is None else axis
    t = (a + 1) % 3
    ea, et = vec[:, a], vec[:, t]
    k = int(np.argmax(np.abs(ea)))
    ea = ea * np.sign(ea[k])
    w_perp = math.tan(cone_angle) * lam[a] * spin / lam[t]
    return spin * ea + w_perp * et


def hat(v: np.ndarray) -> np.ndarray:
    """Skew matrix (3,3) with ``hat(v) @ u = v × u``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def so3_exp(theta: np.ndarray) -> np.ndarray:
    """Rotation matrix (3,3) ``exp(θ̂)`` (Rodrigues), θ (3,) rad."""
    a2 = float(theta @ theta)
    th = hat(theta)
    if a2 < 1e-12:
        s, c = 1.0 - a2 / 6.0, 0.5 - a2 / 24.0
    else:
        a = math.sqrt(a2)
        s, c = math.sin(a) / a, (1.0 - math.cos(a)) / a2
    return np.eye(3) + s * th + c * (th @ th)


def so3_left_jacobian(theta: np.ndarray) -> np.ndarray:
    """Left Jacobian (3,3) of SO(3): ``exp((θ+δ)^) = exp((J_l δ)^) exp(θ̂) + O(δ²)``."""
    a2 = float(theta @ theta)
    th = hat(theta)
    if a2 < 1e-12:
        b, c = 0.5 - a2 / 24.0, 1.0 / 6.0 - a2 / 120.0
    else:
        a = math.sqrt(a2)
        b, c = (1.0 - math.cos(a)) / a2, (a - math.sin(a)) / (a2 * a)
    return np.eye(3) + b * th + c * (th @ th)


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
    """Kinetic energy T = ½ ωᵀJ̃ω + ω·(Aᵀṡ) + ½ ṡᵀμṡ (…) J (energy/modal-row arrays)."""
    _, w, s, sd = split_state(sys, y)
    jt = inertia_tensor(sys, s)
    a = coupling_rows(sys, s)
    return (
        0.5 * np.einsum("...a,...ab,...b->...", w, jt, w)
        + np.einsum("...a,...n,...na->...", w, sd, a)
        + 0.5 * np.einsum("...m,mn,...n->...", sd, sys.mu, sd)
    )


def potential_energy(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """V = ½ sᵀΛs (…) J; for "Q4" plus ``V3_mnp s_m s_n s_p + V4_mnpq s_m s_n s_p s_q``."""
    s = split_state(sys, y)[2]
    v = 0.5 * np.einsum("...m,mn,...n->...", s, sys.Lam, s)
    if sys.quartic:
        ss = np.einsum("...m,...n->...mn", s, s)
        v = v + np.einsum("...mn,...p,mnp->...", ss, s, sys.V3)
        v = v + np.einsum("...mn,...pq,mnpq->...", ss, ss, sys.V4)
    return v


def potential_gradient(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """∂V/∂s (N,) J/(√kg·m) at one s (N,): ``Λs`` (+ ``3 V3·ss + 4 V4·sss`` for "Q4")."""
    g = sys.Lam @ s
    return g + potential_nonlinear_force(sys, s) if sys.quartic else g


def potential_nonlinear_force(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """``∂V/∂s − Λs = 3 V3·ss + 4 V4·sss`` (N,) J/(√kg·m) at one s (N,) (zeros unless "Q4")."""
    ss = np.outer(s, s).ravel()
    return sys._V3g @ ss + sys._V4g @ np.outer(ss, s).ravel()


def potential_hessian(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """∂²V/∂s² (N,N) 1/s² at one s (N,): ``Λ`` (+ ``6 V3·s + 12 V4·ss`` for "Q4")."""
    if not sys.quartic:
        return sys.Lam
    n = sys.n_modes
    ss = np.outer(s, s).ravel()
    h3 = (sys._V3g.reshape(n * n, n) @ s).reshape(n, n)  # 3 V3·s
    h4 = (sys._V4g.reshape(n * n, n * n) @ ss).reshape(n, n)  # 4 V4·ss
    return sys.Lam + 2.0 * h3 + 3.0 * h4


def potential_barrier(
    sys: ReducedSystem, n_directions: int = 4000, seed: int = 0
) -> tuple[float, np.ndarray]:
    """Lowest barrier of the "Q4" potential: ``(V_b (J), s_b (N,))``.

    Along a ray ``s = r d`` (d scaled so that ½ dᵀΛd = ½) ``V(r) = r²/2 + c3 r³ + c4 r⁴``; where
    the quartic turns V down, its first maximum (the smaller positive root of
    ``4c4 r² + 3c3 r + 1 = 0``) is the energy a motion needs to escape along d. ``V_b`` is the
    smallest such maximum over ``n_directions`` random directions (a sampled estimate from above;
    ``inf`` when V rises along every sampled ray, e.g. for Q), ``s_b`` the point where it is
    reached. Why: V4 truncates the manifold energy and can be negative definite, so V is unbounded
    below; a state whose modal energy exceeds V_b may run off to where Q4 has no meaning."""
    n = sys.n_modes
    if not sys.quartic or n == 0:
        return math.inf, np.zeros(n)
    d = np.random.default_rng(seed).standard_normal((n_directions, n))
    d /= np.sqrt(np.einsum("km,mn,kn->k", d, sys.Lam, d))[:, None]
    c3 = np.einsum("mnp,km,kn,kp->k", sys.V3, d, d, d)
    c4 = np.einsum("mnpq,km,kn,kp,kq->k", sys.V4, d, d, d, d)
    a, b = 4.0 * c4, 3.0 * c3
    disc = b * b - 4.0 * a  # roots of a r² + b r + 1
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
        roots = np.stack([(-b - sq) / (2 * a), (-b + sq) / (2 * a)], 1)
    roots = np.where((roots > 0.0) & np.isfinite(roots), roots, np.inf)
    r = roots.min(axis=1)
    v = np.where(np.isfinite(r), 0.5 * r * r + c3 * r**3 + c4 * r**4, np.inf)
    k = int(np.argmin(v))
    return float(v[k]), (r[k] * d[k] if np.isfinite(v[k]) else np.zeros(n))


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
    _, w, s, sd = split_state(sys, y)
    a = coupling_rows(sys, s)
    return np.einsum("...na,...a->...n", a, w) + np.einsum("mn,...n->...m", sys.mu, sd)


def dissipation_rate(sys: ReducedSystem, y: np.ndarray) -> np.ndarray:
    """Power dissipated by modal damping P_d = ṡᵀCṡ (…) W."""
    sd = split_state(sys, y)[3]
    return np.einsum("...m,mn,...n->...", sd, sys.C, sd)


# ---------------------------------------------------------------------------------------------
# equations of motion (single state, lean)
# ---------------------------------------------------------------------------------------------


def mass_matrix(sys: ReducedSystem, s: np.ndarray) -> np.ndarray:
    """Generalised mass matrix 𝕄(s) (3+N, 3+N) = [[J̃, Aᵀ], [A, μ]] at s (N,).

    For "P" the rotational rows use the P arrays and the modal rows the Q arrays (unsymmetric)."""
    m3 = 3 + sys.n_modes
    z = np.empty(m3 - 2)
    z[0] = 1.0
    z[1:] = s
    return ((z[:, None] * z).ravel() @ sys._Mt).reshape(m3, m3)


def generalised_system(sys: ReducedSystem, s, w, sd, torque=None, force=None):
    """``(𝕄, b)`` of ``𝕄(s) ν̇ = b``, ν = (ω, ṡ), at one state (s (N,), ω (3,), ṡ (N,)).

    With T = ½ νᵀ𝕄(s)ν (Q) the Euler–Poincaré equations read
    ``𝕄ν̇ = [−ω × h, ∂T/∂s − Λs − Cṡ] − 𝕄̇ν``, h = (𝕄ν)[:3], 𝕄̇ = Σ_k ṡ_k ∂𝕄/∂s_k.
    Optional external body-frame torque τ (3,) N m and modal force Q (N,) √kg·m/s²."""
    n = sys.n_modes
    m3 = 3 + n
    z = np.empty(n + 1)
    z[0] = 1.0
    z[1:] = s
    nu = np.empty(m3)
    nu[:3] = w
    nu[3:] = sd
    m = ((z[:, None] * z).ravel() @ sys._Mt).reshape(m3, m3)
    # P[k] = ½ ∂𝕄/∂s_k ν  (N, 3+N)
    p = ((z @ sys._Yt).reshape(n * m3, m3) @ nu).reshape(n, m3)
    b = -2.0 * (sd @ p)  # −𝕄̇ν
    hx, hy, hz = (m[:3] @ nu).tolist()
    wx, wy, wz = w.tolist()
    b[0] -= wy * hz - wz * hy
    b[1] -= wz * hx - wx * hz
    b[2] -= wx * hy - wy * hx
    pe = p if sys.same_rows else ((z @ sys._YtE).reshape(n * m3, m3) @ nu).reshape(n, m3)
    b[3:] += pe @ nu - sys.Lam @ s - sys.C @ sd  # ∂T/∂s_k = νᵀ (½∂𝕄/∂s_k) ν
    if sys.quartic:
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
# prescribed rotation and rotating-frame linearisation
# ---------------------------------------------------------------------------------------------


def _as_system(model, formulation: str) -> ReducedSystem:
    if isinstance(model, ReducedSystem):
        return model
    return reduced_system(model, formulation)


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
    g = (s @ sys._J2s).reshape(n, 9)
    a = sys.c + (s @ sys._Ds).reshape(n, 3)
    ww = np.outer(w, w).ravel()
    f = (
        (0.5 * sys._J1f + g) @ ww
        + (sys._Dsk @ w).reshape(n, n) @ sd
        - potential_gradient(sys, s)
        - sys.C @ sd
        - a @ wd
    )
    if force is not None:
        f = f + force(t)
    return np.concatenate([sd, np.linalg.solve(sys.mu, f)])


def rotating_frame_matrices(model, omega_vec, formulation: str = "Q"):
    """Linearised modal equation about steady rotation ω (3,) rad/s and s = 0::

        μ s̈ + (Γ + C) ṡ + (Λ − ωᵀJ2ω) s = ½ ωᵀJ1ω      (constant forcing not returned)

    Returns ``(μ, Γ + C, Λ − ωᵀJ2ω)``, each (N,N); Γ_km = ω·(D_mk − D_km) is antisymmetric
    (gyroscopic), the stiffness symmetric. ``model``: ReducedModel or ReducedSystem. For "L" the
    spin stiffening (J2g) is absent, so the stiffness softens as Λ − ωᵀJ2uω."""
    sys = _as_system(model, formulation)
    n = sys.n_modes
    w = np.asarray(omega_vec, float)
    gam = -(sys._Dsk @ w).reshape(n, n)
    k = sys.Lam - (sys._J2w @ np.outer(w, w).ravel()).reshape(n, n)
    return sys.mu.copy(), gam + sys.C, 0.5 * (k + k.T)


def rotating_stiffness_is_positive(model, omega_vec, formulation: str = "Q") -> bool:
    """True if the rotating-frame stiffness Λ − ωᵀJ2ω is positive definite (stable spin)."""
    k = rotating_frame_matrices(model, omega_vec, formulation)[2]
    return bool(k.shape[0] == 0 or np.linalg.eigvalsh(k).min() > 0.0)


def rotating_eigenvalues(model, omega_vec, formulation: str = "Q", damped: bool = False):
    """Eigenvalues λ (2N,) 1/s of the rotating-frame quadratic problem
    ``(λ²μ + λ(Γ + C) + K) φ = 0`` (C included if ``damped``), sorted by |Im λ| then Re λ.
    Undamped, positive-definite K: λ = ±iω_r, the rotating-frame (Campbell) frequencies."""
    m, g, k = rotating_frame_matrices(model, omega_vec, formulation)
    if not damped:
        sys = _as_system(model, formulation)
        g = g - sys.C
    n = m.shape[0]
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ g]])
    lam = np.linalg.eigvals(a)
    return lam[np.lexsort((lam.real, np.abs(lam.imag)))]
