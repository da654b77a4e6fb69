"""Prestress stage: nonlinear statics of the free-floating inflated membrane.

Load stepping on the pressure with Newton–Raphson and a backtracking line search. The six rigid
motions of a free body are removed by the mass-weighted frame conditions ``Ψᵀ M Δx = 0`` (centre of
mass and mean axes fixed) through a bordered system; because pressure and membrane forces are
self-equilibrated, the Lagrange multipliers stay at round-off, i.e. there are no spurious reactions.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.errors import QuadmodesError
from quadmodes.fe.membrane import MembraneSet
from quadmodes.fe.model import (
    Structure,
    internal_force,
    mass_matrix,
    rigid_body_modes,
    strain_energy,
    tangent_low_rank,
    tangent_stiffness,
    with_load_factor,
    with_tension_field,
)
from quadmodes.fe.pressure import PressureSet, enclosed_volume
from quadmodes.linalg.krylov import gmres
from quadmodes.structure.bordered import (
    bordered_full_solver,
    bordered_matrix,
    bordered_operator,
)

Progress = Callable[[str, float], None]
log = logging.getLogger(__name__)


class ConvergenceError(QuadmodesError, RuntimeError):
    """A Newton iteration did not converge; the message is one line naming the stage."""


@dataclass(frozen=True)
class PrestressedState:
    """The inflated equilibrium: the reference for modes and quadratic modes.

    x: ``(n, 3)`` equilibrium vector DOFs (m). residual_norm: final ``‖f(x)‖`` relative to the
    pressure force norm. volume0, volume: enclosed volumes before and after inflation (m³).
    stress_resultants: ``(ne, 2)`` principal Cauchy stress resultants of the membrane (N/m).
    strain_major: ``(ne,)`` major principal Green strain. iterations: Newton iterations in total.
    """

    x: np.ndarray
    residual_norm: float
    volume0: float
    volume: float
    stress_resultants: np.ndarray
    strain_major: np.ndarray
    iterations: int

    @property
    def volume_change(self) -> float:
        return self.volume / self.volume0 - 1.0 if self.volume0 else 0.0

    def wrinkle_state(self) -> np.ndarray:
        """Per element 0 taut, 1 wrinkled, 2 slack (Stein–Hedgepeth tension-field criterion)."""
        minor = self.stress_resultants[:, 0]
        # the relaxed law leaves a round-off minor resultant across the wrinkles
        off = minor <= 1e-9 * np.abs(self.stress_resultants).max(initial=0.0)
        state = np.zeros(len(minor), dtype=int)
        state[off] = 1
        state[off & (self.strain_major <= 0.0)] = 2
        return state


def _reduced(structure: Structure, vec: np.ndarray) -> np.ndarray:
    return vec.ravel()[structure.free_dofs]


def backtracking_step(
    residual: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    dx: np.ndarray,
    r: np.ndarray,
    rel: float,
    accept_below: float,
    halvings: int = 12,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Backtracking line search on the residual norm: ``(x + t dx, residual there, t)`` for the
    first ``t = 1, ½, ¼, …`` (at most ``halvings`` tries; the last one is taken if none passes)
    that lowers ‖r‖ by the Armijo factor ``1 − 1e-4 t``; the full step is taken outright once the
    relative residual ``rel`` is below ``accept_below`` (round-off level).

    residual: ``(n, 3) -> (m,)`` residual on the free DOFs (N). x, dx: ``(n, 3)`` state and
    Newton increment (m). r: ``(m,)`` residual at ``x``.
    """
    step = 1.0
    for k in range(halvings):
        if k:
            step *= 0.5
        trial = x + step * dx
        r_trial = residual(trial)
        if np.linalg.norm(r_trial) < (1.0 - 1e-4 * step) * np.linalg.norm(r) or rel < accept_below:
            break
    return trial, r_trial, step


#: Krylov vectors tried with the kept factorisation before the tangent is factorised afresh
#: (0: a fresh double-precision factorisation and a direct solve at every iteration, i.e. the
#: full Newton method).
KRYLOV_ITERATIONS = 20


#: A kept factorisation whose last GMRES solve needed more than this many Krylov vectors is
#: replaced by one of the current tangent before the next solve (None: kept while GMRES
#: converges within :data:`KRYLOV_ITERATIONS`).
REFACTOR_AFTER: int | None = 15


@dataclass
class _KeptFactorisation:
    """The bordered-tangent solve kept between Newton iterations (None before the first);
    steps: Krylov vectors of the last GMRES solve with it."""

    solve: Callable[[np.ndarray], np.ndarray] | None = None
    count: int = 0
    steps: int = 0


