"""The files of ``run`` and how they survive an interruption.

For a run case NAME written into the folder OUT::

    OUT/NAME/                 the complete result: results.nc, summary.json, then the figures
    OUT/NAME.partial/         an interrupted run: checkpoint.npz (written every ~10 s of wall
                              time, at the end of the integration and on Ctrl-C/SIGTERM), and
                              after Ctrl-C/SIGTERM its partial results.nc / summary.json
                              (complete = 0)
    OUT/.NAME.partial-<pid>-…/  hidden staging folder while the results are written

An interrupted run never writes into OUT/NAME, so a complete result there survives any
interruption of a rerun. ``--resume`` continues from the checkpoint (bit for bit the
uninterrupted run); a run without it refuses to discard a checkpoint unless ``--restart``.
The data are moved in before the figures are drawn: an interruption while plotting keeps them.
Figures of an earlier run are removed when new data arrive (a ``--no-plots`` rerun says so);
other files in OUT/NAME that the run did not write are listed. Left-over staging folders of
killed runs are removed at the next start.
"""

from __future__ import annotations

import shlex
import shutil
from dataclasses import dataclass
from pathlib import Path

import typer
from rich.markup import escape

from quadmodes.cli.common import UserError, clean_stale_staging, err, staged_output

#: The files of a run's data; anything else but figures (``*.png``) in its folder is listed.
DATA_FILES = ("results.nc", "summary.json")


def note(text: str) -> None:
    """One line on stderr (markup escaped)."""
    err.print(escape(text), highlight=False, soft_wrap=True)


@dataclass(frozen=True)
class RunFolders:
    """The result folder of one run case and its partial folder (module docstring)."""

    target: Path
    partial: Path

    @property
    def checkpoint(self) -> Path:
        return self.partial / "checkpoint.npz"

    @property
    def has_checkpoint(self) -> bool:
        return self.checkpoint.is_file()


def run_folders(output_dir: Path, name: str) -> RunFolders:
    """The folders of run case ``name`` in ``output_dir``."""
    return RunFolders(output_dir / name, output_dir / f"{name}.partial")


def _clean_leftovers(folders: RunFolders) -> None:
    """Staging folders of dead processes, temporary checkpoint files of a killed run, and a
    partial folder without a checkpoint (nothing to resume)."""
    clean_stale_staging(folders.target)
    clean_stale_staging(folders.partial)
    if not folders.partial.is_dir():
        return
    for tmp in folders.partial.glob(".checkpoint.npz.*"):
        tmp.unlink(missing_ok=True)
    if not folders.has_checkpoint:
        shutil.rmtree(folders.partial, ignore_errors=True)
        note(f"note: removed {folders.partial} (partial results without a checkpoint to resume)")


def check_folders(all_folders: list[RunFolders], *, resume: bool, restart: bool) -> None:
    """Before any work: clean left-overs; with ``resume`` at least one checkpoint must exist;
    without it an existing checkpoint is discarded only with ``restart`` (else UserError)."""
    if resume and restart:
        raise UserError("--restart: discards the checkpoint that --resume continues; pass one")
    for folders in all_folders:
        _clean_leftovers(folders)
    with_checkpoint = [f for f in all_folders if f.has_checkpoint]
    if resume and not with_checkpoint:
        raise UserError(f"--resume: no checkpoint at {all_folders[0].checkpoint}; run without "
                        "--resume")  # fmt: skip
    if not resume and with_checkpoint:
        if not restart:
            raise UserError(
                f"{with_checkpoint[0].checkpoint} holds an interrupted run; continue it with "
                "--resume, or pass --restart to discard it"
            )
        for folders in with_checkpoint:
            shutil.rmtree(folders.partial, ignore_errors=True)
            note(f"note: discarded the checkpoint in {folders.partial} (--restart)")


def save_partial(result, folders: RunFolders, saved: bool) -> str:
    """Write the partial results of an interrupted run into its partial folder (beside the
    checkpoint); returns the sentence saying where they are."""
    from quadmodes.runs.results import write_run_data

    if not saved:
        return "nothing was saved (the first chunk had not ended)"
    with staged_output(folders.partial) as scratch:
        write_run_data(result, scratch)
    return (f"its checkpoint and partial results (complete = 0) are in {folders.partial}; "
            f"{folders.target} is untouched")  # fmt: skip


def stop(message: str, code: int) -> typer.Exit:
    """Print ``message`` on stderr and return the exit to raise (status ``code``)."""
    note(message)
    return typer.Exit(code=code)


