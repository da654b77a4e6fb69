"""The ``run`` command: integrate run cases (free-body runs and hub-driven spin-ups), write their
outputs, print their summaries."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table

from quadmodes.cli import extra_outputs as extras
from quadmodes.cli import path_rows
from quadmodes.cli.common import (
    NoCacheFlag,
    RunAxis,
    RunCaseArgument,
    RunFormulation,
    RunMethod,
    UserError,
    check_output_folder,
    err,
    flag,
    guard_model_size,
    guard_reduced_model,
    one_line_errors,
    out,
    output_path,
    progress_bars,
    sigterm_as_interrupt,
)
from quadmodes.cli.run_files import (
    RunFolders,
    check_folders,
    checkpoint_interval,
    note,
    resume_hint,
    resume_point,
    run_folders,
    stop,
    stopped_message,
)
from quadmodes.cli.run_tables import dt_table, mode_lines, mode_table
from quadmodes.io.run_report import ANSWER_ROWS

# ------------------------------------------------------------------------------ summary tables

#: (label, summary key or keys, format) of a free-body run's summary table.
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
    *ANSWER_ROWS,  # the answer: cone growth, dissipated power, time constants
    ("this run / energy sink at the fit's state | at the start",
     ("time_constant_ratio", "time_constant_ratio_to_start"), "{:.4f} | {:.4f}"),
    ("spin (rule below)", "spin_verdict", "{}"),
    ("bending log decrement (free decay only)", "log_decrement", "{:.4f}"),
    ("retained modes N", "n_modes", "{}"),
    ("mode choice", "mode_rule", "{}"),
    ("rotating stiffness min eigenvalue (s⁻²)", "rotating_stiffness_min_eigenvalue", "{:.4g}"),
    ("valid: spin (Λ − ωᵀJ2ω > 0 up to it)", "valid_spin", "{}"),
    ("valid: initial deformation (energy within 2 % of the FE model's; —: none)",
     "valid_initial_deformation", "{}"),
    *path_rows.PATH_ROWS,  # the path's validity, the until event, the times to cone angles
]  # fmt: skip

#: (label, summary key, format) of a spin-up's summary table.
_SPINUP_ROWS = [
    ("status", "status", "{}"),
    ("formulation", "formulation", "{}"),
    ("hub rate before the change Ω₀ (rad/s; 0: from rest)", "omega_0_rad_s", "{:.4g}"),
    ("final hub rate Ωs (rad/s)", "omega_s_rad_s", "{:.4g}"),
    ("peak in-plane tip deflection (m)", "peak_tip_deflection_m", "{:.4f}"),
    ("time of the peak (s)", "peak_time_s", "{:.3f}"),
    ("max |v| after the spin-up (m)", "max_abs_after_spinup_m", "{:.4g}"),
    ("settled (|v| < 5 % of its peak) from (s)", "settling_time_s", "{:.2f}"),
    *path_rows.PATH_ROWS[:3],  # a spin change: the model's validity along its path
    ("rotating stiffness min eigenvalue (s⁻²)", "rotating_stiffness_min_eigenvalue", "{:.4g}"),
    ("steps", "steps", "{}"),
    ("wall time (s)", "wall_s", "{:.1f}"),
]


def _format_row(summary: dict, key, fmt: str) -> str:
    """``fmt`` filled with the summary's value(s) at ``key`` (a key or a tuple); "—" if missing."""
    keys = key if isinstance(key, tuple) else (key,)
    values = [summary.get(k) for k in keys]
    if any(v is None for v in values):
        return "—"
    return fmt.format(*values)


