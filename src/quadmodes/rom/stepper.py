"""The stepper contract of :func:`quadmodes.rom.integrators.integrate`: what a fixed-step method
of the reduced free-body equations provides. This is the extension point for a new reduced
integrator: write one class satisfying :class:`Stepper` and pass it as ``integrate(...,
method=TheClass)`` (or register it by name in :data:`quadmodes.rom.integrators.STEPPERS`).

Contract
--------
A stepper is made per run by its factory, ``factory(sys, dt)`` (the class itself, or any
callable such as ``functools.partial(TheClass, option=…)``) with the
:class:`~quadmodes.rom.system.ReducedSystem` ``sys`` and the step ``dt`` (s) actually used
(``span / ceil(span / dt)``). It has

``name: str``
    the label of :attr:`Solution.method <quadmodes.rom.solution.Solution>` and of failure
    messages.
``order: int``
    its order of accuracy p (the global error is O(Δt^p) for smooth solutions); documentation
    and tests (the built-ins: midpoint 2, backward Euler 1).
``step(ν₀, s₀, ν₋₁, newton) -> StepResult``
    one step from the state at t₀: ``ν₀ = (ω₀, ṡ₀)`` (3+N,) rad/s and modal velocities,
    ``s₀`` (N,) modal coordinates, ``ν₋₁`` the ν of the step before (ν₀ at the first step: a
    predictor may extrapolate), ``newton`` the :class:`NewtonControl` of the run (an implicit
    method's tolerance, iteration budget and update weights; an explicit one ignores it).
    Returns a :class:`StepResult`: ν₁, s₁, the rotation vector φ (3,) rad of the step (the
    driver updates the attitude as ``q₁ = q₀ ⊗ exp(φ/2)``, q the body-to-inertial quaternion),
    the energy ΔE_d (J) the scheme dissipates in the step (its discrete ``∫ṡᵀCṡ dt``), the
    work counters of the step, and ``failure`` (None on success).

The attitude does not enter the free-body equations of ν and s (no external load), so the
step needs no q. The driver (:func:`quadmodes.rom.fixed_step.run_fixed`) does the bookkeeping,
sampling and failure reporting and sums the counters into ``Solution.stats``: ``n_steps``
(accepted steps), ``n_rhs`` (evaluations of the right-hand side, or of the step residual for
implicit methods), ``n_newton`` (Newton iterations), ``n_jac`` (Jacobian evaluations).

Implicit one-step methods need not write ``step``: subclass
:class:`quadmodes.rom.fixed_step.ImplicitStepper` and provide ``begin``, ``residual`` and
``advance`` (the predictor and chord Newton are shared).
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np


class NewtonControl(NamedTuple):
    """Newton settings of a run: tolerance ``tol`` (relative, energy-weighted), at most
    ``max_iter`` iterations per step, weights ``√diag(J0, μ)`` (3+N,) of the update's max-norm
    and ``Λ`` (N, N) for the energy scale of the state (:func:`~quadmodes.rom.fixed_step.state_scale`)."""

    tol: float
    max_iter: int
    weights: np.ndarray
    lam: np.ndarray


class StepResult(NamedTuple):
    """Outcome of :meth:`Stepper.step`.

    nu: ν₁ (3+N,); s: s₁ (N,); phi: rotation vector of the step (3,) rad (``q₁ = q₀ ⊗
    exp(φ/2)``); dissipated: ΔE_d (J). n_rhs, n_newton, n_jac: the step's work counters.
    failure: None (accepted), ``"newton"`` (Newton did not converge within the budget;
    ``error`` the last relative update) or ``"diverged"`` (singular Newton matrix or a
    non-finite iterate); on failure nu, s, phi may be None."""

    nu: np.ndarray | None
    s: np.ndarray | None
    phi: np.ndarray | None
    dissipated: float
    n_rhs: int
    n_newton: int
    n_jac: int
    failure: str | None = None
    error: float = 0.0


@runtime_checkable
class Stepper(Protocol):
    """A fixed-step method of the reduced free-body equations (module docstring); made per run
    by ``factory(sys, dt)``."""

    name: str
    order: int

    def step(
        self, nu0: np.ndarray, s0: np.ndarray, nu_prev: np.ndarray, newton: NewtonControl
    ) -> StepResult: ...