def remove_old_figures(target: Path) -> list[str]:
    """Remove the figures of an earlier run from ``target``; returns their names."""
    names = []
    if target.is_dir():
        for png in sorted(target.glob("*.png")):
            png.unlink(missing_ok=True)
            names.append(png.name)
    return names


def _others(target: Path) -> list[str]:
    """Files in ``target`` that a run does not write (neither data nor figures)."""
    return sorted(
        p.name for p in target.iterdir() if p.name not in DATA_FILES and p.suffix != ".png"
    )


def commit_run(result, folders: RunFolders, extra: dict, *, plots: bool, signals: dict) -> dict:
    """Move the data of free-body run ``result`` into its folder, then draw its figures
    (:func:`commit`). Returns the summary."""
    from quadmodes.io.plots import write_plots
    from quadmodes.runs.results import write_run_data

    def data(scratch: Path):
        return write_run_data(result, scratch, extra)

    return commit(folders, data, write_plots, plots=plots, signals=signals)


def commit_spinup(result, folders: RunFolders, *, plots: bool, signals: dict) -> dict:
    """:func:`commit_run` for a hub-driven spin-up (``tip_deflection.png``)."""
    from quadmodes.io.plots import plot_tip_deflection
    from quadmodes.runs.results import spinup_dataset, write_spinup_outputs

    def data(scratch: Path):
        return spinup_dataset(result), write_spinup_outputs(result, scratch, plots=False)

    def draw(ds, target: Path):
        plot_tip_deflection(ds, target / "tip_deflection.png")

    return commit(folders, data, draw, plots=plots, signals=signals)


def commit(folders: RunFolders, data, draw, *, plots: bool, signals: dict) -> dict:
    """Write the data (``data(scratch) -> (dataset, summary)``) into a staging folder and move
    them into the result folder (old figures removed, the data files replaced together), drop
    the partial folder, then draw the figures (``draw(dataset, folder)``) if ``plots``. Ctrl-C
    while drawing keeps the data and exits with status ``signals["exit"]`` (130; 143 after
    SIGTERM). Returns the summary."""
    target = folders.target
    with staged_output(target) as scratch:
        ds, info = data(scratch)
        old_figures = remove_old_figures(target)
    shutil.rmtree(folders.partial, ignore_errors=True)
    if old_figures and not plots:
        note(f"note: removed {len(old_figures)} figure(s) of an earlier run from {target} "
             f"(--no-plots): {', '.join(old_figures)}")  # fmt: skip
    others = _others(target)
    if others:
        note(f"note: {target} also holds files this run did not write: {', '.join(others)}")
    if plots:
        try:
            draw(ds, target)
        except KeyboardInterrupt:
            raise stop(f"stopped while drawing the figures; the data are saved in {target} "
                       f"({', '.join(DATA_FILES)}); the figures are incomplete", signals["exit"]) from None  # fmt: skip
    return info


def stopped_message(all_folders: list[RunFolders], hint: str) -> str:
    """What an interruption outside the integration leaves: the checkpoints to continue."""
    kept = [str(f.partial) for f in all_folders if f.has_checkpoint]
    if kept:
        return f"stopped; checkpoints kept in {', '.join(kept)}: continue with {hint} --resume"
    return "stopped; nothing of the unfinished run was written"


def resume_point(setup, folders: RunFolders, resume: bool):
    """(progress, wall s) of the checkpoint to resume from, or None (no --resume or none)."""
    from quadmodes.runs.run_checkpoint import RunCheckpoint

    if not (resume and folders.has_checkpoint):
        return None
    start = RunCheckpoint(folders.checkpoint, setup).load()
    t = start[0].steps * setup.run.integration.duration / setup.run.integration.n_steps
    note(f"{setup.run.name}: resuming from {folders.checkpoint} at t = {t:.6g} s")
    return start


def resume_hint(case: str | None, output_dir: Path, overrides: dict, flags: dict) -> str:
    """The command line of this run (to repeat with --resume)."""
    parts = ["quadmodes", "run", *([case] if case else []), "-o", str(output_dir)]
    for key, value in overrides.items():
        if value is not None:
            parts += [f"--{key.replace('_', '-')}", str(value)]
    parts += [option for option, given in flags.items() if given]
    return shlex.join(parts)


def checkpoint_interval(text: str) -> float:
    """``--checkpoint-every`` in s (UserError unless a time >= 0)."""
    from quadmodes.case import parse_quantity

    if text.strip() in ("0", "0.0"):
        return 0.0
    seconds = parse_quantity(text, "time", "--checkpoint-every")
    if not seconds >= 0:
        raise UserError('--checkpoint-every: must be a wall time >= 0, e.g. "10 s"')
    return float(seconds)
