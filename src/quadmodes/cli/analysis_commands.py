"""Linearised analyses about steady spin: ``campbell`` (reduced model over a range of spin rates)
and ``rotating`` (full order against reduced, branch by branch)."""

from __future__ import annotations

import json
import sys
from typing import Annotated

import numpy as np
import typer
from rich.markup import escape
from rich.table import Table

from quadmodes.cli.common import (
    DEFAULT_CASE,
    LINEAR_FORMULATIONS,
    JsonFlag,
    LargeModelFlag,
    NoCacheFlag,
    UserError,
    axis_option,
    case_argument,
    check_output_folder,
    deprecated_bare_number,
    err,
    formulation_option,
    guard_model_size,
    guard_reduced_model,
    load_model_case,
    one_line_errors,
    out,
    output_file_in,
    output_path,
    parse_formulations,
    parse_units,
    progress_bars,
    staged_output,
    units_option,
    write_file_in,
)
from quadmodes.io.atomic import write_text

AXIS_HELP = (
    "body-frame spin axis: x, y, z, minor, intermediate, major, or three numbers such as "
    "0,0,1; a free body must spin about a principal axis (for equal moments: exactly the axis "
    "given)"
)


def _axis_request(axis: str | None):
    """The parsed ``--axis`` (None: the command's default)."""
    from quadmodes.rom.spin_axis import parse_axis

    return parse_axis(axis, "--axis")


# ------------------------------------------------------------------------------ campbell


def _campbell_summary(result, case_name: str, formulation: str) -> dict:
    """The JSON summary of ``campbell``: spin rates and branch frequencies (rad/s, and Hz as
    ``rotating`` reports them; rotating frame; SI whatever ``--units``), the spin rates where
    the rotating stiffness is not positive definite and the critical speeds (a branch meeting
    an engine-order line f = kΩ)."""
    from quadmodes.analysis.campbell_figure import engine_order_crossings

    return {
        "case": case_name,
        "formulation": formulation,
        "spin_rate_rad_s": [float(v) for v in result.spin],
        "axis": [float(v) for v in result.axis],
        "branches": list(result.labels),
        # null where a branch does not exist (it ended or had not started: tracking refused a
        # poor match)
        "frequency_rad_s": _finite(np.asarray(result.frequency).tolist()),
        "frequency_hz": _finite(np.asarray(result.frequency_hz).tolist()),
        # ω/Ω (null at Ω = 0): spin-independent for a body stiffened by its spin alone
        "frequency_ratio": _finite(np.asarray(result.ratio).tolist()),
        "notes": list(result.notes),
        "unstable_spin_rates_rad_s": [
            float(w)
            for w, u, k in zip(result.spin, result.unstable, result.min_stiffness, strict=True)
            if np.any(u) or k <= 0.0
        ],
        # where the free body's rotating stiffness changes definiteness (branches end there)
        "divergence_spin_rad_s": [float(w) for w in result.divergence],
        "divergence_spin_hz": [float(w) / (2 * np.pi) for w in result.divergence],
        "critical_speeds": [{"spin_rad_s": c.spin, "spin_hz": c.spin / (2 * np.pi),
                             "order": c.order, "branch": c.label}
                            for c in engine_order_crossings(result)],  # fmt: skip
    }


