"""One step of the seed's first-order implicit scheme in velocity form, for the numpy driver
:func:`quadmodes.rom.fixed_step.run_fixed`::

    𝕄(s₁)(ν₁ − ν₀) = Δt b(s₁, ν₁),   s₁ = s₀ + Δt ṡ₁,   q₁ = q₀ ⊗ exp(Δt ω₁ / 2)

with the analytic Jacobian. Numerically dissipative (ζ_num ≈ ωΔt/2) and does not conserve H.
"""

from __future__ import annotations

import numpy as np

from quadmodes.rom.dynamics import potential_hessian, potential_nonlinear_force
from quadmodes.rom.fixed_step import ImplicitStepper
from quadmodes.rom.system import ReducedSystem
from quadmodes.rotations import cross_matrix


class BackwardEulerStep(ImplicitStepper):
    """Residual and analytic Jacobian of one backward-Euler step (velocity form), x = ν₁.

    ``r = 𝕄(s₁)(ν₁ − ν₀) − Δt b(s₁, ν₁)``, ``s₁ = s₀ + Δt ṡ₁``, with
    ``b = [−ω × h, P_E·ν − Λs − Cṡ] − 2 ṡ·P`` (``P[k] = ½∂𝕄/∂s_k ν``, see
    :mod:`quadmodes.rom.dynamics`); "Q4" replaces ``Λs`` by the full potential gradient
    ``∂V/∂s(s₁)``. The implicit-step protocol of
    :class:`~quadmodes.rom.fixed_step.ImplicitStepper`, hence a
    :class:`~quadmodes.rom.stepper.Stepper`."""

    name = "backward-euler"
    order = 1

    def __init__(self, sys: ReducedSystem, dt: float):
        self.n = n = sys.n_modes
        self.m3 = 3 + n
        self.dt = dt
        self.same = sys.same_rows
        flat = sys.flat
        self.Mt, self.Yt, self.YtE, self.WtE, self.Wt = (
            flat.Mt,
            flat.Yt,
            flat.YtE,
            flat.WtE,
            flat.Wt,
        )
        self.Lam, self.C, self.F1 = sys.Lam, sys.C, sys.F1
        self.LC = np.hstack([sys.Lam, sys.C])
        self.z1 = np.ones(n + 1)
        self.y1 = np.empty(2 * n)
        self.sys = sys
        self.quartic = sys.nonlinear

    def begin(self, x0, s0):
        """Per-step constants from the state at t0."""
        self.x0 = x0
        self.s0 = s0

    def advance(self, x1):
        """(ν₁, s₁, rotation vector Δt ω₁ of the step, dissipated energy Δt ṡ₁ᵀCṡ₁)."""
        sd1 = x1[3:]
        return x1, self.s0 + self.dt * sd1, self.dt * x1[:3], self.dt * float(sd1 @ self.C @ sd1)

    def residual(self, x, jac=False):
        """Residual (3+N,) and, if ``jac``, its Jacobian (3+N, 3+N) with respect to x."""
        n, m3, dt = self.n, self.m3, self.dt
        z1 = self.z1
        sd1 = x[3:]
        z1[1:] = self.s0 + dt * sd1
        m1 = ((z1[:, None] * z1).ravel() @ self.Mt).reshape(m3, m3)
        y1 = (z1 @ self.Yt).reshape(n * m3, m3)
        p = (y1 @ x).reshape(n, m3)
        pe = p if self.same else ((z1 @ self.YtE).reshape(n * m3, m3) @ x).reshape(n, m3)
        b = -2.0 * (sd1 @ p)
        h = (m1[:3] @ x).tolist()
        hx, hy, hz = h
        wx, wy, wz = x[:3].tolist()
        b[0] -= wy * hz - wz * hy
        b[1] -= wz * hx - wx * hz
        b[2] -= wx * hy - wy * hx
        yv = self.y1
        yv[:n] = z1[1:]
        yv[n:] = sd1
        b[3:] += pe @ x - self.LC @ yv - self.F1
        if self.quartic:
            b[3:] -= potential_nonlinear_force(self.sys, z1[1:])
        dxv = x - self.x0
        r = m1 @ dxv - dt * b
        if not jac:
            return r
        return r, self._jacobian(x, dxv, m1, y1, p, pe, h)

    def _jacobian(self, x, dxv, m1, y1, p, pe, h):
        """∂r/∂x (3+N, 3+N) from the intermediates of :meth:`residual` at the same x: ν₁ − ν₀,
        𝕄(s₁), Y(z₁), P, P_E and h (3 floats)."""
        n, m3, dt = self.n, self.m3, self.dt
        sd1 = x[3:]
        jm = m1.copy()
        pd = (y1 @ dxv).reshape(n, m3)
        jm[:, 3:] += (2.0 * dt) * pd.T
        # ∂b/∂ν
        db = -2.0 * (sd1 @ y1.reshape(n, m3 * m3)).reshape(m3, m3)
        db[:, 3:] -= 2.0 * p.T
        ww = cross_matrix(*x[:3].tolist())
        db[:3, :3] += cross_matrix(*h)
        db[:3] -= ww @ m1[:3]
        db[3:] += 2.0 * pe
        db[3:, 3:] -= self.C
        # ∂b/∂s
        dbs = -2.0 * ((sd1 @ self.Wt).reshape(n * m3, m3) @ x).reshape(n, m3).T
        dbs[:3] -= 2.0 * (ww @ p[:, :3].T)
        dbs[3:] += (self.WtE @ (x[:, None] * x).ravel()).reshape(n, n) - self.Lam
        if self.quartic:
            dbs[3:] -= potential_hessian(self.sys, self.z1[1:]) - self.Lam
        jm -= dt * db
        jm[:, 3:] -= (dt * dt) * dbs
        return jm
