"""Campbell diagrams: rotating-frame frequencies of the reduced model versus steady spin rate.

Two cases (see docs/kane-and-campbell.md):

* **Clamped body on a spinning hub** (``model.free is False``): the hub turns at the constant
  rate Ω about ``axis``; the modal equation linearised about s = 0 is the quadratic eigenproblem

      (λ² μ + λ (Γ(ω) [+ C]) + Λ − ωᵀJ2ω) φ = 0,    ω = Ω e,

  solved through its companion matrix (:func:`quadmodes.rom.dynamics.rotating_frame_matrices`). The
  steady centrifugal forcing ½ωᵀJ1ω only shifts the static equilibrium, which does not enter the
  linear (s-independent) coefficients.
* **Free body spinning about a principal axis** (``model.free is True``): the relative
  equilibrium is ``ṡ = 0``, ``s = s*`` and ``ω = Ω e*``, where ``s*`` is the quasi-static
  centrifugal deformation, ``(Λ − ωᵀJ2ω) s* = ½ ωᵀJ1ω``, and ``e*`` the principal axis of the
  deformed inertia J̃(s*) next to the requested axis (``ω × J̃(s*)ω = 0``), found by a fixed-point
  iteration. The full body-frame Q equations of :mod:`quadmodes.rom.dynamics` (state ``z = (ω, s, ṡ)``,
  3 + 2N values; the attitude q does not enter them) are linearised about it by central differences
  of :func:`quadmodes.rom.dynamics.rhs`, so the three rotational perturbations and all rotation–
  deformation couplings (A(s*), J̃(s*), the ω̇ coupling c + s*D) are included. Its 3 + 2N roots
  are a zero root (the neighbouring relative equilibrium at another spin rate), the nutation pair
  and the 2N elastic roots.

Each spin rate gives N (clamped) or N + 1 (free: plus nutation) roots with Im λ ≥ 0; a root with
a real pair (divergence, e.g. formulation "L" above the first in-plane frequency) is kept as its
growing member (frequency 0, growth Re λ > 0). Branches are followed from one spin rate to the next
by the modal assurance criterion of the state eigenvectors in the energy inner product (kinetic
𝕄 on velocities plus |Λ − ωᵀJ2ω| on displacements), with an optimal assignment
(:func:`scipy.optimize.linear_sum_assignment`) — never by sorting frequencies, so crossing branches
keep their identity. Degenerate roots (equal frequencies, e.g. y/z pairs at Ω = 0) have no unique
eigenvectors: there the eigenvectors of the one-sided limit (spin rate nudged towards the next
point) are used.
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from quadmodes.rom import dynamics as dy
from quadmodes.rom.reduced import ReducedModel

#: Two roots closer than this (relative to their magnitude) are degenerate.
DEGENERATE_RTOL = 1e-7


@dataclass(frozen=True)
class CampbellResult:
    """Frequencies of the reduced model linearised about steady spin, per tracked branch (SI).

    spin (ns,) rad/s: spin rates Ω. axis (3,): unit spin axis in the body frame (requested).
    formulation: "Q", "P", "L". free: free body (True) or clamped to a hub (False).
    labels (nb,): branch names (model mode label dominant at the first spin rate, or "nutation").
    frequency (ns, nb) rad/s: |Im λ| along each branch. growth (ns, nb) 1/s: Re λ (> 0 unstable).
    mac (ns, nb): MAC of each branch with itself at the previous spin rate (1 at the first).
    min_stiffness (ns,) 1/s²: smallest eigenvalue of the rotating stiffness Λ − ωᵀJ2ω (s = s*).
    s_eq (ns, N) √kg·m: relative-equilibrium modal coordinates (zero for a clamped body).
    spin_axis (ns, 3): the axis of the relative equilibrium (= axis for a clamped body).
    vectors (ns, nb, 3+2N or 2N) complex: state eigenvectors (free: δω, δs, δṡ; clamped: δs, δṡ),
    unit energy norm.
    """

    spin: np.ndarray
    axis: np.ndarray
    formulation: str
    free: bool
    labels: tuple[str, ...]
    frequency: np.ndarray
    growth: np.ndarray
    mac: np.ndarray
    min_stiffness: np.ndarray
    s_eq: np.ndarray
    spin_axis: np.ndarray
    vectors: np.ndarray = field(repr=False)
    mode_labels: tuple[str, ...] = ()

    @property
    def frequency_hz(self) -> np.ndarray:
        return self.frequency / (2.0 * np.pi)

    @property
    def unstable(self) -> np.ndarray:
        """(ns, nb) bool: roots with positive real part (beyond round-off)."""
        scale = 1e-7 * (1.0 + np.abs(self.frequency).max(initial=0.0))
        return self.growth > scale

    def branch(self, label: str) -> int:
        """Index of the first branch with ``label`` (exact, else first label containing it)."""
        for i, lab in enumerate(self.labels):
            if lab == label:
                return i
        for i, lab in enumerate(self.labels):
            if label in lab:
                return i
        raise KeyError(f"no branch labelled {label!r}; branches: {', '.join(self.labels)}")


# ---------------------------------------------------------------------------------------------
# linearisation at one spin rate
# ---------------------------------------------------------------------------------------------


def _unit(axis) -> np.ndarray:
    e = np.asarray(axis, float)
    norm = np.linalg.norm(e)
    if e.shape != (3,) or not norm > 0.0:
        raise ValueError("axis: give a non-zero 3-vector")
    return e / norm


def principal_axis(model: ReducedModel, index: int) -> np.ndarray:
    """Principal axis (3,) of J0, ``index`` into ascending moments (0: minor, 2: major)."""
    lam, vec = np.linalg.eigh(0.5 * (model.J0 + model.J0.T))
    e = vec[:, index]
    return e * np.sign(e[np.argmax(np.abs(e))])


def default_axis(model: ReducedModel) -> np.ndarray:
    """z for a hub-clamped body; the symmetry axis (the principal axis whose moment differs most
    from the other two) for a free body."""
    if not model.free:
        return np.array([0.0, 0.0, 1.0])
    lam = np.linalg.eigvalsh(0.5 * (model.J0 + model.J0.T))
    gaps = [min(abs(lam[i] - lam[j]) for j in range(3) if j != i) for i in range(3)]
    return principal_axis(model, int(np.argmax(gaps)))


def _abs_sym(k: np.ndarray) -> np.ndarray:
    """Matrix absolute value of a symmetric matrix, floored to stay positive definite."""
    if k.size == 0:
        return k
    lam, vec = np.linalg.eigh(k)
    a = np.abs(lam)
    a = np.maximum(a, 1e-12 * max(a.max(), 1e-300))
    return (vec * a) @ vec.T


def relative_equilibrium(
    sys: dy.ReducedSystem, spin: float, axis: np.ndarray, iterations: int = 50, tol: float = 1e-13
):
    """Relative equilibrium of the free body spinning at ``spin`` (rad/s) near ``axis``.

    Fixed point of ``(Λ − ωᵀJ2ω) s = ½ ωᵀJ1ω`` (for "Q4" ``∂V/∂s − (ωᵀJ2ω) s = ½ ωᵀJ1ω``
    with the quartic manifold potential, solved by Newton) and ``ω = spin · e*``, e* the eigenvector of
    J̃(s) nearest ``axis`` (sign kept). Returns ``(ω (3,), s (N,), residual)`` where residual is
    the largest |ż| (scaled) of the body-frame equations at (ω, s, ṡ = 0)."""
    n = sys.n_modes
    e = _unit(axis)
    s = np.zeros(n)
    w = spin * e
    for _ in range(iterations):
        w_old, s_old = w, s
        if n:
            k = dy.rotating_frame_matrices(sys, w)[2]
            f = 0.5 * np.einsum("kab,a,b->k", sys.J1, w, w)
            s = _static_solve(sys, k, f, s) if sys.quartic else np.linalg.solve(k, f)
        jt = dy.inertia_tensor(sys, s, "rot")
        lam, vec = np.linalg.eigh(0.5 * (jt + jt.T))
        j = int(np.argmax(np.abs(vec.T @ e)))
        e_new = vec[:, j] * np.sign(vec[:, j] @ e)
        w = spin * e_new
        ds = np.linalg.norm(s - s_old) / max(np.linalg.norm(s), 1e-300) if n else 0.0
        if np.linalg.norm(w - w_old) <= tol * max(abs(spin), 1e-300) and ds <= tol:
            break
    y = dy.pack_state(sys, omega=w, s=s)
    d = dy.rhs(sys, 0.0, y)
    scale = max(abs(spin), 1e-12) ** 2
    return w, s, float(np.max(np.abs(d[4:]), initial=0.0) / scale)


def _static_solve(
    sys: dy.ReducedSystem,
    k: np.ndarray,
    f: np.ndarray,
    s: np.ndarray,
    iterations: int = 50,
    tol: float = 1e-14,
) -> np.ndarray:
    """Newton solution (N,) of ``k s + (∂V/∂s − Λs)(s) = f`` ("Q4": k = Λ − ωᵀJ2ω, f (N,)
    the centrifugal modal force), started from ``s`` and, failing that, from the linear one."""
    for start in (s, np.linalg.solve(k, f)):
        x = start.copy()
        for _ in range(iterations):
            r = k @ x + dy.potential_nonlinear_force(sys, x) - f
            jac = k + dy.potential_hessian(sys, x) - sys.Lam
            dx = np.linalg.solve(jac, r)
            x = x - dx
            if not np.all(np.isfinite(x)):
                break
            if np.linalg.norm(dx) <= tol * max(np.linalg.norm(x), 1e-300):
                return x
    raise ValueError("relative equilibrium (Q4): Newton on the modal statics did not converge")


def _free_jacobian(sys: dy.ReducedSystem, w: np.ndarray, s: np.ndarray, mass: float, length):
    """Central-difference Jacobian (3+2N, 3+2N) of the body-frame equations in z = (ω, s, ṡ)."""
    n = sys.n_modes
    z0 = np.concatenate([w, s, np.zeros(n)])
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    s_scale = np.sqrt(mass) * length  # s that changes the inertia by O(1)
    w_scale = max(float(np.linalg.norm(w)), 1.0)
    rate = np.sqrt(max(float(np.max(np.diag(sys.Lam), initial=1.0)), 1.0))
    steps = np.concatenate(
        [np.full(3, 1e-6 * w_scale), np.full(n, 1e-6 * s_scale), np.full(n, 1e-6 * s_scale * rate)]
    )
    m = 3 + 2 * n
    jac = np.empty((m, m))
    for j in range(m):
        zp, zm = z0.copy(), z0.copy()
        zp[j] += steps[j]
        zm[j] -= steps[j]
        fp = dy.rhs(sys, 0.0, np.concatenate([q0, zp]))[4:]
        fm = dy.rhs(sys, 0.0, np.concatenate([q0, zm]))[4:]
        jac[:, j] = (fp - fm) / (2.0 * steps[j])
    return jac


def _linearise(sys: dy.ReducedSystem, model: ReducedModel, spin: float, axis: np.ndarray, damped):
    """Roots λ, state eigenvectors (columns), energy weight W, min stiffness eig, s*, axis."""
    n = sys.n_modes
    if sys.free:
        w, s, _ = relative_equilibrium(sys, spin, axis)
        sys_l = sys if damped else dy.with_damping(sys, np.zeros((n, n)))
        length = float(np.sqrt(np.trace(model.J0) / max(model.mass, 1e-300)))
        jac = _free_jacobian(sys_l, w, s, model.mass, length)
        mm = dy.mass_matrix(sys, s)
        k = dy.rotating_frame_matrices(sys, w)[2] if n else np.zeros((0, 0))
        if sys.quartic and n:  # stiffness of the full potential at s*
            k = k + dy.potential_hessian(sys, s) - sys.Lam
        # energy weight on z = (δω, δs, δṡ): ½ νᵀ𝕄ν with ν = (δω, δṡ), plus ½ δsᵀ|K|δs
        wgt = np.zeros((3 + 2 * n, 3 + 2 * n))
        vel = np.r_[0:3, 3 + n : 3 + 2 * n]
        wgt[np.ix_(vel, vel)] = 0.5 * (mm + mm.T)
        wgt[3 : 3 + n, 3 : 3 + n] = _abs_sym(k)
        e_eq = w / spin if spin != 0.0 else _unit(axis)
    else:
        w = spin * _unit(axis)
        s = np.zeros(n)
        mu, g, k = dy.rotating_frame_matrices(sys, w)
        if not damped:
            g = g - sys.C
        minv = np.linalg.inv(mu)
        jac = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ g]])
        wgt = np.zeros((2 * n, 2 * n))
        wgt[:n, :n] = _abs_sym(k)
        wgt[n:, n:] = mu
        e_eq = _unit(axis)
    lam, vec = np.linalg.eig(jac)
    kmin = float(np.linalg.eigvalsh(k).min()) if n else np.inf
    return lam, vec, wgt, kmin, s, e_eq


def _select(lam: np.ndarray, count: int, scale: float) -> np.ndarray:
    """Indices of the ``count`` roots of a Campbell point: Im λ > tol first (ascending
    frequency); then the near-real roots by decreasing Re λ (growing member of a divergent pair
    first, then 0)."""
    tol = 1e-7 * scale
    upper = np.flatnonzero(lam.imag > tol)
    upper = upper[np.argsort(lam.imag[upper])]
    real = np.flatnonzero(np.abs(lam.imag) <= tol)
    real = real[np.argsort(-lam.real[real])]
    idx = np.concatenate([upper, real])[:count]
    if idx.size < count:
        raise RuntimeError("campbell: not enough roots with Im λ ≥ 0 (overdamped system?)")
    return idx


def _normalise(vec: np.ndarray, wgt: np.ndarray) -> np.ndarray:
    norms = np.sqrt(np.maximum(np.einsum("ik,ij,jk->k", vec.conj(), wgt, vec).real, 1e-300))
    return vec / norms


def _mac(a: np.ndarray, b: np.ndarray, wgt: np.ndarray) -> np.ndarray:
    """MAC matrix (ka, kb) of columns of a and b in the inner product ``xᴴ W y``."""
    cross = a.conj().T @ wgt @ b
    na = np.einsum("ik,ij,jk->k", a.conj(), wgt, a).real
    nb = np.einsum("ik,ij,jk->k", b.conj(), wgt, b).real
    return np.abs(cross) ** 2 / np.maximum(np.outer(na, nb), 1e-300)


def _degenerate(lam_all: np.ndarray, idx: np.ndarray, scale: float) -> bool:
    """True if a selected root coincides with any other root (multiple root: e.g. the triple
    zero of a free body at rest, or a y/z pair of a beam): its eigenvector is not unique."""
    d = np.abs(lam_all[idx][:, None] - lam_all[None, :])
    d[np.arange(idx.size), idx] = np.inf
    return bool(np.any(d <= DEGENERATE_RTOL * (scale + np.abs(lam_all[idx]))[:, None]))


@dataclass(frozen=True)
class _Point:
    """Selected roots of one spin rate (columns of vec: unit-energy state eigenvectors)."""

    spin: float
    lam: np.ndarray
    vec: np.ndarray
    wgt: np.ndarray
    kmin: float
    s: np.ndarray
    axis: np.ndarray

    def reordered(self, order: np.ndarray) -> _Point:
        return _Point(
            self.spin, self.lam[order], self.vec[:, order], self.wgt, self.kmin, self.s, self.axis
        )


#: A branch match is accepted when its MAC is at least MAC_ACCEPT and every competitor of the
#: same branch is at least MAC_MARGIN below it; otherwise the spin step is halved.
MAC_ACCEPT = 0.9
MAC_MARGIN = 0.5


def _match(p0: _Point, p1: _Point, scale: float):
    """Assignment of p1's roots to p0's branches: order (p1 index per branch), the MAC of each
    assigned pair, and whether the match is unambiguous."""
    wgt = 0.5 * (p0.wgt + p1.wgt)
    mac = _mac(p0.vec, p1.vec, wgt)
    dist = np.abs(p0.lam[:, None] - p1.lam[None, :]) / scale
    rows, cols = linear_sum_assignment(-(mac - 1e-3 * dist))
    order = np.empty(len(rows), int)
    order[rows] = cols
    best = mac[np.arange(len(rows)), order]
    rivals = mac.copy()
    rivals[np.arange(len(rows)), order] = -np.inf
    runner = rivals.max(axis=1, initial=-np.inf)
    rivals_c = mac.copy()
    rivals_c[np.arange(len(rows)), order] = -np.inf
    runner_c = rivals_c.max(axis=0, initial=-np.inf)[order]
    ok = bool(
        np.all(best >= MAC_ACCEPT)
        and np.all(runner <= best - MAC_MARGIN)
        and np.all(runner_c <= best - MAC_MARGIN)
    )
    return order, best, ok


# ---------------------------------------------------------------------------------------------
# Campbell sweep
# ---------------------------------------------------------------------------------------------


def campbell(
    model: ReducedModel,
    spin_rates_rad_s,
    axis=None,
    formulation: str = "Q",
    damped: bool = False,
    max_bisections: int = 30,
    max_refinements: int = 200,
) -> CampbellResult:
    """Campbell diagram of ``model`` over ``spin_rates_rad_s`` (rad/s, swept in the given order).

    ``axis``: body-frame spin axis (3-vector), or an int principal-axis index of J0 (0 minor …
    2 major) for a free body; default :func:`default_axis`. ``formulation``: "Q" (quadratic modes,
    spin stiffening), "P" or "L" (linear modes, no stiffening). ``damped``: include the modal
    damping C in the roots (growth then holds −ζω). Modes are tracked by MAC (module docstring);
    where the match between two spin rates is ambiguous the interval is halved, at most
    ``max_bisections`` times (and at most ``max_refinements`` extra points per interval), and
    the branches are followed through the intermediate points. ``result.mac`` keeps the smallest
    MAC along that chain: a low value flags a match that stayed ambiguous (e.g. an exactly
    degenerate pair at every spin rate, where any basis of the pair is valid)."""
    spin = np.asarray(spin_rates_rad_s, float).ravel()
    if spin.size == 0:
        raise ValueError("spin_rates_rad_s: give at least one spin rate")
    if axis is None:
        e = default_axis(model)
    elif isinstance(axis, int | np.integer):
        e = principal_axis(model, int(axis))
    else:
        e = _unit(axis)
    sys = dy.reduced_system(model, formulation)
    n = sys.n_modes
    count = n + (1 if sys.free else 0)
    if count == 0:
        raise ValueError("campbell: the clamped model has no modes")
    scale = max(float(np.sqrt(np.max(np.diag(sys.Lam), initial=0.0))), float(np.abs(spin).max()))
    scale = max(scale, 1.0)
    step = float(np.abs(np.diff(spin)).min()) if spin.size > 1 else 0.0
    nudge = 1e-4 * step if step > 0.0 else 1e-6 * scale

    def point(om: float, direction: float) -> _Point:
        lam_all, vec_all, wgt, kmin, s, ax = _linearise(sys, model, om, e, damped)
        idx = _select(lam_all, count, scale)
        lam, vec = lam_all[idx], vec_all[:, idx]
        if _degenerate(lam_all, idx, scale):
            # no unique eigenvectors: use those of the one-sided limit towards the next point
            lam2, vec2 = _linearise(sys, model, om + direction * nudge, e, damped)[:2]
            idx2 = _select(lam2, count, scale)
            lam2, vec2 = lam2[idx2], vec2[:, idx2]
            rows, cols = linear_sum_assignment(np.abs(lam[:, None] - lam2[None, :]))
            vec = vec.astype(complex)
            vec[:, rows] = vec2[:, cols]
        return _Point(om, lam, _normalise(vec, wgt), wgt, kmin, s, ax)

    def bridge(p0: _Point, p1: _Point, depth: int) -> tuple[_Point, np.ndarray]:
        """p1 reordered to follow p0's branches; halve the step while the match is ambiguous.
        Returns the reordered point and the smallest MAC along the chain per branch."""
        order, mac, ok = _match(p0, p1, scale)
        if ok or depth == 0 or budget[0] <= 0:
            return p1.reordered(order), mac
        budget[0] -= 1
        d = np.sign(p1.spin - p0.spin)
        mid = point(0.5 * (p0.spin + p1.spin), d)
        pm, mac_a = bridge(p0, mid, depth - 1)
        p1, mac_b = bridge(pm, p1, depth - 1)
        return p1, np.minimum(mac_a, mac_b)

    ns = spin.size
    pts: list[_Point] = []
    macs = np.ones((ns, count))
    for i, om in enumerate(spin):
        if i + 1 < ns:
            direction = float(np.sign(spin[i + 1] - om)) or 1.0
        else:
            direction = float(np.sign(om - spin[i - 1])) if i else 1.0
        p = point(om, direction or 1.0)
        if not pts:
            p = p.reordered(np.lexsort((p.lam.real, np.abs(p.lam.imag))))
        else:
            budget = [max_refinements]  # persistent degeneracy must not bisect forever
            p, macs[i] = bridge(pts[-1], p, max_bisections)
        pts.append(p)
    freq = np.array([np.abs(p.lam.imag) for p in pts])
    growth = np.array([p.lam.real for p in pts])
    vectors = np.array([p.vec.T for p in pts])
    kmin = np.array([p.kmin for p in pts])
    s_eq = np.array([p.s for p in pts]).reshape(ns, n)
    axes = np.array([p.axis for p in pts])
    labels = _branch_labels(model, vectors[0], sys.free)
    return CampbellResult(
        spin=spin,
        axis=e,
        formulation=formulation,
        free=bool(sys.free),
        labels=labels,
        frequency=freq,
        growth=growth,
        mac=macs,
        min_stiffness=kmin,
        s_eq=s_eq,
        spin_axis=axes,
        vectors=vectors,
        mode_labels=tuple(model.labels),
    )


def _branch_labels(model: ReducedModel, vectors: np.ndarray, free: bool) -> tuple[str, ...]:
    """Name each branch by its dominant share at the first spin rate: the rotational
    perturbation ("nutation") or the model mode with the largest |δs_k|² + |δṡ_k|²/ω_k²."""
    n = model.n_modes
    om2 = np.maximum(np.diag(model.Lam), 1e-300) if n else np.zeros(0)
    labels = []
    for v in vectors:
        off = 3 if free else 0
        ds, dsd = v[off : off + n], v[off + n : off + 2 * n]
        shares = np.abs(ds) ** 2 + np.abs(dsd) ** 2 / om2
        if free:
            jt = model.J0
            rot = float(np.real(v[:3].conj() @ jt @ v[:3]))
            elastic = float(np.sum(np.abs(dsd) ** 2 + om2 * np.abs(ds) ** 2))
            if n == 0 or rot >= elastic:
                labels.append("nutation")
                continue
        labels.append(str(model.labels[int(np.argmax(shares))]) if n else "nutation")
    seen: dict[str, int] = {}
    out = []
    for lab in labels:
        seen[lab] = seen.get(lab, 0) + 1
        out.append(lab if seen[lab] == 1 else f"{lab} #{seen[lab]}")
    return tuple(out)


# ---------------------------------------------------------------------------------------------
# output
# ---------------------------------------------------------------------------------------------


def plot_campbell(result: CampbellResult, path=None, orders=(1, 2), title: str | None = None):
    """Campbell figure (matplotlib Figure, Agg canvas): frequency (rad/s) of each branch vs spin
    rate, engine-order lines f = kΩ for k in ``orders`` and unstable roots marked (×, with
    their growth rate on a second panel when there are any). Saved to ``path`` if given."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    unstable = result.unstable
    panels = 2 if unstable.any() else 1
    fig = Figure(figsize=(7.5, 5.0 + 2.0 * (panels - 1)))
    FigureCanvasAgg(fig)
    axs = fig.subplots(panels, 1, sharex=True, squeeze=False)[:, 0]
    ax = axs[0]
    for b, lab in enumerate(result.labels):
        (line,) = ax.plot(result.spin, result.frequency[:, b], "-", lw=1.5, label=lab)
        bad = unstable[:, b]
        if bad.any():
            ax.plot(result.spin[bad], result.frequency[bad, b], "x", color=line.get_color())
            axs[1].plot(result.spin, result.growth[:, b], "-", color=line.get_color(), label=lab)
    top = max(float(np.nanmax(result.frequency, initial=0.0)) * 1.05, 1e-9)
    for k in orders:
        ax.plot(result.spin, k * result.spin, "k:", lw=0.8)
        j = np.searchsorted(k * result.spin, top) - 1
        if 0 <= j < result.spin.size and k * result.spin[j] > 0:
            ax.annotate(f"{k}Ω", (result.spin[j], k * result.spin[j]), fontsize=8)
    ax.set_ylim(0.0, top)
    ax.set_ylabel("rotating-frame frequency (rad/s)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    kind = "free body" if result.free else "clamped to hub"
    ax.set_title(title or f"Campbell diagram ({kind}, formulation {result.formulation})")
    if panels == 2:
        axs[1].axhline(0.0, color="k", lw=0.6)
        axs[1].set_ylabel("growth rate Re λ (1/s)")
        axs[1].grid(True, alpha=0.3)
    axs[-1].set_xlabel("spin rate Ω (rad/s)")
    fig.tight_layout()
    if path is not None:
        fig.savefig(os.fspath(path), dpi=150)
    return fig


def to_dataset(result: CampbellResult):
    """xarray Dataset of a Campbell result with units (CF-style ``units`` attributes)."""
    import xarray as xr

    ds = xr.Dataset(
        {
            "frequency": (("spin", "branch"), result.frequency, {"units": "rad/s"}),
            "frequency_hz": (("spin", "branch"), result.frequency_hz, {"units": "Hz"}),
            "growth_rate": (("spin", "branch"), result.growth, {"units": "1/s"}),
            "mac_previous": (("spin", "branch"), result.mac, {"units": "1"}),
            "min_rotating_stiffness": (("spin",), result.min_stiffness, {"units": "1/s^2"}),
            "equilibrium_modal_coordinates": (
                ("spin", "mode"),
                result.s_eq,
                {"units": "kg^0.5 m"},
            ),
            "equilibrium_spin_axis": (("spin", "xyz"), result.spin_axis, {"units": "1"}),
        },
        coords={
            "spin": ("spin", result.spin, {"units": "rad/s", "long_name": "spin rate"}),
            "branch": ("branch", np.arange(len(result.labels))),
            "branch_label": ("branch", np.array(result.labels, dtype=object)),
            "mode": ("mode", np.arange(result.s_eq.shape[1])),
            "xyz": ("xyz", np.array(["x", "y", "z"], dtype=object)),
        },
        attrs={
            "title": "Campbell diagram of a quadmodes reduced model",
            "formulation": result.formulation,
            "body": "free" if result.free else "clamped to hub",
            "spin_axis_x": float(result.axis[0]),
            "spin_axis_y": float(result.axis[1]),
            "spin_axis_z": float(result.axis[2]),
            "mode_labels": "; ".join(result.mode_labels),
            "tracking": "MAC of state eigenvectors (energy inner product), optimal assignment",
        },
    )
    return ds


def write_campbell(result: CampbellResult, directory, stem: str = "campbell") -> dict[str, Path]:
    """Write ``campbell.png``, ``campbell.nc`` (NetCDF4, h5netcdf, units in attributes) and
    ``campbell.csv`` (one row per spin rate and branch) into ``directory``; returns the paths."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"png": out / f"{stem}.png", "nc": out / f"{stem}.nc", "csv": out / f"{stem}.csv"}
    plot_campbell(result, paths["png"])
    to_dataset(result).to_netcdf(paths["nc"], engine="h5netcdf")
    with open(paths["csv"], "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(
            [
                "spin_rad_s",
                "branch",
                "label",
                "frequency_rad_s",
                "frequency_hz",
                "growth_1_s",
                "mac",
            ]
        )
        for i, om in enumerate(result.spin):
            for b, lab in enumerate(result.labels):
                w.writerow(
                    [
                        f"{om:.10g}",
                        b,
                        lab,
                        f"{result.frequency[i, b]:.10g}",
                        f"{result.frequency_hz[i, b]:.10g}",
                        f"{result.growth[i, b]:.10g}",
                        f"{result.mac[i, b]:.6f}",
                    ]
                )
    return paths


def model_for_case(case, progress=None) -> ReducedModel:
    """Reduced model of a case (name, path or :class:`~quadmodes.case.schema.Case`) with its modes and
    damping ratio; degenerate y/z pairs of a straight beam are split into pure planes."""
    from quadmodes.case import Case, load_case
    from quadmodes.rom.reduced import reduce
    from quadmodes.structure.pipeline import build_modal_model

    if not isinstance(case, Case):
        case = load_case(case)
    mm = build_modal_model(case, progress)
    shapes, labels = mm.modes.shapes, list(mm.labels)
    if case.kind == "beam":
        from quadmodes.runs.spinup import split_planes

        shapes, _, _ = split_planes(mm.structure, mm.modes.frequencies_hz, shapes)
        from quadmodes.structure.labels import label_modes

        labels = label_modes(mm.structure, mm.x, shapes)
        zeta = case.beam.damping_ratio
    else:
        zeta = case.material.damping_ratio
    return reduce(
        mm.structure,
        mm.x,
        mm.modes.frequencies_hz,
        shapes,
        labels,
        zeta,
        progress=progress,
        provenance={"case": case.name},
    )


def campbell_main(
    case_or_model,
    spin_min: float,
    spin_max: float,
    n: int = 41,
    axis=None,
    formulation: str = "Q",
    output_dir=None,
    damped: bool = False,
    progress=None,
) -> tuple[CampbellResult, dict[str, Path]]:
    """Convenience entry for the CLI: build (or take) the reduced model, sweep ``n`` spin rates
    from ``spin_min`` to ``spin_max`` (rad/s), and write the outputs to ``output_dir`` (if given).

    ``case_or_model``: a :class:`ReducedModel`, a case name / TOML path or a Case."""
    if n < 1:
        raise ValueError("n: give at least one spin rate")
    if spin_max < spin_min:
        raise ValueError("spin_max: must not be below spin_min")
    model = (
        case_or_model
        if isinstance(case_or_model, ReducedModel)
        else model_for_case(case_or_model, progress)
    )
    result = campbell(model, np.linspace(spin_min, spin_max, n), axis, formulation, damped)
    paths = write_campbell(result, output_dir) if output_dir is not None else {}
    return result, paths