def _print_run_summaries(summaries: dict[str, dict], spinups: set[str], output_dir: Path) -> None:
    """One summary table a run (and its time-step convergence table), then where it was written."""
    for name, summary in summaries.items():
        rows = _SPINUP_ROWS if name in spinups else _RUN_ROWS
        table = Table("quantity", "value", title=f"{name}: run summary")
        for label, key, fmt in rows:
            table.add_row(label, path_rows.format_row(summary, key, fmt, _format_row))
        out.print(table)
        if summary.get("stability_rule"):
            out.print(escape(f"stability rule: {summary['stability_rule']}"), highlight=False,
                      soft_wrap=True, style="dim")  # fmt: skip
        if summary.get("dt_convergence"):
            # not cropped to 80 columns when the output is not a terminal
            conv = summary["dt_convergence"]
            out.print(dt_table(name, conv["rows"]), width=None if out.is_terminal else 132)
            out.print(escape(f"verdict: {conv['text']}"), highlight=False, soft_wrap=True)
        if summary.get("mode_convergence"):
            conv = summary["mode_convergence"]
            out.print(mode_table(name, conv), width=None if out.is_terminal else 132)
            for line in mode_lines(conv):
                out.print(escape(line), highlight=False, soft_wrap=True)
        out.print(f"results written to {escape(str(output_dir / name))}")


# ------------------------------------------------------------------------------ warnings


def _warn_validity(name: str, validity) -> None:
    """Warn (stderr) when the formulation is outside its validity for this run."""
    if validity is not None and not validity.valid:
        err.print(
            f"[bold yellow]warning:[/] {escape(name)}: {escape(validity.message())}",
            highlight=False,
            soft_wrap=True,
        )


def path_hint(path, formulation: str, model) -> str:
    """What to change when a path leaves its range by its modal amplitudes under a formulation
    whose potential or kinetics stop at second order ("" otherwise): formulation QM (the
    manifold's exact kinetic energy, Q4's potential) holds the coarse 41 Hz body to a 60° cone
    within 2 % of the full order where Q leaves at 32° (docs/manifold-formulation.md)."""
    if not path.amplitudes_fail or formulation == "QM" or not getattr(model, "manifold_potential", False):
        return ""
    return ('; formulation QM (reduced.formulation = "QM": the exact kinetic energy of the '
            "quadratic manifold and the quartic potential) holds larger amplitudes")


def _warn_path(name: str, path, hint: str = "") -> None:
    """Warn (stderr) when the run's path leaves its reduced model's range (the summary, the
    report and results.nc say where, too), with ``hint`` (:func:`path_hint`)."""
    if path is not None and path.left_at is not None:
        err.print(
            f"[bold yellow]warning:[/] {escape(name)}: {escape(path.message())}; past it the "
            f"results are outside the model's validity{escape(hint)}",
            highlight=False,
            soft_wrap=True,
        )


def _warn_stopped_early(name: str, result, target: Path) -> None:
    """Warn (stderr) that a run stopped before its end and wrote partial results."""
    err.print(
        f"[bold yellow]warning:[/] {escape(name)} stopped early ("
        f"{escape(' '.join(result.reason.split()))}); partial results with complete = 0 "
        f"written to {escape(str(target))}",
        highlight=False,
        soft_wrap=True,
    )


# ------------------------------------------------------------------------------ steps of run


def _check_dt_convergence(runs: list) -> None:
    """``--dt-convergence`` needs fixed-step free-body runs: raise UserError otherwise."""
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


def _check_mode_convergence(runs: list) -> None:
    """``--mode-convergence`` needs free-body runs with elastic modes: raise UserError
    otherwise."""
    for r in runs:
        if r.spinup is not None:
            raise UserError(
                f"--mode-convergence: {r.name} is a hub-driven spin-up; it compares "
                "free-body runs only"
            )
        if r.reduced.formulation == "rigid":
            raise UserError(
                f'--mode-convergence: {r.name} has formulation "rigid" (no elastic modes); '
                "use --formulation Q (or L, P, Q4)"
            )


