"""The Newton matrix of a full-order step as GMRES on the current matrix, preconditioned by a
factorisation kept over many steps: for models whose stiff ties are too many to condense.

Why: on the flange-bonded ``paper-membrane`` (6,085 nodes) the end-body ties touch 1,896 free
DOFs (every node of the two bonded patches is tied to its end body), too many for the dense
Schur system of :mod:`~quadmodes.fullorder.condensed`, so the whole Newton matrix was kept, and
it goes stale within a few steps: besides the ties, the graded mesh's 1/16 in elements at the
patch rims are stiff on the step's scale (c Δt / L ≈ 100 against ≈ 6 for 1 in elements), so
their blocks change with every small motion of the iterate (the rigid rotation is already
taken out by the frame covariance; the end bodies turn by only 0.02° relative to the body frame
over 7 steps, and rotating their zones does not help). At 41 Hz the modified Newton needed 7.8
iterations and 0.55 factorisations per step. The error of a kept factorisation lies in a few
directions at a time, concentrated at the rim rings: GMRES on the current matrix,
right-preconditioned by the kept factorisation, reaches 1e-4 of the exact correction in about
four steps where the modified Newton contracts by 0.3–0.5 per iteration.

The operator ``A(z) v = M v + (Δt²/2) J(z₀, z₁) v`` is applied without assembling J (50–75
ms on this model against 0.7–1.2 ms for a step force): J v by the central difference of the
step force, a cubic polynomial of x₁ for SVK membranes and Green-strain bars, so the truncation
error is of order (ε/L)² for the smallest element; at ε = :data:`FD_STEP` × body size the
difference from the assembled matrix is 2e-10 relative on paper-membrane (1e-5 and 1e-7 are
worse). The gas-law terms are in that force. The equations, the step force and the stopping
test are those of the modified Newton: only the linear solve is more accurate.
"""

from __future__ import annotations

import numpy as np

import quadmodes.fullorder.renewal as renewal_module
from quadmodes.fullorder.kernels import StepOperators
from quadmodes.fullorder.renewal import RenewalPipeline
from quadmodes.fullorder.setup import FullOrderProblem
from quadmodes.linalg.krylov import gmres

#: Krylov steps per solve; a solve that does not reach its tolerance within them marks the
#: preconditioner stale (a factorisation costs about 25 such steps on paper-membrane).
KRYLOV_STEPS = 8
#: Renew the preconditioner before a step when the last step needed more Krylov steps than this
#: (a fresh one needs about 7 per step on paper-41hz, growing by about 0.75 per step of age; a
#: factorisation costs about 20 of them: renewing at 12 minimises the sum). The policy
#: ``"fixed"`` (before issue 27); ``"adaptive"`` renews by :data:`FACTOR_COST` instead.
KRYLOV_STEP_BUDGET = 12
#: Policy ``"adaptive"`` (issue 27): the cost of a renewal (assembly + float32 factorisation,
#: 165 ms on paper-41hz) in Krylov steps (a float32 solve and two step forces, about 5 ms). The
#: preconditioner is renewed before a step when the last step's Krylov steps exceed the mean
#: cost per step since the renewal, ``(FACTOR_COST + Σ kᵢ)/T``: the classic replacement rule
#: (renew when the marginal cost passes the average), the optimum for a cost that grows with
#: age. Counted in Krylov steps, not timed, so that a run repeats bit for bit.
FACTOR_COST = 30
#: Policy ``"adaptive"``: Krylov steps per solve before the preconditioner counts as stale (the
#: renewal is then left to :data:`FACTOR_COST`, unless one solve alone outgrows this).
KRYLOV_STEPS_ADAPTIVE = 20
#: Relative residual asked of GMRES: ``KRYLOV_SAFETY × Newton tolerance / estimated
#: correction``, clipped to [KRYLOV_RTOL_MIN, KRYLOV_RTOL_MAX] (Eisenstat–Walker-like: tight far
#: from convergence, one step when the correction is already at the tolerance).
KRYLOV_SAFETY = 0.1
KRYLOV_RTOL_MIN = 1e-4
KRYLOV_RTOL_MAX = 0.5
#: Central-difference step of J v, relative to the body size (m per unit max |v|).
FD_STEP = 1e-6
#: Policy ``"adaptive"``: J v by the forward difference from the step force at the current
#: iterate (computed once per :meth:`KrylovNewtonMatrix.update`), one step force per Krylov
#: step instead of two. Step relative to the body size: on paper-41hz the difference from the
#: central one is 5e-8–2e-7 of |J v| at 3e-9 (truncation ∝ step, round-off ∝ 1/step: 7e-7 at
#: 1e-7, 1e-6 at 1e-10), far below the GMRES tolerances (≥ 1e-4) it serves.
FD_STEP_FORWARD = 3e-9


