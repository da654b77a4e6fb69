"""The table of a Campbell diagram in the unit a user chose (Hz, rpm, rad/s): what ``quadmodes
campbell --units`` prints and what ``qm.campbell(..., units=)`` returns, made by one function so
that the library and the command line show the same numbers in the same units. The arrays of
:class:`~quadmodes.analysis.campbell.CampbellResult` and the files stay SI (rad/s)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.analysis.campbell_figure import engine_order_crossings
from quadmodes.io.display_units import FrequencyUnit, frequency_unit

#: The printed table shows at most this many spin rates (evenly spread) and branches.
TABLE_SPINS, TABLE_BRANCHES = 9, 6


@dataclass(frozen=True)
class CampbellTable:
    """A Campbell diagram's table in ``unit`` ("Hz", "rpm", "rad/s").

    title: its title; labels (≤ 6,): the branches shown; spin (k,) and frequency (k, ≤ 6): the
    rows (at most 9 spin rates of the sweep, evenly spread; rotating frame; NaN where a branch
    does not exist); critical ``((spin, branch, order), …)``: where a branch meets f = kΩ;
    divergence (spins where the rotating stiffness changes definiteness); unstable_from: the
    first spin where it is not positive definite (None: nowhere); ratios ``((branch, least ω/Ω,
    largest ω/Ω), …)`` for a body stiffened by its spin alone (empty otherwise); notes."""

    unit: str
    title: str
    labels: tuple[str, ...]
    spin: np.ndarray
    frequency: np.ndarray
    critical: tuple[tuple[float, str, int], ...]
    divergence: tuple[float, ...]
    unstable_from: float | None
    ratios: tuple[tuple[str, float, float], ...]
    notes: tuple[str, ...]

    def cells(self) -> list[list[str]]:
        """The rows as printed: spin, then each branch's frequency ("-": none), 4 digits."""
        return [[f"{w:.4g}", *(f"{v:.4g}" if np.isfinite(v) else "-" for v in row)]
                for w, row in zip(self.spin, self.frequency, strict=True)]  # fmt: skip

    def to_text(self) -> str:
        """The table and its notes as plain text (tab-separated columns)."""
        lines = [self.title, "\t".join([f"spin ({self.unit})", *self.labels])]
        lines += ["\t".join(row) for row in self.cells()]
        lines += [f"note: {n}" for n in self.notes]
        if self.ratios:
            lines.append("ω/Ω over the sweep: " + "; ".join(
                f"{lab} {lo:.4g}–{hi:.4g}" for lab, lo, hi in self.ratios))  # fmt: skip
        lines += [f"critical speed {w:.4g} {self.unit}: {lab} meets {k}Ω"
                  for w, lab, k in self.critical]  # fmt: skip
        lines += [f"divergence at {w:.4g} {self.unit}" for w in self.divergence]
        return "\n".join(lines)


def campbell_table(result, unit: str | FrequencyUnit = "Hz", case_name: str = "") -> CampbellTable:
    """The :class:`CampbellTable` of ``result`` (a
    :class:`~quadmodes.analysis.campbell.CampbellResult`) in ``unit``."""
    u = frequency_unit(unit, "units")
    spin = np.asarray(result.spin, float)
    rows = np.linspace(0, len(spin) - 1, min(TABLE_SPINS, len(spin))).astype(int)
    freq = u.from_rad_s(np.asarray(result.frequency, float)[:, :TABLE_BRANCHES])
    ratios = ()
    if result.notes:  # a body stiffened by its spin alone: ω/Ω is its spin-free answer
        ratio = np.asarray(result.ratio, float)
        ratios = tuple((lab, float(np.nanmin(r)), float(np.nanmax(r)))
                       for lab, r in zip(result.labels[:TABLE_BRANCHES], ratio.T[:TABLE_BRANCHES],
                                         strict=False) if np.isfinite(r).any())  # fmt: skip
    lost = [w for w, un, k in zip(spin, result.unstable, result.min_stiffness, strict=True)
            if np.any(un) or k <= 0.0]  # fmt: skip
    return CampbellTable(
        unit=u.name, title=f"{case_name}: rotating-frame ({u.name})" if case_name else
        f"rotating-frame ({u.name})", labels=tuple(result.labels[:TABLE_BRANCHES]),
        spin=u.from_rad_s(spin[rows]), frequency=np.atleast_2d(freq[rows]),
        critical=tuple((u.from_rad_s(c.spin), c.label, c.order)
                       for c in engine_order_crossings(result)),  # fmt: skip
        divergence=tuple(u.from_rad_s(w) for w in result.divergence),
        unstable_from=u.from_rad_s(lost[0]) if lost else None, ratios=ratios,
        notes=tuple(result.notes),
    )  # fmt: skip
