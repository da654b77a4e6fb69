"""Candidate reduced potentials against the FE model's own statically condensed energy.

Research code (issue 9, static gate; docs/potentials.md), not part of the public API: evidence
for the choice of a bounded reduced potential. For a reduced model (Φ, g^{mn}, Λ, V3, V4) built
about the inflated equilibrium ``x0`` of a structure, at modal coordinates ``s`` (N,) (√kg·m)
this module evaluates (all in J, all minus the value at ``x0``):

* ``V_Q(s) = ½ sᵀΛs`` and ``V_Q4(s)`` (the project's Q4, from :mod:`quadmodes.rom.dynamics`);
* ``QE(s) = Π(x_QM(s))``, ``x_QM(s) = x0 + Φs + Σ_mn s_m s_n g^{mn}`` (no ½): the exact FE
  total potential on the quadratic-mode manifold;
* ``W_red(s) = min_η Π(x_QM(s) + G⊥η)``, G⊥ an M-orthonormal basis of the quadratic modes
  M-orthogonalised against the retained and rigid modes (Newton on η, ``G⊥ᵀ K G⊥``);

to be compared with ``W_c(s) = min_y Π(x_QM(s) + y)`` over all ``y`` with ``Φᵀ M y = 0`` and
``Ψᵀ M y = 0``, the statically condensed energy of the FE model
(:func:`quadmodes.rom.manifold_energy.condensed_energy`, whose module also defines Π̃, the
energy context and the chart).

**Chart.** Since ``x_QM(s) + G⊥η = x0 + Φσ + Σ ss g⊥ + G⊥η`` (σ(s) the M-projection of
``x_QM(s) − x0`` on Φ), W_red is, like W_c, the minimum at the projected coordinate σ(s)
written in the chart s. In this chart the feasible sets are nested (QM point ⊂ W_red set ⊂ W_c
set), so ``W_c ≤ W_red ≤ QE``, and ``W_c − QE = O(|s|⁶)``: Q4 (the fourth-order Taylor
polynomial of QE) is then also that of W_c.
"""

from __future__ import annotations

import numpy as np

from quadmodes.rom import dynamics as dyn
from quadmodes.rom import system as rsys
from quadmodes.rom.manifold_energy import (
    Condensed,
    EnergyContext,
    _converged,
    _line_search,
    _tangent,
    manifold_displacement,
    potential_force,
    total_potential,
)
from quadmodes.rom.reduced import ReducedModel

# ---------------------------------------------------------------------------------------------
# Potentials of the reduced model
# ---------------------------------------------------------------------------------------------


def quadratic_potential(model: ReducedModel, s: np.ndarray) -> float:
    """``V_Q = ½ sᵀΛs`` (J) at ``s`` (N,) (formulation Q)."""
    return float(0.5 * s @ model.Lam @ s)


def quartic_system(model: ReducedModel) -> rsys.ReducedSystem:
    """The formulation-"Q4" :class:`~quadmodes.rom.system.ReducedSystem` of ``model``."""
    return rsys.reduced_system(model, "Q4")


def quartic_potential(system: rsys.ReducedSystem, s: np.ndarray) -> float:
    """``V_Q4(s)`` (J) of the Q4 system at ``s`` (N,), by :func:`rom.dynamics.potential_energy`."""
    y = np.zeros(7 + 2 * system.n_modes)
    y[0] = 1.0
    y[7 : 7 + system.n_modes] = s
    return float(dyn.potential_energy(system, y))


# ---------------------------------------------------------------------------------------------
# Exact FE energies on the quadratic manifold and condensed on G⊥
# ---------------------------------------------------------------------------------------------


def manifold_energy(ctx: EnergyContext, s: np.ndarray) -> float:
    """``QE(s) = Π̃(x_QM(s))`` (J): the exact total potential on the quadratic manifold."""
    return total_potential(ctx, manifold_displacement(ctx, s))


def _spd_solve(h: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``h⁻¹ rhs`` for a symmetric ``h``, with eigenvalues below 1e-8·max raised to it (a
    descent direction also where the projected tangent is indefinite)."""
    lam, vec = np.linalg.eigh(0.5 * (h + h.T))
    floor = 1e-8 * np.abs(lam).max()
    return vec @ ((vec.T @ rhs) / np.maximum(np.abs(lam), floor))


def condensed_quadratic_mode_energy(
    ctx: EnergyContext, s: np.ndarray, eta0: np.ndarray | None = None, max_iterations: int = 40
) -> Condensed:
    """``W_red(s) = min_η Π̃(x_QM(s) + G⊥η)`` (J) by Newton on η (q,) with the projected
    tangent ``G⊥ᵀKG⊥`` (eigenvalues made positive if it is indefinite) and an energy line
    search, from ``eta0`` (default 0: the quadratic-manifold point)."""
    u_qm = manifold_displacement(ctx, s)
    gp = ctx.g_perp
    eta = np.zeros(gp.shape[1]) if eta0 is None else np.asarray(eta0, float).copy()

    def energy(e):
        return total_potential(ctx, u_qm + gp @ e)

    value = energy(eta)
    decrement = np.inf
    for it in range(1, max_iterations + 1):
        u = u_qm + gp @ eta
        grad = gp.T @ potential_force(ctx, u)
        k, low = _tangent(ctx, u)
        h = gp.T @ (k @ gp)
        for c, v in low:
            h += c * np.outer(gp.T @ v, gp.T @ v)
        d = -_spd_solve(h, grad)
        slope = float(grad @ d)
        decrement = 0.5 * abs(slope)
        if _converged(decrement, value):
            return Condensed(value, eta, it - 1, decrement, True)
        eta, value = _line_search(energy, eta, d, value, slope)
    return Condensed(value, eta, max_iterations, decrement, _converged(decrement, value))


def best_start(ctx: EnergyContext, s: np.ndarray, candidates) -> np.ndarray:
    """The feasible start ``y`` ``(m,)`` of lowest ``Π̃(x_QM(s) + y)`` among ``candidates``
    (the quadratic-manifold point y = 0 is always one)."""
    u_qm = manifold_displacement(ctx, s)
    starts = [np.zeros_like(u_qm)] + [np.asarray(c, float) for c in candidates if c is not None]
    values = [total_potential(ctx, u_qm + y) for y in starts]
    return starts[int(np.argmin(values))]
