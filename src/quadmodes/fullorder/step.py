"""One implicit-midpoint step of the full-order model: the step force (energy–momentum stress
average), the modal damping force, the predictor and the step residual.

A step from ``(x₀, v₀)`` at ``t₀`` to ``t₁ = t₀ + Δt`` solves for ``x₁``::

    v½ = (x₁ − x₀)/Δt,  x½ = (x₀ + x₁)/2,  v₁ = 2 v½ − v₀
    r(x₁) = M (v₁ − v₀)/Δt + f_step(x₀, x₁) + f_d(x½, v½) = 0        (free components)

with f_step the energy–momentum internal force (:func:`step_force`) or ``f(x½)``. SI units;
states are ``(n, 3)`` arrays of vector DOFs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import quadmodes.fullorder.kinematics as kin
from quadmodes.fe.assembly import assemble_vector
from quadmodes.fe.model import Structure, internal_force
from quadmodes.fullorder.kernels import StepOperators, jit_module
from quadmodes.fullorder.setup import FullOrderProblem
from quadmodes.rotations import skew

# ---------------------------------------------------------------------------------------------
# step force: midpoint with the Simo–Tarnow stress average
# ---------------------------------------------------------------------------------------------


def step_force(structure: Structure, x0: np.ndarray, x1: np.ndarray, strain0=None) -> np.ndarray:
    """Internal force (n,3) N of the step x0 → x1 (energy–momentum midpoint): the sum of every
    element set's ``step_force`` (:class:`~quadmodes.fe.elements.ElementSet`).

    St Venant–Kirchhoff membranes, Green-strain bars and quadratic-strain sets (beams, hubs)
    use the stress of the averaged strain ``S̄ = S((ε₀ + ε₁)/2)`` at the midpoint (Simo &
    Tarnow 1992); a wrinkling membrane its strain-space discrete gradient. Since ε is quadratic
    in x, ``ε₁ − ε₀ = Dε(x½)(x₁ − x₀)`` and the energy is quadratic in ε, the step's work equals
    the energy change exactly; ``Dε(x½)ᵀ S̄`` is equilibrated at x½, so H is conserved too.
    Other sets (pressure, cable) use the default ``f(x½)``: the constant-pressure potential is
    cubic, and the midpoint's energy error is the enclosed volume of the increment field (zero
    for a rigid rotation). ``strain0``: per-set start data at x0 from :func:`step_strains`
    (else computed)."""
    out = np.zeros((structure.n, 3))
    strain0 = step_strains(structure, x0) if strain0 is None else strain0
    for e, e0 in zip(structure.elements, strain0, strict=True):
        out += assemble_vector(e.conn, e.step_force(x0, x1, e0), structure.n)
    return out


def step_strains(structure: Structure, x: np.ndarray) -> list:
    """Per element set the start data at x used by :func:`step_force` (``step_start``: the
    strains of membranes and bars, None for other sets)."""
    return [e.step_start(x) for e in structure.elements]


# ---------------------------------------------------------------------------------------------
# damping force
# ---------------------------------------------------------------------------------------------


def rigid_basis(body: kin.Body, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Rigid motions Ψ (n,3,6) of state x about p: translations (positions only), rotations
    ``e_a × (x − t p)``."""
    n = x.shape[0]
    r = x - body.t[:, None] * p
    psi = np.zeros((n, 3, 6))
    for a in range(3):
        psi[:, a, a] = body.t
    # e_a × r: e_x × r = (0, −r_z, r_y), e_y × r = (r_z, 0, −r_x), e_z × r = (−r_y, r_x, 0)
    psi[:, 1, 3], psi[:, 2, 3] = -r[:, 2], r[:, 1]
    psi[:, 0, 4], psi[:, 2, 4] = r[:, 2], -r[:, 0]
    psi[:, 0, 5], psi[:, 1, 5] = -r[:, 1], r[:, 0]
    return psi