def _print_campbell(result, case_name: str, summary: dict, unit) -> None:
    """At most 9 spin rates by the first 6 branches (in ``unit``), the critical speeds and
    where the stiffness is lost: the result's :class:`~quadmodes.analysis.campbell_table.
    CampbellTable` (what ``qm.campbell(units=)`` returns too)."""
    from quadmodes.analysis.campbell_table import campbell_table

    tab = result.table if getattr(result.table, "unit", None) == unit.name else \
        campbell_table(result, unit, case_name)  # fmt: skip
    u = tab.unit
    table = Table(f"spin ({u})", *map(escape, tab.labels), title=escape(tab.title))
    for row in tab.cells():
        table.add_row(*row)
    out.print(table)
    for note in tab.notes:
        err.print(f"note: {escape(note)}")
    if tab.ratios:  # a body stiffened by its spin alone: ω/Ω is its spin-free answer
        out.print("ω/Ω over the sweep: " + "; ".join(
            f"{escape(lab)} {lo:.4g}–{hi:.4g}" for lab, lo, hi in tab.ratios))  # fmt: skip
    if tab.critical:
        crit = Table(f"spin ({u})", "branch", "meets", title="critical speeds (f = kΩ)",
                     caption="k = 1: a load fixed in space; 2: twice a turn")  # fmt: skip
        for w, lab, k in tab.critical:
            crit.add_row(f"{w:.4g}", escape(lab), f"{k}Ω")
        out.print(crit)
    for w in tab.divergence:
        out.print(f"[bold red]divergence at {w:.4g} {u}: the rotating stiffness "
                  "changes definiteness; every branch ends there[/]")  # fmt: skip
    if tab.unstable_from is not None and not tab.divergence:
        out.print(f"[bold red]rotating stiffness not positive definite from {tab.unstable_from:.4g} {u}[/]")


FULL_ORDER_HELP = (
    'spin rates at which the full-order model is linearised about its spinning equilibrium, '
    'comma-separated, e.g. "20 Hz, 41 Hz": its roots are drawn as markers on campbell.png and '
    "stored in campbell.nc (free bodies; minutes per spin on the default meshes)"
)


def parse_full_order(text: str | None, option: str = "--full-order") -> list[float]:
    """The spin rates (rad/s) of ``--full-order`` ("20 Hz, 41 Hz"; [] when not given)."""
    from quadmodes.case import QuantityError, parse_quantity

    if text is None:
        return []
    items = [v.strip() for v in text.split(",") if v.strip()]
    try:
        spins = [parse_quantity(v, "angular_rate", option) for v in items]
    except QuantityError as exc:
        raise UserError(f'{exc}; give spin rates with units, e.g. {option} "20 Hz, 41 Hz"') from None
    if not spins or any(v < 0 for v in spins):
        raise UserError(f'{option}: give one or more non-negative spin rates with units, e.g. '
                        f'{option} "20 Hz, 41 Hz"')  # fmt: skip
    return spins


def _full_order_summary(markers) -> list[dict]:
    """The JSON of the full-order markers: per spin the matched roots (rad/s and Hz)."""
    out = []
    for i in range(markers.count):
        roots = [{"label": str(markers.label[i, j]), "matched": bool(markers.matched[i, j]),
                  "frequency_rad_s": _finite(float(markers.frequency[i, j])),
                  "frequency_hz": _finite(float(markers.frequency[i, j]) / (2 * np.pi)),
                  "relative_error": _finite(float(markers.relative_error[i, j]))}
                 for j in range(markers.frequency.shape[1])
                 if np.isfinite(markers.frequency[i, j])]  # fmt: skip
        out.append({"spin_rate_rad_s": float(markers.spin[i]), "roots": roots})
    return out


#: ``--formulation`` of the linearisations: one name (campbell) or a list (rotating).
FormulationOne = formulation_option("Q, P, L, Q4 or QM (QM: linearised as Q4, the same numbers)",
                                   LINEAR_FORMULATIONS)  # fmt: skip
FormulationList = formulation_option("comma-separated, from Q, P, L, Q4, QM (QM: linearised as "
                                     "Q4, the same numbers)", LINEAR_FORMULATIONS,
                                     listed=True)  # fmt: skip
AxisOption = axis_option(AXIS_HELP)
CampbellUnits = units_option("the table and campbell.png (campbell.nc/.csv stay SI)")
RotatingUnits = units_option("the table (rotating.md and the JSON's text too; its numbers stay in Hz)")
CampbellCase = case_argument("model case (membrane or beam), name or TOML file")
CampbellOutput = output_path("folder for campbell.png/.nc/.csv")


