"""Time integration of the reduced equations (:mod:`quadmodes.rom.dynamics`): one interface.

Contract
--------
``integrate(system, y0, t_span, method="midpoint", dt=None, rtol=1e-9, atol=1e-12,
save_every=1, t_eval=None, solver="DOP853", newton_tol=1e-13, max_newton=25,
backend="auto") -> Solution``

* ``system``: a :class:`~quadmodes.rom.dynamics.ReducedSystem` (a ReducedModel is converted with
  formulation "Q"). ``y0`` (7+2N,) = ``[q, ω, s, ṡ]``; q is normalised first.
* What a fixed-step method provides (a "stepper" object, driven by ``_fixed_run``):
  ``begin(ν₀, s₀)`` (per-step constants), ``residual(ν₁, jac=False)`` returning the residual
  (3+N,) of the step equations in the unknowns ``ν₁ = (ω₁, ṡ₁)`` (s₁ is an explicit linear
  function of ṡ₁ and is eliminated) or ``(r, ∂r/∂ν₁)``, and ``advance(ν₁) -> (ν₁, s₁, φ, ΔE_d)``
  with the attitude update ``q₁ = q₀ ⊗ exp(φ/2)`` (φ the rotation vector of the step) and the
  energy the scheme dissipates in the step (midpoint: ``Δt ṡ½ᵀCṡ½``, the exact discrete balance
  of the quadratic part; backward Euler: ``Δt ṡ₁ᵀCṡ₁``). The driver does the Newton (chord)
  iteration, the bookkeeping, the sampling and the failure handling.
* Step size. Fixed-step methods need ``dt``; the step used is ``(t1 − t0)/n`` with
  ``n = ceil((t1 − t0)/dt)`` (equal to ``dt`` when it divides the span); ``Solution.dt`` is it.
* Output sampling. Fixed step: ``t0``, every ``save_every``-th step, and always the last step;
  with ``t_eval``: ``t0`` and the grid points ``t0 + iΔt`` requested (they must lie on the grid
  within 1e-6 Δt, else ``ValueError``). Adaptive: ``t_eval`` if given (dense output of the
  solver), else, if ``dt`` is given, an even grid over ``t_span`` with spacing
  ``span / ceil(span / (dt·save_every))`` (dense output; ``dt`` is only a sampling interval here),
  else every ``save_every``-th accepted step plus the last.
* Failure: Newton not converging within ``max_newton`` iterations, a singular Newton matrix or a
  non-finite update stops the run with ``status = 1`` and a one-line ``message`` naming the
  step and its time; the samples saved so far plus the last accepted state are returned (its
  time is the last sample's). The adaptive solvers report scipy's failure the same way.
  Success: ``status = 0``, ``message = "ok"``.
* Stats: ``n_steps`` (accepted steps), ``n_rhs`` (evaluations of the right-hand side, or of the
  step residual for implicit methods), ``n_newton`` (Newton iterations), ``n_jac`` (Jacobian
  evaluations), ``wall_s``, ``backend`` ("numpy" or "numba"); Radau adds ``n_lu``.
* Backend (``backend=``): ``"numpy"`` runs the steppers below from Python; ``"numba"`` runs the
  whole midpoint loop in one compiled call (:mod:`quadmodes.rom.midpoint_kernel`, the ``[jit]``
  extra; 20–30× faster for N = 5; same equations and convergence test, results equal to
  round-off); ``"auto"`` (default) uses numba for ``method="midpoint"`` when numba is
  importable, numpy otherwise (backward Euler and the adaptive solvers are numpy only).
  ``"numba"`` without numba, or with another method, raises ``ValueError``.

Methods
-------
* ``"midpoint"`` — Lie-group implicit midpoint in momentum form (theory.md §7)::

      h(s₁, ω₁, ṡ₁) = exp(−Δt ω̂½) h₀               (exact discrete conservation of R h)
      p_s(s₁, ω₁, ṡ₁) − p_s(0) = Δt F_s(s½, ω½, ṡ½),  F_s = ∂L̃/∂s − Cṡ
      s₁ − s₀ = Δt ṡ½,   q₁ = q₀ ⊗ exp(Δt ω½ / 2)

  (·½ = average of the end values.) Second order, symmetric, no numerical dissipation of
  resolved motion; energy error bounded. Newton: analytic Jacobian (3+N)² once per step at the
  predictor (linear extrapolation of ν), then chord iterations until the energy-weighted update,
  or the remaining error estimated from the contraction rate, is below ``newton_tol`` (relative).
  After convergence ω₁ is projected by one 3×3 solve onto ``h₁ = exp(−Δt ω̂½) h₀`` with the
  same φ = Δt ω½ used for q, so that R h is conserved to round-off, not just to the tolerance.
* ``"backward-euler"`` — the seed's first-order implicit scheme in velocity form,
  ``𝕄(s₁)(ν₁ − ν₀) = Δt b(s₁, ν₁)``, ``s₁ = s₀ + Δt ṡ₁``, ``q₁ = q₀ ⊗ exp(Δt ω₁ / 2)``,
  analytic Jacobian. Numerically dissipative (ζ_num ≈ ωΔt/2) and does not conserve H.
* ``"adaptive"`` — scipy's Runge–Kutta solvers (the classes behind ``solve_ivp``, stepped here
  so that steps are counted and dense output is sampled at the save points), ``solver=
  "DOP853"`` (default), ``"Radau"`` or ``"RK45"``; ``method="DOP853"|"Radau"|"RK45"`` are
  aliases. ``E_d`` is integrated as an extra state (dE_d/dt = ṡᵀCṡ).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import integrate as _ode

from quadmodes.rom import dynamics as dyn

METHODS = ("midpoint", "backward-euler", "adaptive")
BACKENDS = ("auto", "numpy", "numba")
ADAPTIVE_SOLVERS = {"DOP853": _ode.DOP853, "Radau": _ode.Radau, "RK45": _ode.RK45}


@dataclass(frozen=True, eq=False)
class Solution:
    """Result of :func:`integrate`.

    t (k,) s; y (k, 7+2N) states ``[q, ω, s, ṡ]``; dissipated (k,) J: energy dissipated by
    modal damping since t0 (the scheme's own discrete form); method; stats (n_steps, n_rhs,
    n_newton, n_jac, wall_s); status 0 (success) or 1 (failure); message; dt (s) for
    fixed-step methods, else None.
    """

    t: np.ndarray
    y: np.ndarray
    method: str
    stats: dict
    status: int
    message: str
    dissipated: np.ndarray = field(default_factory=lambda: np.zeros(0))
    dt: float | None = None

    @property
    def success(self) -> bool:
        return self.status == 0


# ---------------------------------------------------------------------------------------------
# small fast helpers (Python floats: cheaper than numpy for 3- and 4-vectors)
# ---------------------------------------------------------------------------------------------


def _quat_step(q, phi):
    """``q ⊗ exp(φ/2)``, normalised; q (4,), φ (3,) rotation vector (rad)."""
    px, py, pz = phi.tolist()
    a = math.sqrt(px * px + py * py + pz * pz)
    half = 0.5 * a
    k = 0.5 - a * a / 48.0 if a < 1e-4 else math.sin(half) / a
    c = math.cos(half)
    bx, by, bz = k * px, k * py, k * pz
    a0, ax, ay, az = q.tolist()
    r = [
        a0 * c - ax * bx - ay * by - az * bz,
        a0 * bx + c * ax + ay * bz - az * by,
        a0 * by + c * ay + az * bx - ax * bz,
        a0 * bz + c * az + ax * by - ay * bx,
    ]
    nrm = 1.0 / math.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2 + r[3] ** 2)
    return np.array(r) * nrm


def _rotate(theta, v):
    """``exp(θ̂) v`` as a tuple of 3 floats (Rodrigues, scalar arithmetic); θ, v (3,)."""
    tx, ty, tz = theta.tolist()
    hx, hy, hz = v.tolist()
    a2 = tx * tx + ty * ty + tz * tz
    if a2 < 1e-12:
        sa, ca = 1.0 - a2 / 6.0, 0.5 - a2 / 24.0
    else:
        a = math.sqrt(a2)
        sa, ca = math.sin(a) / a, (1.0 - math.cos(a)) / a2
    cx, cy, cz = ty * hz - tz * hy, tz * hx - tx * hz, tx * hy - ty * hx
    ex, ey, ez = ty * cz - tz * cy, tz * cx - tx * cz, tx * cy - ty * cx
    return (hx + sa * cx + ca * ex, hy + sa * cy + ca * ey, hz + sa * cz + ca * ez)


def _left_jacobian(theta):
    """Left Jacobian J_l(θ) (3,3) of SO(3): ``exp((θ+δ)^) = exp((J_l δ)^) exp(θ̂) + O(δ²)``."""
    x, y, z = theta.tolist()
    a2 = x * x + y * y + z * z
    if a2 < 1e-12:
        c, d = 0.5 - a2 / 24.0, 1.0 / 6.0 - a2 / 120.0
    else:
        a = math.sqrt(a2)
        c, d = (1.0 - math.cos(a)) / a2, (a - math.sin(a)) / (a2 * a)
    th = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return _EYE3 + c * th + d * (th @ th)


_EYE3 = np.eye(3)


# ---------------------------------------------------------------------------------------------
# implicit midpoint (momentum form)
# ---------------------------------------------------------------------------------------------


class _Midpoint:
    """Residual and analytic Jacobian of one Lie-group midpoint step, unknowns x = ν₁ = (ω₁, ṡ₁).

    With z = (1, s) and the mass tensor of :class:`~quadmodes.rom.dynamics.ReducedSystem`,
    momenta are ``𝕄(s)ν`` (one matrix product) and ``F_s = P(z, ν)·ν − Λs − Cṡ`` with
    ``P[k] = ½ ∂𝕄_E/∂s_k ν`` (T = ½νᵀ𝕄_Eν).

    Formulation "Q4" (quartic manifold potential): the potential force is the average vector
    field ``∫₀¹ ∂V/∂s(s₀ + τ(s₁ − s₀)) dτ``, exact by Simpson's rule since ∂V/∂s is cubic:
    ``Λs½ + (n(s₀) + 4 n(s½) + n(s₁))/6`` with n = ∂V/∂s − Λs. It is a discrete gradient,
    ``(s₁ − s₀)·F_V = V(s₁) − V(s₀)`` exactly, so the potential adds no energy error: the energy
    error is that of the kinetic terms, as for Q (bounded, O(Δt²), no drift)."""

    def __init__(self, sys: dyn.ReducedSystem, dt: float):
        self.n = n = sys.n_modes
        self.m3 = 3 + n
        self.dt = dt
        self.hdt = 0.5 * dt
        self.Mt, self.Yt, self.YtE, self.WtE = sys._Mt, sys._Yt, sys._YtE, sys._WtE
        self.LC = np.hstack([sys.Lam, sys.C])  # F_s contribution −[Λ C]·(s, ṡ)
        self.C, self.Lam = sys.C, sys.Lam
        self.hC = 0.5 * dt * sys.C
        self.wt = np.concatenate([np.sqrt(np.diag(sys.J0)), np.sqrt(np.diag(sys.mu))])
        self.z1 = np.ones(n + 1)  # z at t1 (z[0] = 1)
        self.zm = np.ones(n + 1)  # z at t½
        self.y_m = np.empty(2 * n)  # (s½, ṡ½)
        self.sys = sys
        self.quartic = sys.quartic

    def momenta(self, x, s):
        """𝕄(s) ν (3+N,): (h, p_s) at ν = x, s."""
        z = self.z1
        z[1:] = s
        m3 = self.m3
        return ((z[:, None] * z).ravel() @ self.Mt).reshape(m3, m3) @ x

    def begin(self, x0, s0):
        """Per-step constants from the state at t0: ν₀, momenta, parts of s₁ and s½."""
        self.x0 = x0
        mom0 = self.momenta(x0, s0)
        self.s_base1 = s0 + self.hdt * x0[3:]  # s1 = s_base1 + ½Δt ṡ1
        self.s_basem = s0 + 0.25 * self.dt * x0[3:]  # s½ = s_basem + ¼Δt ṡ1
        self.h0 = mom0[:3]
        self.p0 = mom0[3:]
        if self.quartic:
            self.n0 = dyn.potential_nonlinear_force(self.sys, s0)

    def advance(self, x1):
        """(ν₁, s₁, rotation vector Δt ω½, dissipated energy Δt ṡ½ᵀCṡ½) of the converged step.

        ω₁ is first projected (one 3×3 solve) so that h(s₁, ω₁, ṡ₁) = exp(−Δt ω̂½) h₀ holds to
        round-off rather than to the Newton tolerance: |H| is then conserved to round-off."""
        m3 = self.m3
        s1 = self.s_base1 + self.hdt * x1[3:]
        z = self.z1
        z[1:] = s1
        m1 = ((z[:, None] * z).ravel() @ self.Mt).reshape(m3, m3)
        phi = (0.5 * self.dt) * (self.x0[:3] + x1[:3])  # used for both h and q: R₁h₁ = R₀h₀
        target = _rotate(-phi, self.h0)
        x1 = x1.copy()
        x1[:3] = np.linalg.solve(m1[:3, :3], target - m1[:3, 3:] @ x1[3:])
        sdm = 0.5 * (self.x0[3:] + x1[3:])
        return x1, s1, phi, self.dt * float(sdm @ self.C @ sdm)

    def residual(self, x, jac=False):
        """Residual (3+N,) and, if ``jac``, its Jacobian (3+N, 3+N) with respect to x."""
        n, m3, dt, hdt = self.n, self.m3, self.dt, self.hdt
        z1, zm = self.z1, self.zm
        sd1 = x[3:]
        z1[1:] = self.s_base1 + hdt * sd1
        m1 = ((z1[:, None] * z1).ravel() @ self.Mt).reshape(m3, m3)
        r = m1 @ x
        numid = 0.5 * (self.x0 + x)
        rh0 = _rotate(-dt * numid[:3], self.h0)  # exp(−Δt ω̂½) h0
        r[0] -= rh0[0]
        r[1] -= rh0[1]
        r[2] -= rh0[2]
        # modal balance p1 − p0 − Δt F_s(½)
        zm[1:] = self.s_basem + 0.25 * dt * sd1
        ym = self.y_m
        ym[:n] = zm[1:]
        ym[n:] = numid[3:]
        pm = ((zm @ self.YtE).reshape(n * m3, m3) @ numid).reshape(n, m3)
        f = pm @ numid - self.LC @ ym
        if self.quartic:  # average vector field of the cubic and quartic potential (Simpson)
            nl = dyn.potential_nonlinear_force
            f -= (self.n0 + 4.0 * nl(self.sys, zm[1:]) + nl(self.sys, z1[1:])) / 6.0
        r[3:] -= self.p0 + dt * f
        if not jac:
            return r
        jm = m1.copy()
        p1 = ((z1 @ self.Yt).reshape(n * m3, m3) @ x).reshape(n, m3)
        jm[:, 3:] += dt * p1.T  # ∂(𝕄(s1)ν1)/∂s1 · ∂s1/∂ṡ1
        jl = _left_jacobian(-dt * numid[:3])
        hh = np.array([[0.0, -rh0[2], rh0[1]], [rh0[2], 0.0, -rh0[0]], [-rh0[1], rh0[0], 0.0]])
        jm[:3, :3] -= hdt * (hh @ jl)
        w2 = (self.WtE @ (numid[:, None] * numid).ravel()).reshape(n, n)  # ∂²T/∂s∂s
        jm[3:] -= dt * pm
        jm[3:, 3:] += self.hC - (0.25 * dt * dt) * (w2 - self.LC[:, :n])
        if self.quartic:  # ∂s½/∂ṡ₁ = ¼Δt, ∂s₁/∂ṡ₁ = ½Δt
            hm = dyn.potential_hessian(self.sys, zm[1:]) - self.Lam
            h1 = dyn.potential_hessian(self.sys, z1[1:]) - self.Lam
            jm[3:, 3:] += (dt * dt) * (hm / 6.0 + h1 / 12.0)
        return r, jm


# ---------------------------------------------------------------------------------------------
# backward Euler (velocity form, the seed's scheme)
# ---------------------------------------------------------------------------------------------


class _BackwardEuler:
    """Residual and analytic Jacobian of one backward-Euler step (velocity form), x = ν₁.

    ``r = 𝕄(s₁)(ν₁ − ν₀) − Δt b(s₁, ν₁)``, ``s₁ = s₀ + Δt ṡ₁``, with
    ``b = [−ω × h, P_E·ν − Λs − Cṡ] − 2 ṡ·P`` (``P[k] = ½∂𝕄/∂s_k ν``, see dynamics);
    "Q4" replaces ``Λs`` by the full potential gradient ``∂V/∂s(s₁)``."""

    def __init__(self, sys: dyn.ReducedSystem, dt: float):
        self.n = n = sys.n_modes
        self.m3 = 3 + n
        self.dt = dt
        self.same = sys.same_rows
        self.Mt, self.Yt, self.YtE, self.WtE, self.Wt = (
            sys._Mt,
            sys._Yt,
            sys._YtE,
            sys._WtE,
            sys._Wt,
        )
        self.Lam, self.C = sys.Lam, sys.C
        self.LC = np.hstack([sys.Lam, sys.C])
        self.wt = np.concatenate([np.sqrt(np.diag(sys.J0)), np.sqrt(np.diag(sys.mu))])
        self.z1 = np.ones(n + 1)
        self.y1 = np.empty(2 * n)
        self.sys = sys
        self.quartic = sys.quartic

    def begin(self, x0, s0):
        """Per-step constants from the state at t0."""
        self.x0 = x0
        self.s0 = s0

    def advance(self, x1):
        """(ν₁, s₁, rotation vector Δt ω₁ of the step, dissipated energy Δt ṡ₁ᵀCṡ₁)."""
        sd1 = x1[3:]
        return x1, self.s0 + self.dt * sd1, self.dt * x1[:3], self.dt * float(sd1 @ self.C @ sd1)

    def residual(self, x, jac=False):
        n, m3, dt = self.n, self.m3, self.dt
        z1 = self.z1
        sd1 = x[3:]
        z1[1:] = self.s0 + dt * sd1
        m1 = ((z1[:, None] * z1).ravel() @ self.Mt).reshape(m3, m3)
        y1 = (z1 @ self.Yt).reshape(n * m3, m3)
        p = (y1 @ x).reshape(n, m3)
        pe = p if self.same else ((z1 @ self.YtE).reshape(n * m3, m3) @ x).reshape(n, m3)
        b = -2.0 * (sd1 @ p)
        hx, hy, hz = (m1[:3] @ x).tolist()
        wx, wy, wz = x[:3].tolist()
        b[0] -= wy * hz - wz * hy
        b[1] -= wz * hx - wx * hz
        b[2] -= wx * hy - wy * hx
        yv = self.y1
        yv[:n] = z1[1:]
        yv[n:] = sd1
        b[3:] += pe @ x - self.LC @ yv
        if self.quartic:
            b[3:] -= dyn.potential_nonlinear_force(self.sys, z1[1:])
        dxv = x - self.x0
        r = m1 @ dxv - dt * b
        if not jac:
            return r
        jm = m1.copy()
        pd = (y1 @ dxv).reshape(n, m3)
        jm[:, 3:] += (2.0 * dt) * pd.T
        # ∂b/∂ν
        db = -2.0 * (sd1 @ y1.reshape(n, m3 * m3)).reshape(m3, m3)
        db[:, 3:] -= 2.0 * p.T
        hh = np.array([[0.0, -hz, hy], [hz, 0.0, -hx], [-hy, hx, 0.0]])
        ww = np.array([[0.0, -wz, wy], [wz, 0.0, -wx], [-wy, wx, 0.0]])
        db[:3, :3] += hh
        db[:3] -= ww @ m1[:3]
        db[3:] += 2.0 * pe
        db[3:, 3:] -= self.C
        # ∂b/∂s
        dbs = -2.0 * ((sd1 @ self.Wt).reshape(n * m3, m3) @ x).reshape(n, m3).T
        dbs[:3] -= 2.0 * (ww @ p[:, :3].T)
        dbs[3:] += (self.WtE @ (x[:, None] * x).ravel()).reshape(n, n) - self.Lam
        if self.quartic:
            dbs[3:] -= dyn.potential_hessian(self.sys, z1[1:]) - self.Lam
        jm -= dt * db
        jm[:, 3:] -= (dt * dt) * dbs
        return r, jm


def _state_scale(x, xg, s, wt, lam):
    """Energy-like scale (√J) of the Newton unknowns, for relative convergence tests."""
    v = float(s @ lam @ s) if len(s) else 0.0
    return float(np.abs(x * wt).max() + np.abs(xg * wt).max()) + math.sqrt(abs(v)) + 1e-300


def _fixed_run(stepper, sys, y0, n_steps, dt, save_idx, newton_tol, max_newton, t0, name):
    """Drive an implicit one-step method. ``stepper`` provides ``begin(ν₀, s₀)``,
    ``residual(ν₁, jac=False) -> r`` or ``(r, ∂r/∂ν₁)`` and ``advance(ν₁) -> (ν₁, s₁, φ, ΔE_d)``
    (q₁ = q₀ ⊗ exp(φ/2)). Returns (ys, dissipated, steps done, stats, status, message)."""
    n = sys.n_modes
    wt = np.concatenate([np.sqrt(np.diag(sys.J0)), np.sqrt(np.diag(sys.mu))])
    lam = sys.Lam
    q = y0[0:4].copy()
    s = y0[7 : 7 + n].copy()
    x = y0[np.r_[4:7, 7 + n : 7 + 2 * n]]  # ν = (ω, ṡ)
    x_prev = x
    out = np.empty((len(save_idx), 7 + 2 * n))
    ed_out = np.empty(len(save_idx))
    out[0] = y0
    ed_out[0] = 0.0
    k_save = 1
    next_save = save_idx[1] if len(save_idx) > 1 else -1
    e_d = 0.0
    n_newton = n_jac = n_res = 0
    status, msg = 0, "ok"
    residual, begin, advance = stepper.residual, stepper.begin, stepper.advance
    inv = np.linalg.inv
    i = 0
    for i in range(1, n_steps + 1):
        begin(x, s)
        xg = 2.0 * x - x_prev  # linear extrapolation predictor
        scale = _state_scale(x, xg, s, wt, lam)
        try:
            r, jm = residual(xg, jac=True)
            jinv = inv(jm)
            n_jac += 1
            (ok, xg, its), err = _newton(residual, xg, r, jinv, wt, scale, newton_tol, max_newton)
        except (np.linalg.LinAlgError, ValueError, OverflowError):
            # a singular Newton matrix, or an iterate that left the reals (math domain error)
            status = 1
            msg = (
                f"{name}: Newton failed at step {i} (t = {t0 + i * dt:.6g} s): singular or "
                "non-finite iterate; reduce dt"
            )
            break
        n_newton += its
        n_res += its
        if not ok:
            status = 1
            msg = (
                f"{name}: Newton did not converge at step {i} (t = {t0 + i * dt:.6g} s) "
                f"after {its} iterations (relative update {err:.2e})"
            )
            break
        xg, s, phi, ded = advance(xg)
        e_d += ded
        q = _quat_step(q, phi)
        x_prev = x
        x = xg
        if i == next_save:
            out[k_save, 0:4] = q
            out[k_save, 4:7] = x[:3]
            out[k_save, 7 : 7 + n] = s
            out[k_save, 7 + n :] = x[3:]
            ed_out[k_save] = e_d
            k_save += 1
            next_save = save_idx[k_save] if k_save < len(save_idx) else -1
    steps_done = i if status == 0 else i - 1
    if status:  # keep what was saved plus the last accepted state
        last = np.concatenate([q, x[:3], s, x[3:]])
        out = np.vstack([out[:k_save], last])
        ed_out = np.append(ed_out[:k_save], e_d)
        k_save += 1
    stats = {"n_steps": steps_done, "n_rhs": n_res, "n_newton": n_newton, "n_jac": n_jac}
    return out[:k_save], ed_out[:k_save], steps_done, stats, status, msg


def _newton(residual, xg, r, jinv, wt, scale, tol, max_iter):
    """Chord iteration x ← x − J⁻¹r(x) with J⁻¹ fixed; converged when the update, or the
    remaining error estimated from the contraction ρ (ρ/(1−ρ)·update), is ≤ tol·scale (weighted
    max-norm), or when the update stagnates at round-off. Returns ((ok, x, iterations), err)."""
    err_prev = math.inf
    err = math.inf
    for it in range(1, max_iter + 1):
        dx = jinv @ r
        xg = xg - dx
        err = float(np.abs(dx * wt).max()) / scale
        if not math.isfinite(err):
            return (False, xg, it), err
        if err <= tol:
            return (True, xg, it), err
        if err_prev < math.inf:
            rho = err / err_prev
            if rho < 0.5 and err * rho <= (1.0 - rho) * tol:
                return (True, xg, it), err
            if rho >= 1.0 and err <= 1e3 * tol:
                return (True, xg, it), err  # stagnation at round-off
        err_prev = err
        r = residual(xg)
    return (False, xg, max_iter), err


# ---------------------------------------------------------------------------------------------
# adaptive (scipy)
# ---------------------------------------------------------------------------------------------


def _adaptive_run(sys, y0, t_span, solver, rtol, atol, t_eval, save_every):
    n = sys.n_modes
    c_mat = sys.C
    counter = [0]
    rhs = dyn.rhs

    def fun(t, z):
        counter[0] += 1
        dz = np.empty_like(z)
        dz[:-1] = rhs(sys, t, z[:-1])
        sd = z[7 + n : 7 + 2 * n]
        dz[-1] = sd @ c_mat @ sd
        return dz

    z0 = np.append(y0, 0.0)
    if np.ndim(atol):
        atol = np.append(np.asarray(atol, float), np.min(atol))
    cls = ADAPTIVE_SOLVERS[solver]
    t0, t1 = t_span
    ode = cls(fun, t0, z0, t1, rtol=rtol, atol=atol)
    ts, zs = [t0], [z0]
    k_eval = 0
    if t_eval is not None:
        t_eval = np.asarray(t_eval, float)
        while k_eval < len(t_eval) and t_eval[k_eval] <= t0:
            k_eval += 1
        ts, zs = ([t0], [z0]) if (len(t_eval) and t_eval[0] <= t0) else ([], [])
    n_steps = 0
    status, msg = 0, "ok"
    while ode.status == "running":
        m = ode.step()
        if ode.status == "failed":
            status, msg = 1, f"{solver} failed at step {n_steps + 1} (t = {ode.t:.6g} s): {m}"
            break
        n_steps += 1
        if t_eval is None:
            if n_steps % save_every == 0 or ode.status == "finished":
                ts.append(ode.t)
                zs.append(ode.y.copy())
        else:
            j = k_eval
            while j < len(t_eval) and t_eval[j] <= ode.t:
                j += 1
            if j > k_eval:
                dense = ode.dense_output()
                vals = dense(t_eval[k_eval:j])
                ts.extend(t_eval[k_eval:j])
                zs.extend(vals.T)
                k_eval = j
    if status:
        ts.append(ode.t)
        zs.append(ode.y.copy())
    z = np.array(zs).reshape(-1, len(z0))
    stats = {"n_steps": n_steps, "n_rhs": counter[0], "n_newton": 0, "n_jac": int(ode.njev)}
    if hasattr(ode, "nlu"):
        stats["n_lu"] = int(ode.nlu)
    return np.asarray(ts, float), z[:, :-1], z[:, -1], stats, status, msg


# ---------------------------------------------------------------------------------------------
# public interface
# ---------------------------------------------------------------------------------------------


def _fixed_grid(t_span, dt, save_every, t_eval):
    t0, t1 = map(float, t_span)
    if dt is None or dt <= 0:
        raise ValueError("fixed-step methods need dt > 0")
    if not t1 > t0:
        raise ValueError(f"t_span must increase, got ({t0}, {t1})")
    n_steps = max(1, math.ceil((t1 - t0) / dt - 1e-9))
    h = (t1 - t0) / n_steps
    if t_eval is None:
        idx = list(range(0, n_steps + 1, max(1, int(save_every))))
        if idx[-1] != n_steps:
            idx.append(n_steps)
    else:
        te = np.asarray(t_eval, float)
        k = np.rint((te - t0) / h).astype(int)
        if np.any(np.abs(t0 + k * h - te) > 1e-6 * h) or k.min() < 0 or k.max() > n_steps:
            raise ValueError("t_eval must lie on the fixed-step grid t0 + i*dt inside t_span")
        idx = sorted(set(k.tolist()) | {0})
    return n_steps, h, idx


_KERNEL: list = []  # [module or None] once looked up: the import is tried once per process


def numba_kernel():
    """:mod:`quadmodes.rom.midpoint_kernel` if numba is importable, else None (looked up once)."""
    if not _KERNEL:
        try:
            from quadmodes.rom import midpoint_kernel
        except ImportError:  # numba (the [jit] extra) not installed
            midpoint_kernel = None
        _KERNEL.append(midpoint_kernel)
    return _KERNEL[0]


def _select_backend(backend: str, method: str):
    """The compiled kernel module to use, or None for the numpy steppers (every formulation,
    "Q4" included, runs on both)."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {BACKENDS}")
    if backend == "numpy":
        return None
    if backend == "numba" and method != "midpoint":
        raise ValueError(f'backend "numba" supports method "midpoint" only, not {method!r}')
    kernel = numba_kernel() if method == "midpoint" else None
    if backend == "numba" and kernel is None:
        raise ValueError(
            'backend "numba" needs numba, which is not installed: pip install "quadmodes[jit]"'
        )
    return kernel


