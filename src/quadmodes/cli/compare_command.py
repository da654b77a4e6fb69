"""The ``compare`` command: reduced formulations against the full-order transient on one window,
with the full-order run estimated first and checkpointed as it goes."""

from __future__ import annotations

import json
import shlex
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table

from quadmodes.analysis.comparison_run import FULL_ORDER_CHECKPOINT_EVERY  # noqa: E402
from quadmodes.cli import extra_outputs as extras
from quadmodes.cli.common import (
    NoCacheFlag,
    UserError,
    case_argument,
    check_output_folder,
    err,
    flag,
    formulation_option,
    guard_model_size,
    guard_reduced_model,
    one_line_errors,
    out,
    output_path,
    parse_formulations,
    progress_bars,
    sigterm_as_interrupt,
)
from quadmodes.cli.run_files import note as print_note
from quadmodes.cli.run_files import stop

#: Full-order runs estimated longer than this (s) need --yes.
LONG_FULL_ORDER_S = 1800.0


@dataclass(frozen=True)
class ComparisonPlan:
    """What ``compare`` runs: the run case cut to the window, the window (s), the full-order
    step (s) and the reduced formulations."""

    run: Any
    window_s: float
    full_dt_s: float
    formulations: tuple[str, ...]
    damping_cutoff_hz: float | None = None
    at: str | None = None  # a point of the reduced path both sides start from (--at)
    results: Path | None = None  # the results.nc the point is read from (--results)


def _num(value, fmt: str) -> str:
    return "n/a" if value is None else format(value, fmt)


def _plan(
    case: str,
    window: str,
    full_dt: str | None,
    modes: str | None,
    spin_rate: str | None,
    formulations: str | None,
    damping_cutoff: str | None = None,
    at: str | None = None,
    results: Path | None = None,
) -> ComparisonPlan:
    """Load the run case and check the options; raises UserError (or a case/quantity error)."""
    from quadmodes.analysis import compare as cmp
    from quadmodes.case import CaseError, load_run_case, parse_quantity
    from quadmodes.runs import simulate

    run = load_run_case(case)
    if run.spinup is not None:
        raise UserError(f"{case}: a hub-driven spin-up; compare needs a free-body run case")
    try:  # the same overrides and checks as ``run`` (modes: N or "auto")
        run = simulate.apply_overrides(run, spin_rate=spin_rate, modes=modes)
    except CaseError as exc:
        if exc.field != "reduced.modes":
            raise
        raise UserError(f"--modes: {exc.detail}") from None
    t_window = parse_quantity(window, "time", "--window")
    dt_full = parse_quantity(full_dt, "time", "--full-dt") if full_dt else run.integration.dt
    if not t_window > 0:
        raise UserError('--window: must be positive, e.g. "1 s"')
    if not 0 < dt_full < t_window:
        raise UserError("--full-dt: must be positive and shorter than the window")
    names = (cmp.default_formulations(run) if formulations is None else parse_formulations(
        formulations, cmp.AVAILABLE, use="rigid, L, P, Q, Q4, QM", none="(none given)"))  # fmt: skip
    cutoff = None
    if damping_cutoff is not None:
        cutoff = parse_quantity(damping_cutoff, "frequency", "--damping-cutoff", "150 Hz")
        if not cutoff > 0:
            raise UserError('--damping-cutoff: must be a positive frequency, e.g. "150 Hz"')
    return ComparisonPlan(cmp.window_run(run, t_window), t_window, dt_full, names, cutoff,
                          _path_event(at, results), results)  # fmt: skip


def _path_event(at: str | None, results: Path | None) -> str | None:
    """``--at`` checked (an event text, :func:`quadmodes.case.run_events.parse_until`);
    ``--results`` needs it and must be a file. UserError otherwise."""
    from quadmodes.case.run_events import parse_until

    if results is not None and at is None:
        raise UserError('--results: names the run the --at point is read from; add --at, e.g. '
                        '--at "cone 10 deg"')  # fmt: skip
    if results is not None and not Path(results).is_file():
        raise UserError(f"--results: no file {results}; give a results.nc of this run")
    if at is None:
        return None
    try:
        parse_until(at)
    except ValueError as exc:
        raise UserError(f"--at: {exc}") from None
    return " ".join(at.split())


