"""Command-line interface: ``quadmodes cases | show-case | modes | calibrate``.

Errors a user can fix (bad case, bad units, failed convergence) print one line on stderr and exit
with status 2; results are written to a scratch folder and moved into place only when complete.
"""

from __future__ import annotations

import contextlib
import json
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from quadmodes import __version__

app = typer.Typer(
    no_args_is_help=True,
    add_completion=False,
    help="Spinning flexible bodies by the method of quadratic modes.",
)
err = Console(stderr=True)
out = Console()

DEFAULT_CASE = "paper-membrane"


class UserError(Exception):
    """An input or convergence problem the user can act on."""


def _user_errors() -> tuple[type[BaseException], ...]:
    from quadmodes.calibrate import CalibrationError
    from quadmodes.config import CaseError
    from quadmodes.prestress import ConvergenceError
    from quadmodes.units import QuantityError

    return (UserError, CaseError, QuantityError, ConvergenceError, CalibrationError, ValueError)


def _fail(exc: BaseException) -> None:
    message = " ".join(str(exc).split())  # one line
    # escape: messages name TOML tables such as "[pressure]", which rich would take as markup
    err.print(
        f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True, emoji=False
    )
    raise typer.Exit(code=2)


@contextlib.contextmanager
def _progress(enabled: bool = True) -> Iterator:
    """A ``progress(stage, fraction)`` callback drawing rich bars on stderr."""
    bars = Progress(
        TextColumn("{task.description:<12}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(),
        console=err,
        transient=False,
        disable=not enabled or not err.is_terminal,
    )
    tasks: dict[str, int] = {}

    def update(stage: str, fraction: float) -> None:
        if stage not in tasks:
            tasks[stage] = bars.add_task(stage, total=1.0)
        bars.update(tasks[stage], completed=fraction)

    with bars:
        yield update


@contextlib.contextmanager
def _staged_output(directory: Path | None) -> Iterator[Path | None]:
    """Write into a scratch folder beside ``directory``; move files in only on success."""
    if directory is None:
        yield None
        return
    directory = directory.resolve()
    created = [p for p in directory.parents if not p.exists()]  # deepest first
    directory.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=f".{directory.name}.partial-", dir=directory.parent))
    done = False
    try:
        yield scratch
        directory.mkdir(exist_ok=True)
        for item in scratch.iterdir():
            target = directory / item.name
            if target.is_dir():
                shutil.rmtree(target)
            item.replace(target)
        done = True
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
        if not done:  # a failed run leaves no folders behind: remove the parents it made
            for folder in created:
                with contextlib.suppress(OSError):
                    folder.rmdir()


def _load(case: str):
    from quadmodes.config import load_case

    return load_case(case)


@app.command()
def version() -> None:
    """Print the package version."""
    out.print(__version__)


@app.command()
def cases() -> None:
    """List the built-in cases."""
    from quadmodes.config import builtin_case_names

    table = Table("name", "kind", "description")
    for name in builtin_case_names():
        c = _load(name)
        table.add_row(name, c.kind, c.description)
    out.print(table)


@app.command("show-case")
def show_case(name: Annotated[str, typer.Argument(help="built-in case name or TOML file")]) -> None:
    """Print a case as TOML (copy it, edit it, pass the file to any command)."""
    from quadmodes.config import builtin_case_names, builtin_case_text

    try:
        if name in builtin_case_names():
            sys.stdout.write(builtin_case_text(name))
        else:
            sys.stdout.write(_load(name).to_toml())
    except _user_errors() as exc:
        _fail(exc)


def _write_modal_outputs(model, directory: Path) -> None:
    from quadmodes import output
    from quadmodes.pipeline import modes_summary

    s, x = model.structure, model.x
    tri, lines, cell_data = None, None, {}
    for e in s.elements:
        kind = type(e).__name__
        if kind == "MembraneSet":
            tri = e.conn
        elif kind in ("BarSet",):
            lines = e.conn
    if model.prestress is not None:
        res = model.prestress.stress_resultants
        cell_data = {
            "stress_resultant_minor_N_per_m": res[:, 0],
            "stress_resultant_major_N_per_m": res[:, 1],
            "wrinkle_state": model.prestress.wrinkle_state(),
        }
    if tri is None:  # beam: draw the centreline of the position DOFs as lines
        pos = np.flatnonzero(s.translational)
        lines = np.stack([pos[:-1], pos[1:]], 1)
        tri = np.zeros((0, 3), int)
    shapes = model.modes.shapes
    freqs = model.modes.frequencies_hz
    labels = model.labels
    output.write_mesh_vtu(directory / "mesh.vtu", x, tri, lines=lines, cell_data=cell_data or None)
    output.write_modes_pvd(directory / "modes", x, tri, shapes, freqs, labels, lines=lines)
    if len(tri):
        output.plot_mesh_png(directory / "mesh.png", x, tri, title=model.case.name, lines=None)
        if cell_data:
            output.plot_mesh_png(
                directory / "prestress.png",
                x,
                tri,
                title=f"{model.case.name}: minor principal stress resultant after inflation",
                cell_values=cell_data["stress_resultant_minor_N_per_m"],
                cell_label="N/m",
            )
    for k in range(len(freqs)):
        output.plot_mode_png(
            directory / f"mode_{k + 1:02d}.png", x, tri, shapes[k], freqs[k], labels[k],
            lines=lines, index=k + 1,
        )
    output.plot_modes_overview_png(directory / "modes.png", x, tri, shapes, freqs, labels, lines)
    (directory / "modes.json").write_text(json.dumps(modes_summary(model), indent=2))


