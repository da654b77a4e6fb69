"""A reduced potential of the wrinkled structure: the FE potential condensed on a
snapshot-augmented basis.

Formulation Q's ``½ sᵀΛs`` is Taylor-exact about the taut inflated state; once the membrane
wrinkles (tension-field law, :mod:`quadmodes.fe.wrinkling`) the structure is much softer than
that. For the reduced model's chart ``x_QM(s) = x0 + Φs + Σ_mn s_m s_n g^{mn}``
(:mod:`quadmodes.rom.manifold_energy`) this module evaluates

    W_B(s) = min_η Π̃(x_QM(s) + B η)   (J),

Π̃ the FE total potential less its value and round-off residual at ``x0``
(:func:`~quadmodes.rom.manifold_energy.total_potential`), ``B`` ``(m, q)`` an M-orthonormal basis
M-orthogonal to the retained and rigid modes ``[Φ Ψ]``: the quadratic modes ``G⊥`` (so ``W_B ≤
W_red``) plus the M-weighted POD of the condensed minimisers ``y`` of ``W_c`` at training points
(:func:`snapshot_basis`). The feasible sets are nested, ``x_QM + span B ⊂ x_QM + {y ⊥_M [Φ Ψ]}``,
so ``W_c ≤ W_B ≤ W_red`` (for the minima reached), and ``W_B = W_c`` wherever the condensed
minimiser lies in ``span B`` (at the training points when nothing is truncated).

:class:`CondensedPotential` gives ``W_B``, its gradient (envelope theorem) and its condensed
Hessian, and the nonlinear remainders about ``s = 0`` a reduced model adds to its own ``½ sᵀΛs``:
``V(s) = ½ sᵀΛs + W_B(s) − ½ sᵀH0 s`` (zero to second order by construction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from quadmodes.experimental import candidate_potentials as cand
from quadmodes.rom import manifold_energy as me
from quadmodes.rom.manifold_energy import EnergyContext
from quadmodes.rom.reduced import ReducedModel

#: η-Newton stops when the predicted decrease ½|Δη·∇| is below this fraction of |W_B| ...
DECREMENT_RTOL = 1e-14
#: ... or below this absolute floor (J).
DECREMENT_ATOL = 1e-22
#: Below this predicted decrease (relative to |W_B|, or 1e3·ENERGY_ATOL) the energy is too
#: close to its round-off to steer a line search: steps are accepted when the gradient falls.
FULL_STEP_RTOL = 1e-10


# ---------------------------------------------------------------------------------------------
# Training points and the snapshot basis
# ---------------------------------------------------------------------------------------------


def modal_scale(model: ReducedModel) -> np.ndarray:
    """``D`` (N,): the largest nodal displacement (m) per unit modal coordinate (√kg·m) of
    each mode (``runs.initial.largest_nodal_displacement``)."""
    t = np.asarray(model.translational, bool)
    return np.array([np.max(np.linalg.norm(np.asarray(p)[t], axis=1)) for p in model.Phi])


def bending_modes(model: ReducedModel) -> tuple[int, ...]:
    """Indices of the retained modes labelled bending."""
    return tuple(k for k, lab in enumerate(model.labels) if "bending" in str(lab).lower())


def training_points(
    model: ReducedModel, amplitudes_m, n_directions: int, seed: int = 0, bending: bool = True
) -> np.ndarray:
    """Training modal coordinates ``(k, N)`` (√kg·m): ``s = r D⁻¹ d`` for ``n_directions``
    random unit directions ``d`` (uniform on the sphere of the scaled coordinates, seed
    ``seed``) and, if ``bending``, ``d = ±e_k`` for every bending mode k (the convention of
    ``initial.bending_amplitude``: r is the largest nodal displacement), at every amplitude r
    (m) of ``amplitudes_m``. Rows go direction by direction, amplitudes ascending (so each ray
    can be reached by continuation)."""
    n = model.n_modes
    d = np.random.default_rng(seed).standard_normal((n_directions, n))
    dirs = [row / np.linalg.norm(row) for row in d]
    if bending:
        for k in bending_modes(model):
            dirs += [np.eye(n)[k], -np.eye(n)[k]]
    radii = np.sort(np.asarray(amplitudes_m, float))
    scale = modal_scale(model)
    return np.array([r * e / scale for e in dirs for r in radii]).reshape(-1, n)


def _same_ray(previous: np.ndarray, s: np.ndarray) -> float:
    """``c`` in (0, 1) if ``previous = c s`` (the same ray, nearer the origin), else 0."""
    c = float(previous @ s) / float(s @ s)
    if 0.0 < c < 1.0 and np.linalg.norm(previous - c * s) <= 1e-10 * np.linalg.norm(s):
        return c
    return 0.0


def condensed_snapshots(ctx: EnergyContext, training_s: np.ndarray, progress=None) -> list:
    """:class:`~quadmodes.rom.manifold_energy.Condensed` ``W_c`` at each training point
    ``(k, N)``: from the best of the quadratic-manifold point and the previous minimiser (and
    its quadratic extrapolation) when the previous point is on the same ray, else (or if that
    fails) by continuation along the ray (:func:`manifold_energy.condensed_energy_along_ray`).
    ``progress(i, result)`` is called after each point."""
    out, prev = [], None
    for i, s in enumerate(np.asarray(training_s, float)):
        result = None
        c = _same_ray(prev[0], s) if prev is not None and prev[1].converged else 0.0
        if c:
            y = prev[1].unknowns
            start = cand.best_start(ctx, s, [y, y / c**2])
            result = me.condensed_energy(ctx, s, start)
        if result is None or not result.converged:
            result = me.condensed_energy_along_ray(ctx, s)
        out.append(result)
        prev = (s, result)
        if progress:
            progress(i, result)
    return out


def _m_project_out(mass, basis: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """``vectors`` less their M-orthogonal projection on the span of ``basis`` ``(m, p)``."""
    if basis.shape[1] == 0:
        return vectors
    coeff = np.linalg.solve(basis.T @ (mass @ basis), basis.T @ (mass @ vectors))
    return vectors - basis @ coeff


@dataclass(frozen=True)
class SnapshotReport:
    """What :func:`snapshot_basis` did. snapshots: the W_c results at the training points
    (:class:`~quadmodes.rom.manifold_energy.Condensed`, those not converged are left out of the
    POD). n_quadratic: columns of G⊥ in B. n_pod: POD vectors added. pod_values ``(k,)``
    (kg·m²): eigenvalues of the M-correlation of the snapshots' parts M-orthogonal to
    ``[Φ Ψ G⊥]``, descending. captured: share of their sum kept."""

    snapshots: tuple
    n_quadratic: int
    n_pod: int
    pod_values: np.ndarray
    captured: float

    @property
    def n_basis(self) -> int:
        """Columns of B."""
        return self.n_quadratic + self.n_pod


def pod_basis(
    ctx: EnergyContext, snapshots: np.ndarray, tol: float = 1e-8, max_vectors: int | None = None
) -> tuple[np.ndarray, np.ndarray, float]:
    """``(B, pod_values, captured)`` from snapshot displacements ``(k, m)`` (m): B ``(m, q)``
    = [G⊥, the first p POD modes of the snapshots' parts M-orthogonal to [Φ Ψ G⊥]], p the
    fewest whose discarded eigenvalues sum to at most ``tol`` × the total, at most
    ``max_vectors`` (POD vectors, beyond G⊥); eigenvalues below 1e-12 × the largest are
    round-off and never kept."""
    mass, gp = ctx.mass, ctx.g_perp
    y = np.asarray(snapshots, float).reshape(-1, gp.shape[0]).T
    y = _m_project_out(mass, np.hstack([ctx.basis, gp]), y)
    if y.shape[1] == 0:
        return gp.copy(), np.zeros(0), 1.0
    corr = y.T @ (mass @ y)
    lam, vec = np.linalg.eigh(0.5 * (corr + corr.T))
    lam, vec = np.maximum(lam[::-1], 0.0), vec[:, ::-1]
    total = lam.sum()
    if total <= 0.0:
        return gp.copy(), lam, 1.0
    tail = total - np.cumsum(lam)  # discarded after keeping 1, 2, ...
    enough = np.flatnonzero(tail <= tol * total)
    p = int(enough[0]) + 1 if enough.size else len(lam)
    p = min(p, int(np.sum(lam > 1e-12 * lam[0])))
    if max_vectors is not None:
        p = min(p, int(max_vectors))
    modes = y @ (vec[:, :p] / np.sqrt(lam[:p]))
    modes = _m_project_out(mass, np.hstack([ctx.basis, gp]), modes)  # second pass: round-off
    b = np.hstack([gp, me.m_orthonormal(mass, modes)]) if p else gp.copy()
    return b, lam, float(lam[:p].sum() / total)


def snapshot_basis(
    ctx: EnergyContext,
    training_s: np.ndarray,
    tol: float = 1e-8,
    max_vectors: int | None = None,
    progress=None,
) -> tuple[np.ndarray, SnapshotReport]:
    """``(B, report)``: the snapshot-augmented basis ``(m, q)`` for the training modal
    coordinates ``(k, N)`` (√kg·m): the W_c minimisers there (:func:`condensed_snapshots`)
    added to G⊥ by :func:`pod_basis` (``tol``, ``max_vectors``)."""
    results = condensed_snapshots(ctx, training_s, progress)
    ys = [r.unknowns for r in results if r.converged]
    b, lam, captured = pod_basis(ctx, np.array(ys).reshape(len(ys), -1), tol, max_vectors)
    n_q = ctx.g_perp.shape[1]
    return b, SnapshotReport(tuple(results), n_q, b.shape[1] - n_q, lam, captured)


# ---------------------------------------------------------------------------------------------
# The condensed potential
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Minimum:
    """The η-minimiser at s (N,): eta (q,), u (m,) m the displacement ``x_QM(s) + Bη − x0``,
    value W_B (J), force ``∇Π̃(x0 + u)`` (m,) N, the tangent there (sparse K N/m and its
    rank-one terms), Newton iterations, final predicted decrease (J), converged."""

    s: np.ndarray
    eta: np.ndarray
    u: np.ndarray
    value: float
    force: np.ndarray
    tangent: tuple
    iterations: int
    decrement: float
    converged: bool


def manifold_jacobian(ctx: EnergyContext, s: np.ndarray) -> np.ndarray:
    """``J_s = ∂x_QM/∂s`` ``(m, N)``: column k is ``Φ_k + Σ_n s_n (g^{kn} + g^{nk})``."""
    return ctx.phi.T + np.einsum("n,kni->ik", s, ctx.g + np.swapaxes(ctx.g, 0, 1))


def _projected(k, low, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """``leftᵀ (K + Σ c v vᵀ) right``."""
    out = left.T @ (k @ right)
    for c, v in low:
        out += c * np.outer(left.T @ v, right.T @ v)
    return out


class CondensedPotential:
    """``W_B(s) = min_η Π̃(x_QM(s) + Bη)`` on ``ctx`` with basis ``basis`` ``(m, q)``
    (M-orthonormal, M-orthogonal to ``ctx.basis``; e.g. from :func:`snapshot_basis`).

    Cache (the only state): the last :class:`Minimum` (energy, gradient and Hessian at the
    same s share one η-solve) and its η, the warm start of the next solve — used when its
    energy at the new s is below that of η = 0, the quadratic-manifold point. The minimum
    reached is a local one and may depend on that start where the energy is not convex
    (a wrinkling membrane); ``clear()`` forgets it.
    """

    def __init__(self, ctx: EnergyContext, basis: np.ndarray, max_iterations: int = 60):
        self.ctx = ctx
        self.basis = np.asarray(basis, float)
        self.max_iterations = int(max_iterations)
        self._last: Minimum | None = None
        self._h0: np.ndarray | None = None

    @property
    def n_modes(self) -> int:
        return self.ctx.phi.shape[0]

    def clear(self) -> None:
        """Forget the cached minimum (and warm start)."""
        self._last = None

    def _energy(self, u_qm: np.ndarray, eta: np.ndarray) -> float:
        return me.total_potential(self.ctx, u_qm + self.basis @ eta)

    def _start(self, u_qm: np.ndarray, eta0) -> np.ndarray:
        """The start of lowest energy among η = 0, ``eta0`` and the cached η."""
        cands = [np.zeros(self.basis.shape[1])]
        for e in (eta0, None if self._last is None else self._last.eta):
            if e is not None:
                cands.append(np.asarray(e, float))
        values = [self._energy(u_qm, e) for e in cands]
        return cands[int(np.argmin(values))].copy()

    def minimum(self, s: np.ndarray, eta0: np.ndarray | None = None) -> Minimum:
        """The η-minimiser at ``s`` (N,) (cached for the last s; ``eta0`` an extra start).

        Newton on η with the projected tangent ``BᵀKB`` (eigenvalues made positive where it
        is indefinite) and an Armijo energy line search; once the predicted decrease is below
        FULL_STEP_RTOL·|W| (energy round-off territory), or if the line search fails, a step
        is halved until the gradient norm falls instead. Stops at a predicted decrease ≤
        DECREMENT_RTOL·|W| (converged), or when no step makes progress (not converged)."""
        s = np.asarray(s, float)
        last = self._last
        if last is not None and eta0 is None and np.array_equal(last.s, s):
            return last
        ctx, b = self.ctx, self.basis
        u_qm = me.manifold_displacement(ctx, s)
        eta = self._start(u_qm, eta0)
        value = self._energy(u_qm, eta)
        decrement, it = np.inf, 0
        for it in range(self.max_iterations + 1):
            u = u_qm + b @ eta
            force = me.potential_force(ctx, u)
            grad = b.T @ force
            k, low = me._tangent(ctx, u)
            d = -cand._spd_solve(_projected(k, low, b, b), grad)
            slope = float(grad @ d)
            decrement = 0.5 * abs(slope)
            if decrement <= max(DECREMENT_RTOL * abs(value), DECREMENT_ATOL):
                break
            if it == self.max_iterations:
                break
            new = eta
            if decrement > max(FULL_STEP_RTOL * abs(value), 1e3 * me.ENERGY_ATOL):
                new, _ = me._line_search(lambda e: self._energy(u_qm, e), eta, d, value, slope)
            if new is eta:  # round-off territory, or the line search failed
                new = self._gradient_step(u_qm, eta, d, np.linalg.norm(grad))
            if new is eta:  # no step lowers the energy or the gradient: stop where we are
                break
            eta, value = new, self._energy(u_qm, new)
        converged = decrement <= max(DECREMENT_RTOL * abs(value), DECREMENT_ATOL)
        self._last = Minimum(s.copy(), eta, u, value, force, (k, low), it, decrement, converged)
        return self._last

    def _gradient_step(self, u_qm, eta, d, gnorm: float, halvings: int = 20) -> np.ndarray:
        """``η + t d`` for the first ``t = 1, ½, …`` at which ``|Bᵀ∇Π̃|`` is below ``gnorm``
        (``eta`` itself if none is)."""
        t = 1.0
        for _ in range(halvings):
            trial = eta + t * d
            force = me.potential_force(self.ctx, u_qm + self.basis @ trial)
            if np.linalg.norm(self.basis.T @ force) < gnorm:
                return trial
            t *= 0.5
        return eta

    # -- the potential and its derivatives --------------------------------------------------

    def energy(self, s: np.ndarray) -> float:
        """``W_B(s)`` (J) at ``s`` (N,) (√kg·m)."""
        return self.minimum(s).value

    def gradient(self, s: np.ndarray) -> np.ndarray:
        """``dW_B/ds = J_sᵀ ∇Π̃(x*)`` (N,) (J/(√kg·m)), x* the minimiser: the envelope theorem
        (``Bᵀ∇Π̃(x*) = 0``); ``∇Π̃`` is :func:`manifold_energy.potential_force`, the internal
        force ``f(x) − f(x0)`` (the gradient of the potential, not its negative)."""
        m = self.minimum(s)
        return manifold_jacobian(self.ctx, m.s).T @ m.force

    def hessian(self, s: np.ndarray) -> np.ndarray:
        """Condensed Hessian ``(N, N)`` of W_B at ``s``:
        ``J_sᵀK̂J_s + [∇Π̃·(g^{kl} + g^{lk})] − (J_sᵀK̂B)(BᵀK̂B)⁻¹(BᵀK̂J_s)``, ``K̂`` the tangent
        at the minimiser with its rank-one (gas-law) terms. Where the tension-field tangent
        jumps (an element changes state) this is the one-sided Hessian of the current state."""
        m = self.minimum(s)
        ctx, b = self.ctx, self.basis
        k, low = m.tangent
        jac = manifold_jacobian(ctx, m.s)
        g2 = ctx.g + np.swapaxes(ctx.g, 0, 1)
        h_ss = _projected(k, low, jac, jac) + np.einsum("kli,i->kl", g2, m.force)
        if b.shape[1] == 0:
            return 0.5 * (h_ss + h_ss.T)
        h_se = _projected(k, low, jac, b)
        h_ee = _projected(k, low, b, b)
        try:
            corr = h_se @ sla.solve(0.5 * (h_ee + h_ee.T), h_se.T, assume_a="sym")
        except (np.linalg.LinAlgError, sla.LinAlgError):
            corr = h_se @ np.linalg.pinv(h_ee) @ h_se.T
        h = h_ss - corr
        return 0.5 * (h + h.T)

    @property
    def hessian0(self) -> np.ndarray:
        """``H0`` ``(N, N)``: the Hessian at s = 0 (computed once; the cached minimum is kept)."""
        if self._h0 is None:
            last = self._last
            self._h0 = self.hessian(np.zeros(self.n_modes))
            self._last = last
        return self._h0

    def nonlinear_energy(self, s: np.ndarray) -> float:
        """``W_B(s) − ½ sᵀH0 s`` (J): O(|s|³)."""
        s = np.asarray(s, float)
        return self.energy(s) - 0.5 * float(s @ self.hessian0 @ s)

    def nonlinear_force(self, s: np.ndarray) -> np.ndarray:
        """``∇W_B(s) − H0 s`` (N,): O(|s|²)."""
        s = np.asarray(s, float)
        return self.gradient(s) - self.hessian0 @ s

    def nonlinear_hessian(self, s: np.ndarray) -> np.ndarray:
        """``∇²W_B(s) − H0`` (N, N): O(|s|)."""
        return self.hessian(s) - self.hessian0