def _prepared(plan: ComparisonPlan):
    """``(run, setup, point)``: the run with its modes resolved, the full order's setup
    (inflation, initial state, damping modes; once for the estimate and the run), started at
    the reduced path point of ``--at`` (``point``; None: t = 0)."""
    from quadmodes.analysis import comparison_run as runner

    if plan.at is None:
        return (*runner.prepare_comparison(plan.run, plan.window_s, plan.damping_cutoff_hz), None)
    return runner.prepare_path_comparison(plan.run, plan.window_s, plan.at, results=plan.results,
                                   damping_cutoff=plan.damping_cutoff_hz)  # fmt: skip


def _checkpoint_for(target: Path, resume: bool, restart: bool) -> Path:
    """The full-order checkpoint beside ``target``: it must exist to resume; without --resume
    an existing one is discarded only with --restart (else a one-line error)."""
    from quadmodes.analysis.comparison_run import check_checkpoint, checkpoint_beside

    def discarded(text: str) -> None:
        err.print(escape(text), highlight=False)

    return check_checkpoint(checkpoint_beside(target), resume=resume, restart=restart,
                            note=discarded)  # fmt: skip


def _check_estimate(plan: ComparisonPlan, setup, checkpoint: Path, *, go_ahead: bool) -> None:
    """Print the full-order run's estimated wall time; a long run needs ``go_ahead``
    (--yes or --resume), else UserError."""
    from quadmodes.analysis.full_order_runs import estimate_for_run

    run = plan.run
    est = estimate_for_run(run, dt=plan.full_dt_s, window=plan.window_s, setup=setup)
    minutes = est["estimate_s"] / 60.0
    err.print(
        f"full order: {run.name}, {plan.window_s:g} s at dt = {plan.full_dt_s * 1e3:g} ms, estimated "
        f"{minutes:.1f} min (checkpoint {checkpoint.name}; Ctrl-C stops, --resume continues)",
        highlight=False,
    )
    for note in setup.notes:
        if note.startswith("full-order damping"):
            err.print(note, highlight=False)
    if est["estimate_s"] > LONG_FULL_ORDER_S and not go_ahead:
        raise UserError(
            f"--window: the full-order run is estimated at {minutes:.0f} min; pass --yes to "
            "run it (Ctrl-C stops it, --resume continues), or shorten --window"
        )


def _stopped_message(checkpoint: Path, rerun_hint: str) -> str:
    """What Ctrl-C leaves: the checkpoint to resume from, or nothing."""
    if checkpoint.is_file():
        return (f"stopped; the full-order checkpoint is kept at {checkpoint}: continue with "
                f"{rerun_hint} --resume")  # fmt: skip
    return ("stopped before the first full-order checkpoint (every "
            f"{FULL_ORDER_CHECKPOINT_EVERY} steps); nothing to resume")  # fmt: skip


def _run_comparison(plan: ComparisonPlan, setup, checkpoint: Path, *, resume: bool,
                    bars_shown: bool, rerun_hint: str, signals: dict | None = None,
                    on_sample=None, start=None):  # fmt: skip
    """The reduced runs and the checkpointed full-order run
    (:func:`quadmodes.analysis.comparison_run.run_comparison`); Ctrl-C (in either) keeps the
    checkpoint, says how to continue (``rerun_hint``: the command line without --resume) and
    exits with status ``signals["exit"]`` (130, 143 after SIGTERM; see
    :func:`~quadmodes.cli.common.sigterm_as_interrupt`). A full order that stopped otherwise
    is a one-line error (nothing is scored)."""
    from quadmodes.analysis.comparison_run import FullOrderIncomplete, run_comparison

    with progress_bars(bars_shown) as bars:
        try:
            return run_comparison(
                plan.run, plan.window_s, formulations=plan.formulations,
                full_order_dt=plan.full_dt_s, setup=setup, checkpoint=checkpoint, resume=resume,
                checkpoint_every=FULL_ORDER_CHECKPOINT_EVERY, on_sample=on_sample, progress=bars,
                start=start,
            )  # fmt: skip
        except (KeyboardInterrupt, FullOrderIncomplete) as exc:
            if isinstance(exc, FullOrderIncomplete) and not exc.interrupted:
                raise
            err.print(escape(_stopped_message(checkpoint, rerun_hint)), highlight=False,
                      soft_wrap=True)  # fmt: skip
            raise typer.Exit(code=(signals or {}).get("exit", 130)) from None


