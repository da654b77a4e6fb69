"""Modified Newton for one full-order step: the step Jacobian, the factorised Newton matrix
(reused across iterations and steps through the frame covariance), backtracking and the
convergence test.

Iterations ``δx = −(Δt²/2) A⁻¹ r``, ``A = M + (Δt²/2) ∂f_step/∂x₁`` on the free DOFs (+ gas-law
rank-one terms by Sherman–Morrison; the rank-N damping term is left out of A). Converged when
the largest correction is below the problem's tolerance (``newton_tol × body size``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import quadmodes.fullorder.renewal as renewal_module
from quadmodes.errors import QuadmodesError
from quadmodes.fe.assembly import assemble_matrix
from quadmodes.fe.model import Structure, tangent_low_rank, tangent_stiffness
from quadmodes.fullorder.condensed import CondensedNewtonMatrix, TieSplit
from quadmodes.fullorder.kernels import StepOperators
from quadmodes.fullorder.krylov import KrylovNewtonMatrix
from quadmodes.fullorder.preconditioner import PermutedNewtonAssembly, low_rank_terms
from quadmodes.fullorder.setup import FullOrderProblem
from quadmodes.linalg.factor import factorize

#: Refactor when successive Newton corrections shrink by less than this factor.
RHO_REFACTOR = 0.5
#: The same for the soft part of a condensed matrix (its ties are renewed at every iteration,
#: so what is left grows slowly with the age of the soft part: on paper-41hz the contraction
#: goes from 0.02 to 0.07 over 20 steps; renewing at 0.1 saves a Newton iteration per step).
RHO_SOFT = 0.1
#: Condense the ties only when they touch at most this many free DOFs (their Schur system is
#: dense and refactorised at every iteration; the paper models have 75 and 123).
MAX_TIE_DOFS = 600

#: With more tie DOFs than :data:`MAX_TIE_DOFS`: GMRES on the current matrix preconditioned
#: by a kept factorisation (:class:`~quadmodes.fullorder.krylov.KrylovNewtonMatrix`); False:
#: the kept factorisation alone (the modified Newton before session 7; on paper-membrane
#: 1.15–1.5× more CPU time at 41 Hz, about even at 20 Hz, where it goes stale more slowly;
#: docs/performance.md).
KRYLOV_MANY_TIES = True

#: Backtrack on the incremental potential when a Newton correction exceeds this (relative).
LINE_SEARCH = 1e-5

#: Policy ``"adaptive"`` (issue 27): also converged when the error left after the last
#: correction, estimated from the observed contraction θ = ‖δxₖ‖/‖δxₖ₋₁‖ of this matrix as
#: ``θ/(1 − θ) ‖δxₖ‖`` (the stopping test of simplified Newton, Hairer & Wanner IV.8), is at
#: most this fraction of the tolerance. The plain test (‖δxₖ‖ ≤ tol) leaves an error of about
#: θ tol behind; this one at most RATE_STOP × tol, and it spares the last iteration whose only
#: use was to show a correction below the tolerance (on paper-41hz the corrections run
#: 5e-6, 3e-8, 5e-11, 3e-13 of the body size: θ ≈ 2e-3 is set by the damping, which the
#: Newton matrix leaves out).
RATE_STOP = 0.1
#: The Newton policies: ``"adaptive"`` (the default since issue 27: :data:`RATE_STOP`, and the
#: Krylov preconditioner renewed by cost, :data:`~quadmodes.fullorder.krylov.FACTOR_COST`) and
#: ``"fixed"`` (before: converged on ‖δx‖ ≤ tol, renewal by a fixed Krylov-step budget).
POLICIES = ("adaptive", "fixed")


class FullOrderNewtonError(QuadmodesError, RuntimeError):
    """Newton did not converge in a full-order step; the message is one line."""

    def __init__(self, step: int, time: float, residual: float, checkpoint: Path | None = None,
                 cause: str = ""):  # fmt: skip
        """cause: one clause saying why, when known (e.g. the membrane's loss of tension,
        :func:`quadmodes.structure.membrane_tension.loss_of_tension`)."""
        self.step, self.time, self.residual, self.checkpoint = step, time, residual, checkpoint
        self.cause = cause
        kept = f"checkpoint kept at {checkpoint}" if checkpoint else "no checkpoint"
        why = f"; {cause}" if cause else ""
        super().__init__(
            f"full-order Newton did not converge at step {step}, t = {time:.6g} s, residual "
            f"{residual:.2e} (relative correction){why}; {kept}"
        )


# ---------------------------------------------------------------------------------------------
# Newton matrix
# ---------------------------------------------------------------------------------------------


def _membrane_block(e, x0: np.ndarray, x1: np.ndarray, xh: np.ndarray) -> np.ndarray:
    """The Jacobian blocks of a membrane set (``e.step_block``; kept for the tests' old name,
    ``xh`` unused)."""
    return e.step_block(x0, x1)


def step_jacobian(structure: Structure, x0: np.ndarray, x1: np.ndarray, energy_momentum: bool):
    """``∂f_step/∂x₁`` (3n,3n) sparse (N/m) of
    :func:`~quadmodes.fullorder.step.step_force` (or of ``f(x½)``: ½K(x½)) and its rank-one
    gas-law terms ``[(c, v)]``: every element set's ``step_block``
    (:class:`~quadmodes.fe.elements.ElementSet`). The energy–momentum blocks are not symmetric:
    ``½[K_geo(S̄) + B(x½)ᵀ D B(x₁)]`` for membranes, likewise for bars."""
    xh = 0.5 * (x0 + x1)
    low = [(0.5 * c, v) for c, v in tangent_low_rank(structure, xh)]
    if not energy_momentum:
        return 0.5 * tangent_stiffness(structure, xh), low
    mats = [assemble_matrix(e.conn, e.step_block(x0, x1), structure.n)
            for e in structure.elements]  # fmt: skip
    out = mats[0]
    for m in mats[1:]:
        out = out + m
    return out.tocsr(), low


class NewtonMatrix:
    """Sparse factorisation of ``A = M + (Δt²/2) J`` on the free DOFs, J = ∂f_step/∂x₁ at a
    body-frame pair (z₀, z₁) (:func:`step_jacobian`), with its gas-law rank-one terms.

    Frame covariance ``J(𝒬z₀, 𝒬z₁) = 𝒬 J(z₀, z₁) 𝒬ᵀ`` (𝒬 = I ⊗ Q; M commutes with 𝒬) lets one
    factorisation serve later steps whose body-frame pair is close to (z₀, z₁):
    ``A⁻¹ r ≈ 𝒬 A(z)⁻¹ 𝒬ᵀ r`` with Q the current frame, whatever the rigid rotation since."""

    def __init__(self, a_free, low: list, weight: float, free: np.ndarray, single: bool = False,
                 node_order: bool = False, lu=None):  # fmt: skip
        """a_free: A on the free DOFs (sparse); low: rank-one terms ``(c, v)`` of J (v over all
        3n DOFs); weight: Δt²/2 (s²); single: factorise in float32 (a preconditioner);
        node_order: the fill-reducing ordering computed on the node graph, once per pattern
        (:func:`~quadmodes.linalg.factor.lu_factor`; about a quarter of a factorisation).
        lu: A already factorised (then ``a_free``, ``single`` and ``node_order`` are unused)."""
        if lu is None:
            nodes = free // 3 if node_order else None
            lu = factorize(a_free, symmetric=True, single=single, nodes=nodes)
        self.lu = lu
        self.low = []
        for coef, vec in low:
            vf = np.asarray(vec).ravel()[free]
            self.low.append((weight * coef, vf, self.lu.solve(vf)))

    @classmethod
    def at(cls, problem: FullOrderProblem, z0: np.ndarray, z1: np.ndarray,
           ops: StepOperators | None = None, single: bool = False,
           node_order: bool = False) -> NewtonMatrix:  # fmt: skip
        """The Newton matrix of ``problem`` at the body-frame pair (z0, z1) (n,3), assembled
        by ``ops`` (the run's :class:`~quadmodes.fullorder.kernels.StepOperators`; None: the
        straightforward COO assembly of :func:`step_jacobian`); single, node_order: see
        :class:`NewtonMatrix`."""
        weight, free = 0.5 * problem.h * problem.h, problem.free
        if ops is None:
            jac, low = step_jacobian(problem.structure, z0, z1, problem.energy_momentum)
            a = (problem.m_full + weight * jac)[free][:, free].tocsc()
        else:
            low = [(0.5 * c, v) for c, v in tangent_low_rank(problem.structure, 0.5 * (z0 + z1))]
            a = ops.newton_matrix(z0, z1, weight)
        return cls(a, low, weight, free, single, node_order)

    def update(self, z0: np.ndarray, z1: np.ndarray) -> None:
        """Nothing to renew per iterate (the interface of a condensed matrix)."""

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        y = self.lu.solve(rhs)
        for coef, vec, av in self.low:  # Sherman–Morrison for c v vᵀ
            y = y - av * (coef * (vec @ y) / (1.0 + coef * (vec @ av)))
        return y


# ---------------------------------------------------------------------------------------------
# iterations
# ---------------------------------------------------------------------------------------------


def line_search(residual_norm, x1: np.ndarray, dx: np.ndarray, r0: float,
                move: Callable | None = None):  # fmt: skip
    """Backtracking along dx on the residual norm (N): the first α of 1, ½, ¼, … (six halvings)
    with ``‖r(x₁ + α dx)‖ < (1 − 10⁻⁴α) r0``. Returns ``(α, trial point)``, or ``(1, None)`` if
    none qualifies (the caller's convergence control takes over). ``move(x1, δ)``: the point
    a correction δ leads to (default ``x1 + δ``; :func:`advanced`)."""
    alpha = 1.0
    for _ in range(7):
        y = x1 + alpha * dx if move is None else move(x1, alpha * dx)
        trial = residual_norm(y)
        if np.isfinite(trial) and trial < (1.0 - 1e-4 * alpha) * r0:
            return alpha, y
        alpha *= 0.5
    return 1.0, None


@dataclass(frozen=True, eq=False)
class NewtonResult:
    """Outcome of :func:`solve_step`: the end state x1 (n,3) m, ``v½`` and ``f_d`` (n,3) of the
    last residual evaluated at an iterate (the one before the last correction), the Newton
    matrix in use at the end, converged, the last correction (m, max norm), and the numbers of
    iterations and factorisations made."""

    x1: np.ndarray
    vh: np.ndarray
    fd: np.ndarray
    matrix: NewtonMatrix
    converged: bool
    correction: float
    n_newton: int
    n_factor: int


class _LastResidual:
    """The residual with its last evaluation remembered (the line search's last trial is the
    next iterate)."""

    def __init__(self, residual: Callable):
        self.residual, self.y, self.value = residual, None, None

    def __call__(self, y: np.ndarray):
        if self.y is not y:
            self.y, self.value = y, self.residual(y)
        return self.value


def _correction(problem: FullOrderProblem, matrix, r, rot) -> np.ndarray:
    """Newton correction δx (n,3) m of residual r (n,3) N with the matrix applied in frame rot."""
    n = problem.n
    rb = (r @ rot).ravel()[problem.free]
    dz = np.zeros(3 * n)
    dz[problem.free] = -(0.5 * problem.h * problem.h) * matrix.solve(rb)
    return dz.reshape(n, 3) @ rot.T


#: A Newton correction larger than this × the body size means the iteration diverged.
DIVERGED = 1.0


def _rho(matrix) -> float:
    """Contraction above which ``matrix`` is renewed (:data:`RHO_REFACTOR`,
    :data:`RHO_SOFT` for a condensed or a Krylov one)."""
    kept = (CondensedNewtonMatrix, KrylovNewtonMatrix)
    return RHO_SOFT if isinstance(matrix, kept) else RHO_REFACTOR


def matrix_factory(problem: FullOrderProblem, ops: StepOperators | None,
                   full_newton: bool = False, policy: str = "adaptive",
                   threads: int = 1) -> Callable:  # fmt: skip
    """``make(z0, z1)``: the Newton matrix of a run at a body-frame pair (n,3). With ``ops``
    and ties in the structure: a :class:`~quadmodes.fullorder.condensed.CondensedNewtonMatrix`
    (the ties renewed at every iteration; at most :data:`MAX_TIE_DOFS` of them); with more ties:
    a :class:`~quadmodes.fullorder.krylov.KrylovNewtonMatrix` (GMRES on the current matrix,
    preconditioned by a float32 factorisation); without ties, with ``ops``: a
    :class:`NewtonMatrix` assembled by ``ops``; ``full_newton`` or no ``ops``: the
    straightforward :class:`NewtonMatrix`. policy: :data:`POLICIES` (the Krylov matrix's
    renewal rule). threads: with 2 or more and the policy ``"adaptive"``, the Krylov matrix's
    preconditioner is renewed on a second thread every
    :data:`~quadmodes.fullorder.renewal.RENEWAL_LAG` steps
    (:class:`~quadmodes.fullorder.renewal.RenewalPipeline`; ``renewal.BACKGROUND = False``:
    the same schedule inline)."""
    if full_newton or ops is None:
        return lambda z0, z1: NewtonMatrix.at(problem, z0, z1)
    split = TieSplit.of(ops, problem.free)
    if split is None:
        return lambda z0, z1: NewtonMatrix.at(problem, z0, z1, ops)
    if len(split.tie) > MAX_TIE_DOFS and not KRYLOV_MANY_TIES:
        return lambda z0, z1: NewtonMatrix.at(problem, z0, z1, ops)  # the kept whole matrix
    if len(split.tie) > MAX_TIE_DOFS:  # too many for a dense Schur system
        permuted = PermutedNewtonAssembly.of(ops, problem.free)

        def kept(z0, z1, fused=False):
            return _kept(problem, ops, permuted, z0, z1, fused)

        def krylov(z0, z1):
            pipe = None
            if threads >= 2 and policy == "adaptive":  # the thread's: compiled blocks
                pipe = renewal_module.RenewalPipeline(lambda a, b: kept(a, b, True),
                                                      background=renewal_module.BACKGROUND)  # fmt: skip
            return KrylovNewtonMatrix(problem, ops, kept(z0, z1), policy, pipe)

        return krylov
    return lambda z0, z1: CondensedNewtonMatrix(problem, ops, split, z0, z1)


def _kept(problem: FullOrderProblem, ops: StepOperators, permuted: PermutedNewtonAssembly,
          z0: np.ndarray, z1: np.ndarray, fused: bool = False) -> NewtonMatrix:  # fmt: skip
    """The float32 preconditioner of the Krylov path at the body-frame pair (z0, z1) (n,3):
    ``NewtonMatrix.at(problem, z0, z1, ops, single=True, node_order=True)``, assembled straight
    into its permuted data by ``permuted`` (built once per run; the same matrix bit for bit,
    or to round-off with ``fused``: :meth:`PermutedNewtonAssembly.data`)."""
    weight = 0.5 * problem.h * problem.h
    try:
        lu = permuted.factorize(ops, z0, z1, weight, fused)
    except RuntimeError:  # exactly singular: the general path's partial pivoting decides
        return NewtonMatrix.at(problem, z0, z1, ops, single=True, node_order=True)
    low = low_rank_terms(problem.structure, z0, z1)
    return NewtonMatrix(None, low, weight, problem.free, lu=lu)


def solve_step(
    problem: FullOrderProblem, matrix, x: np.ndarray, x1: np.ndarray, rot: np.ndarray,
    residual: Callable, max_newton: int, make: Callable | None = None, full_newton: bool = False,
    policy: str = "fixed",
) -> NewtonResult:  # fmt: skip
    """Modified Newton from the predicted end state x1 (n,3) of the step from x (n,3); the
    Newton matrix is applied in frame rot (3,3). ``matrix``: the factorisation to reuse (None:
    factorise at the start with ``make`` (:func:`matrix_factory`; default: the straightforward
    :class:`NewtonMatrix`)); it is renewed at the current iterate when successive corrections
    shrink by less than :data:`RHO_REFACTOR` (after at least two iterations with it), and its
    ``update`` (the ties of a condensed matrix, the operator of a Krylov one) is taken at every
    iterate; a condensed or Krylov matrix is renewed already when they shrink by less than
    :data:`RHO_SOFT`, a Krylov one also when a solve on it did not converge (``stale``, at the
    current iterate) or the last step needed too many Krylov steps (``worn``, at the start of
    the step). ``full_newton``:
    a fresh factorisation at every iteration (the reference Newton; slow).
    ``residual(y) -> (v½, r, f_d)``. Corrections above :data:`LINE_SEARCH` × body size
    backtrack on the residual norm (:func:`line_search`). policy ``"adaptive"``: converged also
    by the contraction estimate (:data:`RATE_STOP`), and v½ returned as ``(x₁ − x)/Δt`` of the
    end state (``"fixed"``: the v½ of the last residual, before the last correction)."""
    make = make if make is not None else (lambda z0, z1: NewtonMatrix.at(problem, z0, z1))
    n_newton = n_factor = 0
    since = math.inf  # Newton iterations since the last factorisation
    if matrix is None or full_newton or getattr(matrix, "worn", False):
        matrix = make(x @ rot, x1 @ rot)
        n_factor, since = n_factor + 1, 0
    seen, nd, ok = [], math.inf, False  # the corrections made with the current matrix
    stalled = 0  # refactorisations that did not restore contraction (a kink of the law)
    predictor, restarted = x1, False
    residual_at = _LastResidual(residual)
    budget = max_newton  # iterations left (renewed once, by a restart)
    while budget > 0:
        budget -= 1
        vh, r, fd = residual_at(x1)
        if (full_newton or restarted) and since > 0:
            matrix = make(x @ rot, x1 @ rot)
            n_factor, since = n_factor + 1, 0
        matrix.update(x @ rot, x1 @ rot)
        with np.errstate(all="ignore"):
            x1, dx = _step_to(problem, matrix, residual_at, x1, r, rot, search=stalled > 0)
        n_newton, since = n_newton + 1, since + 1
        nd = float(np.max(np.abs(dx)))
        wild = not np.isfinite(nd) or nd > DIVERGED * problem.scale
        if not wild:
            nd = measured(problem, dx, policy)
            rate = policy == "adaptive" and _rate_converged(nd, seen, problem.tol)
            if nd <= problem.tol or rate:
                ok = True
                break
        slow = bool(seen) and nd > _rho(matrix) * seen[-1]
        renew = since >= 2 and (slow or getattr(matrix, "stale", False))
        grew = since <= 3 and bool(seen) and nd > seen[-1] and _twisting(problem, policy)
        if (wild or (renew and grew)) and not restarted:
            # a matrix from earlier steps sent the iteration off (a fast transient in stiff
            # DOFs), or — in a body with beam sections, whose stiff ties turn with their soft
            # twist, so that a matrix may serve one iteration only — the corrections grew
            # with a fresh matrix: start the step again from its predictor, with full Newton
            # (a matrix factorised at every iterate) for the rest of this step
            x1, restarted, budget = predictor, True, max_newton
            matrix = make(x @ rot, x1 @ rot)
            n_factor, since, seen = n_factor + 1, 0, []
            continue
        if not np.isfinite(nd):
            break
        if renew:
            # the frozen matrix no longer contracts well (or a Krylov solve on it did not reach
            # its tolerance): renew it at this iterate; if a fresh matrix did not help either
            # (the wrinkling law's tangent jumps between iterates, and Newton can cycle),
            # backtrack on the residual from now on
            stalled += since <= 3 and n_factor > 0
            matrix = make(x @ rot, x1 @ rot)
            n_factor, since, seen = n_factor + 1, 0, []
            continue
        seen.append(nd)
    if policy == "adaptive":
        vh = (x1 - x) / problem.h  # the end state's, not the last residual's
    return NewtonResult(x1, vh, fd, matrix, ok, nd, n_newton, n_factor)


def _twisting(problem: FullOrderProblem, policy: str) -> bool:
    """The adaptive policy on a body with beam sections (``problem.triads``)."""
    return policy == "adaptive" and problem.triads is not None


def measured(problem: FullOrderProblem, dx: np.ndarray, policy: str) -> float:
    """The size (m) of a Newton correction dx (n,3) that the test compares with ``problem.tol``
    (``newton_tol`` × the body size): the plain ``max |δx|``, except that policy ``"adaptive"``
    measures a beam node's slope and section directors (``problem.triads``: unit vectors at
    rest, dimensionless) in radians times the body size, ``scale × |δd|``, so that every DOF of
    a beam is held to the same relative accuracy ``newton_tol``: a position to that fraction of
    the body, a direction to that angle — the angle a position error of ``tol`` turns the body
    by. (Held as a length, ``|δd| ≤ tol``, a direction was ``scale`` times looser than the
    body's own rotation.) A hub's axes keep the plain test (membranes on a hub unchanged)."""
    step = np.abs(dx).max(axis=1)
    if policy == "adaptive" and problem.triads is not None:
        rows = problem.triads.ravel()
        step[rows] *= problem.scale
    return float(step.max())


def _rate_converged(nd: float, seen: list[float], tol: float) -> bool:
    """The error left after a correction of size nd (m) is below :data:`RATE_STOP` × tol, by
    the largest contraction θ among the corrections ``seen`` before it with the same matrix
    (at least two of them: one ratio right after a poor predictor is quadratic convergence,
    not the iteration's rate, and would stop it too early)."""
    if len(seen) < 2 or min(seen) <= 0.0:
        return False
    steps = [*seen, nd]
    theta = max(b / a for a, b in zip(steps[:-1], steps[1:], strict=True))
    return theta < 1.0 and theta / (1.0 - theta) * nd <= RATE_STOP * tol


def _step_to(problem: FullOrderProblem, matrix, residual_at: Callable, x1: np.ndarray, r, rot,
             search: bool = False):  # fmt: skip
    """``(x1 + α δx, α δx)``: the Newton correction δx of residual r at x1 (n,3), backtracked
    on the residual norm when it exceeds :data:`LINE_SEARCH` × body size or ``search`` (α = 1
    otherwise)."""
    dx = _correction(problem, matrix, r, rot)
    move = (lambda y, d: advanced(problem.triads, y, d)) if problem.triads is not None else None
    if not search and float(np.max(np.abs(dx))) <= LINE_SEARCH * problem.scale:
        y = x1 + dx if move is None else move(x1, dx)
        return y, y - x1
    # far from the solution (a violent transient): backtrack on the residual
    alpha, trial = line_search(
        lambda y: float(np.linalg.norm(residual_at(y)[1])), x1, dx, float(np.linalg.norm(r)), move
    )
    y = trial if trial is not None else (x1 + alpha * dx if move is None else move(x1, alpha * dx))
    return y, y - x1


def advanced(triads: np.ndarray, x1: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """``x1 + dx`` (n,3), except that the part of dx that turns a beam node's frame
    ``[t, d₂, d₃]`` (rows ``triads`` (k,3)) is applied as a rotation: with
    ``φ = ½(t̂ × δt/|t| + d₂ × δd₂ + d₃ × δd₃)`` (exact for a turn φ of an orthonormal frame),
    each of the three vectors v also gets ``(R(φ) − I − [φ]×) v`` — second order in δ, so
    Newton's rate and its fixed point are unchanged. Why: an additive turn θ stretches the
    frame by θ²/2, and the stiff section ties (EA, κGA) then put a spurious stress EA θ²/2 in
    the Jacobian's geometric part, which swamps a string's twist stiffness GJ/L above θ ~
    1e-4 rad and stalled the tall-hub rotor (docs/full-order.md)."""
    y = x1 + dx
    e, de = x1[triads], dx[triads]  # (k, 3, 3): t, d2, d3
    length = np.linalg.norm(e[:, 0], axis=1)[:, None]
    frame = e.copy()
    frame[:, 0] /= length
    turns = de.copy()
    turns[:, 0] /= length
    phi = 0.5 * np.cross(frame, turns).sum(axis=1)  # (k, 3)
    th2 = np.sum(phi * phi, axis=1)
    th = np.sqrt(th2)
    small = th < 1e-4
    safe = np.where(small, 1.0, th)
    a = np.where(small, 0.5 - th2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    b = np.where(small, -1.0 / 6.0 + th2 / 120.0, (np.sin(safe) - safe) / safe**3)
    dot = np.einsum("kc,kjc->kj", phi, e)  # φ·v for the three vectors
    cross = np.cross(phi[:, None, :], e)
    extra = a[:, None, None] * (phi[:, None, :] * dot[..., None] - th2[:, None, None] * e)
    extra += (b * th2)[:, None, None] * cross
    y[triads] += extra
    return y
