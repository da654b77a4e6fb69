"""Campbell diagrams: rotating-frame frequencies of the reduced model versus steady spin rate.

Each spin rate is one linearisation of the reduced model about steady spin (the clamped body on
a spinning hub, or the free body about its relative equilibrium:
:mod:`quadmodes.analysis.reduced_linearisation`; see docs/kane-and-campbell.md). It gives N
(clamped) or N + 1 (free: plus nutation) roots with Im λ ≥ 0; a root with a real pair
(divergence, e.g. formulation "L" above the first in-plane frequency) is kept as its growing
member (frequency 0, growth Re λ > 0). Branches are followed from one spin rate to the next by
the modal assurance criterion of the state eigenvectors in the energy inner product, degenerate
roots by the span of their cluster, and a poor match is refused: the branch ends and a new one
starts (:mod:`quadmodes.analysis.campbell_tracking`), so labels stay with their branch. Roots
that are degenerate at one spin rate (e.g. y/z pairs at Ω = 0) have no unique eigenvectors:
there the eigenvectors of the one-sided limit (spin rate nudged towards the next point) are used.
The spin axis of a free body follows :mod:`quadmodes.rom.spin_axis` (exactly the requested
axis when it lies in an eigenspace of equal moments). Output (figure, dataset, CSV) and the CLI
entry: :mod:`quadmodes.analysis.campbell_output`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from quadmodes.analysis import campbell_tracking as tr
from quadmodes.analysis.reduced_linearisation import linearise
from quadmodes.rom import system as rsys
from quadmodes.rom.reduced import ReducedModel
from quadmodes.rom.spin_axis import resolve_axis
from quadmodes.runs.manifold_system import linear_formulation

#: Two roots closer than this (relative to their magnitude) are degenerate.
DEGENERATE_RTOL = 1e-7


@dataclass(frozen=True)
class CampbellResult:
    """Frequencies of the reduced model linearised about steady spin, per tracked branch (SI).

    spin (ns,) rad/s: spin rates Ω. axis (3,): unit spin axis in the body frame (requested).
    formulation: "Q", "P", "L", "Q4" or "QM" (as asked; "QM" linearised as "Q4"). free: free body (True) or clamped to a hub (False).
    labels (nb,): branch names (model mode label dominant where the branch starts, or
    "nutation"). A branch whose match to the next spin rate is refused ends there and the root
    that would have continued it starts a new branch, so nb may exceed the roots per spin rate;
    every quantity of a branch is NaN at the spin rates where it does not exist.
    start (nb,): index of the first spin rate of each branch.
    frequency (ns, nb) rad/s: |Im λ| along each branch. growth (ns, nb) 1/s: Re λ (> 0 unstable).
    mac (ns, nb): smallest (span) MAC of each branch with itself at the previous spin rate along
    the halved steps (1 at its first spin rate).
    min_stiffness (ns,) 1/s²: smallest eigenvalue of the rotating stiffness Λ − ωᵀJ2ω (s = s*).
    s_eq (ns, N) √kg·m: relative-equilibrium modal coordinates (zero for a clamped body).
    spin_axis (ns, 3): the axis of the relative equilibrium (= axis for a clamped body).
    vectors (ns, nb, 3+2N or 2N) complex: state eigenvectors (free: δω, δs, δṡ; clamped: δs, δṡ),
    unit energy norm.
    divergence (nd,) rad/s: spin rates where the free body's rotating stiffness loses (or
    regains) positive definiteness between two points of the sweep (empty for a clamped body):
    there the relative equilibrium s* = (Λ − ωᵀJ2ω)⁻¹ ½ωᵀJ1ω passes through infinity, so every
    branch ends at the last point before it and the roots after it start new branches.
    notes: what the sweep changed from the request (e.g. the start of a body without stiffness
    at rest, :func:`quadmodes.analysis.campbell_output.sweep_spins`).
    table: the :class:`~quadmodes.analysis.campbell_table.CampbellTable` printed by ``quadmodes
    campbell`` in the unit asked for (``--units``, ``qm.campbell(units=)``; None: not made).
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
    start: np.ndarray | None = None
    divergence: np.ndarray = field(default_factory=lambda: np.zeros(0))
    notes: tuple[str, ...] = ()
    table: object = field(default=None, repr=False)

    @property
    def frequency_hz(self) -> np.ndarray:
        return self.frequency / (2.0 * np.pi)

    @property
    def ratio(self) -> np.ndarray:
        """(ns, nb) ω/Ω along each branch (NaN at Ω = 0 and where a branch does not exist):
        independent of the spin for a body whose stiffness is all from its spin."""
        spin = np.asarray(self.spin, float)[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(spin > 0.0, self.frequency / np.where(spin > 0.0, spin, 1.0), np.nan)

    @property
    def unstable(self) -> np.ndarray:
        """(ns, nb) bool: roots with positive real part (beyond round-off; False where a branch
        does not exist)."""
        scale = 1e-7 * (1.0 + np.nanmax(np.abs(self.frequency), initial=0.0))
        return np.nan_to_num(self.growth, nan=-np.inf) > scale

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

    @property
    def finite(self) -> bool:
        """Roots, eigenvectors and weight all finite (not so next to a divergence, where the
        relative equilibrium overflows)."""
        return bool(
            np.isfinite(self.lam).all() and np.isfinite(self.vec).all() and np.isfinite(self.wgt).all()
        )

    def reordered(self, order: np.ndarray) -> _Point:
        return _Point(
            self.spin, self.lam[order], self.vec[:, order], self.wgt, self.kmin, self.s, self.axis
        )


# ---------------------------------------------------------------------------------------------
# Campbell sweep
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Sweep:
    """What stays fixed over one sweep: the reduced system, its model, the requested unit axis
    (3,), ``damped``, the number of roots per point, the frequency scale (1/s) and the nudge
    (rad/s) of the one-sided limit at degenerate roots; disp (m,) bool: the displacement (δs)
    entries of the state; balance: match by the spin-free MAC (:func:`stiffless_at_rest`)."""

    sys: rsys.ReducedSystem
    model: ReducedModel
    axis: np.ndarray
    damped: bool
    count: int
    scale: float
    nudge: float
    disp: np.ndarray
    balance: bool = False


def _sweep_setup(
    model: ReducedModel, spin: np.ndarray, axis: np.ndarray, formulation: str, damped: bool
) -> _Sweep:
    # QM's kinetic energy to second order about s = 0 is Q's and its potential is Q4's: its
    # linearisation about a steady spin is Q4's (runs.manifold_system.linear_formulation)
    sys = rsys.reduced_system(model, linear_formulation(formulation))
    count = sys.n_modes + (1 if sys.free else 0)
    if count == 0:
        raise ValueError("campbell: the clamped model has no modes")
    scale = max(float(np.sqrt(np.max(np.diag(sys.Lam), initial=0.0))), float(np.abs(spin).max()))
    scale = max(scale, 1.0)
    step = float(np.abs(np.diff(spin)).min()) if spin.size > 1 else 0.0
    nudge = 1e-4 * step if step > 0.0 else 1e-6 * scale
    n, off = sys.n_modes, 3 if sys.free else 0
    disp = np.zeros(off + 2 * n, bool)
    disp[off : off + n] = True
    return _Sweep(sys, model, axis, damped, count, scale, nudge, disp, stiffless_at_rest(model))


def stiffless_at_rest(model: ReducedModel) -> bool:
    """True for a model expanded about a spinning state whose modal stiffness Λ at rest is not
    positive (smallest eigenvalue ≤ 1e-6 Ω_ref²): a membrane held taut by its spin alone, whose
    every stiffness comes from the spin (its rotating stiffness is singular at Ω = 0, so a
    sweep from 0 meets a spurious divergence at its first step, and its frequencies, all ∝ Ω,
    make the eigenvectors' velocity blocks scale with the spin)."""
    if not model.reference_spin or model.n_modes == 0:
        return False
    lam = np.linalg.eigvalsh(0.5 * (model.Lam + model.Lam.T))
    return bool(lam.min() <= 1e-6 * float(model.reference_spin) ** 2)


def _selected_roots(sw: _Sweep, om: float):
    """``(linearisation, selected λ (count,), their eigenvectors (m, count))`` at ``om`` rad/s."""
    lin = linearise(sw.sys, sw.model, om, sw.axis, sw.damped)
    if not np.isfinite(lin.lam).all():
        idx = np.arange(sw.count)  # no roots (non-finite equilibrium): NaN in every branch
        return lin, idx, lin.lam[idx], lin.vectors[:, idx]
    idx = _select(lin.lam, sw.count, sw.scale)
    return lin, idx, lin.lam[idx], lin.vectors[:, idx]


def _point(sw: _Sweep, om: float, direction: float) -> _Point:
    """Selected roots at spin ``om`` (rad/s); at a degenerate root the eigenvectors of the
    one-sided limit towards ``direction`` (±1) replace the arbitrary basis (the spin nudged by
    ``sw.nudge``, ten times more while the roots there are still degenerate, up to 1000 ×, at
    most 1 % of a spin ≠ 0); a degeneracy the nudge does not lift at a spin ≠ 0 (a symmetry:
    the pairs of an axisymmetric body) keeps its basis and is matched as a cluster by span."""
    lin, idx, lam, vec = _selected_roots(sw, om)
    if _degenerate(lin.lam, idx, sw.scale):
        # nudge up to 1e-1 of the step (and 1e-2 of a spin ≠ 0: the roots of a body stiffened
        # by its spin alone move in proportion to it) until the roots have split
        cap = 1e-2 * abs(om) if om else np.inf
        for k in range(4):
            shift = min(sw.nudge * 10.0**k, cap)
            lin2, idx2, lam2, vec2 = _selected_roots(sw, om + direction * shift)
            split = not _degenerate(lin2.lam, idx2, sw.scale)
            if split:
                break
        if split or not om:  # a degeneracy the spin does not lift (a symmetry) stays a cluster
            rows, cols = linear_sum_assignment(np.abs(lam[:, None] - lam2[None, :]))
            vec = vec.astype(complex)
            vec[:, rows] = vec2[:, cols]
    return _Point(
        om, lam, tr.normalise(vec, lin.weight), lin.weight, lin.min_stiffness, lin.s, lin.axis
    )


def _match(sw: _Sweep, p0: _Point, p1: _Point) -> tuple[_Point, np.ndarray, bool]:
    """p1 (exactly degenerate bases rotated onto p0) reordered to follow p0's branches, the
    (span) MAC per branch and whether the match is clear
    (:func:`quadmodes.analysis.campbell_tracking.match`)."""
    wgt = 0.5 * (p0.wgt + p1.wgt)
    vec = tr.align_degenerate(p0.vec, p1.vec, p1.lam, p1.wgt, sw.scale)
    p1 = _Point(p1.spin, p1.lam, vec, p1.wgt, p1.kmin, p1.s, p1.axis)
    order, mac, ok = tr.match(p0.vec, p0.lam, p1.vec, p1.lam, wgt, sw.scale, sw.disp, sw.balance)
    return p1.reordered(order), mac, ok


def _bridge(
    sw: _Sweep, p0: _Point, p1: _Point, depth: int, budget: list[int]
) -> tuple[_Point, np.ndarray]:
    """p1 reordered to follow p0's branches; halve the step while the match is ambiguous (at most
    ``depth`` levels, ``budget[0]`` extra points, decremented). Returns the reordered point and
    the smallest (span) MAC along the chain per branch."""
    p1m, mac, ok = _match(sw, p0, p1)
    if ok or depth == 0 or budget[0] <= 0:
        return p1m, mac
    budget[0] -= 1
    d = np.sign(p1.spin - p0.spin)
    mid = _point(sw, 0.5 * (p0.spin + p1.spin), d)
    if _crosses(sw, p0, mid) or _crosses(sw, mid, p1):
        return p1m, np.zeros_like(mac)  # a divergence inside the step: the branches end
    pm, mac_a = _bridge(sw, p0, mid, depth - 1, budget)
    p1, mac_b = _bridge(sw, pm, p1, depth - 1, budget)
    return p1, np.minimum(mac_a, mac_b)


def _crosses(sw: _Sweep, p0: _Point, p1: _Point) -> bool:
    """True when no branch can continue from p0 to p1: either point is not finite, or (free
    body) the rotating stiffness changes definiteness between them (a divergence: the relative
    equilibrium passes through infinity; a clamped body's roots pass through zero continuously
    and are tracked on)."""
    if not (p0.finite and p1.finite):
        return True
    return bool(sw.sys.free and (p0.kmin > 0.0) != (p1.kmin > 0.0))


def _divergence_spin(sw: _Sweep, p0: _Point, p1: _Point) -> float:
    """Spin rate (rad/s) between p0 and p1 where the smallest eigenvalue of the rotating
    stiffness Λ − ωᵀJ2ω about p0's equilibrium axis is zero (Brent's method; exact for an axis
    that does not move with s*, e.g. a body of revolution; otherwise within the axis change
    between the points). NaN when it has no sign change there (a non-finite point)."""
    from scipy.optimize import brentq

    from quadmodes.rom import rotating_frame as rf

    axis = p0.axis / max(float(np.linalg.norm(p0.axis)), 1e-300)

    def kmin(om: float) -> float:
        k = rf.rotating_frame_matrices(sw.sys, om * axis)[2]
        return float(np.linalg.eigvalsh(k).min()) if k.size else np.inf

    a, b = p0.spin, p1.spin
    fa, fb = kmin(a), kmin(b)
    if not (np.isfinite(fa) and np.isfinite(fb)) or (fa > 0.0) == (fb > 0.0):
        return float("nan")
    return float(brentq(kmin, a, b, xtol=1e-12 * max(abs(a), abs(b), 1.0)))


def _direction(spin: np.ndarray, i: int) -> float:
    """Sweep direction (±1) at point ``i``: towards the next spin rate (the last point: away from
    the previous one)."""
    if i + 1 < spin.size:
        direction = float(np.sign(spin[i + 1] - spin[i])) or 1.0
    else:
        direction = float(np.sign(spin[i] - spin[i - 1])) if i else 1.0
    return direction or 1.0


@dataclass
class _Branches:
    """Tracking bookkeeping: ``column[c]`` the branch of column c of the current point,
    ``start[b]`` the spin index where branch b starts, ``labels[b]`` its label."""

    column: np.ndarray
    start: list[int]
    labels: list[str]

    def refuse(self, columns: np.ndarray, i: int, names: list[str]) -> None:
        """End the branches of ``columns`` before spin index ``i``; their roots start new
        branches named ``names``."""
        for c, name in zip(columns, names, strict=True):
            self.column[c] = len(self.start)
            self.start.append(i)
            self.labels.append(_unique(name, self.labels))


def _unique(label: str, taken: list[str]) -> str:
    """``label``, or ``label #k`` with the smallest k ≥ 2 not in ``taken``."""
    if label not in taken:
        return label
    k = 2
    while f"{label} #{k}" in taken:
        k += 1
    return f"{label} #{k}"


def _result(
    sw: _Sweep,
    spin: np.ndarray,
    formulation: str,
    pts: list[_Point],
    macs: np.ndarray,
    branches: list[np.ndarray],
    book: _Branches,
) -> CampbellResult:
    """Stack the tracked points (``branches[i]``: branch of each column at spin i) into a
    :class:`CampbellResult` (NaN where a branch does not exist)."""
    ns, nb, m = spin.size, len(book.labels), pts[0].vec.shape[0]
    freq, growth, mac = (np.full((ns, nb), np.nan) for _ in range(3))
    vectors = np.full((ns, nb, m), np.nan + 0j)
    for i, (p, cols) in enumerate(zip(pts, branches, strict=True)):
        freq[i, cols] = np.abs(p.lam.imag)
        growth[i, cols] = p.lam.real
        mac[i, cols] = macs[i]
        vectors[i, cols] = p.vec.T
    return CampbellResult(
        spin=spin,
        axis=sw.axis,
        formulation=formulation,
        free=bool(sw.sys.free),
        labels=tuple(book.labels),
        frequency=freq,
        growth=growth,
        mac=mac,
        min_stiffness=np.array([p.kmin for p in pts]),
        s_eq=np.array([p.s for p in pts]).reshape(spin.size, sw.sys.n_modes),
        spin_axis=np.array([p.axis for p in pts]),
        vectors=vectors,
        mode_labels=tuple(sw.model.labels),
        start=np.array(book.start),
    )


def campbell(
    model: ReducedModel,
    spin_rates_rad_s,
    axis=None,
    formulation: str = "Q",
    damped: bool = False,
    max_bisections: int = 30,
    max_refinements: int = 200,
    axis_option: str = "axis",
) -> CampbellResult:
    """Campbell diagram of ``model`` over ``spin_rates_rad_s`` (rad/s, swept in the given order).

    ``axis``: body-frame spin axis: a name ("x", "y", "z", "minor", "intermediate", "major"), an
    int principal index of J0 (0 minor … 2 major) or three numbers, by the rule of
    :mod:`quadmodes.rom.spin_axis` (``axis_option`` names it in errors); default
    :func:`~quadmodes.rom.spin_axis.default_axis`.
    ``formulation``: "Q" (quadratic modes, spin stiffening), "P" or "L" (linear modes, no
    stiffening), "Q4" (Q with the quartic manifold potential) or "QM" (linearised as Q4: the
    same roots; ``result.formulation`` keeps "QM"). ``damped``: include the modal damping C in the roots (growth then holds −ζω).
    Modes are tracked by MAC (:mod:`quadmodes.analysis.campbell_tracking`); where the match
    between two spin rates is ambiguous the interval is halved, at most ``max_bisections`` times
    (and at most ``max_refinements`` extra points per interval), and the branches are followed
    through the intermediate points. ``result.mac`` keeps the smallest MAC along that chain; a
    branch whose MAC stays below ``MAC_REFUSE`` ends and a new branch starts."""
    spin = np.asarray(spin_rates_rad_s, float).ravel()
    if spin.size == 0:
        raise ValueError("spin_rates_rad_s: give at least one spin rate")
    sw = _sweep_setup(model, spin, resolve_axis(model, axis, axis_option), formulation, damped)
    pts: list[_Point] = []
    macs = np.ones((spin.size, sw.count))
    branches: list[np.ndarray] = []
    book = _Branches(np.arange(sw.count), [0] * sw.count, [])
    divergence: list[float] = []
    for i, om in enumerate(spin):
        p = _point(sw, om, _direction(spin, i))
        if not pts:
            p = p.reordered(np.lexsort((p.lam.real, np.abs(p.lam.imag))))
            book.labels = list(_new_labels(model, p, sw.sys.free, dedupe=True))
        elif _crosses(sw, pts[-1], p):
            if sw.sys.free and pts[-1].finite and p.finite:
                divergence.append(_divergence_spin(sw, pts[-1], p))
            book.refuse(np.arange(sw.count), i, list(_new_labels(model, p, sw.sys.free)))
        else:
            # a fresh budget per interval: persistent degeneracy must not bisect forever
            p, macs[i] = _bridge(sw, pts[-1], p, max_bisections, [max_refinements])
            poor = np.flatnonzero(macs[i] < tr.MAC_REFUSE)
            if poor.size:
                names = _branch_labels(model, p.vec[:, poor].T, sw.sys.free, dedupe=False)
                book.refuse(poor, i, list(names))
                macs[i, poor] = 1.0
        pts.append(p)
        branches.append(book.column.copy())
    res = _result(sw, spin, formulation, pts, macs, branches, book)
    return replace(res, divergence=np.array([d for d in divergence if np.isfinite(d)]))


def _new_labels(model: ReducedModel, p: _Point, free: bool, dedupe: bool = False):
    """Branch names of the roots of ``p`` (:func:`_branch_labels`); "undefined" for every root
    of a point that is not finite."""
    if not p.finite:
        return ("undefined",) * p.lam.size
    return _branch_labels(model, p.vec.T, free, dedupe=dedupe)


def _branch_labels(
    model: ReducedModel, vectors: np.ndarray, free: bool, dedupe: bool = True
) -> tuple[str, ...]:
    """Name each branch by its dominant share where it starts (``vectors`` (k, m)): the
    rotational perturbation ("nutation") or the model mode with the largest
    |δs_k|² + |δṡ_k|²/ω_k²; ``dedupe``: repeated names get " #2", " #3" …"""
    n = model.n_modes
    # ω_k² of the model's modes: about a spinning state those of its rotating-frame stiffness
    # (Λ of a flat membrane is ≈ 0, of either sign, on the manifold: docs/sails.md)
    om2 = np.maximum((2 * np.pi * np.asarray(model.frequencies_hz, float)) ** 2, 1e-300)
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
    if not dedupe:
        return tuple(labels)
    out: list[str] = []
    for lab in labels:
        out.append(_unique(lab, out))
    return tuple(out)