def _rerun_hint(case: str, options: dict[str, str | None], target: Path, plots: bool,
                as_json: bool = False) -> str:  # fmt: skip
    """The compare command line with the options given (to repeat with --resume)."""
    parts = ["quadmodes", "compare", case, "-o", str(target)]
    for option, value in options.items():
        if value is not None:
            parts += [option, value]
    flags = [*([] if plots else ["--no-plots"]), *(["--json"] if as_json else [])]
    return shlex.join([*parts, *flags])


def _ratio(value) -> str:
    return "null" if value is None else f"×{value:.3g}"


def _comparison_tables(payload: dict, plan: ComparisonPlan) -> tuple[Table, Table]:
    """The two tables of a comparison, each narrow enough for 80 columns with every number
    whole (no "…"): errors relative to the full order, then the long-window rates as reduced /
    full with wall times and speed-ups."""
    errors = Table("model", "envelope", "cone angle", "cone change", "spin rate",
                   title=f"{plan.run.name}: {plan.window_s:g} s window, errors relative to "
                   "full order")  # fmt: skip
    rates = Table("model", "cone growth", "diss. power", "spin change", "wall (s)", "speed-up",
                  title="long-window rates as reduced / full, wall times")  # fmt: skip
    for table in (errors, rates):
        for column in table.columns:
            column.no_wrap = True  # numbers never break; the tables fit in 80 columns
    fo = payload["full_order"]
    errors.add_row("full order", *("—",) * 4)
    rates.add_row("full order", *("—",) * 3, f"{fo['wall_s']:.3g}", "1")
    for name, row in payload["formulations"].items():
        errors.add_row(name, *(_num(row[k], ".2e") for k in (
            "envelope_error", "cone_angle_error", "cone_angle_change_error", "spin_rate_error")))  # fmt: skip
        rates.add_row(name, *(_ratio(row.get(k)) for k in ("cone_growth_ratio",
                      "dissipated_power_ratio", "spin_rate_change_ratio")),
                      _num(row["wall_s"], ".3g"), _num(row["speedup"], ".3g"))  # fmt: skip
    return errors, rates


def _print_comparison(payload: dict, plan: ComparisonPlan, target: Path) -> None:
    """Errors relative to full order, long-window ratios reduced / full, wall times and
    speed-ups, one row a model (two tables that keep their numbers in 80 columns); then the
    quasi-steady interval, the full order's fitted rates and the notes."""
    for table in _comparison_tables(payload, plan):
        out.print(table)
    qs = payload.get("quasi_steady")
    if qs:
        f = qs["full_order"]
        out.print(
            f"rates fitted over the quasi-steady part {qs['start_s']:.3g}–{qs['end_s']:.3g} s "
            f"({'capped at 3T/4' if qs['capped'] else 'max(T/2, k·tau)'}, tau = "
            f"{_num(qs['decay_time_s'], '.3g')} s); full order: cone growth "
            f"{_num(f['cone_growth_deg_per_s'], '.3g')} ± {_num(f['cone_growth_se_deg_per_s'], '.2g')}"
            f" deg/s, dissipated power {_num(f['dissipated_power_W'], '.3g')} ± "
            f"{_num(f['dissipated_power_se_W'], '.2g')} W, spin-rate slope "
            f"{_num(f['spin_rate_slope_rad_per_s2'], '.3g')} ± "
            f"{_num(f['spin_rate_slope_se_rad_per_s2'], '.2g')} rad/s²",
            highlight=False,
        )
    for note in payload.get("notes", []):
        out.print(f"note: {escape(note)}", highlight=False)
    out.print(f"results written to {escape(str(target))}")