def _load_runs(
    names: list[str], overrides: dict, dt_convergence: bool, mode_convergence: bool = False,
    allow_large: bool = False,
) -> list:  # fmt: skip
    """Load the run cases and apply the command-line overrides (fast: no model is built); a
    model above the size limit is refused first, unless ``allow_large``."""
    from quadmodes.case import load_run_case
    from quadmodes.runs import simulate

    runs = [simulate.apply_overrides(load_run_case(name), **overrides) for name in names]
    if dt_convergence:
        _check_dt_convergence(runs)
    if mode_convergence:
        _check_mode_convergence(runs)
    from quadmodes.runs.resources import check_run_length
    from quadmodes.runs.run_checks import check_run_step

    for r in runs:
        check_run_length(r, allow_long=allow_large)
        check_run_step(r, allow_coarse=allow_large)  # the spin; the modes once the model is in
        model_case = r.model_case()
        guard_model_size(model_case, allow_large)
        modes = r.reduced.modes if r.reduced.formulation != "rigid" else None
        guard_reduced_model(model_case, modes, allow_large, spins=r.spinup is None,
                            from_option=overrides.get("modes") is not None)  # fmt: skip
    return runs


def _prepare_runs(runs: list, allow_coarse_step: bool = False) -> list:
    """Prepare the free-body runs (reduced model, initial state); spin-ups are returned as
    their run cases. A time step too coarse for the spin or the highest retained mode is
    refused (unless ``allow_coarse_step``, --yes) or printed as a warning."""
    from quadmodes.runs import simulate

    with progress_bars(True) as bars:
        setups = [r if r.spinup is not None else simulate.prepare(
            r, progress=bars, allow_coarse_step=allow_coarse_step) for r in runs]  # fmt: skip
    for s in (s for s in setups if hasattr(s, "system")):  # the free-body RunSetups
        for text in (t for t in s.initial.notes if t.startswith("integration.dt")):
            note(f"warning: {s.run.name}: {text}")
    return setups


@dataclass(frozen=True)
class _Options:
    """How ``run`` runs its cases: figures, resume, the wall time between checkpoints (s), the
    convergence studies, the command line that continues with --resume, and the signal state
    of :func:`~quadmodes.cli.common.sigterm_as_interrupt` (its exit status)."""

    plots: bool
    resume: bool
    checkpoint_every_s: float
    dt_convergence: bool
    mode_convergence: bool
    hint: str
    signals: dict
    animation: Any = None  # --animate: quadmodes.runs.run_folder.Animation, or None

    @property
    def exit_code(self) -> int:
        return int(self.signals["exit"])


def _extras(setup, result, opts: _Options, progress) -> dict:
    """The ``--dt-convergence`` / ``--mode-convergence`` tables of a finished run."""

    extra = {}
    if opts.dt_convergence:
        from quadmodes.runs.dt_convergence import dt_convergence

        extra["dt_convergence"] = dt_convergence(setup, result, progress)
    if opts.mode_convergence:
        from quadmodes.runs.mode_convergence import mode_convergence as convergence

        extra["mode_convergence"] = convergence(setup, result, progress)
    return extra


def _execute_free(setup, folders: RunFolders, opts: _Options) -> tuple[Any, dict]:
    """Integrate one prepared free-body run (checkpointed; resumed with --resume), then write
    its data, figures and report (:func:`~quadmodes.runs.run_folder.write_run_outputs`).
    Ctrl-C/SIGTERM saves the checkpoint and the partial results in the partial folder and
    exits 130/143."""
    from quadmodes.analysis.run_answer import with_linear_answer
    from quadmodes.runs.chunked import Interrupted
    from quadmodes.runs.deformation_check import with_deformation_check
    from quadmodes.runs.run_folder import execute_in_folders

    name = setup.run.name
    with one_line_errors():  # a damaged checkpoint or one of another run
        start = resume_point(setup, folders, opts.resume)
    with progress_bars(True) as bars:  # after the input checks: one static FE solve
        setup = with_deformation_check(setup, bars)
    _warn_validity(name, setup.validity)
    again = f"continue with: {opts.hint} --resume"
    with progress_bars(True) as bars:
        try:
            result = execute_in_folders(setup, folders, every_s=opts.checkpoint_every_s,
                                        start=start, progress=bars, note=note)  # fmt: skip
        except Interrupted as stopped:
            hint = f"; {again}" if stopped.saved else ""
            raise stop(f"{name} stopped ({stopped.reason}); {stopped.where}{hint}", opts.exit_code) from None
        result = with_linear_answer(result)  # energy-sink time constant, stability at the spin
        hint = path_hint(result.path, result.run.reduced.formulation, result.model)
        _warn_path(name, result.path, hint)  # also a membrane's loss of tension (path.message)
        try:
            extra = _extras(setup, result, opts, bars)
        except KeyboardInterrupt:
            kept = (f"its integration is saved in {folders.checkpoint}; {again} (it is not "
                    "repeated)") if folders.has_checkpoint else "nothing was saved"  # fmt: skip
            raise stop(f"{name}: stopped during the convergence runs; {kept}", opts.exit_code) from None
    return result, _write(result, folders, opts, extra)