def newton_direction(
    a: sp.spmatrix, border: int, low_rank: list, rhs: np.ndarray, kept: _KeptFactorisation,
    rtol: float, nodes: np.ndarray | None = None,
) -> np.ndarray:
    """Solve the bordered Newton system ``(a + Σ c v vᵀ) d = rhs`` (``(m + r,)``, ``r =
    border`` constraint rows; ``nodes`` ``(m,)`` the node of each other row, for the ordering)
    to the relative residual ``rtol`` by GMRES on ``a`` preconditioned with a kept factorisation.

    The kept one (of an earlier tangent) is tried first, for at most :data:`KRYLOV_ITERATIONS`
    steps; if that does not converge (or nothing is kept yet), ``a`` is factorised in single
    precision and kept (half the memory, faster; GMRES restores double precision), and in double
    precision if even that does not converge. The factorisation is the dominant cost on large
    meshes; a Krylov step costs one kept solve and one product with ``a``."""
    operator = bordered_operator(a, low_rank)
    stale = REFACTOR_AFTER is not None and kept.steps > REFACTOR_AFTER
    if kept.solve is not None and KRYLOV_ITERATIONS > 0 and not stale:
        result = gmres(operator, kept.solve, rhs, rtol, KRYLOV_ITERATIONS)
        log.debug("GMRES: %d iterations, residual %.2e (tolerance %.1e)", result.iterations,
                  result.residual, rtol)  # fmt: skip
        if result.converged:
            kept.steps = result.iterations
            return result.x
    for single in (True, False):
        kept.solve = bordered_full_solver(a, low_rank, border, single=single, nodes=nodes)
        kept.count += 1
        if KRYLOV_ITERATIONS == 0:  # full Newton: the direct solve
            return kept.solve(rhs)
        result = gmres(operator, kept.solve, rhs, rtol, KRYLOV_ITERATIONS)
        log.debug("GMRES on a fresh factorisation: %d iterations, residual %.2e",
                  result.iterations, result.residual)  # fmt: skip
        kept.steps = result.iterations
        if result.converged:
            break
    return result.x