CompareCase = case_argument("run case (built-in name or TOML file)", "run")
CompareFormulations = formulation_option(
    "comma-separated, from rigid, L, P, Q, Q4, QM (default: rigid,L,P,Q,Q4 and the run case's own "
    "formulation, e.g. QM)", ("rigid", "L", "P", "Q", "Q4", "QM"), listed=True)
CompareOutput = output_path("folder (default: out/compare-<case>)")
ResumeFlag = flag("--resume", "continue the full-order run from its checkpoint")
RestartFlag = flag("--restart", "discard the checkpoint of an interrupted full-order run")
YesFlag = flag(
    "--yes", "run a full-order window estimated over 30 min, or a model above the size limit"
)
ComparePlotsFlag = flag("--plots/--no-plots", "write overlay PNGs")


def compare_command(
    case: CompareCase = "paper-41hz",
    window: Annotated[str, typer.Option(help='simulated window, e.g. "1 s"')] = "1 s",
    full_dt: Annotated[
        str | None, typer.Option("--full-dt", help="full-order step (default: the run's dt)")
    ] = None,
    modes: Annotated[
        str | None,
        typer.Option(help='retained modes N (default: the run\'s), or "auto" as for run'),
    ] = None,
    spin_rate: Annotated[
        str | None, typer.Option("--spin-rate", help='initial spin rate, e.g. "20 Hz"')
    ] = None,
    formulations: CompareFormulations = None,
    damping_cutoff: Annotated[
        str | None,
        typer.Option("--damping-cutoff", help='full-order damping: every FE mode below this, '
                     'e.g. "150 Hz" (default: 3 × max(spin, highest retained mode))'),
    ] = None,
    at: Annotated[
        str | None,
        typer.Option("--at", help='start both sides at this point of the reduced run\'s path, '
                     'e.g. "cone 10 deg", "time 100 s" (the reduced run integrated to it)'),
    ] = None,
    results: Annotated[
        Path | None,
        typer.Option("--results", help="with --at: read the path from this results.nc of the "
                     "same run (its samples; the point located to the step)"),
    ] = None,
    output_dir: CompareOutput = None,
    as_json: Annotated[bool, typer.Option("--json", help="print the table as JSON")] = False,
    resume: ResumeFlag = False,
    restart: RestartFlag = False,
    yes: YesFlag = False,
    plots: ComparePlotsFlag = True,
    no_cache: NoCacheFlag = False,
    animate: extras.AnimateFlag = False, animate_frame: extras.AnimateFrame = "inertial", animate_frames: extras.AnimateFrames = 100,  # fmt: skip
) -> None:
    """Reduced formulations (rigid, L, P, Q, Q4, and the run case's own, e.g. QM) against the
    full-order finite-element transient on one window: errors of the modal-amplitude envelope, cone angle and spin rate; the secular
    cone-growth rate, mean dissipated power and spin-rate change fitted over the quasi-steady part
    of the window, as reduced / full; wall times and speed-ups. Writes comparison.nc/.json/.csv,
    overlay plots and report.html (with --animate also the full order's motion.xdmf). The full order's damping is modal damping (the case's ζ) on every FE mode
    below --damping-cutoff, independent of the reduced basis.

    The full-order run is estimated first and checkpointed as it goes: Ctrl-C (or SIGTERM) stops
    it with exit status 130 (143) and keeps the checkpoint, and the same command with --resume
    continues from it; without --resume an existing checkpoint is discarded only with --restart.
    A full-order run that did not reach the end of the window is never scored.

    --at "cone 10 deg" (or a time, a spin, "flat spin") starts both sides at that point of the
    reduced run's path instead of t = 0: the reduced state there, and the full order from it
    with the part outside the retained modes relaxed (docs/path-validity.md)."""
    with sigterm_as_interrupt() as signals:
        try:
            payload, plan, target = _compare(
                case, window, full_dt, modes, spin_rate, formulations, damping_cutoff,
                output_dir, as_json=as_json, at=at, results=results, resume=resume, restart=restart, yes=yes,
                plots=plots, signals=signals, no_cache=no_cache,
                animation=(animate, animate_frame, animate_frames),
            )  # fmt: skip
        except KeyboardInterrupt:  # outside the integrations (setup, writing)
            message = signals.get("stopped", lambda: "stopped; nothing was written")()
            err.print(escape(message), highlight=False, soft_wrap=True)
            raise typer.Exit(code=signals["exit"]) from None
    if as_json:
        sys.stdout.write(json.dumps(payload, indent=2) + "\n")
        return
    _print_comparison(payload, plan, target)


