"""Full-order rotating-frame frequencies against the reduced model's Campbell frequencies, per
spin rate and branch (:func:`rotating_frequency_comparison`, ``quadmodes rotating``).

Per spin rate: the full-order relative equilibrium (continued from the previous rate,
:mod:`quadmodes.structure.spinning`), its roots near every reduced root
(:mod:`quadmodes.analysis.rotating_modes`), their assignment to the reduced branches by MAC
(:mod:`quadmodes.analysis.rotating_matching`), and one :class:`ComparisonRow` per branch plus
rows for the full-order roots in the searched band that no branch claimed.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np

from quadmodes.analysis.campbell import CampbellResult, campbell
from quadmodes.analysis.rotating_matching import (
    check_capture,
    comparison_vectors,
    full_order_comparison_vectors,
    mac_matrix,
    match_branches,
)
from quadmodes.analysis.rotating_modes import RotatingRoots, rotating_roots
from quadmodes.fe.model import centre_of_mass
from quadmodes.io.display_units import frequency_unit
from quadmodes.rom.spin_axis import resolve_axis
from quadmodes.structure.spinning import SpinningEquilibrium, relative_equilibrium

Progress = Callable[[str, float], None]

#: Rows whose full-order root has less than this share of kinetic energy in the reduced
#: coordinates are flagged in :meth:`ComparisonTable.to_text`.
POORLY_CAPTURED = 0.5


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

    def to_text(self, unit="Hz") -> str:
        """Markdown table of the rows, then the extra full-order roots; spin rates and
        frequencies in ``unit`` ("Hz", "rpm" or "rad/s"; growth rates in 1/s)."""
        u = frequency_unit(unit)
        head = f"| spin ({u.name}) | branch | full order ({u.name}) |"
        sep = "|---|---|---|"
        for f in self.formulations:
            head += f" {f} ({u.name}) | {f} error | {f} MAC |"
            sep += "---|---|---|"
        head += " captured | rigid |"
        sep += "---|---|"
        lines = [head, sep]
        for r in self.rows:
            line = f"| {u.from_hz(r.spin_hz):.6g} | {r.label} | {u.from_hz(r.full_hz):.6g} |"
            for f in self.formulations:
                g = r.rom_growth[f]
                grow = f" (Re λ {g:+.3g})" if g > 1e-6 * max(1.0, 2 * np.pi * r.full_hz) else ""
                line += (f" {u.from_hz(r.rom_hz[f]):.6g}{grow} | {100 * r.rel_error[f]:+.3f} % | "
                         f"{r.mac[f]:.3f} |")  # fmt: skip
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
                f"| spin ({u.name}) | kind | full order ({u.name}) | captured | rigid |",
                "|---|---|---|---|---|",
            ]
            for r in self.extra:
                lines.append(
                    f"| {u.from_hz(r.spin_hz):.6g} | {r.label} | {u.from_hz(r.full_hz):.6g} | "
                    f"{r.captured:.3f} | {r.rigid_fraction:.3f} |"
                )
        return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# the two sides at one spin rate
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ReducedRoots:
    """Roots of one formulation's Campbell result at one spin rate (free body).

    lam (nb,) complex 1/s; delta_omega (nb, 3) and ds (nb, N): the δω and δs parts of the state
    eigenvectors; labels (nb,): the result's branch labels (same order)."""

    lam: np.ndarray
    delta_omega: np.ndarray
    ds: np.ndarray
    labels: tuple[str, ...]


def reduced_roots(result: CampbellResult, i: int) -> ReducedRoots:
    """The :class:`ReducedRoots` of a free-body Campbell result at spin index ``i``."""
    lam = result.growth[i] + 1j * result.frequency[i]
    v = result.vectors[i]
    n = (v.shape[1] - 3) // 2
    return ReducedRoots(lam, v[:, :3], v[:, 3 : 3 + n], result.labels)


@dataclass(frozen=True)
class FullOrderPoint:
    """Full-order roots at one spin rate with their comparison vectors (k, 3 + 2N) and the share
    of each root's kinetic energy in the reduced coordinates, captured (k,)."""

    roots: RotatingRoots
    vectors: np.ndarray
    captured: np.ndarray


