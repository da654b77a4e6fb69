"""One Lie-group implicit midpoint step of formulation "QM": the exact kinetic energy of the
quadratic manifold (:mod:`quadmodes.rom.manifold_kinetics`), formulation Q4's potential, the
damping C(s) on the manifold velocity. The step equations are those of
:class:`~quadmodes.rom.midpoint.MidpointStep` (momentum form, theory.md §7)::

    h(s₁, ν₁) = exp(−Δt ω̂½) h₀,   p(s₁, ν₁) − p₀ = Δt [∂T/∂s(s½, ν½) − F̄_V − C(s½) ṡ½]
    s₁ − s₀ = Δt ṡ½,   q₁ = q₀ ⊗ exp(Δt ω½ / 2),   ΔE_d = Δt ṡ½ᵀ C(s½) ṡ½

with (h, p) = 𝕄(s)ν, 𝕄 quartic in s (J), cubic (coupling) and quadratic (μ), and F̄_V Q4's
Simpson average of ∂V/∂s (an exact discrete gradient). As for Q: ω₁ is projected after
convergence so that R h is conserved to round-off. ∂T/∂s at the midpoint carries a Gonzalez
correction along Δs = s₁ − s₀ that makes it a discrete gradient of the kinetic energy in the
sense the energy balance needs: with (h₁ − h₀)·ω½ = 0 (a rotation about ω½) and
(p₁ − p₀)·ṡ½ = F·Δs/Δt, the identity ½(m₁·ν₁ − m₀·ν₀) = (m₁ − m₀)·ν½ − ½(m₁·ν₀ − m₀·ν₁)
(m = 𝕄ν, 𝕄 symmetric) gives E₁ + E_d,₁ = E₀ + E_d,₀ exactly when the kinetic force Ḡ satisfies
Ḡ·Δs = ½ν₀ᵀ(𝕄(s₁) − 𝕄(s₀))ν₁, and F̄_V is an exact discrete gradient of V. So E + E_d is
conserved to the Newton tolerance (the symmetric midpoint without it: O(Δt²), bounded; this
bound set the controlled step of a long QM path, docs/manifold-formulation.md).

Newton matrix: formulation Q's analytic Jacobian (the parent class's, whose mass evaluation is
Q4's = Q's kinetics) with its 𝕄_Q(s₁) replaced by the manifold 𝕄(s₁); the neglected part is
O(|s|) relative, so the chord iterations converge linearly at a small rate (first increment;
an exact Jacobian belongs with the compiled kernel, docs/manifold-formulation.md)."""

from __future__ import annotations

import numpy as np

from quadmodes.rom import manifold_kinetics as mk
from quadmodes.rom.dynamics import potential_nonlinear_force
from quadmodes.rom.midpoint import MidpointStep
from quadmodes.rom.system import ReducedSystem
from quadmodes.rotations import rotate


