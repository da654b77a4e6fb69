"""The files of a run in its folder, and how they survive an interruption: what ``quadmodes
run`` and :func:`quadmodes.write_results` write.

For a run case NAME written into the folder OUT::

    OUT/NAME/                 the complete result: results.nc, summary.json, then the figures,
                              the motion (``--animate``) and report.html
    OUT/NAME.partial/         an interrupted run: checkpoint.npz (written every ~10 s of wall
                              time, at the end of the integration and on Ctrl-C/SIGTERM), and
                              after Ctrl-C/SIGTERM its partial results.nc / summary.json
                              (complete = 0)
    OUT/.NAME.partial-<pid>-…/  hidden staging folder while the results are written

An interrupted run never writes into OUT/NAME, so a complete result there survives any
interruption of a rerun. A resumed run continues from the checkpoint (bit for bit the
uninterrupted run); without resuming an existing checkpoint is discarded only on request.
The data are moved in before the figures are drawn: an interruption while plotting keeps them
(:class:`OutputsInterrupted`). Figures of an earlier run are removed when new data arrive;
other files in OUT/NAME that the run did not write are listed. Left-over staging folders of
killed runs are removed at the next start. Notes go to a ``note(text)`` callback
(:mod:`quadmodes.io.staging`).
"""

from __future__ import annotations

import contextlib
import shutil
from dataclasses import dataclass
from pathlib import Path

from quadmodes.errors import QuadmodesError
from quadmodes.io.outputs import (
    MANIFEST,
    OutputPathError,
    check_output_path,
    check_replaceable,
    disk_full_as_error,
    foreign,
    owned,
    record,
    remove_owned,
)
from quadmodes.io.staging import Note, clean_stale_staging, log_note, staged_output

#: The files of a run's data; anything else but figures (``*.png``) in its folder is listed.
DATA_FILES = ("results.nc", "summary.json")
#: Written after the data (report, motion): removed when new data arrive, never listed.
EXTRA_FILES = ("report.html", "motion.xdmf", "motion.h5", "motion.gif")


class FolderError(QuadmodesError, ValueError):
    """A checkpoint to resume is missing, or one would be discarded without being asked to."""


class OutputsInterrupted(KeyboardInterrupt):
    """Ctrl-C after the data were saved (while drawing the figures or writing the motion or the
    report); the message says what is saved where."""


@dataclass(frozen=True)
class Animation:
    """The motion file's choices: the frame ("inertial" or "body") and the number of frames."""

    frame: str = "inertial"
    frames: int = 100


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


#: What quadmodes writes into a partial folder (the checkpoint, its temporary files, the
#: partial data and the manifest).
_PARTIAL_FILES = ("checkpoint.npz", *DATA_FILES, MANIFEST)


def _remove_partial(partial: Path) -> None:
    """Remove the partial folder ``partial`` if it holds only what quadmodes writes there;
    else :class:`~quadmodes.io.outputs.OutputPathError` (a user's folder of that name)."""
    if partial.is_symlink():
        raise OutputPathError(f"-o: {partial} is a symbolic link, not a partial folder quadmodes "
                              "wrote; move it away or choose another output folder")  # fmt: skip
    theirs = [p.name for p in partial.iterdir()
              if p.name not in _PARTIAL_FILES and not p.name.startswith(".checkpoint.npz.")]  # fmt: skip
    if theirs:
        raise OutputPathError(f"-o: {partial} holds files quadmodes did not write ({theirs[0]}); "
                              "move it away or choose another output folder")  # fmt: skip
    shutil.rmtree(partial, ignore_errors=True)


def _clean_leftovers(folders: RunFolders, note: Note) -> None:
    """Staging folders of dead processes, temporary checkpoint files of a killed run, and a
    partial folder without a checkpoint (nothing to resume)."""
    clean_stale_staging(folders.target, note)
    clean_stale_staging(folders.partial, note)
    if not folders.partial.is_dir():
        return
    for tmp in folders.partial.glob(".checkpoint.npz.*"):
        tmp.unlink(missing_ok=True)
    if not folders.has_checkpoint:
        _remove_partial(folders.partial)
        note(f"note: removed {folders.partial} (partial results without a checkpoint to resume)")