def shift_targets(lam_ref: np.ndarray, spin: float) -> list[float]:
    """Rotating-frame frequencies (Hz, ascending, distinct) of the reference formulation's roots
    ``lam_ref`` (complex 1/s) at which the full order is searched; the nutation root is 0 at rest
    (spin 0 rad/s): no target there."""
    return sorted(
        {float(abs(v.imag)) / (2 * np.pi) for v in lam_ref if abs(v) > 1e-9 * max(1.0, spin)}
    )


def nutation_like(full: FullOrderPoint) -> np.ndarray:
    """(k,) True for a "tilt" root (rigid, at exactly Ω) that carries an angular-velocity
    change: a nutation that coincides with the tilt (a thin disc, I_e = 2 I_⊥: nutation at
    (I_e/I_⊥ − 1)Ω = Ω). A pure tilt is a change of attitude with δω = (λ + Ω[e]×)θ = 0 and no
    reduced counterpart; a nutation has |δω|²_J ≈ 4Ω² θᴴJθ, against |λ|² θᴴJθ ≈ |λ|² captured."""
    tilt = np.array([k == "tilt" for k in full.roots.kind], bool)
    rot = np.sum(np.abs(full.vectors[:, :3]) ** 2, axis=1)
    scale = np.abs(full.roots.lam) ** 2 * np.maximum(full.captured, 1e-300)
    return tilt & (rot > scale)


