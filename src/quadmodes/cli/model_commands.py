"""Commands on the structural model: ``cases``, ``show-case``, ``schema``, ``modes``,
``calibrate``, ``reduce``."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.markup import escape
from rich.table import Table

from quadmodes._version import __version__
from quadmodes.cli.common import (
    DEFAULT_CASE,
    AnyCase,
    JsonFlag,
    LargeModelFlag,
    ModelCase,
    NoCacheFlag,
    case_argument,
    check_output_folder,
    err,
    flag,
    frequency_option,
    guard_model_size,
    guard_reduced_model,
    load_model_case,
    one_line_errors,
    out,
    output_file_in,
    output_path,
    progress_bars,
    staged_output,
    write_file_in,
)
from quadmodes.io.atomic import write_text


def cases(as_json: JsonFlag = False) -> None:
    """List the built-in cases (--json: {"cases": [{"name", "kind", "description"}, ...]})."""
    from quadmodes.api import cases as builtin_cases

    listing = builtin_cases()
    if as_json:
        sys.stdout.write(json.dumps({"cases": listing}, indent=2) + "\n")
        return
    table = Table("name", "kind", "description")
    for c in listing:
        table.add_row(c["name"], c["kind"], c["description"])
    out.print(table)


def show_case(name: AnyCase, as_json: JsonFlag = False) -> None:
    """Print a case as TOML (copy it, edit it, pass the file to any command): a built-in model
    or run case, or a case file (model or run case: checked, then printed as written, with its
    units and comments); --json: the same content as a JSON object."""
    import tomllib

    from quadmodes.case import builtin_case_names, builtin_case_text, builtin_run_case_names

    with one_line_errors():
        if name in builtin_case_names() or name in builtin_run_case_names(spinup=None):
            text = builtin_case_text(name)
        else:
            text = checked_case_text(name)
    sys.stdout.write(json.dumps(tomllib.loads(text), indent=2) + "\n" if as_json else text)


def checked_case_text(path: str) -> str:
    """The text of the case file ``path`` after validating it as a run case (``kind = "run"``)
    or a model case; a problem raises the case error naming the field."""
    from quadmodes.case import builtin_case_names, load_case, load_run_case
    from quadmodes.case.toml_reading import parse_toml, read_case_file

    text, _ = read_case_file(path, "case", builtin_case_names())
    if parse_toml(text, path).get("kind") == "run":
        load_run_case(path).model_case()  # the run and its model
    else:
        load_case(path)
    return text


def schema(markdown: Annotated[bool, typer.Option("--markdown", help="print the case-file "
           "reference (docs/case-reference.md) instead")] = False) -> None:  # fmt: skip
    """Print the JSON Schema of case files (docs/case-schema.json) for editors: TOML language
    servers such as taplo / Even Better TOML read it (docs/case-reference.md, "Editor support")."""
    from quadmodes.case.reference import reference_markdown, schema_text

    sys.stdout.write(reference_markdown() if markdown else schema_text())


# ------------------------------------------------------------------------------ modes


def _mode_table(title: str, frequencies_hz, labels, slack_onset_m=None) -> Table:
    """Mode number, frequency (Hz) and label, one row a mode (with ``slack_onset_m``, the
    amplitude at which the membrane first loses tension, in mm)."""
    columns = ["mode", "frequency (Hz)", "label"] + (["slackens at (mm)"] if slack_onset_m else [])
    table = Table(*columns, title=title)
    for k, (f, lab) in enumerate(zip(frequencies_hz, labels, strict=True)):
        extra = []
        if slack_onset_m:
            a = slack_onset_m[k]
            extra = ["never" if a is None else f"{1e3 * a:.3g}"]
        table.add_row(str(k + 1), f"{f:.3f}", lab, *extra)
    return table


def _print_modes_summary(name: str, summary: dict) -> None:
    """The ``modes`` report: frequencies, rigid-body frequencies, mass, inertia, prestress."""
    out.print(_mode_table(f"{name}: elastic modes", summary["frequencies_hz"], summary["labels"],
                          summary.get("slack_onset_m")))  # fmt: skip
    spinning = summary.get("spinning_reference")
    none = "none (removed by the frame conditions)" if spinning else "none (clamped)"
    rigid = ", ".join(f"{f:.2e}" for f in summary["rigid_frequencies_hz"]) or none
    out.print(f"rigid-body frequencies (Hz): {rigid}")
    out.print(f"mass: {summary['mass_kg']:.5g} kg")
    inertia = np.array(summary["inertia_kg_m2"])
    out.print(
        "inertia about the centre of mass (kg m²): "
        + "; ".join(" ".join(f"{v:.5g}" for v in row) for row in inertia)
    )
    if "prestress" in summary:
        p = summary["prestress"]
        out.print(
            f"inflation at {summary['pressure_pa']:.1f} Pa: volume change "
            f"{100 * p['volume_change']:.3f} %, stress resultants "
            f"{p['stress_resultant_min_n_per_m']:.3g}–{p['stress_resultant_max_n_per_m']:.3g} N/m, "
            f"{p['elements_in_compression']} elements in compression"
            + (f", {p['elements_wrinkled']} wrinkled" if p.get("elements_wrinkled") else "")
        )
    if spinning:
        out.print(
            f"rotating-frame modes about the spinning state at {spinning['spin_rad_s']:.4g} rad/s "
            f"({spinning['spin_hz']:.4g} Hz); ω/Ω: "
            + ", ".join(f"{r:.4f}" for r in spinning["frequency_ratios"])
        )
        out.print(
            f"spinning state: stress resultants {spinning['stress_resultant_min_n_per_m']:.3g}–"
            f"{spinning['stress_resultant_max_n_per_m']:.3g} N/m (largest at the nodes "
            f"{spinning['stress_resultant_max_nodal_n_per_m']:.3g} N/m), "
            f"{spinning['elements_in_compression']} elements in compression, largest "
            f"displacement {spinning['max_displacement_m']:.3g} m"
        )
        if spinning.get("compressed_area_fraction"):
            where = ", ".join(f"{v:.3g}" for v in spinning["least_tension_position_m"])
            out.print(f"  not taut on {100 * spinning['compressed_area_fraction']:.2g} % of the "
                      f"area; least tension {spinning['least_tension_n_per_m']:.3g} N/m at "
                      f"({where}) m")  # fmt: skip
    for warning in summary.get("warnings", ()):
        err.print(f"[bold yellow]warning:[/] {escape(warning)}", highlight=False, soft_wrap=True)
    if summary.get("slack_onset_m"):
        out.print("slackens at: the mode's largest displacement at which the membrane first "
                  "loses tension (linearised); beyond it the taut model does not hold")  # fmt: skip


ModesOutput = output_path("folder for VTU/PVD, PNG and JSON")


def modes(
    case: ModelCase = DEFAULT_CASE,
    as_json: JsonFlag = False,
    output_dir: ModesOutput = None,
    yes: LargeModelFlag = False,
) -> None:
    """Inflate the case, compute its modes, print a table (and write pictures and ParaView files)."""
    from quadmodes.structure.modal_files import MODAL_OUTPUTS, write_modal_outputs
    from quadmodes.structure.pipeline import build_modal_model, modes_summary

    with one_line_errors():
        check_output_folder(output_dir, replaces=MODAL_OUTPUTS)
        c = load_model_case(case)
        guard_model_size(c, yes)
        with progress_bars(True) as progress, staged_output(output_dir) as scratch:
            model = build_modal_model(c, progress)
            if scratch is not None:
                progress("outputs", 0.0)
                write_modal_outputs(model, scratch)
                progress("outputs", 1.0)
    summary = modes_summary(model)
    if as_json:
        sys.stdout.write(json.dumps(summary, indent=2) + "\n")
        return
    _print_modes_summary(c.name, summary)
    if output_dir is not None:
        out.print(f"outputs written to {output_dir}")


# ------------------------------------------------------------------------------ calibrate


CalibratedOutput = output_path("folder to write calibrated.toml in")
NoAxialFlag = flag("--no-axial", "fit masses only; inertias scale with mass")


def _calibration_summary(result, output_file: Path | None, text: str) -> dict:
    """The JSON of ``calibrate --json``: the calibrated case (TOML text and name), the fitted
    masses (kg), the modes (Hz) and the family frequencies reached (Hz)."""
    return {
        "case": result.case.name,
        "masses_kg": {k: float(v) for k, v in result.masses_kg.items()},
        "end_bodies": [{"name": b.name, "mass_kg": b.mass, "inertia_axial_kg_m2": b.inertia_axial,
                        "inertia_transverse_kg_m2": b.inertia_transverse, "arm_m": b.arm}
                       for b in result.case.end_body],
        "frequencies_hz": [float(f) for f in result.frequencies_hz],
        "labels": list(result.labels),
        "rocking_hz": float(result.rocking_hz),
        "bending_hz": float(result.bending_hz),
        "axial_hz": None if result.axial_hz is None else float(result.axial_hz),
        "output": str(output_file) if output_file is not None else None,
        "case_toml": text,
    }  # fmt: skip


def calibrate(
    case: ModelCase = DEFAULT_CASE,
    output_file: CalibratedOutput = None,
    rocking: Annotated[
        str, typer.Option(help='rear-mass rocking pair target, e.g. "31.2 Hz"')
    ] = "31.2 Hz",
    bending: Annotated[str, typer.Option(help='bending pair target, e.g. "38 Hz"')] = "38 Hz",
    axial: Annotated[
        str | None,
        typer.Option(help='rear-mass axial mode target, e.g. "34.4 Hz"; default: geometric mean '
                     "of the two"),
    ] = None,
    no_axial: NoAxialFlag = False,
    as_json: JsonFlag = False,
    yes: LargeModelFlag = False,
) -> None:
    """Fit the end-body masses (and rear inertia) so the modes match the seed's frequencies.

    The calibrated case (TOML) goes to stdout, or to DIR/calibrated.toml with -o DIR; --json
    prints a JSON object instead (the TOML text is its "case_toml")."""
    from quadmodes.structure.calibrate import calibrate_end_masses

    with one_line_errors():
        rocking_hz = frequency_option(rocking, "--rocking")
        bending_hz = frequency_option(bending, "--bending")
        axial_hz = None if axial is None else frequency_option(axial, "--axial")
        target_axial = None if no_axial else (axial_hz or float(np.sqrt(rocking_hz * bending_hz)))
        output_file = output_file_in(output_file, "calibrated.toml")
        c = load_model_case(case)
        guard_model_size(c, yes)
        with progress_bars(True) as progress:
            result = calibrate_end_masses(c, rocking_hz=rocking_hz, bending_hz=bending_hz,
                                          axial_hz=target_axial, progress=progress)  # fmt: skip
    if not as_json:
        _print_calibration(c.name, result)
    header = (
        f"# Calibrated by `quadmodes calibrate` (quadmodes {__version__}): rocking pair "
        f"{result.rocking_hz:.4f} Hz, bending pair {result.bending_hz:.4f} Hz"
        + (f", rear axial {result.axial_hz:.4f} Hz" if result.axial_hz else "")
        + "\n"
    )
    text = header + result.case.to_toml()
    if output_file is not None:
        write_file_in(output_file, lambda path: write_text(path, text))
    if as_json:
        sys.stdout.write(json.dumps(_calibration_summary(result, output_file, text), indent=2)
                         + "\n")  # fmt: skip
    elif output_file is None:
        sys.stdout.write(text)
    else:
        err.print(f"calibrated case written to {escape(str(output_file))}")


def _print_calibration(name: str, result) -> None:
    """The calibrated modes and end bodies, on stderr (stdout carries the TOML)."""
    err.print(_mode_table(f"{name}: calibrated modes", result.frequencies_hz, result.labels))
    for b in result.case.end_body:
        err.print(
            f"{b.name}: mass {b.mass:.6g} kg, inertia axial {b.inertia_axial:.6g} kg m², "
            f"transverse {b.inertia_transverse:.6g} kg m², arm {b.arm:.6g} m"
        )


# ------------------------------------------------------------------------------ reduce


def _reduced_summary(model, model_case, info: dict, output_file: Path | None) -> dict:
    """The JSON summary of ``reduce``: frequencies, labels, damping, mass, cache entry."""
    return {
        "case": model_case.name,
        "n_modes": model.n_modes,
        "frequencies_hz": [float(f) for f in model.frequencies_hz],
        "labels": list(model.labels),
        "damping_ratio": [float(z) for z in model.damping_ratio],
        "mass_kg": float(model.mass),
        "reference_spin_hz": float(model.reference_spin) / (2.0 * 3.141592653589793),
        "content_key": str(model.provenance.get("content_key", "")),
        "cache": info.get("cache"),
        "cache_path": info.get("path"),
        "output": str(output_file) if output_file is not None else None,
    }


ReducedCase = case_argument("model case, or run case (its model), built-in name or TOML file",
                            "any")  # fmt: skip
ReducedOutput = output_path("folder to write the reduced model in (reduced_model.nc)")


def reduce_command(
    case: ReducedCase = DEFAULT_CASE,
    output_file: ReducedOutput = None,
    modes: Annotated[
        int | None,
        typer.Option("--modes", help="elastic modes to keep (default: the run case's, else 5)"),
    ] = None,
    as_json: JsonFlag = False,
    no_cache: NoCacheFlag = False,
    yes: LargeModelFlag = False,
) -> None:
    """Build the reduced model (quadratic modes, floating-frame arrays) of a case; for a run case
    with reduced.reference = "spinning", about its spinning state (the run's own model).

    Cached in $QUADMODES_CACHE or the per-user cache folder (`quadmodes cache list`): later
    calls and `run` skip the FE work.
    """
    from quadmodes.case import load_run_case
    from quadmodes.models.build import DEFAULT_MODES, reduced_model_for
    from quadmodes.models.cache import caching_disabled
    from quadmodes.rom import artifact
    from quadmodes.runs import simulate

    info: dict = {}
    with one_line_errors(OSError), caching_disabled(no_cache):
        output_file = output_file_in(output_file, "reduced_model.nc")
        if simulate.is_run_case(case):
            run_case = load_run_case(case)
            model_case = run_case.model_case()
            guard_model_size(model_case, yes)
            if modes is None:
                guard_reduced_model(model_case, run_case.reduced.modes, yes)
            if modes is None and run_case.spinup is None:
                from quadmodes.runs.mode_choice import resolve_modes

                run_case, _ = resolve_modes(run_case, model_case)  # "auto" → N
            n_modes = modes if modes is not None else run_case.reduced.modes
            spin = run_case.reference_spin  # a run about its spinning state
            axis = run_case.reference_axis
        else:
            model_case = load_model_case(case)
            n_modes = modes if modes is not None else DEFAULT_MODES
            guard_model_size(model_case, yes)
            spin, axis = 0.0, None
        guard_reduced_model(model_case, n_modes, yes, from_option=modes is not None)
        with progress_bars(True) as progress:
            model = reduced_model_for(model_case, n_modes, progress, info=info, spin=spin,
                                      axis=axis)  # fmt: skip
        if output_file is not None:
            write_file_in(output_file, lambda path: artifact.save_reduced_model(model, path))
    summary = _reduced_summary(model, model_case, info, output_file)
    if as_json:
        sys.stdout.write(json.dumps(summary, indent=2) + "\n")
        return
    table = Table("mode", "frequency (Hz)", "label", "damping", title=f"{model_case.name}: reduced")
    for k, (f, lab, z) in enumerate(
        zip(model.frequencies_hz, model.labels, model.damping_ratio, strict=True)
    ):
        table.add_row(str(k + 1), f"{f:.3f}", lab, f"{z:.3g}")
    out.print(table)
    out.print(f"cache {summary['cache']}: {escape(str(summary['cache_path']))}")
    if output_file is not None:
        out.print(f"reduced model written to {escape(str(output_file))}")
