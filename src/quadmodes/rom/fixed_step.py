"""The numpy driver of the fixed-step methods (the :class:`~quadmodes.rom.stepper.Stepper`
contract: :mod:`quadmodes.rom.midpoint`, :mod:`quadmodes.rom.backward_euler`, or a user's
class): bookkeeping, sampling and failure handling (:func:`run_fixed`), and the base class of
the implicit one-step methods with their predictor and chord Newton (:class:`ImplicitStepper`).
The compiled midpoint kernel (:mod:`quadmodes.rom.midpoint_kernel`) follows the same contract
and shares the convergence weights and the failure messages defined here.

Implicit-step protocol (what an :class:`ImplicitStepper` subclass provides, with the unknowns
``ν₁ = (ω₁, ṡ₁)``; s₁ is an explicit linear function of ṡ₁ and is eliminated):

* ``begin(ν₀, s₀)``: per-step constants from the state at t0;
* ``residual(ν₁, jac=False)``: the residual r (3+N,) of the step equations, or ``(r, ∂r/∂ν₁)``;
* ``advance(ν₁) -> (ν₁, s₁, φ, ΔE_d)``: the converged step, with the attitude update
  ``q₁ = q₀ ⊗ exp(φ/2)`` (φ the rotation vector of the step, rad) and the energy (J) the scheme
  dissipates in the step.

Newton: analytic Jacobian once per step at the predictor (linear extrapolation of ν), then
chord iterations until the energy-weighted update, or the remaining error estimated from the
contraction rate, is below ``newton_tol`` (relative).
"""

from __future__ import annotations

import math

import numpy as np

from quadmodes.rom.solution import work_counters
from quadmodes.rom.stepper import NewtonControl, StepResult
from quadmodes.rom.system import ReducedSystem
from quadmodes.rotations import quat_step


def newton_weights(sys: ReducedSystem) -> np.ndarray:
    """Weights √diag(J0, μ) (3+N,) of the energy-weighted max-norm of the Newton updates."""
    return np.concatenate([np.sqrt(np.diag(sys.J0)), np.sqrt(np.diag(sys.mu))])


def state_scale(x, xg, s, wt, lam):
    """Energy-like scale (√J) of the Newton unknowns, for relative convergence tests:
    max|ν₀ w| + max|ν_pred w| + √|sᵀΛs|."""
    v = float(s @ lam @ s) if len(s) else 0.0
    return float(np.abs(x * wt).max() + np.abs(xg * wt).max()) + math.sqrt(abs(v)) + 1e-300


def chord_newton(residual, xg, r, jinv, wt, scale, tol, max_iter):
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


def failure_message(name: str, step: int, t: float, its: int | None = None, err: float = 0.0):
    """One-line message of a failed step ``step`` at time ``t`` (s): Newton not converging
    after ``its`` iterations (relative update ``err``), or, with ``its`` None, a singular Newton
    matrix or non-finite iterate."""
    if its is None:
        return (
            f"{name}: Newton failed at step {step} (t = {t:.6g} s): singular or "
            "non-finite iterate; reduce dt"
        )
    return (
        f"{name}: Newton did not converge at step {step} (t = {t:.6g} s) "
        f"after {its} iterations (relative update {err:.2e})"
    )


class ImplicitStepper:
    """Base of the implicit one-step methods (module docstring): :meth:`step` of the
    :class:`~quadmodes.rom.stepper.Stepper` contract from the subclass's ``begin``,
    ``residual`` and ``advance``: the predictor ``2ν₀ − ν₋₁``, the analytic Jacobian there,
    chord Newton (:func:`chord_newton`). Subclasses set ``name`` and ``order`` and are made by
    ``cls(sys, dt)``."""

    name = ""
    order = 0

    def step(self, nu0, s0, nu_prev, newton: NewtonControl) -> StepResult:
        """One step from (ν₀, s₀) (the stepper contract); a singular Newton matrix or an iterate
        that left the reals is a ``"diverged"`` failure, no convergence a ``"newton"`` one."""
        self.begin(nu0, s0)
        xg = 2.0 * nu0 - nu_prev  # linear extrapolation predictor
        scale = state_scale(nu0, xg, s0, newton.weights, newton.lam)
        n_jac = 0
        try:
            r, jm = self.residual(xg, jac=True)
            jinv = np.linalg.inv(jm)
            n_jac = 1
            (ok, xg, its), err = chord_newton(
                self.residual, xg, r, jinv, newton.weights, scale, newton.tol, newton.max_iter
            )
        except (np.linalg.LinAlgError, ValueError, OverflowError):
            # a singular Newton matrix, or an iterate that left the reals (math domain error)
            return StepResult(None, None, None, 0.0, 0, 0, n_jac, "diverged")
        if not ok:
            return StepResult(None, None, None, 0.0, its, its, n_jac, "newton", err)
        nu1, s1, phi, ded = self.advance(xg)
        return StepResult(nu1, s1, phi, ded, its, its, n_jac)


