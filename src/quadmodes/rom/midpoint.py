"""One step of the Lie-group implicit midpoint in momentum form (theory.md §7), for the numpy
driver :func:`quadmodes.rom.fixed_step.run_fixed` (the compiled equivalent of the whole loop is
:mod:`quadmodes.rom.midpoint_kernel`)::

    h(s₁, ω₁, ṡ₁) = exp(−Δt ω̂½) h₀               (exact discrete conservation of R h)
    p_s(s₁, ω₁, ṡ₁) − p_s(0) = Δt F_s(s½, ω½, ṡ½),  F_s = ∂L̃/∂s − Cṡ
    s₁ − s₀ = Δt ṡ½,   q₁ = q₀ ⊗ exp(Δt ω½ / 2)

(·½ = average of the end values.) Second order, symmetric, no numerical dissipation of resolved
motion; energy error bounded. After convergence ω₁ is projected by one 3×3 solve onto
``h₁ = exp(−Δt ω̂½) h₀`` with the same φ = Δt ω½ used for q, so that R h is conserved to
round-off, not just to the Newton tolerance.
"""

from __future__ import annotations

import numpy as np

from quadmodes.rom.dynamics import (
    potential_hessian,
    potential_nonlinear_energy,
    potential_nonlinear_force,
)
from quadmodes.rom.fixed_step import ImplicitStepper
from quadmodes.rom.structured_mass import mass_evaluation
from quadmodes.rom.system import ReducedSystem
from quadmodes.rotations import cross_matrix, rotate, so3_left_jacobian