def campbell(
    case: CampbellCase = DEFAULT_CASE,
    spin_min: Annotated[str, typer.Option(help="lowest spin rate, e.g. '0 Hz'")] = "0 Hz",
    spin_max: Annotated[str, typer.Option(
        help="highest spin rate, e.g. '45 Hz' (Kane's beam: '10 rad/s')")] = "45 Hz",
    n: Annotated[int, typer.Option("--points", "-n", help="number of spin rates")] = 41,
    formulation: FormulationOne = "Q",
    modes: Annotated[int | None, typer.Option(
        help="modes of the reduced model (sets modes.count; default: the case's)")] = None,
    axis: AxisOption = None,
    full_order: Annotated[str | None, typer.Option("--full-order", help=FULL_ORDER_HELP)] = None,
    units: CampbellUnits = "Hz",
    output_dir: CampbellOutput = None,
    as_json: JsonFlag = False,
    no_cache: NoCacheFlag = False,
    yes: LargeModelFlag = False,
) -> None:
    """Frequencies of the reduced model linearised about steady spin over a range of spin rates
    (gyroscopic coupling, centrifugal softening, quadratic-mode stiffening), tracked by MAC; by
    default a free body spins about its symmetry axis (the principal axis whose moment differs
    most from the other two), a clamped body on a hub about z; --axis chooses. --full-order adds
    the full-order model's roots at a few spins as markers. The table and campbell.png are in
    --units (Hz by default), with the critical speeds where a branch meets f = kΩ."""
    from quadmodes.analysis.campbell_output import campbell_with_full_order
    from quadmodes.case import parse_quantity
    from quadmodes.models.cache import caching_disabled

    with one_line_errors(), caching_disabled(no_cache):
        lo = parse_quantity(spin_min, "angular_rate", "--spin-min")
        hi = parse_quantity(spin_max, "angular_rate", "--spin-max")
        unit = parse_units(units)
        if n < 1:
            raise UserError(f"--points: {n}; give at least 1 spin rate, e.g. 41")
        if hi < lo:
            raise UserError(f"--spin-max: {spin_max} is below --spin-min {spin_min}; swap them")
        if formulation not in LINEAR_FORMULATIONS:
            raise UserError(f"--formulation: {formulation!r} is not one of Q, P, L, Q4, QM")
        request = _axis_request(axis)
        full_spins = parse_full_order(full_order)
        check_output_folder(output_dir)
        c = _with_mode_count(load_model_case(case), modes)
        if full_spins and c.kind == "beam" and c.beam.support == "clamped":
            raise UserError("--full-order: the full-order rotating-frame analysis is for free "
                            "bodies; this beam is clamped to a hub (drop --full-order)")  # fmt: skip
        guard_model_size(c, yes)
        guard_reduced_model(c, modes, yes, spins=True, from_option=modes is not None)
        with progress_bars(True) as progress, staged_output(output_dir) as scratch:
            result, markers, _ = campbell_with_full_order(
                c, lo, hi, n, axis=request, formulation=formulation, output_dir=scratch,
                progress=progress, axis_option="--axis", full_order_spins=full_spins, unit=unit,
            )
    summary = _campbell_summary(result, c.name, formulation)
    if markers is not None:
        summary["full_order"] = _full_order_summary(markers)
    if as_json:
        sys.stdout.write(json.dumps(summary) + "\n")
        return
    _print_campbell(result, c.name, summary, unit)
    if output_dir is not None:
        out.print(f"outputs written to {output_dir}")


def _with_mode_count(case, modes: int | None):
    """``case`` with ``modes.count`` set to ``--modes`` (validated as the case file)."""
    from quadmodes.case.editing import edit

    if modes is None:
        return case
    if modes < 1:
        raise UserError(f"--modes {modes}: must be at least 1; use e.g. 10")
    return edit(case, [("modes.count", modes)], "--modes")


# ------------------------------------------------------------------------------ rotating


def _parse_spins_hz(spins: str, option: str = "--spin-rate") -> tuple[float, ...]:
    """The comma-separated, non-negative spin rates (Hz) of ``--spin-rate`` (formerly
    ``--spins``): quantities ("0 Hz, 20 Hz, 300 rpm") or, as before, bare numbers of Hz (with a
    deprecation note)."""
    from quadmodes.case import QuantityError, parse_quantity

    items = [v.strip() for v in spins.split(",") if v.strip()]
    try:
        spin_list = tuple(float(v) for v in items)
    except ValueError:
        try:
            spin_list = tuple(parse_quantity(v, "frequency", option) for v in items)
        except QuantityError as exc:
            raise UserError(f'{exc}; give a comma-separated list such as "0 Hz, 20 Hz, '
                            '41 Hz"') from None  # fmt: skip
    else:
        if items:
            deprecated_bare_number(option, spins, "Hz")
    if not spin_list or any(v < 0 for v in spin_list):
        raise UserError(f'{option}: give one or more non-negative spin rates, e.g. "0 Hz, 20 Hz, '
                        '41 Hz"')  # fmt: skip
    return spin_list