def integrate(
    system,
    y0,
    t_span,
    method: str = "midpoint",
    dt: float | None = None,
    rtol: float = 1e-9,
    atol=1e-12,
    save_every: int = 1,
    t_eval=None,
    solver: str = "DOP853",
    newton_tol: float = 1e-13,
    max_newton: int = 25,
    backend: str = "auto",
) -> Solution:
    """Integrate the free-body equations of ``system`` from ``y0`` over ``t_span`` (s).

    See the module docstring for the contract (``backend``: "auto", "numpy" or "numba").
    Returns a :class:`Solution`."""
    sys = system if isinstance(system, dyn.ReducedSystem) else dyn.reduced_system(system, "Q")
    y0 = np.array(y0, float)
    if y0.shape != (sys.n_state,):
        raise ValueError(f"y0 must have shape ({sys.n_state},), got {y0.shape}")
    y0[0:4] /= np.linalg.norm(y0[0:4])
    if method in ADAPTIVE_SOLVERS:
        method, solver = "adaptive", method
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {METHODS}")
    kernel = _select_backend(backend, method)
    start = time.perf_counter()
    if method == "adaptive":
        if solver not in ADAPTIVE_SOLVERS:
            raise ValueError(f"unknown adaptive solver {solver!r}")
        te = t_eval
        if te is None and dt is not None:
            t0, t1 = map(float, t_span)
            k = max(1, math.ceil((t1 - t0) / (dt * save_every) - 1e-9))
            te = np.linspace(t0, t1, k + 1)
        t, y, ed, stats, status, msg = _adaptive_run(
            sys, y0, tuple(map(float, t_span)), solver, rtol, atol, te, max(1, int(save_every))
        )
        step = None
        name = f"adaptive/{solver}"
    else:
        n_steps, h, idx = _fixed_grid(t_span, dt, save_every, t_eval)
        t0 = float(t_span[0])
        if kernel is not None:  # whole loop compiled (midpoint only)
            y, ed, done, stats, status, msg = kernel.fixed_run(
                sys, y0, n_steps, h, idx, newton_tol, max_newton, t0, method
            )
        else:
            stepper = (_Midpoint if method == "midpoint" else _BackwardEuler)(sys, h)
            y, ed, done, stats, status, msg = _fixed_run(
                stepper, sys, y0, n_steps, h, idx, newton_tol, max_newton, t0, method
            )
        t = t0 + h * np.asarray(idx[: len(y)], float)
        if status:
            t[-1] = t0 + h * done
        step = h
        name = method
    stats["wall_s"] = time.perf_counter() - start
    stats["backend"] = "numpy" if kernel is None else "numba"
    return Solution(t, y, name, stats, status, msg, ed, step)