class KrylovNewtonMatrix:
    """``A(z) = M + (Δt²/2) J(z₀, z₁)`` on the free DOFs at the body-frame pair of the last
    :meth:`update`, solved by GMRES (:func:`~quadmodes.linalg.krylov.gmres`) preconditioned by
    ``base``, a factorised Newton matrix at an earlier pair (``base.solve(rhs)``, e.g. a
    single-precision :class:`~quadmodes.fullorder.newton.NewtonMatrix`). ``stale`` is True after
    a solve that did not reach its tolerance within :data:`KRYLOV_STEPS` (the caller renews at
    the current iterate); ``worn`` when the last step (the solves since z₀ last changed) needed
    more than :data:`KRYLOV_STEP_BUDGET` Krylov steps (the caller renews at the next step).
    policy: ``"adaptive"`` (:data:`FACTOR_COST`, :data:`KRYLOV_STEPS_ADAPTIVE`) or ``"fixed"``
    (:data:`KRYLOV_STEP_BUDGET`, :data:`KRYLOV_STEPS`; the rule before issue 27). renewal: a
    :class:`~quadmodes.fullorder.renewal.RenewalPipeline` that swaps in a renewed ``base`` at
    the start of a step on its own schedule (then never ``worn``); None: renewed by the
    caller."""

    def __init__(self, problem: FullOrderProblem, ops: StepOperators, base,
                 policy: str = "adaptive", renewal: RenewalPipeline | None = None):  # fmt: skip
        self.problem, self.ops, self.base = problem, ops, base
        self.renewal = renewal
        self._renewals_counted = 0
        self.weight = 0.5 * problem.h * problem.h
        self.adaptive = policy == "adaptive"
        self.stale = False
        self.krylov_steps = 0  # Krylov steps (preconditioner solves) made, for the statistics
        self._this_step = 0  # the same since z₀ last changed
        self._steps_before = self._krylov_before = 0  # completed steps and their Krylov steps
        self._z0 = self._start = self._z1 = self._f1 = None

    @property
    def worn(self) -> bool:
        """Renew before the next step: the last step's Krylov steps exceed the mean cost per
        step since the renewal (:data:`FACTOR_COST`; ``"fixed"``: :data:`KRYLOV_STEP_BUDGET`).
        Never with a renewal pipeline (it renews on its own schedule)."""
        if self.renewal is not None:
            return False
        if not self.adaptive:
            return self._this_step > KRYLOV_STEP_BUDGET
        return self._past_average(FACTOR_COST)

    def _past_average(self, cost: float) -> bool:
        """The last step's Krylov steps exceed the mean per step since the renewal, the
        renewal counted as ``cost`` Krylov steps."""
        total = cost + self._krylov_before + self._this_step
        return self._this_step * (self._steps_before + 1) > total

    def update(self, z0: np.ndarray, z1: np.ndarray) -> None:
        """Take the operator at the body-frame pair (z0, z1) (n,3) (the start data of the step
        force recomputed only when z0 changed)."""
        if self._z0 is None or not np.array_equal(z0, self._z0):
            cost = renewal_module.RENEWAL_COST  # launch a renewal by the last step's count
            wanted = cost is None or self._past_average(cost)
            if self._z0 is not None:  # a step done: its Krylov steps go into the mean
                self._steps_before += 1
                self._krylov_before += self._this_step
            self._z0 = np.array(z0, float)
            self._start = self.ops.start(self._z0)
            self._this_step = 0
            if self.renewal is not None:
                self._next_step_renewal(z0, z1, wanted)
        self._z1 = np.array(z1, float)
        self._f1 = self.ops.step_force(self._start, self._z1) if self.adaptive else None

    def _next_step_renewal(self, z0: np.ndarray, z1: np.ndarray, wanted: bool) -> None:
        """At the start of a step: swap in the pipeline's renewal due now (the mean cost then
        counts from here), launch the next if ``wanted`` (always, or by
        :data:`~quadmodes.fullorder.renewal.RENEWAL_COST`)."""
        due = self.renewal.step(z0, z1, wanted)
        if due is not None:
            self.base = due
            self._steps_before = self._krylov_before = 0

    def take_renewals(self) -> int:
        """Renewals launched by the pipeline since the last call (for the statistics)."""
        launched = self.renewal.launched if self.renewal is not None else 0
        new, self._renewals_counted = launched - self._renewals_counted, launched
        return new

    def apply(self, v: np.ndarray) -> np.ndarray:
        """``A(z) v`` (n_free,) for v on the free DOFs (body frame)."""
        p = self.problem
        u = np.zeros(3 * p.n)
        u[p.free] = v
        u = u.reshape(p.n, 3)
        size = float(np.max(np.abs(u)))
        if size == 0.0:
            return np.zeros_like(v)
        f = self.ops.step_force
        if self._f1 is not None:  # forward difference from the iterate's step force
            eps = FD_STEP_FORWARD * p.scale / size
            jv = (f(self._start, self._z1 + eps * u) - self._f1) / eps
        else:
            eps = FD_STEP * p.scale / size
            jv = (f(self._start, self._z1 + eps * u) - f(self._start, self._z1 - eps * u)) / (2 * eps)
        return (p.ms @ u + self.weight * jv).ravel()[p.free]

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``A(z)⁻¹ rhs`` (n_free,) to the relative residual that the Newton tolerance needs for
        the correction ``(Δt²/2) A⁻¹ rhs`` (m)."""
        first = self.base.solve(rhs)
        estimate = self.weight * float(np.max(np.abs(first)))
        rtol = KRYLOV_SAFETY * self.problem.tol / max(estimate, 1e-300)
        rtol = min(max(rtol, KRYLOV_RTOL_MIN), KRYLOV_RTOL_MAX)
        cap = KRYLOV_STEPS_ADAPTIVE if self.adaptive else KRYLOV_STEPS
        res = gmres(self.apply, self.base.solve, rhs, rtol, cap, first=first)
        self.krylov_steps += res.iterations
        self._this_step += res.iterations
        self.stale = not res.converged
        return res.x
