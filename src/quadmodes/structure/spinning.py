"""The spinning prestressed state: the centrifugal relative equilibrium of the finite-element
model turning at a constant rate, and the rotating-frame operators about it. The reduced model
can be expanded about this state (``reduced.reference = "spinning"``,
:mod:`quadmodes.rom.reduced`), and the full-order rotating-frame analysis linearises about it:
the eigenproblem is in
:mod:`quadmodes.analysis.rotating_modes`, the comparison in
:mod:`quadmodes.analysis.rotating_comparison`.

**Frame and equations.** The frame turns at the constant rate Ω about the unit axis ``e`` through
the point ``a`` (the centre of mass for a free body, the hub point for a clamped one). With
``M = M_s ⊗ I_3`` the kinetic energy of the rotating-frame vector DOFs ``x`` is

    T = ½ (ẋ + Ω Ê r)ᵀ M (ẋ + Ω Ê r),   r = x − t ⊗ a,   Ê = I_n ⊗ [e]×,

for *every* row: positions and ANCF slope rows alike turn with the frame (``t`` is the
translational indicator, so slopes carry no axis offset). Because ``M_s ⊗ I_3`` commutes with
``Ê`` and ``Ê`` is skew, Lagrange's equations are

    M ẍ + 2Ω M Ê ẋ + f(x) − Ω² M P̂ r = 0,   P̂ = I_n ⊗ (I − e eᵀ)   (−Ê² = P̂),

so the centrifugal force is ``Ω² M_s (r P⊥)`` (N) on all rows, the relative equilibrium solves
``f(x) = Ω² M P̂ r``, and the linearisation about it is

    M q̈ + G q̇ + K q = 0,   G = 2Ω M Ê (skew),   K = K_T(x*) − Ω² M P̂ (centrifugal softening).

These are the rotating-frame frequencies of :mod:`quadmodes.analysis.campbell`: eigenvalues λ, frequency
|Im λ|, for a frame turning with the body at the relative equilibrium.

**Free body: null directions.** At Ω ≠ 0 only two rigid motions leave the rotating-frame problem
unchanged: the translation along ``e`` and the rotation about ``e`` (``K_T ψ_e = e × f = Ω² M Ê r``
cancels the centrifugal term exactly). Transverse translations move the centre of mass off the
axis (net force −Ω² m δc) and transverse tilts meet the centrifugal moment Ω²(I_e − I_⊥)θ, so they
are determined by the equations and must not be constrained (a constraint would exert a reaction;
it is how the body finds the principal axis next to ``e``). The bordered Newton therefore uses the
two mass-weighted conditions ``e·δc = 0`` and ``ψ_eᵀ M δx = 0``; both are orthogonal to the
residual identically, so their multipliers stay at round-off. At Ω = 0 all six are null and all six
are used, as in :mod:`quadmodes.structure.prestress`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.model import (
    Structure,
    centre_of_mass,
    internal_force,
    mass_matrix,
    rigid_body_modes,
    tangent_low_rank,
    tangent_stiffness,
)
from quadmodes.fe.pressure import PressureSet, enclosed_volume
from quadmodes.rotations import skew, unit_axis
from quadmodes.structure.bordered import bordered_solver
from quadmodes.structure.prestress import ConvergenceError, backtracking_step

# ---------------------------------------------------------------------------------------------
# rotating-frame operators
# ---------------------------------------------------------------------------------------------


def default_centre(structure: Structure, x: np.ndarray) -> np.ndarray:
    """Axis point (3,) (m): the centre of mass of ``x`` for a free body, the origin (the hub point
    of :func:`quadmodes.fe.build.build_beam_structure`) for a clamped one."""
    return centre_of_mass(structure, x) if structure.is_free else np.zeros(3)


def arm(structure: Structure, x: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """``r = x − t ⊗ a`` (n, 3): positions measured from the axis point, slope rows unchanged."""
    return x - np.outer(structure.translational.astype(float), centre)


def centrifugal_force(
    structure: Structure, x: np.ndarray, spin: float, axis, centre: np.ndarray
) -> np.ndarray:
    """Centrifugal force ``Ω² M_s (r P⊥)`` (n, 3) (N) at spin ``spin`` (rad/s) about the axis
    ``axis`` through ``centre`` (m); on slope rows the same form acts on the slope vectors."""
    e = unit_axis(axis)
    r = arm(structure, x, centre)
    perp = r - np.outer(r @ e, e)
    return spin**2 * (structure.mass_scalar @ perp)


def rotating_residual(
    structure: Structure, x: np.ndarray, spin: float, axis, centre: np.ndarray
) -> np.ndarray:
    """Rotating-frame equilibrium residual ``f(x) − Ω² M P̂ r`` (n, 3) (N); zero on clamped
    components (reactions)."""
    res = internal_force(structure, x) - centrifugal_force(structure, x, spin, axis, centre)
    res[structure.fixed] = 0.0
    return res


def centrifugal_softening(structure: Structure, spin: float, axis) -> sp.csr_matrix:
    """``Ω² M_s ⊗ (I − e eᵀ)`` (3n, 3n) (N/m), to be subtracted from the tangent stiffness."""
    e = unit_axis(axis)
    return sp.kron(structure.mass_scalar, spin**2 * (np.eye(3) - np.outer(e, e)), format="csr")


def gyroscopic_matrix(structure: Structure, spin: float, axis) -> sp.csr_matrix:
    """Coriolis matrix ``G = 2Ω M_s ⊗ [e]×`` (3n, 3n) (kg/s), skew-symmetric."""
    e = unit_axis(axis)
    return sp.kron(structure.mass_scalar, 2.0 * spin * skew(e), format="csr")


def rotating_stiffness(structure: Structure, x: np.ndarray, spin: float, axis) -> sp.csr_matrix:
    """``K_T(x) − Ω² M P̂`` (3n, 3n) (N/m), without the global gas-law rank-one terms
    (:func:`quadmodes.fe.model.tangent_low_rank`, unchanged by the spin)."""
    return (tangent_stiffness(structure, x) - centrifugal_softening(structure, spin, axis)).tocsr()


#: A mode of the rotating-frame stiffness whose frequency is below this fraction of the spin,
#: of either sign, is neutral: a motion with no stiffness of its own at this spin (a blade
#: hinged on the axis turning about it, an exact symmetry), whose sign is round-off.
NEUTRAL_RATIO = 1e-3


def neutral_modes(frequencies_hz: np.ndarray, spin: float) -> np.ndarray:
    """(N,) True where the rotating-frame frequency (Hz, negative: ω² < 0) is neutral at
    ``spin`` (rad/s): ``|2πf| ≤`` :data:`NEUTRAL_RATIO` ``|Ω|``. The whole body's rotation about
    the spin axis never appears here: the frame conditions remove it."""
    return np.abs(2.0 * np.pi * np.asarray(frequencies_hz, float)) <= NEUTRAL_RATIO * abs(spin)


def null_constraints(structure: Structure, x: np.ndarray, spin: float, axis) -> np.ndarray | None:
    """Mass-weighted frame conditions ``C`` (3n, k) for the bordered solve of a free body: the
    two null directions of the spinning problem (translation along e, rotation about e through the
    centre of mass) when ``spin ≠ 0``, all six rigid motions at rest; None for a clamped body."""
    if not structure.is_free:
        return None
    e = unit_axis(axis)
    psi = rigid_body_modes(structure, x)
    if spin == 0.0:
        cols = psi
    else:
        cols = np.stack([psi[:, :3] @ e, psi[:, 3:] @ e], axis=1)
    return mass_matrix(structure) @ cols


# ---------------------------------------------------------------------------------------------
# relative equilibrium
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SpinningEquilibrium:
    """Relative equilibrium in the frame turning at ``spin`` about ``axis`` through ``centre``.

    x (n, 3) m: vector DOFs. spin rad/s. axis (3,), centre (3,) m. residual: final
    ‖f − Ω²MP̂r‖ on the free DOFs relative to the larger of the centrifugal and pressure force
    norms. multiplier_ratio: ‖C λ‖ / ‖f_c‖ of the frame conditions' reactions (≈ 0: no spurious
    support). volume0, volume (m³): enclosed volume of the reference state (at rest) and here (0
    without a pressure set). iterations: Newton iterations in total.
    """

    x: np.ndarray
    spin: float
    axis: np.ndarray
    centre: np.ndarray
    residual: float
    multiplier_ratio: float
    volume0: float
    volume: float
    iterations: int

    @property
    def volume_change(self) -> float:
        return self.volume / self.volume0 - 1.0 if self.volume0 else 0.0


def _volume(structure: Structure, x: np.ndarray) -> float:
    sets = [e for e in structure.elements if isinstance(e, PressureSet)]
    return sum(enclosed_volume(x, s.conn) for s in sets) if sets else 0.0


def _residual_scale(structure: Structure, x, spin, e, centre, r: np.ndarray) -> float:
    """Force scale (N) of the convergence test: centrifugal plus pressure force norms on the free
    DOFs, at least ‖r‖, floored for load-free states (a beam at rest) at the force of a 1e-6
    strain on the stiffest DOF."""
    free = structure.free_dofs
    scale = np.linalg.norm(centrifugal_force(structure, x, spin, e, centre).ravel()[free])
    scale += sum(
        np.linalg.norm(s.force(x)) for s in structure.elements if isinstance(s, PressureSet)
    )
    k_diag = np.abs(rotating_stiffness(structure, x, spin, e).diagonal()[free]).max()
    extent = float(np.ptp(x[structure.translational], axis=0).max()) if x.size else 1.0
    return max(scale, np.linalg.norm(r), 1e-6 * k_diag * extent)


def _newton(structure, x, spin, e, centre, constraint, rtol, max_iterations):
    """Newton–Raphson with backtracking on ``rotating_residual``; the increments satisfy
    ``Cᵀ Δx = 0`` (bordered solve). Returns ``(x, relative residual, iterations)``."""
    free = structure.free_dofs
    cf = None if constraint is None else constraint[free]

    def residual(y: np.ndarray) -> np.ndarray:
        return rotating_residual(structure, y, spin, e, centre).ravel()[free]

    r = residual(x)
    scale = _residual_scale(structure, x, spin, e, centre, r)
    rel = np.linalg.norm(r) / scale
    history = [rel]
    for it in range(1, max_iterations + 1):
        stalled = len(history) > 3 and rel < 1e-8 and rel > 0.5 * min(history[-4:-1])
        if rel <= rtol or stalled:
            return x, rel, it - 1
        k = rotating_stiffness(structure, x, spin, e)[free][:, free]
        low = [(c, v[free]) for c, v in tangent_low_rank(structure, x)]
        solve = bordered_solver(k, cf, low)
        dx = np.zeros(3 * structure.n)
        dx[free] = -solve(r)
        x, r, _ = backtracking_step(residual, x, dx.reshape(-1, 3), r, rel, 1e-7)
        rel = np.linalg.norm(r) / scale
        history.append(rel)
        if not np.isfinite(rel):
            break
    raise ConvergenceError(
        f"spinning equilibrium: Newton did not converge at {spin / (2 * np.pi):.4g} Hz "
        f"(relative residual {rel:.2e} after {max_iterations} iterations)"
    )


def _multiplier_ratio(structure, x, spin, e, centre, constraint) -> float:
    """‖C λ‖/‖f_c‖ with λ the least-squares multipliers of the residual: the reaction the frame
    conditions would have to supply (0 if they only remove null directions)."""
    if constraint is None:
        return 0.0
    free = structure.free_dofs
    r = rotating_residual(structure, x, spin, e, centre).ravel()[free]
    c = constraint[free]
    lam = np.linalg.lstsq(c, r, rcond=None)[0]
    fc = np.linalg.norm(centrifugal_force(structure, x, spin, e, centre).ravel()[free])
    return float(np.linalg.norm(c @ lam) / max(fc, 1e-300))


def relative_equilibrium(
    structure: Structure,
    x_start: np.ndarray,
    spin: float,
    axis,
    centre: np.ndarray | None = None,
    start_spin: float = 0.0,
    reference: np.ndarray | None = None,
    rtol: float = 1e-10,
    max_iterations: int = 40,
    max_halvings: int = 8,
) -> SpinningEquilibrium:
    """Relative equilibrium of ``structure`` spinning at ``spin`` (rad/s) about ``axis`` through
    ``centre`` (m; default :func:`default_centre` of ``x_start``), from ``x_start`` (n, 3) (m), the
    equilibrium at ``start_spin`` (rad/s; e.g. the inflated state at 0). ``reference``: the state
    whose enclosed volume is ``volume0`` (default ``x_start``; pass the state at rest when
    continuing from another spin rate).

    Bordered Newton (module docstring: the conditions remove exactly the null directions). If
    Newton fails, the spin is approached by continuation in Ω² from ``start_spin``, halving the
    increment up to ``max_halvings`` times."""
    e = unit_axis(axis)
    c = default_centre(structure, x_start) if centre is None else np.asarray(centre, float)
    x, total, rel = np.array(x_start, float), 0, 0.0
    lo, pending, halvings = float(start_spin) ** 2, [float(spin) ** 2], 0
    while pending:
        om = float(np.sqrt(pending[-1]))
        try:
            con = null_constraints(structure, x_start, om, e)
            x_new, rel, its = _newton(structure, x, om, e, c, con, rtol, max_iterations)
        except (ConvergenceError, RuntimeError):
            if halvings >= max_halvings:
                raise
            halvings += 1
            pending.append(0.5 * (lo + pending[-1]))
            continue
        x, total, lo = x_new, total + its, pending.pop()
    om = abs(float(spin))
    con = null_constraints(structure, x_start, om, e)
    return SpinningEquilibrium(
        x=x,
        spin=float(spin),
        axis=e,
        centre=c,
        residual=float(rel),
        multiplier_ratio=_multiplier_ratio(structure, x, om, e, c, con) if om else 0.0,
        volume0=_volume(structure, x_start if reference is None else reference),
        volume=_volume(structure, x),
        iterations=total,
    )