def _compare(case, window, full_dt, modes, spin_rate, formulations, damping_cutoff, output_dir,
             *, as_json, resume, restart, yes, plots, signals, no_cache,
             animation=(False, "inertial", 100), at=None, results=None):  # fmt: skip
    """The body of :func:`compare_command`: returns (payload, plan, output folder);
    ``animation``: the ``--animate``, ``--animate-frame``, ``--animate-frames`` values."""
    from quadmodes.analysis import comparison_run as runner
    from quadmodes.io.outputs import check_free_space
    from quadmodes.models.cache import caching_disabled
    from quadmodes.runs.run_folder import OutputsInterrupted

    # RuntimeError: a full-order Newton failure (one line, checkpoint kept)
    with one_line_errors(RuntimeError), caching_disabled(no_cache):
        plan = _plan(case, window, full_dt, modes, spin_rate, formulations, damping_cutoff,
                     at, results)  # fmt: skip
        animation = extras.animation_choice(*animation)
        target = output_dir or Path("out") / f"compare-{plan.run.name}"
        check_output_folder(target)
        runner.check_comparison_folder(target)  # the checkpoint inside it, no user file replaced
        model_case = plan.run.model_case()
        guard_model_size(model_case, yes)
        guard_reduced_model(model_case, plan.run.reduced.modes, yes, spins=True,
                            from_option=modes is not None)  # fmt: skip
        checkpoint = _checkpoint_for(target, resume, restart)
        options = {"--window": window, "--full-dt": full_dt, "--modes": modes,
                   "--spin-rate": spin_rate, "--formulation": formulations,
                   "--damping-cutoff": damping_cutoff, "--at": at,
                   "--results": None if results is None else str(results)}  # fmt: skip
        hint = _rerun_hint(case, options, target, plots, as_json)
        signals["stopped"] = lambda: _stopped_message(checkpoint, hint)
        # modes resolved once; inflation, initial state and damping modes, once for the
        # estimate and the run
        run, setup, point = _prepared(plan)
        if resume:
            runner.check_checkpoint_key(checkpoint, setup)
        check_free_space(target, runner.comparison_output_bytes(setup, plan.window_s,
                                                                len(plan.formulations)))  # fmt: skip
        _check_estimate(plan, setup, checkpoint, go_ahead=yes or resume)
        recorder = runner.full_order_recorder(animation, setup, plan.window_s, plan.full_dt_s)
        result = _run_comparison(
            replace(plan, run=run), setup, checkpoint, resume=resume, bars_shown=True,
            rerun_hint=hint, signals=signals, on_sample=recorder, start=point,
        )  # fmt: skip
        try:
            payload = runner.write_comparison_outputs(
                result, target, plots=plots, setup=setup, recorder=recorder, animation=animation,
                checkpoint=checkpoint, note=print_note, run=plan.run,
            )  # fmt: skip
        except OutputsInterrupted as stopped:
            raise stop(str(stopped), signals["exit"]) from None
    return payload, plan, target