def _symmetric_pinv(g: np.ndarray, rcond: float = 1e-12) -> np.ndarray:
    """Pseudo-inverse of the symmetric matrix g (k,k) (eigenvalues below ``rcond`` × the
    largest dropped), as ``np.linalg.pinv(g, rcond, hermitian=True)`` without its overhead."""
    w, u = np.linalg.eigh(g)
    keep = np.abs(w) > rcond * np.max(np.abs(w))
    return (u[:, keep] / w[keep]) @ u[:, keep].T


def damping_force(
    body: kin.Body,
    c: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    hub_rotation: np.ndarray | None = None,
    hub_omega: np.ndarray | None = None,
    hub_point: np.ndarray | None = None,
    mphi: np.ndarray | None = None,
) -> np.ndarray:
    """Modal damping force f_d (n,3) N at state (x, v) (the force in ``M a + f_d + f = 0``).

    Free body: ``f_d = W C Wᵀ v`` with ``W = Π M 𝒬 Φ``, Q the best-fit (mean-axes) rotation of x,
    Π the M-orthogonal projector off the rigid motions Ψ(x) about the CoM
    (``Π = I − MΨ(ΨᵀMΨ)⁻¹Ψᵀ``): ``Wᵀv`` is the modal velocity of the elastic part of v, f_d has
    zero net force and zero moment about the CoM (H is untouched) and ``vᵀ f_d ≥ 0``.
    Clamped body: ``W = M 𝒬 Φ`` with Q the hub rotation, applied to the velocity relative to
    the hub (the clamp reactions take the net load). ``c`` (K,K) 1/s: the modal damping of the
    modes Φ_d with ``mphi`` (K,n,3) = ``M_s Φ_d`` (default: the body's retained modes)."""
    mphi = body.MPhi if mphi is None else mphi
    n_modes = mphi.shape[0]
    n = x.shape[0]
    mphi_flat = mphi.reshape(n_modes, 3 * n)
    jit = jit_module()
    if hub_rotation is None and jit is not None:  # the same sums, compiled (fullorder.jit)
        ms = body.ms
        x, v = np.ascontiguousarray(x, float), np.ascontiguousarray(v, float)
        return jit.damping_free(x, v, body.t, body.w, body.MX, ms.indptr, ms.indices, ms.data,
                                np.ascontiguousarray(mphi_flat), np.ascontiguousarray(c, float))
    # W = Π Y, Y = M 𝒬 Φ: Yᵀu = (M Φ)ᵀ(Qᵀ-rotated u), Y q = (Σ q_k M φ_k) rotated by Q;
    # neither Y (3n × K) nor Ψ (3n × 6) is formed
    if hub_rotation is None:
        p = kin.centre(body, x)
        rot = kin.best_fit_rotation(body, x, p)
        r = x - body.t[:, None] * p
        g_inv = _rigid_gram_inverse(body, r)
        vel = v - _rigid_motion(body, r, g_inv @ _rigid_moments(body, r, body.ms @ v))  # Πᵀv
    else:
        rot = hub_rotation
        r = x - body.t[:, None] * hub_point
        vel = v - r @ skew(hub_omega).T  # v − Ω × r
    q = c @ (mphi_flat @ (vel @ rot).ravel())
    f = (q @ mphi_flat).reshape(n, 3) @ rot.T
    if hub_rotation is None:
        f = f - body.ms @ _rigid_motion(body, r, g_inv @ _rigid_moments(body, r, f))  # Π Y q
    return f