def _write(result, folders: RunFolders, opts: _Options, extra: dict | None = None) -> dict:
    """:func:`~quadmodes.runs.run_folder.write_run_outputs` into the run's folder (its partial
    folder dropped); Ctrl-C after the data exits with ``opts.exit_code`` (the data kept)."""
    from quadmodes.runs.run_folder import OutputsInterrupted, write_run_outputs

    try:
        return write_run_outputs(result, folders.target, extra=extra, plots=opts.plots,
                                 animation=opts.animation, partial=folders.partial, note=note)  # fmt: skip
    except OutputsInterrupted as stopped:
        raise stop(str(stopped), opts.exit_code) from None


def _execute_spinup(run, folders: RunFolders, opts: _Options) -> tuple[Any, dict]:
    """Integrate a hub-driven spin-up (not checkpointed) and write its outputs (data first)."""
    from quadmodes.runs import simulate

    result = simulate.simulate_spinup(run)
    _warn_validity(run.name, result.validity)
    if result.path is not None and result.path.message():  # a spin change: its path
        err.print(f"[bold yellow]warning:[/] {escape(run.name)}: {escape(result.path.message())}",
                  highlight=False, soft_wrap=True)  # fmt: skip
    return result, _write(result, folders, opts)


def _run_all(setups: list, output_dir: Path, opts: _Options):
    """Run every prepared case; returns (summaries, names of spin-ups, names that failed)."""
    from quadmodes.runs import simulate

    summaries: dict[str, dict] = {}
    spinups: set[str] = set()
    failed: list[str] = []
    for setup in setups:
        is_spinup = not isinstance(setup, simulate.RunSetup)
        name = setup.name if is_spinup else setup.run.name
        folders = run_folders(output_dir, name)
        with one_line_errors(OSError):
            if is_spinup:
                spinups.add(name)
                result, summaries[name] = _execute_spinup(setup, folders, opts)
            else:
                result, summaries[name] = _execute_free(setup, folders, opts)
        if not result.complete:
            failed.append(name)
            _warn_stopped_early(name, result, folders.target)
    return summaries, spinups, failed


# ------------------------------------------------------------------------------ run

RunOutput = output_path("folder; each run writes DIR/<case name>/", optional=False)
DtConvergenceFlag = flag(
    "--dt-convergence", "also run at dt/2 and dt/4 and print a convergence table"
)
ModeConvergenceFlag = flag(
    "--mode-convergence",
    "also run with the next two pair-whole mode counts above N and print a convergence table",
)
RunPlotsFlag = flag("--plots/--no-plots", "write PNG figures")
RunResumeFlag = flag(
    "--resume", "continue interrupted runs from their checkpoints (DIR/<case name>.partial/)"
)
RunRestartFlag = flag("--restart", "discard the checkpoint of an interrupted run and start again")
CheckpointEvery = Annotated[
    str,
    typer.Option(
        "--checkpoint-every",
        help='wall time between checkpoints of the integration, e.g. "10 s" (0: every chunk)',
    ),
]
RunYesFlag = flag(
    "--yes", "run above the size limits (50,000 nodes, 60 modes, 5 million steps)"
)