def check_folders(all_folders: list[RunFolders], *, resume: bool, restart: bool,
                  note: Note | None = None, estimate_bytes: float = 0.0) -> None:  # fmt: skip
    """Before any work: the output paths (:func:`check_output_folders`, ``estimate_bytes``
    free), clean left-overs; with ``resume`` at least one checkpoint must exist; without it an
    existing checkpoint is discarded only with ``restart`` (else :class:`FolderError`)."""
    note = note or log_note
    if resume and restart:
        raise FolderError("--restart: discards the checkpoint that --resume continues; pass one")
    check_output_folders(all_folders, estimate_bytes)
    for folders in all_folders:
        _clean_leftovers(folders, note)
    with_checkpoint = [f for f in all_folders if f.has_checkpoint]
    if resume and not with_checkpoint:
        raise FolderError(f"--resume: no checkpoint at {all_folders[0].checkpoint}; run without "
                          "--resume")  # fmt: skip
    if not resume and with_checkpoint:
        if not restart:
            raise FolderError(
                f"{with_checkpoint[0].checkpoint} holds an interrupted run; continue it with "
                "--resume, or pass --restart to discard it"
            )
        for folders in with_checkpoint:
            _remove_partial(folders.partial)
            note(f"note: discarded the checkpoint in {folders.partial} (--restart)")


def resume_point(setup, folders: RunFolders, resume: bool, note: Note | None = None):
    """(progress, wall s) of the checkpoint to resume ``setup`` from, or None (not ``resume``
    or no checkpoint)."""
    from quadmodes.runs.run_checkpoint import RunCheckpoint

    if not (resume and folders.has_checkpoint):
        return None
    start = RunCheckpoint(folders.checkpoint, setup).load()
    t = start[0].t_done  # a controlled step; else on the fixed grid
    if t is None:
        t = start[0].steps * setup.run.integration.duration / setup.run.integration.n_steps
    (note or log_note)(f"{setup.run.name}: resuming from {folders.checkpoint} at t = {t:.6g} s")
    return start


def save_partial(result, folders: RunFolders, saved: bool, note: Note | None = None) -> str:
    """Write the partial results of an interrupted run into its partial folder (beside the
    checkpoint); returns the sentence saying where they are."""
    from quadmodes.runs.results import write_run_data

    if not saved:
        return "nothing was saved (the first chunk had not ended)"
    with staged_output(folders.partial, note, announce=False, beside=True) as scratch:  # the last partial
        write_run_data(result, scratch)
    return (f"its checkpoint and partial results (complete = 0) are in {folders.partial}; "
            f"{folders.target} is untouched")  # fmt: skip


def remove_old_figures(target: Path) -> list[str]:
    """Remove the figures (``*.png``) quadmodes wrote into ``target`` earlier (its manifest,
    :mod:`quadmodes.io.outputs`; a user's own PNG stays); returns their names."""
    return remove_owned(target, ".png")


def remove_old_extras(target: Path) -> None:
    """Remove the report and motion files (:data:`EXTRA_FILES`) of an earlier run (only those
    quadmodes wrote)."""
    mine = owned(target)
    for name in EXTRA_FILES:
        path = target / name
        if name in mine and not path.is_symlink():
            path.unlink(missing_ok=True)


def _others(target: Path) -> list[str]:
    """Files in ``target`` that quadmodes did not write (not in its manifest)."""
    mine = owned(target) | {MANIFEST}
    return sorted(p.name for p in target.iterdir() if p.name not in mine)


def output_bytes(runs) -> float:
    """A generous estimate (bytes) of what the free-body run cases ``runs`` write: their
    samples (7 + 2N states and about 12 diagnostics, float64) in results.nc, the checkpoint
    and the partial results, plus 2 MB of figures and report each (spin-ups: small)."""
    total = 0.0
    for run in (r for r in runs if r.spinup is None):
        integ = run.integration
        n_modes = run.reduced.modes if isinstance(run.reduced.modes, int) else 40
        samples = integ.n_steps // max(1, int(getattr(integ, "save_every", 1) or 1)) + 1
        total += 3.0 * samples * (7 + 2 * n_modes + 12) * 8 + 2e6
    return total