class MidpointStep(ImplicitStepper):
    """Residual and analytic Jacobian of one Lie-group midpoint step, unknowns x = ν₁ = (ω₁, ṡ₁).

    Momenta are ``𝕄(s)ν`` and ``F_s = P(z, ν)·ν − Λs − Cṡ`` with ``P[k] = ½ ∂𝕄_E/∂s_k ν``
    (T = ½νᵀ𝕄_Eν), z = (1, s), 𝕄 evaluated by blocks
    (:class:`~quadmodes.rom.structured_mass.BlockMass`, O(N²)) or, ``dense=True``, from the dense
    mass tensor (:class:`~quadmodes.rom.structured_mass.DenseMass`, O(N⁴): the reference the
    blocks are checked and timed against); the same results to round-off. The default
    (``dense=None``) uses the dense tensor below
    :data:`~quadmodes.rom.structured_mass.NUMPY_BLOCKS_FROM` modes, where it is the cheaper.

    Formulation "Q4" (quartic manifold potential): the potential force is the average vector
    field ``∫₀¹ ∂V/∂s(s₀ + τ(s₁ − s₀)) dτ``, exact by Simpson's rule since ∂V/∂s is cubic:
    ``F1 + Λs½ + (n(s₀) + 4 n(s½) + n(s₁))/6`` with n = ∂V/∂s − Λs − F1. It is a discrete gradient,
    ``(s₁ − s₀)·F_V = V(s₁) − V(s₀)`` exactly, so the potential adds no energy error: the energy
    error is that of the kinetic terms, as for Q (bounded, O(Δt²), no drift).

    A system with a ``nonlinear_potential`` N(s) (not a polynomial: e.g. the condensed energy
    of a wrinkling membrane) uses the same Simpson average plus Gonzalez's correction along
    Δs = s₁ − s₀, ``F̄ += [V_nl(s₁) − V_nl(s₀) − F̄·Δs] Δs/|Δs|²``, so that the discrete
    gradient is exact again (``Δs·F̄ = V_nl(s₁) − V_nl(s₀)``); the chord Jacobian leaves the
    correction out (it is O(Δt⁴) where N is smooth).

    The implicit-step protocol of :class:`~quadmodes.rom.fixed_step.ImplicitStepper`
    (:meth:`begin`, :meth:`residual`, :meth:`advance`), hence a
    :class:`~quadmodes.rom.stepper.Stepper`; the whole loop has a compiled form
    (:mod:`quadmodes.rom.midpoint_kernel`, ``backend="numba"``)."""

    name = "midpoint"
    order = 2

    def __init__(self, sys: ReducedSystem, dt: float, dense: bool | None = None):
        self.n = n = sys.n_modes
        self.m3 = 3 + n
        self.dt = dt
        self.hdt = 0.5 * dt
        self.mass = mass_evaluation(sys, dense)
        self.LC = np.hstack([sys.Lam, sys.C])  # F_s contribution −[Λ C]·(s, ṡ)
        self.C, self.Lam, self.F1 = sys.C, sys.Lam, sys.F1
        self.hC = 0.5 * dt * sys.C
        self.z1 = np.ones(n + 1)  # z at t1 (z[0] = 1)
        self.zm = np.ones(n + 1)  # z at t½
        self.y_m = np.empty(2 * n)  # (s½, ṡ½)
        self.sys = sys
        self.quartic = sys.nonlinear  # Q4's tensors and/or a nonlinear potential
        self.exact_gradient = sys.nonlinear_potential is not None
        self._last = (None, None)  # (s₁, 𝕄(s₁)) of the last advance: the next begin's 𝕄(s₀)

    def momenta(self, x, s):
        """𝕄(s) ν (3+N,): (h, p_s) at ν = x, s."""
        z = self.z1
        z[1:] = s
        return self.mass.matrix(z) @ x

    def begin(self, x0, s0):
        """Per-step constants from the state at t0: ν₀, momenta, parts of s₁ and s½."""
        self.x0 = x0
        s_last, m_last = self._last
        # the driver passes back the s₁ of advance: its 𝕄 is known (bit for bit the same)
        mom0 = m_last @ x0 if s0 is s_last else self.momenta(x0, s0)
        self.s_base1 = s0 + self.hdt * x0[3:]  # s1 = s_base1 + ½Δt ṡ1
        self.s_basem = s0 + 0.25 * self.dt * x0[3:]  # s½ = s_basem + ¼Δt ṡ1
        self.h0 = mom0[:3]
        self.p0 = mom0[3:]
        if self.quartic:
            self.n0 = potential_nonlinear_force(self.sys, s0)
        if self.exact_gradient:
            self.s0 = s0.copy()
            self.v0 = potential_nonlinear_energy(self.sys, s0)

    def advance(self, x1):
        """(ν₁, s₁, rotation vector Δt ω½, dissipated energy Δt ṡ½ᵀCṡ½) of the converged step.

        ω₁ is first projected (one 3×3 solve) so that h(s₁, ω₁, ṡ₁) = exp(−Δt ω̂½) h₀ holds to
        round-off rather than to the Newton tolerance: |H| is then conserved to round-off."""
        s1 = self.s_base1 + self.hdt * x1[3:]
        z = self.z1
        z[1:] = s1
        m1 = self.mass.matrix(z)
        self._last = (s1, m1)
        phi = (0.5 * self.dt) * (self.x0[:3] + x1[:3])  # used for both h and q: R₁h₁ = R₀h₀
        target = rotate(-phi, self.h0)
        x1 = x1.copy()
        x1[:3] = np.linalg.solve(m1[:3, :3], target - m1[:3, 3:] @ x1[3:])
        sdm = 0.5 * (self.x0[3:] + x1[3:])
        return x1, s1, phi, self.dt * float(sdm @ self.C @ sdm)

    def residual(self, x, jac=False):
        """Residual (3+N,) and, if ``jac``, its Jacobian (3+N, 3+N) with respect to x."""
        n, dt, hdt = self.n, self.dt, self.hdt
        z1, zm = self.z1, self.zm
        sd1 = x[3:]
        z1[1:] = self.s_base1 + hdt * sd1
        m1 = self.mass.matrix(z1)
        r = m1 @ x
        numid = 0.5 * (self.x0 + x)
        rh0 = rotate(-dt * numid[:3], self.h0)  # exp(−Δt ω̂½) h0
        r[0] -= rh0[0]
        r[1] -= rh0[1]
        r[2] -= rh0[2]
        # modal balance p1 − p0 − Δt F_s(½)
        zm[1:] = self.s_basem + 0.25 * dt * sd1
        ym = self.y_m
        ym[:n] = zm[1:]
        ym[n:] = numid[3:]
        pm = self.mass.products(zm, numid)
        f = pm @ numid - self.LC @ ym - self.F1
        if self.quartic:  # average vector field of the cubic and quartic potential (Simpson)
            nl = potential_nonlinear_force
            fv = (self.n0 + 4.0 * nl(self.sys, zm[1:]) + nl(self.sys, z1[1:])) / 6.0
            if self.exact_gradient:
                fv = fv + self._gonzalez(fv, z1[1:])
            f -= fv
        r[3:] -= self.p0 + dt * f
        if not jac:
            return r
        return r, self._jacobian(x, m1, numid, rh0, pm)

    def _gonzalez(self, fv, s1):
        """Correction (N,) making the averaged nonlinear force ``fv`` an exact discrete gradient
        of the nonlinear potential between s₀ and ``s1``."""
        ds = s1 - self.s0
        dd = float(ds @ ds)
        if dd <= 1e-300:
            return np.zeros_like(fv)
        dv = potential_nonlinear_energy(self.sys, s1) - self.v0
        return ((dv - float(fv @ ds)) / dd) * ds

    def _jacobian(self, x, m1, numid, rh0, pm):
        """∂r/∂x (3+N, 3+N) from the intermediates of :meth:`residual` at the same x: 𝕄(s₁),
        ν½, exp(−Δt ω̂½) h₀ and P_E(z½, ν½)."""
        n, dt, hdt = self.n, self.dt, self.hdt
        z1, zm = self.z1, self.zm
        jm = m1.copy()
        p1 = self.mass.products(z1, x, energy=False)
        jm[:, 3:] += dt * p1.T  # ∂(𝕄(s1)ν1)/∂s1 · ∂s1/∂ṡ1
        jl = so3_left_jacobian(-dt * numid[:3])
        jm[:3, :3] -= hdt * (cross_matrix(*rh0) @ jl)
        w2 = self.mass.second(numid)  # ∂²T/∂s∂s
        jm[3:] -= dt * pm
        jm[3:, 3:] += self.hC - (0.25 * dt * dt) * (w2 - self.LC[:, :n])
        if self.quartic:  # ∂s½/∂ṡ₁ = ¼Δt, ∂s₁/∂ṡ₁ = ½Δt
            hm = potential_hessian(self.sys, zm[1:]) - self.Lam
            h1 = potential_hessian(self.sys, z1[1:]) - self.Lam
            jm[3:, 3:] += (dt * dt) * (hm / 6.0 + h1 / 12.0)
        return jm
