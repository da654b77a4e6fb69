"""Validation results and the validation page: :class:`Row` (one measured number against its
reference and tolerance), the Markdown tables, and :func:`validation_markdown` (docs/validation.md).

The check modules (:mod:`quadmodes.validation.fe_checks`,
:mod:`quadmodes.validation.dynamics_checks`) return rows; ``quadmodes validate`` assembles the
page.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Row:
    """One validation result; ``tolerance`` is relative unless ``absolute`` is set."""

    check: str
    measured: float
    reference: float
    tolerance: float
    unit: str = ""
    absolute: bool = False
    source: str = ""
    report_only: bool = False

    @property
    def error(self) -> float:
        diff = abs(self.measured - self.reference)
        return diff if self.absolute else diff / abs(self.reference)

    @property
    def passed(self) -> bool:
        return self.report_only or bool(self.error <= self.tolerance)


#: A validation check: runs and returns its rows.
Check = Callable[[], list[Row]]


def format_rows(rows: list[Row]) -> str:
    """Markdown table of rows."""
    lines = [
        "| check | measured | reference | error | tolerance | pass | source |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        kind = "abs" if r.absolute else "rel"
        name = r.check.replace("|", "\\|")  # a literal pipe would split the Markdown cell
        tol = "reported" if r.report_only else f"{r.tolerance:.2g}"
        verdict = "—" if r.report_only else ("yes" if r.passed else "**NO**")
        lines.append(
            f"| {name} | {r.measured:.6g} {r.unit} | {r.reference:.6g} {r.unit} | "
            f"{r.error:.2e} ({kind}) | {tol} | {verdict} | {r.source} |"
        )
    return "\n".join(lines)


def convergence_markdown(conv: list[dict]) -> str:
    """Table of the first five frequencies per mesh with differences to the finest mesh."""
    if not conv:
        return ""
    finest = np.array(conv[-1]["frequencies_hz"])
    head = "| refinement | edge (in) | nodes | " + " | ".join(f"f{k + 1} (Hz)" for k in range(5)) + " |"
    lines = [head, "|---|---|---|" + "---|" * 5]
    for c in conv:
        f = np.array(c["frequencies_hz"])
        cells = [f"{v:.3f} ({100 * (v / r - 1):+.2f} %)" for v, r in zip(f, finest, strict=True)]
        lines.append(
            f"| {c['refinement']} | {c['edge_in']} | {c['nodes']} | " + " | ".join(cells) + " |"
        )
    lines.append("")
    lines.append("Labels on the finest mesh: " + ", ".join(conv[-1]["labels"]) + ".")
    return "\n".join(lines)


def validation_markdown(
    rows: list[Row], conv: list[dict], sections: dict[str, list[Row]] | None = None
) -> str:
    """The validation page (docs/validation.md) from measured rows, a convergence study and
    further titled sections of rows (dynamics, full order)."""
    from quadmodes._version import __version__

    parts = [
        "# Validation",
        "",
        f"Measured by `quadmodes validate --write docs/validation.md` (quadmodes {__version__}).",
        "Every number below comes from that run; tolerances are the issue's acceptance limits.",
        "A row marked **NO** is a limit this version does not meet (docs/full-order.md says why);",
        "rows marked \"reported\" are measured and shown without a limit.",
        "",
        "## Finite-element foundation",
        "",
        format_rows(rows),
        "",
    ]
    if conv:
        parts += [
            "## Mesh convergence of the paper model",
            "",
            "End-body masses fixed at the calibrated values (calibrated on the 1 in mesh);",
            "differences are relative to the finest mesh.",
            "",
            convergence_markdown(conv),
            "",
        ]
    for title, sec in (sections or {}).items():
        if sec:
            parts += [f"## {title}", "", format_rows(sec), ""]
    return "\n".join(parts)