def check_output_folders(all_folders: list[RunFolders], estimate_bytes: float = 0.0) -> None:
    """Before any work: every run folder and partial folder is writable by quadmodes (no
    symbolic link, names within the file system's limits, no data file of the user's in the
    way) and ``estimate_bytes`` are free (:class:`~quadmodes.io.outputs.OutputPathError`)."""
    for i, folders in enumerate(all_folders):
        check_output_path(folders.target, "-o", partial=True,
                          estimate_bytes=estimate_bytes if i == 0 else 0.0)  # fmt: skip
        check_output_path(folders.partial, "-o")
        check_replaceable(folders.target, (*DATA_FILES, *EXTRA_FILES))
        check_replaceable(folders.partial, DATA_FILES)


def _draw_staged(draw, ds, target: Path, note: Note) -> None:
    """``draw(ds, folder)`` into a hidden folder inside ``target``, then the figures moved in
    and listed in its manifest; a figure whose name a user's file holds is not moved (noted)."""
    import tempfile

    scratch = Path(tempfile.mkdtemp(prefix=".quadmodes-figures-", dir=target))
    try:
        draw(ds, scratch)
        names = sorted(p.name for p in scratch.iterdir())
        theirs = set(foreign(target, names))
        for name in names:
            if name not in theirs:
                (scratch / name).replace(target / name)
        record(target, [n for n in names if n not in theirs])
        if theirs:
            note(f"note: kept {', '.join(sorted(theirs))} in {target} (not written by "
                 "quadmodes); the new figure(s) of that name were not written")  # fmt: skip
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def guarded(target: Path, what: str, write) -> None:
    """Run ``write()`` (an extra file, :data:`EXTRA_FILES`, into ``target``; then listed in its
    manifest); Ctrl-C raises :class:`OutputsInterrupted` (the data are saved)."""
    try:
        write()
    except KeyboardInterrupt:
        raise OutputsInterrupted(f"stopped while writing {what}; the data are saved in {target}") from None
    record(target, [n for n in EXTRA_FILES if (target / n).is_file()])


def commit(target: Path, data, draw, *, plots: bool, note: Note | None = None,
           partial: Path | None = None, after_data=None, what: str = "run",
           saved: str = ", ".join(DATA_FILES)):  # fmt: skip
    """Write the data (``data(scratch) -> (dataset, summary)``) into a staging folder and move
    them into ``target`` (old figures and extras removed, the data files replaced together),
    drop the ``partial`` folder (and call ``after_data()``), then draw the figures
    (``draw(dataset, folder)``) if ``plots``; ``what`` (an earlier "run") and ``saved`` (the
    data files) word the notes. Ctrl-C while drawing raises :class:`OutputsInterrupted`.
    Returns (dataset, summary)."""
    note = note or log_note
    with staged_output(target, note, beside=True) as scratch:  # in OUT, never in OUT/NAME
        ds, info = data(scratch)
        old_figures = remove_old_figures(target)
        remove_old_extras(target)
    if partial is not None and partial.is_dir():
        with contextlib.suppress(OutputPathError):  # a user's folder of that name stays
            _remove_partial(partial)
    if after_data is not None:
        after_data()
    if old_figures and not plots:
        note(f"note: removed {len(old_figures)} figure(s) of an earlier {what} from {target} "
             f"(--no-plots): {', '.join(old_figures)}")  # fmt: skip
    others = _others(target)
    if others and what == "run":
        note(f"note: {target} also holds files this run did not write: {', '.join(others)}")
    if plots:
        try:
            _draw_staged(draw, ds, target, note)
        except KeyboardInterrupt:
            raise OutputsInterrupted(f"stopped while drawing the figures; the data are saved in "
                                     f"{target} ({saved}); the figures are incomplete") from None  # fmt: skip
    return ds, info