class ManifoldMidpointStep(MidpointStep):
    """The midpoint step of "QM" (module docstring) for ``sys`` (the model's Q4 or QM
    :class:`ReducedSystem`: potential, Newton weights, the Newton matrix's Q kinetics) and
    ``arrays`` (:class:`~quadmodes.rom.manifold_kinetics.ManifoldArrays`; default the QM
    system's ``manifold``), step ``dt`` (s). Made by
    :func:`quadmodes.rom.integrators.integrate` for a QM system and method "midpoint"."""

    name = "midpoint-QM"

    def __init__(self, sys: ReducedSystem, dt: float, arrays: mk.ManifoldArrays | None = None):
        if not sys.quartic:
            raise ValueError("formulation QM needs the Q4 system of the model (its V3, V4)")
        super().__init__(sys, dt)
        self.arrays = sys.manifold if arrays is None else arrays

    def momenta(self, x, s):
        """𝕄(s) ν (3+N,): (h, p) at ν = x."""
        return mk.mass_matrix(self.arrays, s) @ x

    def advance(self, x1):
        """(ν₁, s₁, Δt ω½, ΔE_d) of the converged step, ω₁ projected onto h₁ = exp(−Δt ω̂½) h₀."""
        ma = self.arrays
        s1 = self.s_base1 + self.hdt * x1[3:]
        m1 = mk.mass_matrix(ma, s1)
        self._last = (s1, m1)
        phi = (0.5 * self.dt) * (self.x0[:3] + x1[:3])
        x1 = x1.copy()
        target = np.asarray(rotate(-phi, self.h0))  # R₁h₁ = R₀h₀ to round-off
        x1[:3] = np.linalg.solve(m1[:3, :3], target - m1[:3, 3:] @ x1[3:])
        sdm = 0.5 * (self.x0[3:] + x1[3:])
        sm = self.s_basem + 0.25 * self.dt * x1[3:]
        c = mk.damping_matrix(ma, sm)
        return x1, s1, phi, self.dt * float(sdm @ c @ sdm)

    def _kinetic_discrete_gradient(self, x, sm, numid):
        """∂T/∂s(s½, ν½) (N,) corrected along Δs = s₁ − s₀ (Gonzalez) so that
        Ḡ·Δs = ½ ν₀ᵀ(𝕄(s₁) − 𝕄(s₀))ν₁ = ½(ν₀·𝕄(s₁)ν₁ − 𝕄(s₀)ν₀·ν₁), which makes the step's
        energy balance exact (module docstring), at ``x`` = ν₁; the difference of 𝕄 by
        :func:`~quadmodes.rom.manifold_kinetics.kinetic_difference` (no cancellation: the
        correction keeps a round-off error of order ε|v|² as Δs → 0). It is O(Δt²) for any Δs
        (the defect is linear in Δs) and symmetric in the step's two ends."""
        e = mk.tangents(self.arrays, sm)  # E(s½): one sweep for both
        g = mk.kinetic_gradient(self.arrays, sm, numid, e)
        ds = self.hdt * (self.x0[3:] + x[3:])  # s₁ − s₀ = Δt ṡ½
        dd = float(ds @ ds)
        if dd <= 1e-300:
            return g
        kinetic = 0.5 * mk.kinetic_difference(self.arrays, sm, ds, self.x0, x, e)
        return g + ((kinetic - float(g @ ds)) / dd) * ds

    def residual(self, x, jac=False):
        """Residual (3+N,) of the step equations and, if ``jac``, the chord Newton matrix."""
        ma, dt = self.arrays, self.dt
        s1 = self.s_base1 + self.hdt * x[3:]
        sm = self.s_basem + 0.25 * dt * x[3:]
        m1 = mk.mass_matrix(ma, s1)
        r = m1 @ x
        numid = 0.5 * (self.x0 + x)
        r[:3] -= np.asarray(rotate(-dt * numid[:3], self.h0))
        nl = potential_nonlinear_force
        fv = self.F1 + self.Lam @ sm + (self.n0 + 4.0 * nl(self.sys, sm) + nl(self.sys, s1)) / 6.0
        c = mk.damping_matrix(ma, sm)
        f = self._kinetic_discrete_gradient(x, sm, numid) - fv - c @ numid[3:]
        r[3:] -= self.p0 + dt * f
        if not jac:
            return r
        _, jq = MidpointStep.residual(self, x, jac=True)
        z = self.z1  # the parent's residual left z₁ = (1, s₁) there
        return r, jq + (m1 - self.mass.matrix(z))


def run_manifold(sys: ReducedSystem, arrays: mk.ManifoldArrays, y0: np.ndarray, dt: float,
                 n_steps: int, save_every: int = 1, newton_tol: float = 1e-12,
                 max_newton: int = 20):  # fmt: skip
    """Formulation "QM" from ``y0 = [q, ω, s, ṡ]`` (7+2N,) over ``n_steps`` steps of ``dt`` s
    (the numpy driver :func:`~quadmodes.rom.fixed_step.run_fixed`). Returns
    ``(t (K,), ys (K, 7+2N), E_d (K,) J)`` sampled every ``save_every`` steps; a step that
    fails raises RuntimeError with the driver's one-line message."""
    from quadmodes.rom.fixed_step import run_fixed

    save_idx = np.arange(0, n_steps + 1, save_every)
    y0 = np.asarray(y0, float).copy()
    y0[:4] /= np.linalg.norm(y0[:4])
    step = ManifoldMidpointStep(sys, dt, arrays)
    ys, ed, done, _, status, msg = run_fixed(step, sys, y0, n_steps, dt, save_idx, newton_tol,
                                             max_newton, 0.0, step.name)  # fmt: skip
    if status != 0:
        raise RuntimeError(msg)
    return save_idx[: len(ys)] * dt, ys, ed


def energy(sys: ReducedSystem, arrays: mk.ManifoldArrays, y: np.ndarray) -> float:
    """T + V (J) of a state ``y = [q, ω, s, ṡ]``: the manifold kinetic energy and Q4's potential."""
    from quadmodes.rom.dynamics import potential_energy

    n = sys.n_modes
    nu = np.concatenate([y[4:7], y[7 + n :]])
    kinetic = 0.5 * nu @ mk.mass_matrix(arrays, y[7 : 7 + n]) @ nu
    return float(kinetic + potential_energy(sys, y[None])[0])


def angular_momentum(arrays: mk.ManifoldArrays, y: np.ndarray) -> np.ndarray:
    """Inertial angular momentum R h (3,) kg m²/s of a state ``y = [q, ω, s, ṡ]``."""
    from quadmodes.rotations import rotation_matrix

    n = arrays.n_modes
    nu = np.concatenate([y[4:7], y[7 + n :]])
    h = (mk.mass_matrix(arrays, y[7 : 7 + n]) @ nu)[:3]
    return rotation_matrix(y[:4]) @ h