def _assign(
    rr: ReducedRoots, full: FullOrderPoint, eligible: np.ndarray, model, spin: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(full-order index per reduced root (nb,), or −1; MAC (nb,))``; zero reduced roots
    (nutation at rest) stay unmatched."""
    lam = rr.lam
    present = np.isfinite(lam)
    lam = np.where(present, lam, 0.0)
    dw, ds = np.nan_to_num(rr.delta_omega), np.nan_to_num(rr.ds)
    vec = comparison_vectors(lam, dw, ds, model.J0, np.diag(model.Lam))
    rom_ok = present & (np.abs(lam) > 1e-9 * max(1.0, spin))
    idx, mac = match_branches(vec[rom_ok], lam[rom_ok], full.vectors, full.roots.lam, eligible,
                              full.captured)  # fmt: skip
    full_idx, full_mac = np.full(lam.size, -1), np.zeros(lam.size)
    full_idx[rom_ok], full_mac[rom_ok] = idx, mac
    return full_idx, full_mac


# ---------------------------------------------------------------------------------------------
# rows
# ---------------------------------------------------------------------------------------------


def _relative_error(rom_hz: float, full_hz: float) -> float:
    """(rom − full)/full; 0 when both are 0 (nutation at rest), NaN without a full-order root."""
    if full_hz and np.isfinite(full_hz):
        return (rom_hz - full_hz) / full_hz
    return 0.0 if full_hz == 0.0 and rom_hz == 0.0 else np.nan


def _formulation_entry(
    rr: ReducedRoots, label: str, j: int, full_hz: float, full: FullOrderPoint, model,
    claimed: np.ndarray,
) -> tuple[float, float, float, float]:
    """``(frequency Hz, growth Re λ 1/s, relative error, MAC)`` of one formulation's root
    matched to the full-order root ``j`` (−1: none; ``claimed`` (nb,) the full-order root each
    of its roots was assigned to), else its branch ``label``: the roots of every formulation are
    matched to the same full-order roots, so an entry does not depend on that formulation's own
    branch tracking (which may end a branch where the reference formulation's continues)."""
    lam = rr.lam
    mine = np.flatnonzero(claimed == j) if j >= 0 else np.zeros(0, int)
    fb = int(mine[0]) if mine.size else (rr.labels.index(label) if label in rr.labels else -1)
    if fb >= 0 and not np.isfinite(lam[fb]):
        fb = -1
    rom_hz = float(abs(lam[fb].imag) / (2 * np.pi)) if fb >= 0 else np.nan
    growth = float(lam[fb].real) if fb >= 0 else np.nan
    if j >= 0 and fb >= 0:
        v = comparison_vectors(
            lam[fb : fb + 1],
            rr.delta_omega[fb : fb + 1],
            rr.ds[fb : fb + 1],
            model.J0,
            np.diag(model.Lam),
        )
        mac = float(mac_matrix(v, full.vectors[j : j + 1])[0, 0])
    else:
        mac = np.nan
    return rom_hz, growth, _relative_error(rom_hz, full_hz), mac


def _branch_row(
    spin_hz: float,
    label: str,
    j: int,
    full: FullOrderPoint,
    reduced: dict[str, ReducedRoots],
    model,
    claimed: dict[str, np.ndarray],
) -> ComparisonRow:
    """The row of branch ``label`` at ``spin_hz`` (Hz), matched to full-order root ``j``;
    ``claimed[f]`` the full-order root of each root of formulation f (−1: none)."""
    roots = full.roots
    full_hz = float(roots.frequency_hz[j]) if j >= 0 else (0.0 if spin_hz == 0.0 else np.nan)
    entries = {
        f: _formulation_entry(rr, label, j, full_hz, full, model, claimed[f])
        for f, rr in reduced.items()
    }
    return ComparisonRow(
        spin_hz=spin_hz,
        label=label,
        full_hz=full_hz,
        full_growth=float(roots.lam[j].real) if j >= 0 else np.nan,
        rom_hz={f: e[0] for f, e in entries.items()},
        rel_error={f: e[2] for f, e in entries.items()},
        mac={f: e[3] for f, e in entries.items()},
        rom_growth={f: e[1] for f, e in entries.items()},
        captured=float(full.captured[j]) if j >= 0 else np.nan,
        rigid_fraction=float(roots.rigid_fraction[j]) if j >= 0 else np.nan,
    )


def _unclaimed_rows(
    spin_hz: float,
    full: FullOrderPoint,
    claimed: set[int],
    targets: Sequence[float],
    formulations: Sequence[str],
) -> list[ComparisonRow]:
    """Rows for the full-order roots within [0.9 min, 1.1 max] of the targets (Hz) that no branch
    claimed: "tilt" (rigid attitude root) or "other"."""
    roots = full.roots
    lo, hi = min(targets, default=0.0), max(targets, default=0.0)
    out = []
    for j in range(roots.lam.size):
        fj = roots.frequency_hz[j]
        if j in claimed or not (0.9 * lo <= fj <= 1.1 * hi):
            continue
        nan = {f: np.nan for f in formulations}
        out.append(
            ComparisonRow(
                spin_hz,
                roots.kind[j] if roots.kind[j] == "tilt" else "other",
                float(fj),
                float(roots.lam[j].real),
                nan,
                nan,
                nan,
                nan,
                float(full.captured[j]),
                float(roots.rigid_fraction[j]),
            )
        )
    return out


def _rows_at_spin(
    spin_hz: float,
    labels: Sequence[str],
    full: FullOrderPoint,
    reduced: dict[str, ReducedRoots],
    targets: Sequence[float],
    model,
) -> tuple[list[ComparisonRow], list[ComparisonRow]]:
    """``(branch rows, unclaimed rows)`` at one spin rate; ``reduced`` per formulation, the first
    one the reference whose assignment fixes the full-order root of each branch."""
    formulations = tuple(reduced)
    spin = 2.0 * np.pi * spin_hz
    eligible = np.array([k == "elastic" for k in full.roots.kind]) | nutation_like(full)
    assigned = {f: _assign(reduced[f], full, eligible, model, spin) for f in formulations}
    ref_idx = assigned[formulations[0]][0]
    present = np.isfinite(reduced[formulations[0]].lam)
    rows = [
        _branch_row(spin_hz, label, ref_idx[b], full, reduced, model,
                    {f: a[0] for f, a in assigned.items()})
        for b, label in enumerate(labels)
        if present[b]  # a branch that ended (refused match) or has not started has no row
    ]
    claimed = {int(j) for f in formulations for j in assigned[f][0] if j >= 0}
    return rows, _unclaimed_rows(spin_hz, full, claimed, targets, formulations)


# ---------------------------------------------------------------------------------------------
# the comparison
# ---------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _timed(timings: dict[str, float], key: str) -> Iterator[None]:
    """Add the wall seconds of the block to ``timings[key]``."""
    t0 = time.perf_counter()
    yield
    timings[key] = timings.get(key, 0.0) + time.perf_counter() - t0


def case_state(case):
    """``(Case, structure for vibrations (gas law set), inflated state x (n, 3) m)`` of a case name,
    TOML path or Case (pipeline.structure_for_case, reference_state, with_gas_law)."""
    from quadmodes.case import Case, load_case
    from quadmodes.structure.pipeline import reference_state, structure_for_case, with_gas_law

    if not isinstance(case, Case):
        case = load_case(case)
    structure = structure_for_case(case)
    x0, _ = reference_state(case, structure)
    return case, with_gas_law(case, structure, x0), x0


def _case_and_model(case, n_modes: int, model, timings: dict[str, float]):
    """``(Case, structure, x0, reduced model)`` of a free-body case (timed)."""
    from quadmodes.models.build import reduced_model_for

    with _timed(timings, "inflation"):
        case, structure, x0 = case_state(case)
        if not structure.is_free:
            raise ValueError("rotating_frequency_comparison: the case must be a free body")
    with _timed(timings, "reduced model"):
        rom = model if model is not None else reduced_model_for(case, n_modes)
    if rom.X.shape != x0.shape:
        raise ValueError("model: the reduced model does not belong to this case (node count)")
    return case, structure, x0, rom


def rotating_frequency_comparison(
    case,
    spins_hz: Sequence[float] = (0.0, 20.0, 41.0),
    n_modes: int = 5,
    formulations: Sequence[str] = ("Q", "L"),
    axis=None,
    model=None,
    per_target: int = 6,
    progress: Progress | None = None,
    axis_option: str = "axis",
) -> ComparisonTable:
    """Rotating-frame frequencies of the full-order FE model about its spinning relative
    equilibrium against :func:`quadmodes.analysis.campbell.campbell` of the reduced model, per spin rate
    (Hz, swept in the given order) and branch.

    ``case``: name, TOML path or Case of a free membrane body. ``axis``: spin axis as in
    campbell (a name "x" … "major", a principal index of the reduced model's J0, 0 minor … 2
    major, or three numbers; :mod:`quadmodes.rom.spin_axis`, ``axis_option`` names it in
    errors; None: the axis of a model about a spinning state, e.g. a flat membrane's normal,
    else the minor axis); the full order spins about the same body axis. ``model``:
    a ReducedModel of this case (default ``models.build.reduced_model_for(case, n_modes)``, cached).
    Full-order roots are searched near every reduced root (``per_target`` per shift) and assigned
    to branches by the MAC of energy-weighted (δω, s, ṡ) vectors (:func:`match_branches`)."""
    timings: dict[str, float] = {}
    case, structure, x0, rom = _case_and_model(case, n_modes, model, timings)
    e = resolve_axis(rom, axis, axis_option, default=0)
    spins_hz = [float(s) for s in spins_hz]
    formulations = tuple(formulations)
    with _timed(timings, "campbell"):
        spins = 2.0 * np.pi * np.asarray(spins_hz)
        results = {f: campbell(rom, spins, e, formulation=f) for f in formulations}
    labels = results[formulations[0]].labels
    timings["equilibrium"] = timings["eigen"] = 0.0
    rows, extra, equilibria = [], [], []
    x_prev, om_prev, centre = x0, 0.0, centre_of_mass(structure, x0)
    for i, fhz in enumerate(spins_hz):
        om = 2.0 * np.pi * fhz
        with _timed(timings, "equilibrium"):
            eq = relative_equilibrium(
                structure, x_prev, om, e, centre=centre, start_spin=om_prev, reference=x0
            )
        equilibria.append(eq)
        x_prev, om_prev = eq.x, om
        reduced = {f: reduced_roots(results[f], i) for f in formulations}
        # shifts at the reference formulation's roots (the others are matched among the same
        # full-order roots)
        targets = shift_targets(reduced[formulations[0]].lam, om)
        with _timed(timings, "eigen"):
            roots = rotating_roots(structure, eq.x, om, e, targets, per_target=per_target)
        full = FullOrderPoint(roots, *full_order_comparison_vectors(structure, eq.x, roots, rom, e))
        check_capture(full.captured, roots.frequency_hz, fhz)
        branch_rows, unclaimed = _rows_at_spin(fhz, labels, full, reduced, targets, rom)
        rows += branch_rows
        extra += unclaimed
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