def _run_data(result, extra: dict | None):
    """The ``data`` and ``draw`` of :func:`commit` for a free-body run or a spin-up."""
    from quadmodes.io import plots as figures
    from quadmodes.runs import results

    if hasattr(result, "diagnostics"):
        def draw_run(ds, target: Path):
            from quadmodes.io.run_report import MODEL_PICTURE
            from quadmodes.runs.run_motion import model_picture

            figures.write_plots(ds, target)
            model_picture(result, target / MODEL_PICTURE)
            for name, draw in getattr(result, "figures", ()):  # added by the analyses
                draw(target / name)

        return (lambda scratch: results.write_run_data(result, scratch, extra)), draw_run

    def data(scratch: Path):
        return results.spinup_dataset(result), results.write_spinup_outputs(result, scratch, plots=False)

    def draw(ds, target: Path):
        figures.plot_tip_deflection(ds, target / "tip_deflection.png")

    return data, draw


def write_run_outputs(result, target: Path, *, extra: dict | None = None, plots: bool = True,
                      animation: Animation | None = None, partial: Path | None = None,
                      note: Note | None = None) -> dict:  # fmt: skip
    """Everything ``quadmodes run`` writes for ``result`` (a free-body ``RunResult`` or a
    ``SpinupRun``) into ``target``: the data (``results.nc``, ``summary.json``, with ``extra``
    summary keys) all or nothing, then if ``plots`` the PNG figures, with ``animation`` the
    motion (``motion.xdmf`` + ``motion.h5``), then ``report.html``. ``partial``: the run's
    partial folder, removed once the data are in. Ctrl-C after the data raises
    :class:`OutputsInterrupted`. Returns the summary."""
    from quadmodes.io.animation import write_animation
    from quadmodes.io.run_report import write_run_report
    from quadmodes.runs.run_motion import run_motion

    note = note or log_note
    target = Path(target)
    data, draw = _run_data(result, extra)
    kept = (f"the checkpoint is kept in {partial}: continue with --resume"
            if partial is not None and (partial / "checkpoint.npz").is_file()
            else f"{target} is as it was")  # fmt: skip
    with disk_full_as_error(f"the results into {target}", kept):
        _, summary = commit(target, data, draw, plots=plots, note=note, partial=partial)
    if animation is not None and not hasattr(result, "system"):
        note(f"note: --animate: {result.run.name} is a hub-driven spin-up; no motion file")
    elif animation is not None:
        def motion():
            write_animation(run_motion(result, animation.frames, animation.frame), target, note)

        guarded(target, "motion.xdmf", motion)
    guarded(target, "report.html", lambda: write_run_report(target, summary, result))
    return summary


def execute_in_folders(setup, folders: RunFolders, *, every_s: float, start=None,
                       progress=None, note: Note | None = None):  # fmt: skip
    """Integrate the prepared free-body run ``setup`` checkpointed into ``folders.checkpoint``
    (every ``every_s`` s of wall time; from ``start``, a :func:`resume_point`); returns its
    ``RunResult``. Ctrl-C writes the partial results into the partial folder
    (:func:`save_partial`) and raises :class:`~quadmodes.runs.chunked.Interrupted` with
    ``where``: the sentence saying what was saved where."""
    from quadmodes.runs import simulate
    from quadmodes.runs.chunked import Interrupted
    from quadmodes.runs.run_checkpoint import RunCheckpoint

    checkpoint = RunCheckpoint(folders.checkpoint, setup, every_s)
    kept = (f"the last checkpoint is kept at {folders.checkpoint}: continue with --resume"
            if folders.has_checkpoint else "no checkpoint was saved")  # fmt: skip
    try:
        with disk_full_as_error(f"the checkpoint {folders.checkpoint}", kept):
            return simulate.execute(setup, progress, checkpoint=checkpoint, resume=start)
    except Interrupted as stopped:
        stopped.where = save_partial(stopped.partial, folders, stopped.saved, note)
        raise