def _rigid_moments(body: kin.Body, r: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``Ψᵀu`` (6,): the net ``Σ tᵢuᵢ`` and the moment ``Σ rᵢ × uᵢ`` of u (n,3) about the
    point of r = x − t p (n,3) (:func:`rigid_basis` without forming it)."""
    p = r.T @ u  # Σ rᵢ uᵢᵀ; its antisymmetric part is the moment
    return np.concatenate([body.t @ u, [p[1, 2] - p[2, 1], p[2, 0] - p[0, 2], p[0, 1] - p[1, 0]]])


def _rigid_motion(body: kin.Body, r: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``Ψa`` (n,3): the rigid motion ``tᵢ a_t + a_r × rᵢ`` of a (6,)."""
    return body.t[:, None] * a[:3] + r @ skew(a[3:]).T


def _rigid_gram_inverse(body: kin.Body, r: np.ndarray) -> np.ndarray:
    """``(ΨᵀMΨ)⁻¹`` (6,6) for r = x − t p (n,3) (:func:`_gram_inverse`)."""
    return _gram_inverse(body, r.T @ (body.ms @ r), body.w @ r)


def _gram_inverse(body: kin.Body, p: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``(ΨᵀMΨ)⁻¹`` (6,6) (pseudo-inverse, as ``np.linalg.pinv(·, 1e-12, hermitian=True)``)
    from ``P = rᵀ M_s r`` (3,3) and ``s = Σ wᵢrᵢ`` (3,) (w = M_s t): translation block
    ``(tᵀM_s t) I``, coupling ``e_b × s`` (zero about the centre of mass of a body without
    slope rows), rotation block ``tr(P) I − P``."""
    g = np.zeros((6, 6))
    g[:3, :3] = float(body.t @ body.w) * np.eye(3)
    g[:3, 3:] = -skew(s)  # column b: e_b × s = −[s]× e_b
    g[3:, :3] = g[:3, 3:].T
    g[3:, 3:] = np.trace(p) * np.eye(3) - p
    return _symmetric_pinv(g)


def step_damping(problem: FullOrderProblem, t: float, xh: np.ndarray, vh: np.ndarray) -> np.ndarray:
    """f_d (n,3) N of the problem at time t (s) and midpoint state (xh, vh) (zero without
    damping; with the hub's rotation and angular velocity at t for a clamped body)."""
    if problem.c is None:
        return np.zeros_like(xh)
    if problem.hub is None:
        return damping_force(problem.body, problem.c, xh, vh, mphi=problem.MPhi_d)
    hub = problem.hub
    return damping_force(
        problem.body, problem.c, xh, vh, hub.rotation(t), hub.angular_velocity(t), problem.point,
        mphi=problem.MPhi_d,
    )


def dissipated_work(
    problem: FullOrderProblem, x0: np.ndarray, x1: np.ndarray, vh: np.ndarray, fd: np.ndarray,
    t_mid: float,
) -> float:  # fmt: skip
    """Work Δt v½ᵀ f_d (J) of the damping force over the step x0 → x1 (clamped body: on the
    motion relative to the hub at the midpoint time ``t_mid``)."""
    if problem.hub is not None:
        rel = 0.5 * (x0 + x1) - np.outer(problem.tr, problem.point)
        vh = vh - np.cross(problem.hub.angular_velocity(t_mid), rel)
    return problem.h * float(np.sum(vh * fd))


# ---------------------------------------------------------------------------------------------
# frames and predictor
# ---------------------------------------------------------------------------------------------


def body_frame(
    body: kin.Body, x: np.ndarray, hub: kin.HubDrive | None, t: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(c, R, b)`` of state x at time t: origin c (3,) (CoM of a free body, hub point of a
    clamped one), frame R (3,3) (best-fit rotation, or hub rotation) and the body-frame
    configuration ``b = Rᵀ(x − t c)`` (n,3)."""
    if hub is None:
        c = kin.centre(body, x)
        rot = kin.best_fit_rotation(body, x, c)
    else:
        c = np.asarray(hub.point, float)
        rot = hub.rotation(t)
    return c, rot, (x - body.t[:, None] * c) @ rot


def extrapolate(
    body: kin.Body, prev: tuple, now: tuple, hub: kin.HubDrive | None, t1: float
) -> np.ndarray:
    """Predicted x₁ (n,3) from the body frames ``(c, R, b)`` of the last two states: origin,
    rotation (``R₁ = R₀ R₋₁ᵀ R₀``, or the hub's R(t₁)) and body-frame configuration extrapolated
    linearly. Exact for a steady rigid rotation; the error is O(h²) of the body-frame (elastic)
    acceleration. The plain ``x + h v`` would be off by ½h²Ω²|r| (mm at 41 Hz), and any use of the
    velocity or acceleration would feed the unresolved stiff components (ωh ≫ 1), which the
    midpoint keeps nearly frozen in position while their velocity alternates."""
    c_m, r_m, b_m = prev
    c_0, r_0, b_0 = now
    c_1 = 2.0 * c_0 - c_m
    r_1 = hub.rotation(t1) if hub is not None else r_0 @ (r_m.T @ r_0)
    return body.t[:, None] * c_1 + (2.0 * b_0 - b_m) @ r_1.T


def newton_frame(problem: FullOrderProblem, t: float, xh: np.ndarray) -> np.ndarray:
    """Rotation (3,3) in which the Newton matrix is applied: the hub's at t (s), else the
    best-fit rotation of the midpoint state xh (n,3)."""
    if problem.hub is not None:
        return problem.hub.rotation(t)
    return kin.best_fit_rotation(problem.body, xh, kin.centre(problem.body, xh))


def prescribe(problem: FullOrderProblem, x1: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """x1 (n,3) with its clamped components (in the hub frame ``rot``) set to the reference
    values (unchanged for a free body)."""
    rows = problem.fixed_rows
    if problem.hub is None or not len(rows):
        return x1
    fixed = problem.structure.fixed[rows]
    rel = x1 - np.outer(problem.tr, problem.point)
    z = rel[rows] @ rot
    z[fixed] = problem.X[rows][fixed]
    x1 = x1.copy()
    x1[rows] = z @ rot.T + np.outer(problem.tr[rows], problem.point)
    return x1


def predict(
    problem: FullOrderProblem, x: np.ndarray, v: np.ndarray, frame_prev: tuple | None,
    frame_now: tuple, t1: float,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """``(x₁, R)``: the predicted end state (n,3) of the step from (x, v) and the Newton frame R
    (3,3) at ``t1`` (s). Predictor: :func:`extrapolate` of the body frames ``frame_prev`` and
    ``frame_now`` (:func:`body_frame`), or ``x + Δt v`` without a history (the first step, or
    after a resume); clamped components prescribed (:func:`prescribe`)."""
    if frame_prev is None:
        x1 = x + problem.h * v
    else:
        x1 = extrapolate(problem.body, frame_prev, frame_now, problem.hub, t1)
    xh = 0.5 * (x + x1)
    rot = newton_frame(problem, t1, xh)
    return prescribe(problem, x1, rot), rot


# ---------------------------------------------------------------------------------------------
# residual
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class StepResidual:
    """Residual of the step from (x0, v0) (n,3) at ``t0`` (s): ``self(y)`` returns
    ``(v½, r, f_d)`` (n,3) of the end state y, r in N. ``strain0``: the start data of the step
    force (``ops.start(x0)``, or :func:`step_strains` at x0 without ``ops``; None for the plain
    midpoint). ``ops``: the run's :class:`~quadmodes.fullorder.kernels.StepOperators` (None:
    the straightforward :func:`step_force`)."""

    problem: FullOrderProblem
    x0: np.ndarray
    v0: np.ndarray
    t0: float
    strain0: list | None
    ops: StepOperators | None = None

    @classmethod
    def start(cls, problem: FullOrderProblem, x0, v0, t0: float,
              ops: StepOperators | None = None) -> StepResidual:  # fmt: skip
        """The residual of the step from (x0, v0) at t0 (the start strains computed once)."""
        if ops is not None:
            return cls(problem, x0, v0, t0, ops.start(x0), ops)
        em = problem.energy_momentum
        return cls(problem, x0, v0, t0, step_strains(problem.structure, x0) if em else None)

    def __call__(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p, x = self.problem, self.x0
        h = p.h
        yh, vh = 0.5 * (x + y), (y - x) / h
        fd = step_damping(p, self.t0 + 0.5 * h, yh, vh)
        if self.ops is not None:
            f_int = self.ops.step_force(self.strain0, y)
        elif p.energy_momentum:
            f_int = step_force(p.structure, x, y, self.strain0)
        else:
            f_int = internal_force(p.structure, yh)
        return vh, (2.0 / h) * (p.ms @ (vh - self.v0)) + f_int + fd, fd