class _Samples:
    """Sample buffer of a fixed-step run: rows ``[q, ω, s, ṡ]`` (7+2N) and E_d (J) at the step
    indices ``save_idx`` (increasing, starting at 0, whose row is ``y0``)."""

    def __init__(self, y0, save_idx):
        self.out = np.empty((len(save_idx), len(y0)))
        self.ed = np.empty(len(save_idx))
        self.out[0] = y0
        self.ed[0] = 0.0
        self.idx = save_idx
        self.k = 1
        self.next_step = save_idx[1] if len(save_idx) > 1 else -1

    def store(self, q, x, s, e_d):
        """Write the state at step ``next_step`` (q (4,), ν (3+N,), s (N,), E_d)."""
        n, row = len(s), self.out[self.k]
        row[0:4] = q
        row[4:7] = x[:3]
        row[7 : 7 + n] = s
        row[7 + n :] = x[3:]
        self.ed[self.k] = e_d
        self.k += 1
        self.next_step = self.idx[self.k] if self.k < len(self.idx) else -1

    def result(self, failed, q, x, s, e_d):
        """(ys, dissipated) saved so far; after a failure plus the last accepted state."""
        out, ed = self.out[: self.k], self.ed[: self.k]
        if failed:
            out = np.vstack([out, np.concatenate([q, x[:3], s, x[3:]])])
            ed = np.append(ed, e_d)
        return out, ed


def run_fixed(stepper, sys, y0, n_steps, dt, save_idx, newton_tol, max_newton, t0, name):
    """Drive ``stepper`` (the :class:`~quadmodes.rom.stepper.Stepper` contract) for
    ``n_steps`` steps of ``dt`` (s) from ``y0`` (7+2N,), q normalised; ``name`` labels failure
    messages. Returns (ys (K, 7+2N), dissipated (K,), steps done, stats, status, message)."""
    n = sys.n_modes
    newton = NewtonControl(newton_tol, max_newton, newton_weights(sys), sys.Lam)
    q = y0[0:4].copy()
    s = y0[7 : 7 + n].copy()
    x = y0[np.r_[4:7, 7 + n : 7 + 2 * n]]  # ν = (ω, ṡ)
    x_prev = x
    samples = _Samples(y0, save_idx)
    e_d = 0.0
    n_rhs = n_newton = n_jac = 0
    status, msg = 0, "ok"
    step = stepper.step
    i = 0
    for i in range(1, n_steps + 1):
        res = step(x, s, x_prev, newton)
        n_rhs, n_newton, n_jac = n_rhs + res.n_rhs, n_newton + res.n_newton, n_jac + res.n_jac
        if res.failure is not None:
            its = res.n_newton if res.failure == "newton" else None
            status, msg = 1, failure_message(name, i, t0 + i * dt, its, res.error)
            break
        e_d += res.dissipated
        q = quat_step(q, res.phi)
        x_prev = x
        x, s = res.nu, res.s
        if i == samples.next_step:
            samples.store(q, x, s, e_d)
    steps_done = i if status == 0 else i - 1
    out, ed_out = samples.result(status != 0, q, x, s, e_d)
    stats = work_counters(steps_done, n_rhs, n_newton, n_jac)
    return out, ed_out, steps_done, stats, status, msg
