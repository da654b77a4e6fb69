"""The FE model's own statically condensed energy W_c about a reduced model's chart.

For a reduced model (Φ, g^{mn}, Λ) built about the inflated equilibrium ``x0`` of a structure,
at modal coordinates ``s`` (N,) (√kg·m) this module evaluates (in J, minus the value at ``x0``)

* ``W_c(s) = min_y Π(x_QM(s) + y)``, ``x_QM(s) = x0 + Φs + Σ_mn s_m s_n g^{mn}`` (no ½), over
  all ``y`` with ``Φᵀ M y = 0`` and ``Ψᵀ M y = 0`` (rigid motions about the centre of mass of
  ``x0``): the statically condensed energy of the FE model (bordered Newton with an energy line
  search), and its minimiser ``y``: what the product uses it for is the full order's relaxed
  initial deformation of a large bending amplitude and the deformation check.

The candidate reduced potentials compared with it (Q, Q4, the exact manifold energy QE, W_red
condensed on the quadratic modes G⊥ of :attr:`EnergyContext.g_perp`) are research code, in
:mod:`quadmodes.experimental.candidate_potentials` (docs/potentials.md).

Π is the total potential of the structure, :func:`quadmodes.fe.model.strain_energy` (strain
energy of every element set plus the pressure potential: ``−p V`` at constant pressure, the
gas-law potential otherwise), whose gradient is :func:`quadmodes.fe.model.internal_force`. The
round-off residual ``f(x0)`` of the equilibrium is removed (``Π̃(x) = Π(x) − Π(x0) − f(x0)·(x −
x0)``) so that every energy starts at second order.

**Chart.** The modal coordinate is the reduced model's own: ``s`` of ``x_QM(s)``. The quadratic
modes have components along the retained modes (``Φᵀ M g^{mn} = −Φᵀ B(u^m, u^n)/ω²``, large for
the bending → axial coupling), so the M-projection of ``x_QM(s) − x0`` on Φ is ``σ(s) = s +
ΦᵀM Σ s s g``, not ``s``. W_c is the minimum at the *projected* coordinate σ(s) written in the
chart s: ``W_c(s) = min_{ΦᵀMy=0, ΨᵀMy=0} Π(x0 + Φσ(s) + y)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.model import (
    Structure,
    internal_force,
    mass_matrix,
    rigid_body_modes,
    strain_energy,
    tangent_low_rank,
    tangent_stiffness,
)
from quadmodes.rom.reduced import ReducedModel
from quadmodes.structure.bordered import bordered_solver

#: Newton stops when the predicted energy decrease ½|Δ·r| is below this fraction of the energy.
ENERGY_RTOL = 1e-12
#: ... or below this absolute floor (J): the round-off of Π(x) − Π(x0) for Π(x0) of order 10² J.
ENERGY_ATOL = 1e-13


@dataclass(frozen=True, eq=False)
class EnergyContext:
    """Everything the energies need, flattened to scalar DOFs (``m = 3n``).

    structure, x0 ``(n, 3)`` m: the FE model and its inflated equilibrium. pi0 (J): Π(x0).
    f0 ``(m,)`` N: round-off residual f(x0). phi ``(N, m)`` 1/√kg: modes. g ``(N, N, m)`` 1/kg:
    quadratic modes. mass: ``M`` ``(m, m)`` sparse kg. basis ``(m, N+r)``: [Φ, Ψ] (retained and
    rigid modes). g_perp ``(m, q)``: M-orthonormal basis of the g^{mn} M-orthogonal to
    ``basis`` (q ≤ N(N+1)/2). free ``(m_f,)``: unconstrained scalar DOFs. shift_scale (1/s²):
    the largest retained ω² (scale of the tangent shift where it is indefinite).
    """

    structure: Structure
    x0: np.ndarray
    pi0: float
    f0: np.ndarray
    phi: np.ndarray
    g: np.ndarray
    mass: sp.csr_matrix
    basis: np.ndarray
    g_perp: np.ndarray
    free: np.ndarray
    shift_scale: float


def m_orthonormal(mass: sp.spmatrix, vectors: np.ndarray, rtol: float = 1e-10) -> np.ndarray:
    """M-orthonormal basis ``(m, q)`` of the span of ``vectors`` ``(m, k)`` (directions with
    Gram eigenvalue below ``rtol`` × the largest are dropped)."""
    gram = vectors.T @ (mass @ vectors)
    lam, vec = np.linalg.eigh(0.5 * (gram + gram.T))
    keep = lam > rtol * lam.max()
    return vectors @ (vec[:, keep] / np.sqrt(lam[keep]))


def energy_context(structure: Structure, x0: np.ndarray, model: ReducedModel) -> EnergyContext:
    """The :class:`EnergyContext` of ``model`` about ``x0`` ``(n, 3)`` (m) on ``structure``.

    ``x0`` may be shifted rigidly from the state the model was built at (e.g. ``model.X``,
    about the centre of mass): Π and f are translation invariant."""
    n_modes = model.n_modes
    phi = np.asarray(model.Phi, float).reshape(n_modes, -1)
    g = np.asarray(model.G, float).reshape(n_modes, n_modes, -1)
    mass = mass_matrix(structure)
    if structure.is_free:
        psi = rigid_body_modes(structure, x0)
        psi = m_orthonormal(mass, psi)  # drops massless rotations (line beams about their axis)
    else:
        psi = np.zeros((phi.shape[1], 0))
    basis = np.hstack([phi.T, psi])
    iu = np.triu_indices(n_modes)
    gq = g[iu].T  # (m, N(N+1)/2)
    coeff = np.linalg.solve(basis.T @ (mass @ basis), basis.T @ (mass @ gq))
    g_perp = m_orthonormal(mass, gq - basis @ coeff)
    return EnergyContext(
        structure=structure,
        x0=np.asarray(x0, float),
        pi0=strain_energy(structure, x0),
        f0=internal_force(structure, x0).ravel(),
        phi=phi,
        g=g,
        mass=mass,
        basis=basis,
        g_perp=g_perp,
        free=structure.free_dofs,
        shift_scale=float(np.max(np.diag(model.Lam))),
    )


# ---------------------------------------------------------------------------------------------
# Exact FE energies
# ---------------------------------------------------------------------------------------------


def manifold_displacement(ctx: EnergyContext, s: np.ndarray) -> np.ndarray:
    """``Φs + Σ_mn s_m s_n g^{mn}`` ``(m,)`` (m) at ``s`` (N,)."""
    return s @ ctx.phi + np.einsum("m,n,mni->i", s, s, ctx.g)


def total_potential(ctx: EnergyContext, u: np.ndarray) -> float:
    """``Π̃(x0 + u) = Π(x0 + u) − Π(x0) − f(x0)·u`` (J) for a displacement ``u`` ``(m,)`` (m)."""
    x = ctx.x0 + u.reshape(-1, 3)
    return strain_energy(ctx.structure, x) - ctx.pi0 - float(ctx.f0 @ u)


def potential_force(ctx: EnergyContext, u: np.ndarray) -> np.ndarray:
    """``∇Π̃(x0 + u) = f(x0 + u) − f(x0)`` ``(m,)`` (N)."""
    return internal_force(ctx.structure, ctx.x0 + u.reshape(-1, 3)).ravel() - ctx.f0


@dataclass(frozen=True)
class Condensed:
    """A condensed energy: value (J), the minimiser (η (q,) or y (m,) m), Newton iterations,
    the final predicted decrease ½|Δ·r| (J), and whether it met the tolerance."""

    value: float
    unknowns: np.ndarray
    iterations: int
    decrement: float
    converged: bool


def _line_search(energy, z, dz, e0: float, slope: float, halvings: int = 30):
    """Armijo backtracking on the energy: ``(z + t dz, energy there)`` for the first
    ``t = 1, ½, …`` with ``E ≤ E0 + 1e-4 t slope`` (``slope = ∇E·dz < 0``); round-off
    tolerant (accepts E within the absolute floor)."""
    t = 1.0
    for _ in range(halvings):
        trial = z + t * dz
        e = energy(trial)
        if e <= e0 + 1e-4 * t * slope + ENERGY_ATOL:
            return trial, e
        t *= 0.5
    return z, e0


def _converged(decrement: float, value: float) -> bool:
    return decrement <= max(ENERGY_RTOL * abs(value), ENERGY_ATOL)


def _tangent(ctx: EnergyContext, u: np.ndarray):
    """Sparse tangent ``K`` ``(m, m)`` and its rank-one terms at ``x0 + u``."""
    x = ctx.x0 + u.reshape(-1, 3)
    return tangent_stiffness(ctx.structure, x), tangent_low_rank(ctx.structure, x)


def _descent_solver(ctx: EnergyContext, u: np.ndarray, r: np.ndarray, mu: float, tries: int = 8):
    """Factorised ``[[K + μM, C], [Cᵀ, 0]]`` (free DOFs, ``C = M[Φ Ψ]``) at ``x0 + u`` with the
    smallest μ of ``mu, 1e-3·scale, 10×, …`` (μ = 0 first if ``mu`` is 0) whose Newton step
    ``Δy = −solve(r)`` descends (``r·Δy < 0``): returns ``(solve, μ, Δy)`` on the free DOFs."""
    free = ctx.free
    k, low = _tangent(ctx, u)
    k = k[free][:, free]
    low = [(c, v[free]) for c, v in low]
    constraint = (ctx.mass @ ctx.basis)[free]
    for _ in range(tries):
        kk = k if mu == 0.0 else k + mu * ctx.mass[free][:, free]
        solve = bordered_solver(kk, constraint, low)
        d = -solve(r)
        if float(r @ d) < 0.0:
            break
        mu = 1e-3 * ctx.shift_scale if mu == 0.0 else 10.0 * mu
    return solve, mu, d


def condensed_energy(
    ctx: EnergyContext,
    s: np.ndarray,
    y0: np.ndarray | None = None,
    max_iterations: int = 60,
) -> Condensed:
    """``W_c(s) = min_y Π̃(x_QM(s) + y)`` (J) over ``y`` ``(m,)`` with ``[Φ Ψ]ᵀ M y = 0``.

    Bordered Newton ``[[K, MB], [BᵀM, 0]] [Δy; λ] = [−r; 0]``
    (:func:`quadmodes.structure.bordered.bordered_solver`; the factorisation is kept while the
    decrement falls tenfold per iteration) with an energy line search. Where the constrained
    tangent is indefinite (the Newton step does not descend) ``K`` is shifted by ``μM``, μ
    rising tenfold from 1e-3 of the largest retained ω², until it does. Stops when the predicted
    decrease ½|r·Δy| is below ENERGY_RTOL·|W| (or ENERGY_ATOL); with a shift (or a kept
    factorisation) that is the decrease predicted by the matrix used, a lower estimate.
    The minimum found is the one reached from the start (the energy is not convex where the
    membrane goes into compression).
    ``y0`` must be feasible (e.g. the minimiser at a smaller amplitude on the same ray, or
    ``G⊥η`` of W_red; see :mod:`quadmodes.experimental.candidate_potentials`); default 0, the
    quadratic-manifold point."""
    free = ctx.free
    u_qm = manifold_displacement(ctx, s)
    y = np.zeros_like(u_qm) if y0 is None else np.asarray(y0, float).copy()

    def energy(yy):
        return total_potential(ctx, u_qm + yy)

    value = energy(y)
    decrement, previous, solve, mu = np.inf, np.inf, None, 0.0
    for it in range(1, max_iterations + 1):
        r = potential_force(ctx, u_qm + y)
        d = None
        if solve is not None and decrement < 0.1 * previous:  # modified Newton: keep the LU
            d = -solve(r[free])
            if float(r[free] @ d) >= 0.0:
                d = None
        if d is None:
            mu = 0.1 * mu if mu > 1e-3 * ctx.shift_scale else 0.0  # last shift, relaxed
            solve, mu, d = _descent_solver(ctx, u_qm + y, r[free], mu)
        dy = np.zeros_like(y)
        dy[free] = d
        slope = float(r @ dy)
        previous, decrement = decrement, 0.5 * abs(slope)
        if _converged(decrement, value):
            return Condensed(value, y, it - 1, decrement, True)
        y, value = _line_search(energy, y, dy, value, slope)
    return Condensed(value, y, max_iterations, decrement, _converged(decrement, value))


#: Continuation schedules of :func:`condensed_energy_along_ray` (equal steps along the ray).
RAY_SCHEDULES = (1, 4, 16)


def condensed_energy_along_ray(ctx: EnergyContext, s: np.ndarray, progress=None) -> Condensed:
    """:func:`condensed_energy` at ``s`` (N,) reached by continuation along the ray ``a s``,
    ``a → 1``, in 1, 4 and then 16 equal steps until Newton converges at every step (a large
    deformation is not reached from the quadratic-manifold point in one go). The result's
    ``converged`` is False if even 16 steps fail. ``progress(fraction)``, if given, is called
    after every continuation step with the share of the worst-case schedule done."""
    s = np.asarray(s, float)
    total, done = sum(RAY_SCHEDULES), 0
    for steps in RAY_SCHEDULES:
        y = None
        for a in np.linspace(0.0, 1.0, steps + 1)[1:]:
            result = condensed_energy(ctx, a * s, y0=y)
            done += 1
            if progress:
                progress(done / total)
            if not result.converged:
                break
            y = result.unknowns
        if result.converged:
            return result
        done = sum(RAY_SCHEDULES[: RAY_SCHEDULES.index(steps) + 1])
    return result
