"""Command-line interface: ``quadmodes cases | show-case | modes | calibrate | reduce | run``.

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
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from quadmodes import __version__
from quadmodes.io.atomic import write_text

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
    from quadmodes.case.schema import CaseError
    from quadmodes.case.units import QuantityError
    from quadmodes.structure.calibrate import CalibrationError
    from quadmodes.structure.prestress import ConvergenceError

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
    from quadmodes.case.schema import load_case

    return load_case(case)


@app.command()
def version() -> None:
    """Print the package version."""
    out.print(__version__)


@app.command()
def cases() -> None:
    """List the built-in cases."""
    from quadmodes.case.schema import builtin_case_names, builtin_run_case_names, load_run_case

    table = Table("name", "kind", "description")
    for name in builtin_case_names():
        c = _load(name)
        table.add_row(name, c.kind, c.description)
    for name in builtin_run_case_names(spinup=None):
        r = load_run_case(name)
        table.add_row(name, r.kind, r.description)
    out.print(table)


@app.command("show-case")
def show_case(name: Annotated[str, typer.Argument(help="built-in case name or TOML file")]) -> None:
    """Print a case as TOML (copy it, edit it, pass the file to any command)."""
    from quadmodes.case.schema import builtin_case_names, builtin_case_text, builtin_run_case_names

    try:
        if name in builtin_case_names() or name in builtin_run_case_names(spinup=None):
            sys.stdout.write(builtin_case_text(name))
        else:
            sys.stdout.write(_load(name).to_toml())
    except _user_errors() as exc:
        _fail(exc)


def _write_modal_outputs(model, directory: Path) -> None:
    from quadmodes.io import pictures, vtk
    from quadmodes.structure.pipeline import modes_summary

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
    vtk.write_mesh_vtu(directory / "mesh.vtu", x, tri, lines=lines, cell_data=cell_data or None)
    vtk.write_modes_pvd(directory / "modes", x, tri, shapes, freqs, labels, lines=lines)
    if len(tri):
        pictures.plot_mesh_png(directory / "mesh.png", x, tri, title=model.case.name, lines=None)
        if cell_data:
            pictures.plot_mesh_png(
                directory / "prestress.png",
                x,
                tri,
                title=f"{model.case.name}: minor principal stress resultant after inflation",
                cell_values=cell_data["stress_resultant_minor_N_per_m"],
                cell_label="N/m",
            )
    for k in range(len(freqs)):
        pictures.plot_mode_png(
            directory / f"mode_{k + 1:02d}.png", x, tri, shapes[k], freqs[k], labels[k],
            lines=lines, index=k + 1,
        )
    pictures.plot_modes_overview_png(directory / "modes.png", x, tri, shapes, freqs, labels, lines)
    write_text(directory / "modes.json", json.dumps(modes_summary(model), indent=2))


@app.command()
def modes(
    case: Annotated[str, typer.Argument(help="built-in case name or TOML file")] = DEFAULT_CASE,
    as_json: Annotated[bool, typer.Option("--json", help="print JSON on stdout")] = False,
    output_dir: Annotated[
        Path | None, typer.Option("-o", "--output", help="folder for VTU/PVD, PNG and JSON")
    ] = None,
) -> None:
    """Inflate the case, compute its modes, print a table (and write pictures and ParaView files)."""
    from quadmodes.structure.pipeline import build_modal_model, modes_summary

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
    from quadmodes.structure.calibrate import calibrate_end_masses

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
        write_text(output_file, text)
        err.print(f"calibrated case written to {output_file}")


def main() -> None:  # pragma: no cover - console entry point
    app()


VALIDATION_SUITES = ("fe", "reduced", "full-order")


@app.command()
def validate(
    write: Annotated[
        Path | None, typer.Option("--write", help="write the tables to this Markdown file")
    ] = None,
    suite: Annotated[
        list[str] | None,
        typer.Option(
            "--suite",
            help="fe | reduced | full-order (repeat to combine; default: all three)",
        ),
    ] = None,
    convergence: Annotated[
        bool, typer.Option("--convergence/--no-convergence", help="paper-model mesh convergence")
    ] = True,
    quick: Annotated[
        bool, typer.Option("--quick", help="only the fast checks (the subset the tests run)")
    ] = False,
) -> None:
    """Run the validation suite and print (or write) the measured tables with pass/fail.

    The whole suite (finite elements, reduced dynamics, full order) takes tens of minutes on two
    cores; --quick runs the subset the tests also run."""
    from quadmodes.validation import dynamics_checks as vdyn
    from quadmodes.validation import fe_checks as validation

    chosen = list(suite or VALIDATION_SUITES)
    bad = [s for s in chosen if s not in VALIDATION_SUITES]
    if bad:
        _fail(UserError(f"--suite: unknown {', '.join(bad)}; choose from fe, reduced, full-order"))
    checks: dict[str, dict] = {
        "fe": validation.FE_CHECKS,
        "reduced": vdyn.ROM_CHECKS,
        "full-order": vdyn.FULL_ORDER_CHECKS,
    }
    titles = {"reduced": "Reduced dynamics", "full-order": "Full-order reference"}
    results: dict[str, list] = {k: [] for k in chosen}
    todo = [
        (k, name, fn)
        for k in chosen
        for name, fn in checks[k].items()
        if not quick or name in vdyn.FAST or k == "fe"
    ]
    with _progress() as progress:
        for i, (k, name, fn) in enumerate(todo):
            progress("validation", i / max(len(todo), 1))
            err.print(f"running {k}/{name} ...")
            try:
                results[k] += fn()
            except (*_user_errors(), ImportError, RuntimeError) as exc:
                err.print(f"[bold red]check {escape(name)} failed to run:[/] {escape(str(exc))}")
                results[k].append(
                    validation.Row(f"{name}: ran to completion", 0.0, 1.0, 0.0, absolute=True,
                                   source=" ".join(str(exc).split())[:200])
                )
        progress("validation", 1.0)
        conv = validation.mesh_convergence() if convergence and "fe" in chosen and not quick else []
    sections = {titles[k]: results[k] for k in chosen if k != "fe"}
    text = validation.validation_markdown(results.get("fe", []), conv, sections)
    if write is None:
        sys.stdout.write(text)
    else:
        write_text(write, text)
        err.print(f"written {write}")
    failed = [r.check for rows in results.values() for r in rows if not r.passed]
    if failed:
        err.print(f"[bold red]{len(failed)} checks failed:[/] {', '.join(failed)}")
        raise typer.Exit(code=1)


# ------------------------------------------------------------------------------ reduce / run


@app.command("reduce")
def reduce_command(
    case: Annotated[
        str, typer.Argument(help="model case, or run case (its model), built-in name or TOML file")
    ] = DEFAULT_CASE,
    output_file: Annotated[
        Path | None, typer.Option("-o", "--output", help="write the reduced model (NetCDF)")
    ] = None,
    modes: Annotated[
        int | None,
        typer.Option("--modes", help="elastic modes to keep (default: the run case's, else 5)"),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print JSON on stdout")] = False,
) -> None:
    """Build the reduced model (quadratic modes, floating-frame arrays) of a case.

    Cached in $QUADMODES_CACHE or ~/.cache/quadmodes: later calls and `run` skip the FE work.
    """
    from quadmodes.case.schema import load_run_case
    from quadmodes.rom import artifact
    from quadmodes.runs import model_cache, simulate

    info: dict = {}
    try:
        if simulate.is_run_case(case):
            run_case = load_run_case(case)
            model_case = run_case.model_case()
            n_modes = modes if modes is not None else run_case.reduced.modes
        else:
            model_case = _load(case)
            n_modes = modes if modes is not None else model_cache.DEFAULT_MODES
        with _progress(not as_json) as progress:
            model = model_cache.reduced_model_for(model_case, n_modes, progress, info=info)
        if output_file is not None:
            artifact.save_reduced_model(model, output_file)
    except (*_user_errors(), OSError) as exc:
        _fail(exc)
    summary = {
        "case": model_case.name,
        "n_modes": model.n_modes,
        "frequencies_hz": [float(f) for f in model.frequencies_hz],
        "labels": list(model.labels),
        "damping_ratio": [float(z) for z in model.damping_ratio],
        "mass_kg": float(model.mass),
        "content_key": str(model.provenance.get("content_key", "")),
        "cache": info.get("cache"),
        "cache_path": info.get("path"),
        "output": str(output_file) if output_file is not None else None,
    }
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


def _run_progress(update):
    """Wrap a bar callback: without a terminal (no bars), print the progress in 10 % steps."""
    shown: dict[str, int] = {}

    def progress(stage: str, fraction: float) -> None:
        update(stage, fraction)
        if err.is_terminal:
            return
        tenth = int(10 * fraction + 1e-9)
        if shown.get(stage, -1) < tenth:
            shown[stage] = tenth
            err.print(f"{escape(stage)}: {10 * tenth} %", highlight=False)

    return progress


_RUN_ROWS = [
    ("status", "status", "{}"),
    ("steps", "steps", "{}"),
    ("wall time (s)", "wall_s", "{:.1f}"),
    ("max |H(t) − H0| / |H0|", "H_relative_drift", "{:.2e}"),
    ("energy start → end (J)", ("energy_start_J", "energy_end_J"), "{:.6g} → {:.6g}"),
    ("dissipated energy (J)", "dissipated_energy_J", "{:.4g}"),
    ("spin rate start → end (Hz)", ("spin_rate_start_hz", "spin_rate_end_hz"), "{:.5f} → {:.5f}"),
    (
        "cone angle start → end (deg)",
        ("cone_angle_start_deg", "cone_angle_end_deg"),
        "{:.4f} → {:.4f}",
    ),
    ("bending log decrement", "log_decrement", "{:.4f}"),
    ("rotating stiffness min eigenvalue (s⁻²)", "rotating_stiffness_min_eigenvalue", "{:.4g}"),
    ("reduced model valid at this spin", "valid", "{}"),
]


def _format_row(summary: dict, key, fmt: str) -> str:
    keys = key if isinstance(key, tuple) else (key,)
    values = [summary.get(k) for k in keys]
    if any(v is None for v in values):
        return "—"
    return fmt.format(*values)


_SPINUP_ROWS = [
    ("status", "status", "{}"),
    ("formulation", "formulation", "{}"),
    ("final hub rate Ωs (rad/s)", "omega_s_rad_s", "{:.4g}"),
    ("peak in-plane tip deflection (m)", "peak_tip_deflection_m", "{:.4f}"),
    ("time of the peak (s)", "peak_time_s", "{:.3f}"),
    ("max |v| after the spin-up (m)", "max_abs_after_spinup_m", "{:.4f}"),
    ("rotating stiffness min eigenvalue (s⁻²)", "rotating_stiffness_min_eigenvalue", "{:.4g}"),
    ("steps", "steps", "{}"),
    ("wall time (s)", "wall_s", "{:.1f}"),
]


def _warn_validity(name: str, validity) -> None:
    if validity is not None and not validity.valid:
        err.print(
            f"[bold yellow]warning:[/] {escape(name)}: {escape(validity.message())}",
            highlight=False,
            soft_wrap=True,
        )


def _dt_table(name: str, rows: list[dict]) -> Table:
    def rel(v) -> str:
        return "—" if v is None else f"{v:.2e}"

    table = Table(
        "dt (ms)",
        "steps",
        "cone angle end (deg)",
        "rel. change",
        "spin rate end (Hz)",
        "rel. change",
        "dissipated (J)",
        "rel. change",
        title=f"{name}: time-step convergence (t = {rows[0]['t_end_s']:.4g} s)",
        box=box.SIMPLE_HEAD,
    )
    for r in rows:
        table.add_row(
            f"{1e3 * r['dt_s']:.4g}",
            str(r["steps"]),
            f"{r['cone_angle_deg']:.6f}",
            rel(r["rel_change_cone_angle_deg"]),
            f"{r['spin_rate_hz']:.6f}",
            rel(r["rel_change_spin_rate_hz"]),
            f"{r['dissipated_energy_J']:.6g}",
            rel(r["rel_change_dissipated_energy_J"]),
        )
    return table


@app.command("run")
def run_command(
    case: Annotated[
        str | None,
        typer.Argument(help="run case (built-in name or TOML file); default: both paper cases"),
    ] = None,
    output_dir: Annotated[
        Path, typer.Option("-o", "--output", help="folder; each run writes DIR/<case name>/")
    ] = Path("out"),
    as_json: Annotated[bool, typer.Option("--json", help="print the summary as JSON")] = False,
    method: Annotated[str | None, typer.Option(help="midpoint | backward-euler | adaptive")] = None,
    dt: Annotated[str | None, typer.Option(help='time step, e.g. "0.25 ms"')] = None,
    duration: Annotated[str | None, typer.Option(help='simulated time, e.g. "4 s"')] = None,
    formulation: Annotated[str | None, typer.Option(help="Q | P | L | rigid | Q4")] = None,
    spin_rate: Annotated[
        str | None,
        typer.Option(
            "--spin-rate",
            help='initial spin rate, or the final hub rate Ωs of a spin-up, e.g. "10 rad/s"',
        ),
    ] = None,
    dt_convergence: Annotated[
        bool,
        typer.Option(
            "--dt-convergence", help="also run at dt/2 and dt/4 and print a convergence table"
        ),
    ] = False,
    plots: Annotated[bool, typer.Option("--plots/--no-plots", help="write PNG figures")] = True,
) -> None:
    """Integrate run cases; write results.nc, summary.json and PNG figures per case.

    With no CASE, runs the seed's two cases, paper-0.5hz and paper-41hz. A run case with a
    [spinup] table (e.g. kane-spinup) is a hub-driven spin-up of a clamped beam.

    A formulation outside its validity (rotating-frame stiffness not positive definite at some
    spin rate up to the run's) prints a warning; the JSON summary says `valid: false`.

    Exit status 2 for bad input (nothing written), 1 if a run stopped early or diverged (partial
    results).
    """
    from quadmodes.case.schema import load_run_case
    from quadmodes.runs import simulate
    from quadmodes.runs.results import write_outputs, write_spinup_outputs

    names = [case] if case is not None else list(simulate.PAPER_RUN_CASES)
    try:
        runs = [
            simulate.apply_overrides(
                load_run_case(name),
                method=method,
                dt=dt,
                duration=duration,
                formulation=formulation,
                spin_rate=spin_rate,
            )
            for name in names
        ]
        if dt_convergence:
            for r in runs:
                if r.spinup is not None:
                    raise UserError(
                        f"--dt-convergence: {r.name} is a spin-up integrated by DOP853 with "
                        "its own step control; it has no fixed step"
                    )
                if r.integration.method == "adaptive":
                    raise UserError(
                        "--dt-convergence: needs a fixed-step method (midpoint or "
                        'backward-euler), not "adaptive"'
                    )
        with _progress(True) as bars:
            setups = [
                r if r.spinup is not None else simulate.prepare(r, progress=bars) for r in runs
            ]
    except _user_errors() as exc:
        _fail(exc)
    summaries: dict[str, dict] = {}
    spinups: set[str] = set()
    failed: list[str] = []
    for setup in setups:
        is_spinup = not isinstance(setup, simulate.RunSetup)
        name = setup.name if is_spinup else setup.run.name
        target = output_dir / name
        try:
            if is_spinup:
                spinups.add(name)
                result = simulate.simulate_spinup(setup)
                _warn_validity(name, result.validity)
                with _staged_output(target) as scratch:
                    summaries[name] = write_spinup_outputs(result, scratch, plots=plots)
            else:
                _warn_validity(name, setup.validity)
                with _progress(True) as bars:
                    result = simulate.execute(setup, _run_progress(bars))
                    extra = None
                    if dt_convergence:
                        rows = simulate.dt_convergence(setup, result, _run_progress(bars))
                        extra = {"dt_convergence": rows}
                with _staged_output(target) as scratch:
                    summaries[name] = write_outputs(result, scratch, plots=plots, extra=extra)
        except (*_user_errors(), OSError) as exc:
            _fail(exc)
        if not result.complete:
            failed.append(name)
            err.print(
                f"[bold yellow]warning:[/] {escape(name)} stopped early ("
                f"{escape(' '.join(result.reason.split()))}); partial results with complete = 0 "
                f"written to {escape(str(target))}",
                highlight=False,
                soft_wrap=True,
            )
    if as_json:
        payload = next(iter(summaries.values())) if case is not None else summaries
        sys.stdout.write(json.dumps(payload, indent=2) + "\n")
    else:
        for name, summary in summaries.items():
            rows = _SPINUP_ROWS if name in spinups else _RUN_ROWS
            table = Table("quantity", "value", title=f"{name}: run summary")
            for label, key, fmt in rows:
                table.add_row(label, _format_row(summary, key, fmt))
            out.print(table)
            if summary.get("dt_convergence"):
                # not cropped to 80 columns when the output is not a terminal
                out.print(
                    _dt_table(name, summary["dt_convergence"]),
                    width=None if out.is_terminal else 132,
                )
            out.print(f"results written to {escape(str(output_dir / name))}")
    if failed:
        raise typer.Exit(code=1)


@app.command()
def campbell(
    case: Annotated[
        str, typer.Argument(help="model case (membrane or beam), name or TOML file")
    ] = "kane-beam",
    spin_min: Annotated[str, typer.Option(help="lowest spin rate, e.g. '0 Hz'")] = "0 rad/s",
    spin_max: Annotated[str, typer.Option(help="highest spin rate, e.g. '10 rad/s'")] = "10 rad/s",
    n: Annotated[int, typer.Option("--points", "-n", help="number of spin rates")] = 41,
    formulation: Annotated[str, typer.Option(help="Q, P, L or Q4")] = "Q",
    output_dir: Annotated[
        Path | None, typer.Option("-o", "--output", help="folder for campbell.png/.nc/.csv")
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print JSON on stdout")] = False,
) -> None:
    """Frequencies of the reduced model linearised about steady spin over a range of spin rates
    (gyroscopic coupling, centrifugal softening, quadratic-mode stiffening), tracked by MAC; free
    bodies spin about their minor principal axis, clamped bodies on a hub about z."""
    from quadmodes.analysis.campbell import campbell_main
    from quadmodes.case.units import parse_quantity

    try:
        lo = parse_quantity(spin_min, "angular_rate", "--spin-min")
        hi = parse_quantity(spin_max, "angular_rate", "--spin-max")
        if formulation not in ("Q", "P", "L", "Q4"):
            raise UserError(f"--formulation: {formulation!r} is not one of Q, P, L, Q4")
        c = _load(case)
        with _progress(not as_json) as progress, _staged_output(output_dir) as scratch:
            result, _ = campbell_main(
                c, lo, hi, n, formulation=formulation, output_dir=scratch, progress=progress
            )
    except _user_errors() as exc:
        _fail(exc)
    freqs = np.asarray(result.frequency)
    summary = {
        "case": c.name,
        "formulation": formulation,
        "spin_rate_rad_s": [float(v) for v in result.spin],
        "branches": list(result.labels),
        "frequency_rad_s": freqs.tolist(),
        "unstable_spin_rates_rad_s": [
            float(w)
            for w, u, k in zip(result.spin, result.unstable, result.min_stiffness, strict=True)
            if np.any(u) or k <= 0.0
        ],
    }
    if as_json:
        sys.stdout.write(json.dumps(summary) + "\n")
        return
    table = Table("spin (rad/s)", *result.labels[:6], title=f"{c.name}: rotating-frame (rad/s)")
    for k in np.linspace(0, len(result.spin) - 1, min(9, len(result.spin))).astype(int):
        table.add_row(f"{result.spin[k]:.3g}", *[f"{v:.4g}" for v in freqs[k, :6]])
    out.print(table)
    if summary["unstable_spin_rates_rad_s"]:
        out.print(
            f"[bold red]rotating stiffness not positive definite from "
            f"{summary['unstable_spin_rates_rad_s'][0]:.4g} rad/s[/]"
        )
    if output_dir is not None:
        out.print(f"outputs written to {output_dir}")


# ------------------------------------------------------------------------------ compare

def _num(value, fmt: str) -> str:
    return "n/a" if value is None else format(value, fmt)


#: Full-order runs estimated longer than this (s) need --yes.
LONG_FULL_ORDER_S = 1800.0


@app.command("compare")
def compare_command(
    case: Annotated[
        str, typer.Argument(help="run case (built-in name or TOML file)")
    ] = "paper-41hz-coarse",
    window: Annotated[str, typer.Option(help='simulated window, e.g. "1 s"')] = "1 s",
    full_dt: Annotated[
        str | None, typer.Option("--full-dt", help='full-order step (default: the run\'s dt)')
    ] = None,
    modes: Annotated[
        int | None, typer.Option(help="retained modes of the reduced model (default: the run's)")
    ] = None,
    spin_rate: Annotated[
        str | None, typer.Option("--spin-rate", help='initial spin rate, e.g. "20 Hz"')
    ] = None,
    formulations: Annotated[
        str, typer.Option(help="comma-separated, from rigid, L, P, Q, Q4")
    ] = "rigid,L,P,Q,Q4",
    output_dir: Annotated[
        Path | None, typer.Option("-o", "--output", help="folder (default: out/compare-<case>)")
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print the table as JSON")] = False,
    resume: Annotated[
        bool, typer.Option("--resume", help="continue the full-order run from its checkpoint")
    ] = False,
    yes: Annotated[
        bool, typer.Option("--yes", help="run a full-order window estimated over 30 min")
    ] = False,
    plots: Annotated[bool, typer.Option("--plots/--no-plots", help="write overlay PNGs")] = True,
) -> None:
    """Reduced formulations (rigid, L, P, Q, Q4) against the full-order finite-element transient on
    one window: errors of the modal-amplitude envelope, cone angle and spin rate, wall times and
    speed-ups. Writes comparison.nc/.json/.csv and overlay plots.

    The full-order run is estimated first and checkpointed as it goes: Ctrl-C stops it, and the
    same command with --resume continues from the checkpoint."""
    from quadmodes.analysis import compare as cmp
    from quadmodes.case.schema import load_run_case
    from quadmodes.case.units import parse_quantity
    from quadmodes.fullorder import estimate_for_run, full_order_for_run, setup_for_run
    from quadmodes.runs import simulate

    try:
        run = load_run_case(case)
        if run.spinup is not None:
            raise UserError(f"{case}: a hub-driven spin-up; compare needs a free-body run case")
        run = simulate.apply_overrides(run, spin_rate=spin_rate)
        t_window = parse_quantity(window, "time", "--window")
        dt_full = parse_quantity(full_dt, "time", "--full-dt") if full_dt else run.integration.dt
        if not t_window > 0:
            raise UserError('--window: must be positive, e.g. "1 s"')
        if not 0 < dt_full < t_window:
            raise UserError("--full-dt: must be positive and shorter than the window")
        names = tuple(f.strip() for f in formulations.split(",") if f.strip())
        bad = [f for f in names if f not in cmp.AVAILABLE]
        if bad or not names:
            raise UserError(
                f"--formulations: unknown {', '.join(bad) or '(none given)'}; use rigid, L, P, Q, Q4"
            )
        if modes is not None:
            if modes < 1:
                raise UserError("--modes: must be at least 1")
            run = run.model_copy(
                update={"reduced": run.reduced.model_copy(update={"modes": modes})}
            )
        run = cmp.window_run(run, t_window)
        target = output_dir or Path("out") / f"compare-{run.name}"
        checkpoint = target.resolve().parent / f".{target.name}.fullorder-checkpoint.npz"
        if resume and not checkpoint.exists():
            raise UserError(f"--resume: no checkpoint at {checkpoint}; run without --resume")
        if not resume and checkpoint.exists():
            checkpoint.unlink()
        setup = setup_for_run(run)  # inflation + initial state, once for estimate and run
        est = estimate_for_run(run, dt=dt_full, window=t_window, setup=setup)
        minutes = est["estimate_s"] / 60.0
        err.print(
            f"full order: {run.name}, {t_window:g} s at dt = {dt_full * 1e3:g} ms, estimated "
            f"{minutes:.1f} min (checkpoint {checkpoint.name}; Ctrl-C stops, --resume continues)",
            highlight=False,
        )
        if est["estimate_s"] > LONG_FULL_ORDER_S and not yes and not resume:
            raise UserError(
                f"--window: the full-order run is estimated at {minutes:.0f} min; pass --yes to "
                "run it (Ctrl-C stops it, --resume continues), or shorten --window"
            )

        def full(r, dt):
            return full_order_for_run(
                r, dt=dt, progress=bars, setup=setup, checkpoint=checkpoint,
                checkpoint_every=500, resume=resume,
            )  # fmt: skip

        with _progress(not as_json) as bars:
            try:
                result = cmp.compare(
                    run, t_window, formulations=names, full_order_dt=dt_full,
                    full_order=full, progress=bars,
                )  # fmt: skip
            except KeyboardInterrupt:
                err.print(
                    f"stopped; the full-order checkpoint is kept at {checkpoint}: continue with "
                    f"quadmodes compare {case} --window '{window}' --resume"
                )
                raise typer.Exit(code=130) from None
        with _staged_output(target) as scratch:
            payload = cmp.write_comparison(result, scratch, plots=plots)
        checkpoint.unlink(missing_ok=True)
    except _user_errors() as exc:
        _fail(exc)
    except RuntimeError as exc:  # a full-order Newton failure (one line, checkpoint kept)
        _fail(exc)
    if as_json:
        sys.stdout.write(json.dumps(payload, indent=2) + "\n")
        return
    table = Table(
        "model", "envelope", "cone angle", "cone change", "spin rate", "wall (s)", "speed-up",
        title=f"{run.name}: {t_window:g} s window, errors relative to full order",
    )
    fo = payload["full_order"]
    table.add_row("full order", "—", "—", "—", "—", f"{fo['wall_s']:.3g}", "1")
    for name, row in payload["formulations"].items():
        table.add_row(
            name, *(_num(row[k], ".2e") for k in ("envelope_error", "cone_angle_error",
                                                  "cone_angle_change_error", "spin_rate_error")),
            _num(row["wall_s"], ".3g"), _num(row["speedup"], ".3g"),
        )  # fmt: skip
    out.print(table)
    out.print(f"results written to {escape(str(target))}")


@app.command("rotating")
def rotating_command(
    case: Annotated[
        str, typer.Argument(help="free membrane model case (name or TOML file)")
    ] = "paper-membrane-coarse",
    spins: Annotated[str, typer.Option(help='spin rates, comma-separated, in Hz')] = "0,20,41",
    modes: Annotated[int, typer.Option(help="retained modes of the reduced model")] = 5,
    formulations: Annotated[str, typer.Option(help="comma-separated, from Q, P, L, Q4")] = "Q,L",
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="write the Markdown table to this file")
    ] = None,
) -> None:
    """Rotating-frame frequencies of the full-order model linearised about its spinning
    equilibrium (centrifugal prestress, gyroscopic coupling) against the reduced model's
    (campbell), branch by branch, matched by MAC. Frequencies in Hz, rotating frame."""
    from quadmodes.analysis.rotating import rotating_frequency_comparison

    try:
        try:
            spin_list = tuple(float(v) for v in spins.split(",") if v.strip())
        except ValueError:
            raise UserError(f'--spins: "{spins}" is not a comma-separated list of Hz values, '
                            'e.g. "0,20,41"') from None  # fmt: skip
        if not spin_list or any(v < 0 for v in spin_list):
            raise UserError('--spins: give one or more non-negative spin rates in Hz, e.g. "0,20,41"')
        names = tuple(f.strip() for f in formulations.split(",") if f.strip())
        bad = [f for f in names if f not in ("Q", "P", "L", "Q4")]
        if bad or not names:
            raise UserError(f"--formulations: unknown {', '.join(bad) or '(none)'}; use Q, P, L, Q4")
        if modes < 1:
            raise UserError("--modes: must be at least 1")
        c = _load(case)
        with _progress() as bars:
            table = rotating_frequency_comparison(c, spin_list, modes, names, progress=bars)
    except _user_errors() as exc:
        _fail(exc)
    text = table.to_text()
    out.print(text, markup=False, highlight=False, soft_wrap=True)
    if output is not None:
        write_text(output, f"# {table.case}: rotating-frame frequencies, full order vs reduced\n\n{text}\n")
        err.print(f"written {output}")
