"""Full-order rotating-frame analysis: the centrifugal relative equilibrium of the finite-element
model spinning at a constant rate, its linearised (gyroscopic) eigenproblem, and the comparison
of those frequencies with the reduced model's (:mod:`quadmodes.analysis.campbell`).

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

**Eigenproblem.** ``K`` is indefinite for a free spinning body (−Ω² m on transverse translations,
Ω²(I_e − I_⊥) < 0 on tilts about a minor axis) and singular (rotation about ``e``), so the usual
symmetric form of a gyroscopic system, which needs K ≻ 0, is not available. The roots are found
instead by complex shift-invert Arnoldi (``scipy.sparse.linalg.eigs``) on the companion pencil
``A z = λ B z``, ``z = (q, q̇)``, ``A = [[0, I], [−K, −G]]``, ``B = diag(I, M)``: one sparse complex
LU of ``K + σG + σ²M`` (3n) per shift σ = i·ω_target applies ``(A − σB)⁻¹B``. Rigid roots of the
free body: the translations are an exactly invariant subspace with roots 0 (along e) and the
defective ±iΩ (across e); Arnoldi runs on the mass-weighted complement (centre of mass fixed), where
they do not exist. The tilt about a transverse axis (the equilibrium spinning about a slightly
tilted axis) is the exact root iΩ with a pure rigid-rotation eigenvector; it has no counterpart in
the reduced model (it is a change of attitude, not of ω or s) and is labelled ``"tilt"``; the
rotation about ``e`` and the spin-rate change give a double zero, far from the shifts.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import linear_sum_assignment

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
from quadmodes.rotations import skew
from quadmodes.structure.prestress import ConvergenceError, _bordered_solver

Progress = Callable[[str, float], None]

#: Rows whose full-order root has less than this share of kinetic energy in the reduced
#: coordinates are flagged in :meth:`ComparisonTable.to_text`.
POORLY_CAPTURED = 0.5

#: Relative offset of a shift from its target frequency (keeps K + σG + σ²M regular).
SHIFT_OFFSET = 3e-3

# ---------------------------------------------------------------------------------------------
# rotating-frame operators
# ---------------------------------------------------------------------------------------------


def unit_axis(axis) -> np.ndarray:
    """The unit vector (3,) along ``axis``; raises ValueError for a zero or malformed axis."""
    e = np.asarray(axis, float)
    norm = np.linalg.norm(e)
    if e.shape != (3,) or not norm > 0.0:
        raise ValueError("axis: give a non-zero 3-vector")
    return e / norm


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


def _newton(structure, x, spin, e, centre, constraint, rtol, max_iterations):
    """Newton–Raphson with backtracking on ``rotating_residual``; the increments satisfy
    ``Cᵀ Δx = 0`` (bordered solve). Returns ``(x, relative residual, iterations, multipliers)``."""
    free = structure.free_dofs
    cf = None if constraint is None else constraint[free]
    r = rotating_residual(structure, x, spin, e, centre).ravel()[free]
    scale = np.linalg.norm(centrifugal_force(structure, x, spin, e, centre).ravel()[free])
    scale += sum(
        np.linalg.norm(s.force(x)) for s in structure.elements if isinstance(s, PressureSet)
    )
    # floor for load-free states (a beam at rest): the force of a 1e-6 strain on the stiffest DOF
    k_diag = np.abs(rotating_stiffness(structure, x, spin, e).diagonal()[free]).max()
    extent = float(np.ptp(x[structure.translational], axis=0).max()) if x.size else 1.0
    scale = max(scale, np.linalg.norm(r), 1e-6 * k_diag * extent)
    rel = np.linalg.norm(r) / scale
    history = [rel]
    for it in range(1, max_iterations + 1):
        stalled = len(history) > 3 and rel < 1e-8 and rel > 0.5 * min(history[-4:-1])
        if rel <= rtol or stalled:
            return x, rel, it - 1
        k = rotating_stiffness(structure, x, spin, e)[free][:, free]
        low = [(c, v[free]) for c, v in tangent_low_rank(structure, x)]
        solve = _bordered_solver(k, cf, low)
        dx = np.zeros(3 * structure.n)
        dx[free] = -solve(r)
        dx = dx.reshape(-1, 3)
        step = 1.0
        for _ in range(12):
            trial = x + step * dx
            r_trial = rotating_residual(structure, trial, spin, e, centre).ravel()[free]
            if np.linalg.norm(r_trial) < (1.0 - 1e-4 * step) * np.linalg.norm(r) or rel < 1e-7:
                break
            step *= 0.5
        x, r = trial, r_trial
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


# ---------------------------------------------------------------------------------------------
# linearised rotating-frame eigenproblem
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RotatingRoots:
    """Roots of ``(λ²M + λG + K) q = 0`` near the requested targets (Im λ > 0 only).

    lam (k,) complex 1/s: eigenvalues, ascending Im λ. shapes (k, n, 3) complex (1/√kg):
    displacement parts, mass-normalised (qᴴMq = 1), zero on clamped components.
    rigid_fraction (k,): mass-weighted share of the rigid motions (about the centre of mass) in q.
    residual (k,): ‖(λ²M + λG + K) q‖ / (|λ|²‖Mq‖ + ‖Kq‖). kind (k,): "elastic", or "tilt" for
    the exact rigid root iΩ of a free body (attitude change, no reduced-model counterpart).
    """

    lam: np.ndarray
    shapes: np.ndarray
    rigid_fraction: np.ndarray
    residual: np.ndarray
    kind: tuple[str, ...]
    spin: float

    @property
    def frequency_hz(self) -> np.ndarray:
        return np.abs(self.lam.imag) / (2.0 * np.pi)


def _complex_solver(q: sp.spmatrix, low_rank) -> Callable:
    """Sparse complex LU of ``Q + Σ c v vᵀ`` (Sherman–Morrison for the gas-law terms)."""
    lu = spla.splu(q.tocsc(), permc_spec="COLAMD")
    if not low_rank:
        return lu.solve
    pre = [(c, v, lu.solve(v.astype(complex))) for c, v in low_rank]

    def solve(b):
        y = lu.solve(b)
        for c, v, kv in pre:
            y = y - kv * (c * (v @ y) / (1.0 + c * (v @ kv)))
        return y

    return solve


def rotating_roots(
    structure: Structure,
    x: np.ndarray,
    spin: float,
    axis,
    targets_hz: Sequence[float],
    per_target: int = 6,
    tol: float = 1e-12,
    merge_rtol: float = 0.25,
    seed: int = 0,
) -> RotatingRoots:
    """Roots of the rotating-frame linearisation about ``x`` (an equilibrium at ``spin`` rad/s
    about ``axis``) nearest to each of ``targets_hz`` (Hz, rotating frame).

    Complex shift-invert Arnoldi on the companion pencil, one LU of ``K + σG + σ²M`` per shift
    σ = 2πi f (targets closer than ``merge_rtol`` share a shift), ``per_target`` roots per shift;
    for a free body the Krylov space is kept on the centre-of-mass-free subspace (module
    docstring). Roots found by several shifts are merged."""
    e = unit_axis(axis)
    free = structure.free_dofs
    nf = free.size
    m = mass_matrix(structure)[free][:, free].tocsr()
    k = rotating_stiffness(structure, x, spin, e)[free][:, free].tocsr()
    g = gyroscopic_matrix(structure, spin, e)[free][:, free].tocsr()
    low = [(c, v[free]) for c, v in tangent_low_rank(structure, x)]
    if structure.is_free:
        t = rigid_body_modes(structure, x)[free][:, :3]
        mt = m @ t
        # complex, contiguous copies: mixed real/complex products fall off the BLAS fast path
        left = np.ascontiguousarray(t, dtype=complex)
        right = np.ascontiguousarray(np.linalg.solve(t.T @ mt, mt.T), dtype=complex)

        def project(v):  # M-orthogonal removal of the translations (CoM fixed)
            return v - left @ (right @ v)
    else:

        def project(v):
            return v

    def k_apply(v):
        out = k @ v
        for c, w in low:
            out = out + c * w * (w @ v)
        return out

    # shifts: targets grouped into clusters spanning at most a factor (1 + merge_rtol); a shift
    # exactly on a root makes K + σG + σ²M singular (at Ω = 0 the targets are the roots), so it
    # sits SHIFT_OFFSET above the cluster centre; a zero target (divergence) is searched just
    # above the real axis
    clusters: list[list[float]] = []
    for f in sorted(max(abs(float(f)), 0.05) for f in targets_hz):
        if clusters and f <= clusters[-1][0] * (1.0 + merge_rtol):
            clusters[-1].append(f)
        else:
            clusters.append([f])
    rng = np.random.default_rng(seed)
    found_lam, found_q = [], []
    for cluster in clusters:
        centre_hz = 0.5 * (cluster[0] + cluster[-1]) * (1.0 + SHIFT_OFFSET)
        sigma = 2j * np.pi * centre_hz
        solve = _complex_solver((k + sigma * g + sigma**2 * m).astype(complex), low)

        def op(z, sigma=sigma, solve=solve):
            z1, z2 = project(z[:nf]), project(z[nf:])
            y1 = project(-solve(m @ z2 + g @ z1 + sigma * (m @ z1)))
            return np.concatenate([y1, z1 + sigma * y1])

        a = spla.LinearOperator((2 * nf, 2 * nf), matvec=op, dtype=complex)
        v0 = rng.standard_normal(2 * nf) + 1j * rng.standard_normal(2 * nf)
        v0 = np.concatenate([project(v0[:nf]), project(v0[nf:])])
        reach = 2.0 * np.pi * max(abs(f - centre_hz) for f in cluster)
        kk = per_target + 2 * len(cluster)
        while True:
            kk = min(kk, 2 * nf - 2)
            ncv = min(2 * nf, max(2 * kk + 1, 20))
            nu, vec = spla.eigs(a, k=kk, which="LM", v0=v0, tol=tol, ncv=ncv)
            lam = sigma + 1.0 / nu
            # every target must lie well inside the disc of roots found around σ, so that the
            # roots nearest to it are all among them
            if reach <= 0.6 * np.abs(lam - sigma).max() or kk >= 2 * nf - 2:
                break
            kk *= 2
        found_lam.append(lam)
        found_q.append(vec[:nf].T)
    lam = np.concatenate(found_lam)
    qs = np.concatenate(found_q)
    keep = lam.imag > 1e-9 * max(1.0, np.abs(lam).max())
    lam, qs = lam[keep], qs[keep]
    # residuals and mass normalisation
    mq = (m @ qs.T).T
    kq = np.stack([k_apply(q) for q in qs]) if qs.size else qs
    gq = (g @ qs.T).T
    res = lam[:, None] ** 2 * mq + lam[:, None] * gq + kq
    resid = np.linalg.norm(res, axis=1) / (
        np.abs(lam) ** 2 * np.linalg.norm(mq, axis=1) + np.linalg.norm(kq, axis=1)
    )
    norms = np.sqrt(np.einsum("ki,ki->k", qs.conj(), mq).real)
    qs, mq = qs / norms[:, None], mq / norms[:, None]
    # a root found by several shifts: keep the most accurate copy (the nearest shift's); two
    # roots are the same if the eigenvalues agree to 1e-6 and the shapes are parallel (so an exactly
    # degenerate pair keeps both members)
    uniq: list[int] = []
    for i in np.argsort(resid):
        same = [
            j
            for j in uniq
            if abs(lam[i] - lam[j]) <= 1e-6 * abs(lam[i]) and abs(qs[j].conj() @ mq[i]) ** 2 > 0.9
        ]
        if not same:
            uniq.append(int(i))
    uniq = sorted(uniq, key=lambda i: lam[i].imag)
    lam, qs, resid = lam[uniq], qs[uniq], resid[uniq]
    full = np.zeros((lam.size, 3 * structure.n), complex)
    full[:, free] = qs
    rigid = _rigid_fraction(structure, x, full)
    kind = tuple(
        "tilt"
        if structure.is_free
        and spin != 0.0
        and rigid[i] > 0.99
        and abs(lam[i].imag - abs(spin)) <= 1e-6 * abs(spin)
        else "elastic"
        for i in range(lam.size)
    )
    return RotatingRoots(
        lam=lam,
        shapes=full.reshape(lam.size, structure.n, 3),
        rigid_fraction=rigid,
        residual=resid,
        kind=kind,
        spin=float(spin),
    )


def _rigid_fraction(structure: Structure, x: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Mass-weighted rigid share (k,) of complex vectors (k, 3n); 0 for a clamped body."""
    if not structure.is_free or vectors.size == 0:
        return np.zeros(vectors.shape[0])
    psi = rigid_body_modes(structure, x)
    m = mass_matrix(structure)
    mpsi = m @ psi
    coef = np.linalg.solve(psi.T @ mpsi, mpsi.T @ vectors.T)  # (6, k)
    rig = np.einsum("ik,ij,jk->k", coef.conj(), psi.T @ mpsi, coef).real
    tot = np.einsum("ki,ki->k", vectors.conj(), (m @ vectors.T).T).real
    return rig / np.maximum(tot, 1e-300)