def run_command(
    case: RunCaseArgument = None,
    output_dir: RunOutput = Path("out"),
    as_json: Annotated[bool, typer.Option("--json", help="print {case name: summary} as JSON")] = False,
    method: RunMethod = None,
    dt: Annotated[str | None, typer.Option(help='time step, e.g. "0.25 ms"')] = None,
    duration: Annotated[str | None, typer.Option(help='simulated time, e.g. "4 s"')] = None,
    formulation: RunFormulation = None,
    axis: RunAxis = None,
    spin_rate: Annotated[
        str | None,
        typer.Option(
            "--spin-rate",
            help='initial spin rate, or the final hub rate Ωs of a spin-up, e.g. "10 rad/s"',
        ),
    ] = None,
    modes: Annotated[
        str | None,
        typer.Option(
            help='elastic modes N (overrides reduced.modes), or "auto": every mode up to '
            "reduced.mode_margin (default 2.5) × the spin frequency, pairs whole"
        ),
    ] = None,
    until: path_rows.UntilOption = None, step_tolerance: path_rows.StepToleranceOption = None,
    dt_convergence: DtConvergenceFlag = False,
    mode_convergence: ModeConvergenceFlag = False,
    plots: RunPlotsFlag = True,
    resume: RunResumeFlag = False,
    restart: RunRestartFlag = False,
    checkpoint_every: CheckpointEvery = "10 s",
    no_cache: NoCacheFlag = False,
    yes: RunYesFlag = False, animate: extras.AnimateFlag = False, animate_frame: extras.AnimateFrame = "inertial", animate_frames: extras.AnimateFrames = 100,  # fmt: skip
) -> None:
    """Integrate run cases; write results.nc, summary.json, PNG figures and report.html per case.

    With no CASE, runs the seed's two cases, paper-0.5hz and paper-41hz. A run case with a
    \\[spinup] table (e.g. kane-spinup) is a hub-driven spin-up of a clamped beam.

    A formulation outside its validity (rotating-frame stiffness not positive definite at some
    spin rate up to the run's) prints a warning; the JSON summary says `valid: false`.

    The integration is checkpointed (DIR/<case name>.partial/) every --checkpoint-every of wall
    time and on Ctrl-C or SIGTERM, which write the partial results there (never over DIR/<case
    name>/); --resume continues bit for bit (cases without a checkpoint start afresh).

    Exit status 2 for bad input (nothing written), 1 if a run stopped early or diverged (partial
    results), 130 after Ctrl-C (143 after SIGTERM).
    """
    from quadmodes.models.cache import caching_disabled
    from quadmodes.runs import simulate

    names = [case] if case is not None else list(simulate.PAPER_RUN_CASES)
    overrides = dict(method=method, dt=dt, duration=duration, formulation=formulation,
                     spin_rate=spin_rate, modes=modes, axis=axis, until=until,
                     step_tolerance=step_tolerance)  # fmt: skip
    flags = {"--dt-convergence": dt_convergence, "--mode-convergence": mode_convergence,
             "--no-plots": not plots}  # fmt: skip
    with sigterm_as_interrupt() as signals:
        opts = _Options(plots, resume, 0.0, dt_convergence, mode_convergence,
                        resume_hint(case, output_dir, overrides, flags), signals)  # fmt: skip
        all_folders: list[RunFolders] = []
        try:
            with caching_disabled(no_cache), one_line_errors():
                check_output_folder(output_dir)
                opts = replace(opts, checkpoint_every_s=checkpoint_interval(checkpoint_every), animation=extras.animation_choice(animate, animate_frame, animate_frames))
                runs = _load_runs(names, overrides, dt_convergence, mode_convergence, yes)
                all_folders = [run_folders(output_dir, r.name) for r in runs]
                check_folders(all_folders, resume=resume, restart=restart, runs=runs)
                setups = _prepare_runs(runs, allow_coarse_step=yes)
            with caching_disabled(no_cache):
                summaries, spinups, failed = _run_all(setups, output_dir, opts)
        except KeyboardInterrupt:
            raise stop(stopped_message(all_folders, opts.hint), opts.exit_code) from None
    if as_json:
        # one shape whatever the arguments: {case name: summary}
        sys.stdout.write(json.dumps(summaries, indent=2) + "\n")
    else:
        _print_run_summaries(summaries, spinups, output_dir)
    if failed:
        raise typer.Exit(code=1)