def _finite(value):
    """A JSON-safe float (None for NaN or infinity); dicts and lists element by element."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float | np.floating):
        return float(value) if np.isfinite(value) else None
    return value


def _rotating_summary(table, unit: str = "Hz") -> dict:
    """The JSON of ``rotating --json``: the case, spin rates (Hz), formulations and one object
    per branch row (frequencies in Hz, rotating frame; growth rates in 1/s: the keys name
    their unit); ``text`` is the printed table, in ``unit`` (``text_units``)."""
    import dataclasses

    return {
        "case": table.case,
        "formulations": list(table.formulations),
        "spins_hz": sorted({float(r.spin_hz) for r in table.rows}),
        "n_nodes": int(table.n_nodes),
        "rows": [_finite(dataclasses.asdict(r)) for r in table.rows],
        "unmatched_full_order_roots": [_finite(dataclasses.asdict(r)) for r in table.extra],
        "text": table.to_text(unit),
        "text_units": getattr(unit, "name", unit),
    }


RotatingCase = case_argument("free membrane model case (name or TOML file)")
RotatingOutput = output_path("folder to write the Markdown table in (rotating.md)")


def rotating_command(
    case: RotatingCase = DEFAULT_CASE,
    spin_rate: Annotated[str, typer.Option(
        "--spin-rate", help='spin rates, comma-separated, e.g. "0 Hz, 20 Hz, 41 Hz"')
    ] = "0 Hz, 20 Hz, 41 Hz",  # fmt: skip
    modes: Annotated[int, typer.Option(help="retained modes of the reduced model")] = 5,
    formulation: FormulationList = "Q,L",
    axis: AxisOption = None,
    units: RotatingUnits = "Hz",
    output: RotatingOutput = None,
    as_json: JsonFlag = False,
    no_cache: NoCacheFlag = False,
    yes: LargeModelFlag = False,
) -> None:
    """Rotating-frame frequencies of the full-order model linearised about its spinning
    equilibrium (centrifugal prestress, gyroscopic coupling) against the reduced model's
    (campbell), branch by branch, matched by MAC. Frequencies in the rotating frame, in --units
    (Hz by default; the JSON's numbers stay in Hz, keys named *_hz). Default --axis: the minor axis, or for a body whose
    model is expanded about a spinning state (a membrane without stiffness at rest) that
    state's axis (a flat membrane's normal)."""
    from quadmodes.analysis.rotating_comparison import rotating_frequency_comparison
    from quadmodes.models.cache import caching_disabled

    with one_line_errors(), caching_disabled(no_cache):
        output = output_file_in(output, "rotating.md")
        unit = parse_units(units)
        spin_list = _parse_spins_hz(spin_rate)
        names = parse_formulations(formulation, LINEAR_FORMULATIONS, use="Q, P, L, Q4, QM")
        request = _axis_request(axis)
        if modes < 1:
            raise UserError("--modes: must be at least 1")
        c = load_model_case(case)
        guard_model_size(c, yes)
        guard_reduced_model(c, modes, yes, spins=True, from_option=True)
        with progress_bars(True) as bars:
            table = rotating_frequency_comparison(
                c, spin_list, modes, names, axis=request, progress=bars, axis_option="--axis"
            )
    text = table.to_text(unit)
    if as_json:
        sys.stdout.write(json.dumps(_rotating_summary(table, unit), indent=2) + "\n")
    else:
        out.print(text, markup=False, highlight=False, soft_wrap=True)
    if output is not None:
        head = f"# {table.case}: rotating-frame frequencies, full order vs reduced"
        write_file_in(output, lambda path: write_text(path, f"{head}\n\n{text}\n"))
        if not as_json:
            err.print(f"written {output}")
