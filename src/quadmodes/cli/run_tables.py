"""The convergence tables ``quadmodes run`` prints: ``--dt-convergence`` (judged on the cone
growth) and ``--mode-convergence``."""

from __future__ import annotations

from rich import box
from rich.table import Table


def dt_table(name: str, rows: list[dict]) -> Table:
    """The ``--dt-convergence`` table: the cone growth (secular rate ± standard error, change)
    and the end values at dt, dt/2, dt/4, with their relative changes in parentheses."""

    def cell(r, key, fmt) -> str:
        c = r[f"rel_change_{key}"]
        return f"{r[key]:{fmt}}" + ("" if c is None else f" ({c:.1e})")

    table = Table("dt (ms)", "steps", "cone-growth rate (deg/s)", "cone-angle change (deg)",
                  "spin rate end (Hz)", "dissipated (J)",
                  title=f"{name}: time-step convergence (t = {rows[0]['t_end_s']:.4g} s; "
                  "relative change from the previous dt)", box=box.SIMPLE_HEAD)  # fmt: skip
    for r in rows:
        c = r["rel_change_cone_growth_rate_deg_per_s"]
        rate = (f"{r['cone_growth_rate_deg_per_s']:.5g} ± {r['cone_growth_rate_se_deg_per_s']:.1g}"
                + ("" if c is None else f" ({c:.1e})"))  # fmt: skip
        table.add_row(f"{1e3 * r['dt_s']:.4g}", str(r["steps"]), rate,
                      cell(r, "cone_angle_change_deg", ".5g"), cell(r, "spin_rate_hz", ".6f"),
                      cell(r, "dissipated_energy_J", ".6g"))  # fmt: skip
    return table


def mode_table(name: str, conv: dict) -> Table:
    """The ``--mode-convergence`` table: one column per mode count, one row per headline number
    (value, and its relative change from the previous count in parentheses)."""
    from quadmodes.runs.mode_convergence import HEADLINES

    rows = conv["rows"]
    table = Table(
        "quantity",
        *(f"N = {r['n_modes']}" for r in rows),
        title=f"{name}: mode convergence, t = {rows[0]['t_end_s']:.4g} s (relative change "
        "from the previous N)",
        box=box.SIMPLE_HEAD,
    )
    for key, label, unit, judged in HEADLINES:
        cells = []
        for r in rows:
            v, c = r[key], r[f"rel_change_{key}"]
            cell = "—" if v is None else f"{v:.5g}"
            cells.append(cell if c is None else f"{cell} ({c:.1e})")
        table.add_row(f"{label} ({unit})" + ("" if judged else ", not judged"), *cells)
    table.add_row("steps", *(str(r["steps"]) for r in rows))
    table.add_row("run wall time (s)", *(f"{r['wall_s']:.1f}" for r in rows))
    table.add_row("reduction (s; 0: cached)", *(f"{r['reduce_s']:.1f}" for r in rows))
    return table


def mode_lines(conv: dict) -> list[str]:
    """The modes each larger N adds, and the verdict."""
    lines = []
    for r in conv["rows"][1:]:
        added = ", ".join(
            f"{m['mode']} {m['label']} {m['frequency_hz']:.2f} Hz" for m in r["added_modes"]
        )
        lines.append(f"N = {r['n_modes']} adds mode(s) {added}")
    return [*lines, f"verdict: {conv['text']}"]
