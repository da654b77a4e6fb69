"""Campbell diagrams: rotating-frame frequencies of the reduced model versus steady spin rate.

Each spin rate is one linearisation of the reduced model about steady spin (the clamped body on
a spinning hub, or the free body about its relative equilibrium:
:mod:`quadmodes.analysis.reduced_linearisation`; see docs/kane-and-campbell.md). It gives N
(clamped) or N + 1 (free: plus nutation) roots with Im λ ≥ 0; a root with a real pair
(divergence, e.g. formulation "L" above the first in-plane frequency) is kept as its growing
member (frequency 0, growth Re λ > 0). Branches are followed from one spin rate to the next by
the modal assurance criterion of the state eigenvectors in the energy inner product (kinetic 𝕄
on velocities plus |Λ − ωᵀJ2ω| on displacements), with an optimal assignment
(:func:`scipy.optimize.linear_sum_assignment`) — never by sorting frequencies, so crossing branches
keep their identity. Degenerate roots (equal frequencies, e.g. y/z pairs at Ω = 0) have no unique
eigenvectors: there the eigenvectors of the one-sided limit (spin rate nudged towards the next
point) are used. Output (figure, dataset, CSV) and the CLI entry:
:mod:`quadmodes.analysis.campbell_output`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from quadmodes.analysis.reduced_linearisation import linearise
from quadmodes.analysis.spin_axis import resolve_axis
from quadmodes.rom import system as rsys
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
# mode tracking between spin rates
# ---------------------------------------------------------------------------------------------


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


@dataclass(frozen=True)
class _Sweep:
    """What stays fixed over one sweep: the reduced system, its model, the requested unit axis
    (3,), ``damped``, the number of roots per point, the frequency scale (1/s) and the nudge
    (rad/s) of the one-sided limit at degenerate roots."""

    sys: rsys.ReducedSystem
    model: ReducedModel
    axis: np.ndarray
    damped: bool
    count: int
    scale: float
    nudge: float


def _sweep_setup(
    model: ReducedModel, spin: np.ndarray, axis: np.ndarray, formulation: str, damped: bool
) -> _Sweep:
    sys = rsys.reduced_system(model, formulation)
    count = sys.n_modes + (1 if sys.free else 0)
    if count == 0:
        raise ValueError("campbell: the clamped model has no modes")
    scale = max(float(np.sqrt(np.max(np.diag(sys.Lam), initial=0.0))), float(np.abs(spin).max()))
    scale = max(scale, 1.0)
    step = float(np.abs(np.diff(spin)).min()) if spin.size > 1 else 0.0
    nudge = 1e-4 * step if step > 0.0 else 1e-6 * scale
    return _Sweep(sys, model, axis, damped, count, scale, nudge)


def _selected_roots(sw: _Sweep, om: float):
    """``(linearisation, selected λ (count,), their eigenvectors (m, count))`` at ``om`` rad/s."""
    lin = linearise(sw.sys, sw.model, om, sw.axis, sw.damped)
    idx = _select(lin.lam, sw.count, sw.scale)
    return lin, idx, lin.lam[idx], lin.vectors[:, idx]


def _point(sw: _Sweep, om: float, direction: float) -> _Point:
    """Selected roots at spin ``om`` (rad/s); at a degenerate root the eigenvectors of the
    one-sided limit towards ``direction`` (±1) replace the arbitrary basis."""
    lin, idx, lam, vec = _selected_roots(sw, om)
    if _degenerate(lin.lam, idx, sw.scale):
        _, _, lam2, vec2 = _selected_roots(sw, om + direction * sw.nudge)
        rows, cols = linear_sum_assignment(np.abs(lam[:, None] - lam2[None, :]))
        vec = vec.astype(complex)
        vec[:, rows] = vec2[:, cols]
    return _Point(
        om, lam, _normalise(vec, lin.weight), lin.weight, lin.min_stiffness, lin.s, lin.axis
    )


def _bridge(
    sw: _Sweep, p0: _Point, p1: _Point, depth: int, budget: list[int]
) -> tuple[_Point, np.ndarray]:
    """p1 reordered to follow p0's branches; halve the step while the match is ambiguous (at most
    ``depth`` levels, ``budget[0]`` extra points, decremented). Returns the reordered point and
    the smallest MAC along the chain per branch."""
    order, mac, ok = _match(p0, p1, sw.scale)
    if ok or depth == 0 or budget[0] <= 0:
        return p1.reordered(order), mac
    budget[0] -= 1
    d = np.sign(p1.spin - p0.spin)
    mid = _point(sw, 0.5 * (p0.spin + p1.spin), d)
    pm, mac_a = _bridge(sw, p0, mid, depth - 1, budget)
    p1, mac_b = _bridge(sw, pm, p1, depth - 1, budget)
    return p1, np.minimum(mac_a, mac_b)


def _direction(spin: np.ndarray, i: int) -> float:
    """Sweep direction (±1) at point ``i``: towards the next spin rate (the last point: away from
    the previous one)."""
    if i + 1 < spin.size:
        direction = float(np.sign(spin[i + 1] - spin[i])) or 1.0
    else:
        direction = float(np.sign(spin[i] - spin[i - 1])) if i else 1.0
    return direction or 1.0


def _result(
    sw: _Sweep, spin: np.ndarray, formulation: str, pts: list[_Point], macs: np.ndarray
) -> CampbellResult:
    """Stack the tracked points into a :class:`CampbellResult`."""
    vectors = np.array([p.vec.T for p in pts])
    return CampbellResult(
        spin=spin,
        axis=sw.axis,
        formulation=formulation,
        free=bool(sw.sys.free),
        labels=_branch_labels(sw.model, vectors[0], sw.sys.free),
        frequency=np.array([np.abs(p.lam.imag) for p in pts]),
        growth=np.array([p.lam.real for p in pts]),
        mac=macs,
        min_stiffness=np.array([p.kmin for p in pts]),
        s_eq=np.array([p.s for p in pts]).reshape(spin.size, sw.sys.n_modes),
        spin_axis=np.array([p.axis for p in pts]),
        vectors=vectors,
        mode_labels=tuple(sw.model.labels),
    )


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
    2 major) for a free body; default :func:`~quadmodes.analysis.spin_axis.default_axis`.
    ``formulation``: "Q" (quadratic modes, spin stiffening), "P" or "L" (linear modes, no
    stiffening). ``damped``: include the modal damping C in the roots (growth then holds −ζω).
    Modes are tracked by MAC (module docstring); where the match between two spin rates is
    ambiguous the interval is halved, at most ``max_bisections`` times (and at most
    ``max_refinements`` extra points per interval), and the branches are followed through the
    intermediate points. ``result.mac`` keeps the smallest MAC along that chain: a low value flags
    a match that stayed ambiguous (e.g. an exactly degenerate pair at every spin rate, where any
    basis of the pair is valid)."""
    spin = np.asarray(spin_rates_rad_s, float).ravel()
    if spin.size == 0:
        raise ValueError("spin_rates_rad_s: give at least one spin rate")
    sw = _sweep_setup(model, spin, resolve_axis(model, axis), formulation, damped)
    pts: list[_Point] = []
    macs = np.ones((spin.size, sw.count))
    for i, om in enumerate(spin):
        p = _point(sw, om, _direction(spin, i))
        if not pts:
            p = p.reordered(np.lexsort((p.lam.real, np.abs(p.lam.imag))))
        else:
            # a fresh budget per interval: persistent degeneracy must not bisect forever
            p, macs[i] = _bridge(sw, pts[-1], p, max_bisections, [max_refinements])
        pts.append(p)
    return _result(sw, spin, formulation, pts, macs)


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
