"""Time integration of the reduced equations (:mod:`quadmodes.rom.dynamics`): one interface,
the entry point :func:`integrate` and its choice of backend.

Where things are: the methods (one step each) in :mod:`quadmodes.rom.midpoint` and
:mod:`quadmodes.rom.backward_euler`, their numpy driver (Newton, bookkeeping, failures) in
:mod:`quadmodes.rom.fixed_step`, the compiled midpoint loop in
:mod:`quadmodes.rom.midpoint_kernel`, the scipy solvers in :mod:`quadmodes.rom.adaptive`, the
output policy in :mod:`quadmodes.rom.sampling` and the result in :mod:`quadmodes.rom.solution`.

Contract
--------
``integrate(system, y0, t_span, method="midpoint", dt=None, rtol=1e-9, atol=1e-12,
save_every=1, t_eval=None, solver="DOP853", newton_tol=1e-13, max_newton=25,
backend="auto") -> Solution``

* ``system``: a :class:`~quadmodes.rom.system.ReducedSystem` (a ReducedModel is converted with
  formulation "Q"). ``y0`` (7+2N,) = ``[q, ω, s, ṡ]``; q is normalised first.
* ``method``: the name of a built-in fixed-step method (:data:`STEPPERS`: "midpoint",
  "backward-euler"), "adaptive" (or a scipy solver's name), or a stepper factory: a class
  satisfying :class:`~quadmodes.rom.stepper.Stepper` (the written contract: what a stepper
  receives, returns, its work counters and order), or any callable ``(sys, dt) -> Stepper``.
  Each fixed step is the stepper's ``step``; the driver
  (:func:`~quadmodes.rom.fixed_step.run_fixed`) does the bookkeeping, the sampling and the
  failure handling. The built-in implicit methods derive from
  :class:`~quadmodes.rom.fixed_step.ImplicitStepper` (``begin``, ``residual``, ``advance``;
  predictor and chord Newton shared) and report as dissipated energy their discrete balance
  (midpoint: ``Δt ṡ½ᵀCṡ½``, exact for the quadratic part; backward Euler: ``Δt ṡ₁ᵀCṡ₁``).
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
  whole midpoint loop in one compiled call (:mod:`quadmodes.rom.midpoint_kernel`, numba, a core
  dependency; 20–30× faster for N = 5; same equations and convergence test, results equal to
  round-off; formulation "QM" has its own loop, :mod:`quadmodes.rom.manifold_kernel`);
  ``"auto"`` (default) uses numba for the midpoint (the built-in
  :class:`~quadmodes.rom.midpoint.MidpointStep`, or QM's) when numba is importable, numpy otherwise (backward Euler, the adaptive solvers and
  other steppers are numpy only). ``"numba"`` without numba, or with another method, raises
  ``ValueError``.

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

import time
from collections.abc import Callable

import numpy as np

from quadmodes.rom.adaptive import ADAPTIVE_SOLVERS, run_adaptive
from quadmodes.rom.backward_euler import BackwardEulerStep
from quadmodes.rom.fixed_step import run_fixed
from quadmodes.rom.midpoint import MidpointStep
from quadmodes.rom.sampling import adaptive_times, fixed_grid, fixed_times
from quadmodes.rom.solution import Solution
from quadmodes.rom.stepper import Stepper
from quadmodes.rom.system import ReducedSystem, reduced_system

#: The built-in fixed-step methods: name → stepper factory (``factory(sys, dt)``; the
#: :class:`~quadmodes.rom.stepper.Stepper` contract). A new method registered here is available
#: by name to ``integrate`` (and to everything that passes a method name through).
STEPPERS: dict[str, Callable[..., Stepper]] = {
    MidpointStep.name: MidpointStep,
    BackwardEulerStep.name: BackwardEulerStep,
}
METHODS = (*STEPPERS, "adaptive")
BACKENDS = ("auto", "numpy", "numba")

_KERNEL: list = []  # [module or None] once looked up: the import is tried once per process


def numba_kernel():
    """:mod:`quadmodes.rom.midpoint_kernel` if numba is importable, else None (looked up once)."""
    if not _KERNEL:
        try:
            from quadmodes.rom import midpoint_kernel
        except ImportError:  # numba cannot be imported on this platform: numpy steppers
            midpoint_kernel = None
        _KERNEL.append(midpoint_kernel)
    return _KERNEL[0]


def _select_backend(backend: str, method: str, sys: ReducedSystem | None = None,
                    compiled: bool | None = None):  # fmt: skip
    """The compiled kernel module to use, or None for the numpy steppers (every formulation,
    "Q4" included, runs on both; a system with a ``nonlinear_potential``, a Python object, on
    the numpy steppers only). ``compiled``: the method has the compiled midpoint loop (default:
    ``method == "midpoint"``)."""
    compiled = method == "midpoint" if compiled is None else compiled
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {BACKENDS}")
    general = sys is not None and sys.nonlinear_potential is not None
    if backend == "numba" and general:
        raise ValueError('backend "numba" cannot evaluate a nonlinear potential; use "numpy"')
    if sys is not None and sys.manifold is not None:  # formulation "QM": its own kernel
        return _manifold_backend(backend, method, compiled)
    if backend == "numpy" or general:
        return None
    if backend == "numba" and not compiled:
        raise ValueError(f'backend "numba" supports method "midpoint" only, not {method!r}')
    kernel = numba_kernel() if compiled else None
    if backend == "numba" and kernel is None:
        raise ValueError(
            'backend "numba" needs numba, which cannot be imported here (a core dependency: '
            'reinstall quadmodes, or use backend "numpy")'
        )
    return kernel


def _manifold_backend(backend: str, method: str, compiled: bool):
    """The compiled loop of formulation "QM" (:mod:`quadmodes.rom.manifold_kernel`) for its
    midpoint with backend "numba" or "auto" (numba importable), else None (numpy step)."""
    if backend == "numpy":
        return None
    if not compiled:
        if backend == "numba":
            raise ValueError(f'backend "numba" supports method "midpoint" only, not {method!r}')
        return None
    if numba_kernel() is None:
        if backend == "numba":
            raise ValueError('backend "numba" needs numba, which cannot be imported here; '
                             'use backend "numpy"')  # fmt: skip
        return None
    from quadmodes.rom import manifold_kernel

    return manifold_kernel


def _integrate_fixed(sys, y0, t_span, factory, dt, save_every, t_eval, newton, kernel):
    """(t, ys, dissipated, stats, status, message, step, name) of a fixed-step method made by
    ``factory(sys, h)``; ``newton`` = (newton_tol, max_newton); ``kernel`` the compiled module
    or None (the stepper's ``step`` from Python)."""
    n_steps, h, idx = fixed_grid(t_span, dt, save_every, t_eval)
    t0 = float(t_span[0])
    if kernel is not None:  # whole loop compiled (midpoint only)
        name = getattr(kernel, "NAME", "midpoint")
        y, ed, done, stats, status, msg = kernel.fixed_run(
            sys, y0, n_steps, h, idx, *newton, t0, name
        )
    else:
        stepper = factory(sys, h)
        if not isinstance(stepper, Stepper):
            raise TypeError(f"method {factory!r} did not make a Stepper (name, order, step)")
        name = stepper.name
        y, ed, done, stats, status, msg = run_fixed(
            stepper, sys, y0, n_steps, h, idx, *newton, t0, name
        )
    t = fixed_times(t0, h, idx, len(y), status, done)
    return t, y, ed, stats, status, msg, h, name


def _resolve_method(method, solver: str):
    """``(name, factory, solver, compiled)`` of ``method``: a built-in name (factory None for
    "adaptive"), a scipy solver's name, or a stepper factory; ``compiled``: the built-in
    midpoint, whose whole loop has a compiled form (a subclass runs its own Python step)."""
    if not isinstance(method, str):
        if not callable(method):
            raise ValueError(f"method must be a name in {METHODS} or a stepper class, not {method!r}")
        name = getattr(method, "name", None) or getattr(method, "__name__", repr(method))
        return str(name), method, solver, method is MidpointStep
    if method in ADAPTIVE_SOLVERS:
        method, solver = "adaptive", method
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {METHODS}")
    factory = STEPPERS.get(method)
    return method, factory, solver, factory is MidpointStep


def _manifold_factory(method: str, factory):
    """The step of formulation "QM" for ``method``: its own midpoint
    (:class:`~quadmodes.rom.manifold_midpoint.ManifoldMidpointStep`), or a user's stepper."""
    from quadmodes.rom.manifold_midpoint import ManifoldMidpointStep

    if factory is MidpointStep:
        return ManifoldMidpointStep
    if method in STEPPERS or method == "adaptive":
        raise ValueError(f'formulation "QM" is integrated by method "midpoint" only, not {method!r}')
    return factory


def integrate(
    system,
    y0,
    t_span,
    method: str | Callable[..., Stepper] = "midpoint",
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

    See the module docstring for the contract (``method``: a name or a stepper class,
    :class:`~quadmodes.rom.stepper.Stepper`; ``backend``: "auto", "numpy" or "numba").
    Returns a :class:`~quadmodes.rom.solution.Solution`."""
    sys = system if isinstance(system, ReducedSystem) else reduced_system(system, "Q")
    y0 = np.array(y0, float)
    if y0.shape != (sys.n_state,):
        raise ValueError(f"y0 must have shape ({sys.n_state},), got {y0.shape}")
    y0[0:4] /= np.linalg.norm(y0[0:4])
    method, factory, solver, compiled = _resolve_method(method, solver)
    if sys.manifold is not None:
        factory = _manifold_factory(method, factory)
    kernel = _select_backend(backend, method, sys, compiled)
    start = time.perf_counter()
    if method == "adaptive":
        if solver not in ADAPTIVE_SOLVERS:
            raise ValueError(f"unknown adaptive solver {solver!r}")
        save = max(1, int(save_every))
        te = adaptive_times(t_span, dt, save_every, t_eval)
        t, y, ed, stats, status, msg = run_adaptive(
            sys, y0, tuple(map(float, t_span)), solver, rtol, atol, te, save
        )
        step, name = None, f"adaptive/{solver}"
    else:
        t, y, ed, stats, status, msg, step, name = _integrate_fixed(
            sys, y0, t_span, factory, dt, save_every, t_eval, (newton_tol, max_newton), kernel
        )
    stats["wall_s"] = time.perf_counter() - start
    stats["backend"] = "numpy" if kernel is None else "numba"
    return Solution(t, y, name, stats, status, msg, ed, step)