def solve_static(
    structure: Structure,
    x_start: np.ndarray,
    rtol: float = 1e-10,
    max_iterations: int = 40,
    stage: str = "statics",
) -> tuple[np.ndarray, float, int]:
    """Newton–Raphson with line search to ``‖f‖ ≤ rtol · scale``; returns ``(x, rel_residual, its)``.

    The scale is the norm of the pressure force (or of the first residual without pressure).
    Inexact Newton: the linear systems are solved to the relative residual ``10 rel`` clipped
    to [1e-3, 1e-2] (``rel`` the current relative residual; near the solution each iteration
    gains at least a factor 1000), by GMRES on the current tangent preconditioned with the
    factorisation of an earlier one while that converges quickly (:func:`newton_direction`).
    """
    x = x_start.copy()
    free = structure.free_dofs

    def residual(y: np.ndarray) -> np.ndarray:
        return _reduced(structure, internal_force(structure, y))

    msub = mass_matrix(structure)[free][:, free] if structure.is_free else None
    pressure_sets = [e for e in structure.elements if isinstance(e, PressureSet)]
    scale = 0.0
    for ps in pressure_sets:
        scale += np.linalg.norm(ps.force(x))
    r = residual(x)
    scale = max(scale, np.linalg.norm(r), 1e-300)
    rel = np.linalg.norm(r) / scale
    history = [rel]
    kept = _KeptFactorisation()
    lin_tol, step = 1.0, 0.0
    for it in range(1, max_iterations + 1):
        # Converged: below rtol, or stalled at the round-off floor (stiff ties and small elements
        # put it near 1e-9 relative): no gain over two iterations at a level below 1e-7.
        # Or at that floor after one iteration: below 10 rtol and far less gain than the linear
        # tolerance of the last step promised (the rest is round-off in the residual).
        stalled = len(history) > 3 and rel < 1e-7 and rel > 0.5 * min(history[-4:-1])
        floor = len(history) > 1 and rel < 10.0 * rtol and rel > 10.0 * lin_tol * history[-2]
        if rel <= rtol or stalled or floor:
            return x, rel, it - 1
        # Near the solution (below 1e-6, after a full step) the tangent of the last iterate
        # serves as the operator: it differs by about the step, far below the linear tolerance.
        if not (it > 1 and rel < 1e-6 and step == 1.0):
            k = tangent_stiffness(structure, x)[free][:, free]
            psi = rigid_body_modes(structure, x)[free] if structure.is_free else None
            constraint = msub @ psi if structure.is_free else None
            a = bordered_matrix(k, constraint)
        rhs = np.zeros(a.shape[0])
        rhs[: free.size] = -r
        lin_tol = float(np.clip(10.0 * rel, 1e-3, 1e-2))
        dx = np.zeros(3 * structure.n)
        d_free = newton_direction(a, a.shape[0] - free.size, tangent_low_rank(structure, x), rhs,
                                  kept, lin_tol, free // 3)[: free.size]  # fmt: skip
        if constraint is not None:  # the frame conditions exactly, as a direct solve has them
            d_free = d_free - psi @ np.linalg.solve(constraint.T @ psi, constraint.T @ d_free)
        dx[free] = d_free
        # Backtracking on the residual norm (the tangent can be indefinite early in inflation).
        x, r, step = backtracking_step(residual, x, dx.reshape(-1, 3), r, rel, 1e-6)
        rel = np.linalg.norm(r) / scale
        history.append(rel)
        log.debug(
            "%s: iteration %d step %.3g relative residual %.3e (%d factorisations)",
            stage, it, step, rel, kept.count,
        )
        if not np.isfinite(rel):
            break
    raise ConvergenceError(
        f"{stage}: Newton did not converge (relative residual {rel:.2e} after {max_iterations} "
        "iterations)"
    )


#: Shift of the first pseudo-transient iteration relative to ``max diag K / max diag M`` (1/s²):
#: small enough that the first step moves a stress-free flat patch by a fraction of its size.
PSEUDO_TRANSIENT_SHIFT = 1e-3
#: An accepted pseudo-transient step at least halves the shift (a refused one quadruples it):
#: on the flat-ended cylinder of tests/test_flat_inflation.py 15 iterations instead of 70 with
#: the plain ``μ ‖f_new‖/‖f_old‖`` rule, whose shift falls only as fast as the residual.
SHIFT_MAX_RATIO = 0.5
#: Relative residual below which refused steps mean the round-off floor (stiff end-body ties put
#: it near 1e-9), not a failure: after :data:`FLOOR_REFUSALS` refusals in a row it is converged.
FLOOR = 1e-7
FLOOR_REFUSALS = 4


def solve_pseudo_transient(
    structure: Structure,
    x_start: np.ndarray,
    rtol: float = 1e-10,
    max_iterations: int = 300,
    stage: str = "inflation",
) -> tuple[np.ndarray, float, int]:
    """Pseudo-transient continuation to ``‖f‖ ≤ rtol · scale``; returns ``(x, rel_residual, its)``.

    Each iteration solves ``(K + μ M) Δx = −f`` (a backward-Euler step of a fictitious damped
    motion, ``M`` the mass): the shift ``μ`` (1/s²) regularises a tangent that is singular or
    indefinite, e.g. a stress-free flat end disc, which has no stiffness out of its plane until
    the pressure bulges it, or a wrinkled region under the tension-field law. A step that lowers
    the total potential energy (elastic energy minus the pressure's work; within its round-off,
    one that lowers the residual) is taken and ``μ`` follows the residual (switched evolution
    relaxation, ``μ ← μ min(½, ‖f_new‖/‖f_old‖)``), so the last iterations are Newton's; a step
    that does not is refused and ``μ`` quadrupled. Below :data:`FLOOR`, :data:`FLOOR_REFUSALS`
    refusals in a row are the round-off floor: converged. The energy, not the residual, is the merit:
    for large ``μ`` the step is the energy's steepest descent in the mass metric, while the
    residual norm can stall where the tangent is indefinite (a compressed membrane). The frame
    conditions of a free body are kept as in :func:`solve_static`; the fixed point is the same
    equilibrium ``f = 0``."""
    free = structure.free_dofs
    msub = mass_matrix(structure)[free][:, free]
    x = x_start.copy()

    def residual(y: np.ndarray) -> np.ndarray:
        return _reduced(structure, internal_force(structure, y))

    pressure_sets = [e for e in structure.elements if isinstance(e, PressureSet)]
    r = residual(x)
    scale = max(sum(np.linalg.norm(ps.force(x)) for ps in pressure_sets), np.linalg.norm(r), 1e-300)
    rel = np.linalg.norm(r) / scale
    energy = strain_energy(structure, x)
    k = tangent_stiffness(structure, x)[free][:, free]
    mu = PSEUDO_TRANSIENT_SHIFT * k.diagonal().max() / msub.diagonal().max()
    refused = 0
    for it in range(1, max_iterations + 1):
        if rel <= rtol or (rel < FLOOR and refused >= FLOOR_REFUSALS):
            return x, rel, it - 1
        k = tangent_stiffness(structure, x)[free][:, free]
        psi = rigid_body_modes(structure, x)[free] if structure.is_free else None
        constraint = msub @ psi if psi is not None else None
        a = bordered_matrix(k + mu * msub, constraint)
        solve = bordered_full_solver(a, tangent_low_rank(structure, x), a.shape[0] - free.size,
                                     nodes=free // 3)  # fmt: skip
        rhs = np.zeros(a.shape[0])
        rhs[: free.size] = -r
        dx = np.zeros(3 * structure.n)
        dx[free] = solve(rhs)[: free.size]
        trial = x + dx.reshape(-1, 3)
        r_trial = residual(trial)
        rel_trial = np.linalg.norm(r_trial) / scale
        log.debug("%s: pseudo-transient iteration %d shift %.3g relative residual %.3e",
                  stage, it, mu, rel_trial)  # fmt: skip
        energy_trial = strain_energy(structure, trial)
        round_off = 1e-11 * abs(energy)
        lower = energy_trial < energy - round_off
        if np.isfinite(rel_trial) and (lower or (energy_trial <= energy + round_off
                                                 and rel_trial < rel)):  # fmt: skip
            mu *= min(SHIFT_MAX_RATIO, rel_trial / rel)
            x, r, rel, energy, refused = trial, r_trial, rel_trial, energy_trial, 0
        else:
            mu, refused = 4.0 * mu, refused + 1
    raise ConvergenceError(
        f"{stage}: pseudo-transient continuation did not converge (relative residual "
        f"{rel:.2e} after {max_iterations} iterations)"
    )


def equilibrium(structure: Structure, x: np.ndarray, rtol: float) -> tuple[np.ndarray, float, int]:
    """The equilibrium of ``structure`` from ``x``: Newton (:func:`solve_static`), and where
    Newton fails pseudo-transient continuation (:func:`solve_pseudo_transient`) from ``x``."""
    try:
        return solve_static(structure, x, rtol=rtol, stage="inflation")
    except ConvergenceError as exc:
        log.debug("Newton failed (%s); pseudo-transient continuation", exc)
        return solve_pseudo_transient(structure, x, rtol=rtol)


#: Newton iterations of a load step below which the next pressure increment is doubled.
GROW_BELOW = 8


def inflate(
    structure: Structure,
    steps: int = 1,
    rtol: float = 1e-10,
    progress: Progress | None = None,
    cuts: int = 6,
) -> PrestressedState:
    """Inflate from the stress-free shape to full pressure and return the equilibrium with its
    stress report.

    Path following on the pressure: the first increment is ``1/steps`` of it; an increment whose
    equilibrium is not found (:func:`equilibrium`) is halved (at most ``cuts`` times below
    ``1/steps``), one found in fewer than :data:`GROW_BELOW` iterations doubles the next (up to
    ``1/steps``). The path is followed
    with St Venant–Kirchhoff membranes (stiff from the stress-free state on); membranes with the
    tension-field law (``tension_field``) are then relaxed at full pressure from that
    equilibrium, their compressed elements wrinkling (equal to it where the membrane is taut)."""
    x = structure.reference.copy()
    pressure_sets = [e for e in structure.elements if isinstance(e, PressureSet)]
    if not pressure_sets:
        raise ValueError("pressure: the structure has no pressure load; add a [pressure] section")
    triangles = pressure_sets[0].conn
    volume0 = enclosed_volume(x, triangles)
    svk = with_tension_field(structure, False)
    factor, increment, total_its = 0.0, 1.0 / steps, 0
    rel = np.inf
    while factor < 1.0 - 1e-12:
        target = min(1.0, factor + increment)
        try:
            x_new, rel, its = equilibrium(with_load_factor(svk, target), x, rtol)
        except ConvergenceError as exc:
            if increment * steps < 0.5**cuts:
                raise ConvergenceError(
                    f"inflation: no equilibrium found at {100 * target:.3g} % of the pressure "
                    f"({exc}); raise [pressure] steps (now {steps}), use a finer mesh "
                    "([mesh] edge_length) or check the pressure"
                ) from None
            increment *= 0.5
            continue
        x, factor, total_its = x_new, target, total_its + its
        if its < GROW_BELOW:
            increment = min(2.0 * increment, 1.0 / steps)
        if progress:
            progress("inflation", factor)
    if any(isinstance(e, MembraneSet) and e.tension_field for e in structure.elements):
        x, rel, its = equilibrium(structure, x, rtol)
        total_its += its
    return prestressed_state(structure, x, float(rel), volume0, triangles, total_its)


def prestressed_state(
    structure: Structure, x: np.ndarray, rel: float, volume0: float, triangles: np.ndarray,
    iterations: int,
) -> PrestressedState:
    """The :class:`PrestressedState` of the equilibrium ``x`` ``(n, 3)`` (m)."""
    membranes = [e for e in structure.elements if isinstance(e, MembraneSet)]
    resultants = np.concatenate([m.principal_stress_resultants(x) for m in membranes])
    strain_major = np.concatenate(
        [np.linalg.eigvalsh(m.strain_stress(x)[1])[:, 1] for m in membranes]
    )
    return PrestressedState(
        x=x,
        residual_norm=rel,
        volume0=volume0,
        volume=enclosed_volume(x, triangles),
        stress_resultants=resultants,
        strain_major=strain_major,
        iterations=iterations,
    )