# ---------------------------------------------------------------------------------------------
# identification with reduced-model branches
# ---------------------------------------------------------------------------------------------


def rotation_and_modal_parts(
    structure: Structure, x: np.ndarray, phi: np.ndarray, shapes: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Best-fit (mass-weighted) rigid rotation θ (k, 3) about the centre of mass of ``x`` and the
    modal coordinates ``a = Φᵀ M (q − Ψθ)`` (k, N) (√kg·m per unit q) of full-order shapes
    (k, n, 3); ``phi`` (N, n, 3) the retained (mass-normalised) modes. θ is zero for a clamped
    body."""
    m = mass_matrix(structure)
    q = shapes.reshape(shapes.shape[0], -1).T  # (3n, k)
    if structure.is_free:
        psi = rigid_body_modes(structure, x)
        mpsi = m @ psi
        coef = np.linalg.solve(psi.T @ mpsi, mpsi.T @ q)
        theta = coef[3:]
        q = q - psi[:, 3:] @ theta
    else:
        theta = np.zeros((3, q.shape[1]), complex)
    a = phi.reshape(phi.shape[0], -1) @ (m @ q)
    return theta.T, a.T


def comparison_vectors(
    lam: np.ndarray, delta_omega: np.ndarray, ds: np.ndarray, inertia: np.ndarray, lam_modes
) -> np.ndarray:
    """Energy-weighted vectors (k, 3 + 2N) ``(Lᵀδω, Λ^{1/2} δs, λ δs)`` used for the MAC between
    full-order and reduced roots (``inertia`` = L Lᵀ (3, 3) kg m², ``lam_modes`` (N,) ω_k² 1/s²):
    kinetic energy of rotation, strain and kinetic energy of the retained modes."""
    chol = np.linalg.cholesky(0.5 * (inertia + inertia.T))
    return np.concatenate(
        [delta_omega @ chol, ds * np.sqrt(np.maximum(lam_modes, 0.0)), lam[:, None] * ds], axis=1
    )


def full_order_comparison_vectors(
    structure: Structure, x: np.ndarray, roots: RotatingRoots, model, axis
) -> tuple[np.ndarray, np.ndarray]:
    """Comparison vectors (k, 3 + 2N) of full-order roots, and the share of each root's kinetic
    energy that the reduced coordinates (δω, s) capture (k,).

    The frame of the reduced model turns with the body (mean axes), so a best-fit rotation θ of
    the full-order shape appears there as ``δω = (λ + Ω[e]×) θ`` (linearised ``ω = Rᵀ(Ωe) + θ̇``)."""
    theta, a = rotation_and_modal_parts(structure, x, model.Phi, roots.shapes)
    e = unit_axis(axis)
    dw = roots.lam[:, None] * theta + roots.spin * np.cross(e, theta)
    vec = comparison_vectors(roots.lam, dw, a, model.J0, np.diag(model.Lam))
    # kinetic energy captured: |λ|²(θᵀJθ + |a|²) against |λ|² qᴴMq = |λ|² (mass-normalised q)
    jt = np.einsum("ka,ab,kb->k", theta.conj(), model.J0, theta).real
    captured = (jt + np.sum(np.abs(a) ** 2, axis=1)).real
    return vec, captured


def _mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC matrix (ka, kb) of the rows of ``a`` and ``b`` (Euclidean inner product)."""
    cross = a.conj() @ b.T
    na = np.sum(np.abs(a) ** 2, axis=1)
    nb = np.sum(np.abs(b) ** 2, axis=1)
    return np.abs(cross) ** 2 / np.maximum(np.outer(na, nb), 1e-300)


def match_branches(
    rom_vectors: np.ndarray,
    rom_lam: np.ndarray,
    full_vectors: np.ndarray,
    full_lam: np.ndarray,
    eligible: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Optimal assignment of reduced-model roots (nb) to eligible full-order roots by MAC of the
    comparison vectors, with a small frequency-distance tie-break. Returns ``(index (nb,) into the
    full-order roots, or −1; MAC (nb,))``."""
    idx = np.flatnonzero(eligible)
    nb = rom_vectors.shape[0]
    out, macs = np.full(nb, -1), np.zeros(nb)
    if idx.size == 0:
        return out, macs
    mac = _mac(rom_vectors, full_vectors[idx])
    scale = max(float(np.abs(rom_lam).max(initial=1.0)), 1.0)
    dist = np.abs(rom_lam[:, None] - full_lam[idx][None, :]) / scale
    rows, cols = linear_sum_assignment(-(mac - 0.1 * dist))
    out[rows] = idx[cols]
    macs[rows] = mac[rows, cols]
    return out, macs


# ---------------------------------------------------------------------------------------------
# comparison with the reduced model
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ComparisonRow:
    """One branch at one spin rate (frequencies in the rotating frame, Hz).

    full_hz: full-order root matched to the first formulation's branch (NaN if none).
    rom_hz / rel_error / mac: per formulation, the reduced-model frequency, (rom − full)/full and
    the MAC of that reduced root with the full-order root of this row. rom_growth: Re λ (1/s) of
    the reduced root (> 0: divergent). captured: share of the full-order root's kinetic energy in
    the reduced coordinates (δω, s). rigid_fraction: rigid share of the full-order shape.
    """

    spin_hz: float
    label: str
    full_hz: float
    full_growth: float
    rom_hz: dict[str, float]
    rel_error: dict[str, float]
    mac: dict[str, float]
    rom_growth: dict[str, float]
    captured: float
    rigid_fraction: float


@dataclass(frozen=True)
class ComparisonTable:
    """Full-order versus reduced rotating-frame frequencies (see :func:`rotating_frequency_
    comparison`). rows: branch rows; extra: full-order roots in the searched band that no branch
    claimed (label "tilt" for the rigid attitude root, "other" for elastic roots outside the
    reduced basis); equilibria: one per spin; timings: wall seconds per stage."""

    case: str
    axis: np.ndarray
    formulations: tuple[str, ...]
    rows: tuple[ComparisonRow, ...]
    extra: tuple[ComparisonRow, ...]
    equilibria: tuple[SpinningEquilibrium, ...]
    n_nodes: int
    timings: dict = field(default_factory=dict)

    def row(self, spin_hz: float, label: str) -> ComparisonRow:
        for r in self.rows:
            if abs(r.spin_hz - spin_hz) <= 1e-9 * max(1.0, spin_hz) and r.label == label:
                return r
        raise KeyError(f"no row for {label!r} at {spin_hz} Hz")

    def max_error(self, formulation: str, elastic_only: bool = False) -> float:
        """Largest |relative error| of ``formulation`` over the rows (NaN rows skipped)."""
        vals = [
            abs(r.rel_error[formulation])
            for r in self.rows
            if np.isfinite(r.rel_error[formulation])
            and not (elastic_only and r.label == "nutation")
        ]
        return max(vals, default=float("nan"))

    def to_text(self) -> str:
        """Markdown table of the rows, then the extra full-order roots."""
        head = "| spin (Hz) | branch | full order (Hz) |"
        sep = "|---|---|---|"
        for f in self.formulations:
            head += f" {f} (Hz) | {f} error | {f} MAC |"
            sep += "---|---|---|"
        head += " captured | rigid |"
        sep += "---|---|"
        lines = [head, sep]
        for r in self.rows:
            line = f"| {r.spin_hz:g} | {r.label} | {r.full_hz:.4f} |"
            for f in self.formulations:
                g = r.rom_growth[f]
                grow = f" (Re λ {g:+.3g})" if g > 1e-6 * max(1.0, 2 * np.pi * r.full_hz) else ""
                line += (
                    f" {r.rom_hz[f]:.4f}{grow} | {100 * r.rel_error[f]:+.3f} % | {r.mac[f]:.3f} |"
                )
            line += f" {r.captured:.3f} | {r.rigid_fraction:.3f} |"
            lines.append(line)
        if any(r.captured < POORLY_CAPTURED for r in self.rows):
            lines += [
                "",
                f"captured < {POORLY_CAPTURED}: the full-order root lies mostly outside the reduced "
                "basis (δω, Φs); its MAC only compares the captured part.",
            ]
        if self.extra:
            lines += ["", "Full-order roots in the searched band without a reduced branch:", ""]
            lines += [
                "| spin (Hz) | kind | full order (Hz) | captured | rigid |",
                "|---|---|---|---|---|",
            ]
            for r in self.extra:
                lines.append(
                    f"| {r.spin_hz:g} | {r.label} | {r.full_hz:.4f} | {r.captured:.3f} | "
                    f"{r.rigid_fraction:.3f} |"
                )
        return "\n".join(lines)


def _rom_roots(result, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(λ (nb,), δω (nb, 3), δs (nb, N)) of a free-body Campbell result at spin index i."""
    lam = result.growth[i] + 1j * result.frequency[i]
    v = result.vectors[i]
    n = (v.shape[1] - 3) // 2
    return lam, v[:, :3], v[:, 3 : 3 + n]


def case_state(case):
    """``(Case, structure for vibrations (gas law set), inflated state x (n, 3) m)`` of a case name,
    TOML path or Case (pipeline.structure_for_case, reference_state, with_gas_law)."""
    from quadmodes.case.schema import Case, load_case
    from quadmodes.structure.pipeline import reference_state, structure_for_case, with_gas_law

    if not isinstance(case, Case):
        case = load_case(case)
    structure = structure_for_case(case)
    x0, _ = reference_state(case, structure)
    return case, with_gas_law(case, structure, x0), x0


def rotating_frequency_comparison(
    case,
    spins_hz: Sequence[float] = (0.0, 20.0, 41.0),
    n_modes: int = 5,
    formulations: Sequence[str] = ("Q", "L"),
    axis=0,
    model=None,
    per_target: int = 6,
    progress: Progress | None = None,
) -> ComparisonTable:
    """Rotating-frame frequencies of the full-order FE model about its spinning relative
    equilibrium against :func:`quadmodes.analysis.campbell.campbell` of the reduced model, per spin rate
    (Hz, swept in the given order) and branch.

    ``case``: name, TOML path or Case of a free membrane body. ``axis``: spin axis (3-vector) or
    principal-axis index of the reduced model's J0 (0 minor, 2 major), as in campbell. ``model``:
    a ReducedModel of this case (default ``simulate.reduced_model_for(case, n_modes)``, cached).
    Full-order roots are searched near every reduced root (``per_target`` per shift) and assigned
    to branches by the MAC of energy-weighted (δω, s, ṡ) vectors (:func:`match_branches`)."""
    from quadmodes.analysis import campbell as cb
    from quadmodes.runs.model_cache import reduced_model_for

    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    case, structure, x0 = case_state(case)
    if not structure.is_free:
        raise ValueError("rotating_frequency_comparison: the case must be a free body")
    timings["inflation"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    rom = model if model is not None else reduced_model_for(case, n_modes)
    timings["reduced model"] = time.perf_counter() - t0
    if rom.X.shape != x0.shape:
        raise ValueError("model: the reduced model does not belong to this case (node count)")
    e = cb.principal_axis(rom, int(axis)) if isinstance(axis, int | np.integer) else unit_axis(axis)
    spins_hz = [float(s) for s in spins_hz]
    formulations = tuple(formulations)
    t0 = time.perf_counter()
    results = {
        f: cb.campbell(rom, 2.0 * np.pi * np.asarray(spins_hz), e, formulation=f)
        for f in formulations
    }
    timings["campbell"] = time.perf_counter() - t0
    labels = results[formulations[0]].labels
    timings["equilibrium"] = timings["eigen"] = 0.0
    rows, extra, equilibria = [], [], []
    x_prev, om_prev = x0, 0.0
    for i, fhz in enumerate(spins_hz):
        om = 2.0 * np.pi * fhz
        t0 = time.perf_counter()
        eq = relative_equilibrium(
            structure,
            x_prev,
            om,
            e,
            centre=centre_of_mass(structure, x0),
            start_spin=om_prev,
            reference=x0,
        )
        timings["equilibrium"] += time.perf_counter() - t0
        equilibria.append(eq)
        x_prev, om_prev = eq.x, om
        rom_data = {f: _rom_roots(results[f], i) for f in formulations}
        # shifts at the reference formulation's roots (the others are matched among the same
        # full-order roots); the nutation root is 0 at rest: no target there
        lam_ref = rom_data[formulations[0]][0]
        targets = sorted(
            {float(abs(v.imag)) / (2 * np.pi) for v in lam_ref if abs(v) > 1e-9 * max(1.0, om)}
        )
        t0 = time.perf_counter()
        roots = rotating_roots(structure, eq.x, om, e, targets, per_target=per_target)
        timings["eigen"] += time.perf_counter() - t0
        fvec, captured = full_order_comparison_vectors(structure, eq.x, roots, rom, e)
        eligible = np.array([k == "elastic" for k in roots.kind])
        assigned: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for f in formulations:
            lam, dw, ds = rom_data[f]
            vec = comparison_vectors(lam, dw, ds, rom.J0, np.diag(rom.Lam))
            rom_ok = np.abs(lam) > 1e-9 * max(1.0, om)  # zero roots (nutation at rest) unmatched
            idx, mac = match_branches(vec[rom_ok], lam[rom_ok], fvec, roots.lam, eligible)
            full_idx, full_mac = np.full(lam.size, -1), np.zeros(lam.size)
            full_idx[rom_ok], full_mac[rom_ok] = idx, mac
            assigned[f] = (full_idx, full_mac)
        ref_idx = assigned[formulations[0]][0]
        for b, label in enumerate(labels):
            j = ref_idx[b]
            full_hz = float(roots.frequency_hz[j]) if j >= 0 else (0.0 if om == 0.0 else np.nan)
            rom_hz, err, macs, growth = {}, {}, {}, {}
            for f in formulations:
                lam, dw, ds = rom_data[f]
                fb = results[f].labels.index(label) if label in results[f].labels else -1
                rom_hz[f] = float(abs(lam[fb].imag) / (2 * np.pi)) if fb >= 0 else np.nan
                growth[f] = float(lam[fb].real) if fb >= 0 else np.nan
                err[f] = (
                    (rom_hz[f] - full_hz) / full_hz
                    if full_hz and np.isfinite(full_hz)
                    else (0.0 if full_hz == 0.0 and rom_hz[f] == 0.0 else np.nan)
                )
                if j >= 0 and fb >= 0:
                    v = comparison_vectors(
                        lam[fb : fb + 1], dw[fb : fb + 1], ds[fb : fb + 1], rom.J0, np.diag(rom.Lam)
                    )
                    macs[f] = float(_mac(v, fvec[j : j + 1])[0, 0])
                else:
                    macs[f] = np.nan
            rows.append(
                ComparisonRow(
                    spin_hz=fhz,
                    label=label,
                    full_hz=full_hz,
                    full_growth=float(roots.lam[j].real) if j >= 0 else np.nan,
                    rom_hz=rom_hz,
                    rel_error=err,
                    mac=macs,
                    rom_growth=growth,
                    captured=float(captured[j]) if j >= 0 else np.nan,
                    rigid_fraction=float(roots.rigid_fraction[j]) if j >= 0 else np.nan,
                )
            )
        claimed = {int(j) for f in formulations for j in assigned[f][0] if j >= 0}
        lo, hi = min(targets, default=0.0), max(targets, default=0.0)
        for j in range(roots.lam.size):
            fj = roots.frequency_hz[j]
            if j in claimed or not (0.9 * lo <= fj <= 1.1 * hi):
                continue
            nan = {f: np.nan for f in formulations}
            extra.append(
                ComparisonRow(
                    fhz,
                    roots.kind[j] if roots.kind[j] == "tilt" else "other",
                    float(fj),
                    float(roots.lam[j].real),
                    nan,
                    nan,
                    nan,
                    nan,
                    float(captured[j]),
                    float(roots.rigid_fraction[j]),
                )
            )
        if progress:
            progress("rotating-frame comparison", (i + 1) / len(spins_hz))
    return ComparisonTable(
        case=case.name,
        axis=e,
        formulations=formulations,
        rows=tuple(rows),
        extra=tuple(extra),
        equilibria=tuple(equilibria),
        n_nodes=int(structure.n),
        timings=timings,
    )