@app.command()
def modes(
    case: Annotated[str, typer.Argument(help="built-in case name or TOML file")] = DEFAULT_CASE,
    as_json: Annotated[bool, typer.Option("--json", help="print JSON on stdout")] = False,
    output_dir: Annotated[
        Path | None, typer.Option("-o", "--output", help="folder for VTU/PVD, PNG and JSON")
    ] = None,
) -> None:
    """Inflate the case, compute its modes, print a table (and write pictures and ParaView files)."""
    from quadmodes.pipeline import build_modal_model, modes_summary

    try:
        c = _load(case)
        with _progress(not as_json) as progress, _staged_output(output_dir) as scratch:
            model = build_modal_model(c, progress)
            if scratch is not None:
                progress("outputs", 0.0)
                _write_modal_outputs(model, scratch)
                progress("outputs", 1.0)
    except _user_errors() as exc:
        _fail(exc)
    summary = modes_summary(model)
    if as_json:
        sys.stdout.write(json.dumps(summary, indent=2) + "\n")
        return
    table = Table("mode", "frequency (Hz)", "label", title=f"{c.name}: elastic modes")
    for k, (f, lab) in enumerate(zip(summary["frequencies_hz"], summary["labels"], strict=True)):
        table.add_row(str(k + 1), f"{f:.3f}", lab)
    out.print(table)
    rigid = ", ".join(f"{f:.2e}" for f in summary["rigid_frequencies_hz"]) or "none (clamped)"
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
        )
    if output_dir is not None:
        out.print(f"outputs written to {output_dir}")


@app.command()
def calibrate(
    case: Annotated[str, typer.Argument(help="built-in case name or TOML file")] = DEFAULT_CASE,
    output_file: Annotated[
        Path | None, typer.Option("-o", "--output", help="write the calibrated case (TOML)")
    ] = None,
    rocking: Annotated[float, typer.Option(help="rear-mass rocking pair target (Hz)")] = 31.2,
    bending: Annotated[float, typer.Option(help="bending pair target (Hz)")] = 38.0,
    axial: Annotated[
        float | None,
        typer.Option(help="rear-mass axial mode target (Hz); default: geometric mean of the two"),
    ] = None,
    no_axial: Annotated[
        bool, typer.Option("--no-axial", help="fit masses only; inertias scale with mass")
    ] = False,
) -> None:
    """Fit the end-body masses (and rear inertia) so the modes match the seed's frequencies."""
    from quadmodes.calibrate import calibrate_end_masses

    target_axial = None if no_axial else (axial or float(np.sqrt(rocking * bending)))
    try:
        c = _load(case)
        with _progress() as progress:
            result = calibrate_end_masses(
                c, rocking_hz=rocking, bending_hz=bending, axial_hz=target_axial, progress=progress
            )
    except _user_errors() as exc:
        _fail(exc)
    table = Table("mode", "frequency (Hz)", "label", title=f"{c.name}: calibrated modes")
    for k, (f, lab) in enumerate(zip(result.frequencies_hz, result.labels, strict=True)):
        table.add_row(str(k + 1), f"{f:.3f}", lab)
    err.print(table)
    for b in result.case.end_body:
        err.print(
            f"{b.name}: mass {b.mass:.6g} kg, inertia axial {b.inertia_axial:.6g} kg m², "
            f"transverse {b.inertia_transverse:.6g} kg m², arm {b.arm:.6g} m"
        )
    header = (
        f"# Calibrated by `quadmodes calibrate` (quadmodes {__version__}): rocking pair "
        f"{result.rocking_hz:.4f} Hz, bending pair {result.bending_hz:.4f} Hz"
        + (f", rear axial {result.axial_hz:.4f} Hz" if result.axial_hz else "")
        + "\n"
    )
    text = header + result.case.to_toml()
    if output_file is None:
        sys.stdout.write(text)
    else:
        tmp = output_file.with_name(f".{output_file.name}.partial")
        tmp.write_text(text)
        tmp.replace(output_file)
        err.print(f"calibrated case written to {output_file}")


def main() -> None:  # pragma: no cover - console entry point
    app()


@app.command()
def validate(
    write: Annotated[
        Path | None, typer.Option("--write", help="write the tables to this Markdown file")
    ] = None,
    convergence: Annotated[
        bool, typer.Option("--convergence/--no-convergence", help="paper-model mesh convergence")
    ] = True,
) -> None:
    """Run the validation suite and print (or write) the measured tables with pass/fail."""
    from quadmodes import validation

    rows = []
    with _progress() as progress:
        for k, (name, check) in enumerate(validation.FE_CHECKS.items()):
            progress("validation", k / len(validation.FE_CHECKS))
            err.print(f"running {name} ...")
            rows += check()
        progress("validation", 1.0)
        conv = validation.mesh_convergence() if convergence else []
    text = validation.validation_markdown(rows, conv)
    if write is None:
        sys.stdout.write(text)
    else:
        tmp = write.with_name(f".{write.name}.partial")
        tmp.write_text(text)
        tmp.replace(write)
        err.print(f"written {write}")
    failed = [r.check for r in rows if not r.passed]
    if failed:
        err.print(f"[bold red]{len(failed)} checks failed:[/] {', '.join(failed)}")
        raise typer.Exit(code=1)
