"""A comparison with the full order as ``quadmodes compare`` and :func:`quadmodes.compare` run
it: the run's modes resolved once, the full-order run checkpointed as it goes and resumable,
never scored unless it reached the end of the window, then the files of the comparison.

The full-order checkpoint of a comparison written into folder OUT is the hidden file
``OUT/.fullorder-checkpoint.npz`` (:func:`checkpoint_beside`: inside the output folder, never
beside it; one of the earlier layout, ``.OUT.fullorder-checkpoint.npz`` beside OUT, is moved
in: :func:`adopt_legacy_checkpoint`); it is removed once the comparison's data are written. Without ``resume`` an existing checkpoint is discarded only on
request (:func:`check_checkpoint`). A full-order run that stopped early raises
:class:`FullOrderIncomplete` (``interrupted``: Ctrl-C, the checkpoint is kept for a resume).
"""

from __future__ import annotations

import os
import shutil
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path

from quadmodes.errors import QuadmodesError
from quadmodes.io.outputs import disk_full_as_error
from quadmodes.io.staging import Note, log_note
from quadmodes.runs.run_folder import Animation, commit, guarded

#: Full-order steps between two checkpoints (the factorisation is renewed after each, so a
#: resumed run repeats the uninterrupted one only with the same value).
FULL_ORDER_CHECKPOINT_EVERY = 500

Progress = Callable[[str, float], None]


class CheckpointError(QuadmodesError, ValueError):
    """A full-order checkpoint is missing, damaged, or would be discarded unasked."""


class FullOrderIncomplete(RuntimeError):
    """The full-order run did not reach the end of the window, so nothing is scored against
    it. ``interrupted``: stopped by Ctrl-C (its checkpoint, if one was written, continues it);
    ``reason``: the full order's one-line message; ``checkpoint``: the checkpoint path or None."""

    def __init__(self, reason: str, interrupted: bool, checkpoint: Path | None = None):
        super().__init__(f"full order stopped early ({reason}); nothing is scored against it")
        self.reason, self.interrupted, self.checkpoint = reason, interrupted, checkpoint


def complete_or_raise(sol, checkpoint: Path | None = None):
    """``sol`` if the full-order run reached the end of the window, else
    :class:`FullOrderIncomplete` (never scored as a reference)."""
    if sol.status == 0:
        return sol
    message = " ".join(str(sol.message).split())
    raise FullOrderIncomplete(message, message.startswith("interrupted"), checkpoint)


#: The files of a comparison's data; a user's file of one of these names is refused.
COMPARISON_FILES = ("comparison.nc", "comparison.json", "comparison.csv")

#: The name of the full-order checkpoint inside a comparison's output folder.
CHECKPOINT_NAME = ".fullorder-checkpoint.npz"


def checkpoint_beside(target: Path) -> Path:
    """The full-order checkpoint of a comparison written into ``target`` (inside it)."""
    return Path(os.path.abspath(target)) / CHECKPOINT_NAME


def check_comparison_folder(target: Path, option: str = "-o") -> None:
    """Before any work: quadmodes can write ``target`` (no symbolic link, short enough) and
    none of the comparison's files there is a user's own
    (:class:`~quadmodes.io.outputs.OutputPathError`)."""
    from quadmodes.io.outputs import check_output_path, check_replaceable
    from quadmodes.runs.run_folder import EXTRA_FILES

    check_output_path(target, option)
    check_replaceable(target, (*COMPARISON_FILES, *EXTRA_FILES), option)


def check_checkpoint_readable(path: Path, option: str = "--resume", fix: str | None = None) -> None:
    """Raise :class:`CheckpointError` (naming ``option``) if the checkpoint ``path`` (.npz) is
    truncated, not a checkpoint or unreadable; ``fix``: how to start again (default: delete it
    and run again without ``option``)."""
    import numpy as np

    try:
        with np.load(path, allow_pickle=False) as data:
            if "version" not in data.files or "step" not in data.files:
                raise ValueError("not a quadmodes checkpoint")
            int(data["step"])
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as exc:
        raise CheckpointError(
            f"{option}: the checkpoint {path} is damaged (truncated or not a quadmodes "
            f"checkpoint, {type(exc).__name__}); {fix or f'delete it and run again without {option}'}"
        ) from None


def legacy_checkpoint(checkpoint: Path) -> Path:
    """Where versions before 0.2 kept the checkpoint ``OUT/.fullorder-checkpoint.npz``: beside
    the folder, ``.OUT.fullorder-checkpoint.npz`` (``compare -o .`` wrote into the parent)."""
    target = Path(os.path.abspath(checkpoint)).parent
    return target.parent / f".{target.name}.fullorder-checkpoint.npz"


def adopt_legacy_checkpoint(checkpoint: Path, note: Note | None = None) -> None:
    """Move a checkpoint of the earlier layout (:func:`legacy_checkpoint`) to ``checkpoint``
    inside the output folder (created if need be), so that it is resumed as any other (the
    checkpoint's own key still checks that it is this comparison's); one ``note`` line says
    so. Where both exist the one inside is the newer layout's: the old one is named as ignored
    and left as it is."""
    old = legacy_checkpoint(checkpoint)
    if not old.is_file() or old.is_symlink():
        return
    note = note or log_note
    if checkpoint.exists():
        note(f"note: ignored the checkpoint {old} of an earlier version (the one inside the "
             f"output folder, {checkpoint}, is used); delete it when no longer needed")  # fmt: skip
        return
    checkpoint.parent.mkdir(parents=True, exist_ok=True)
    shutil.move(old, checkpoint)
    note(f"note: moved the checkpoint {old} of an earlier version into the output folder, "
         f"{checkpoint}")  # fmt: skip


def check_checkpoint(checkpoint: Path, *, resume: bool, restart: bool,
                     note: Note | None = None) -> Path:  # fmt: skip
    """Before any work: a checkpoint of the earlier layout is moved in first
    (:func:`adopt_legacy_checkpoint`); then ``checkpoint`` must exist and be readable to
    ``resume``; without ``resume`` an existing one is discarded only with ``restart`` (else
    :class:`CheckpointError`). Returns ``checkpoint``."""
    adopt_legacy_checkpoint(checkpoint, note)
    if resume and restart:
        raise CheckpointError("--restart: discards the checkpoint that --resume continues; pass one")
    if resume and not checkpoint.exists():
        raise CheckpointError(f"--resume: no checkpoint at {checkpoint}; run without --resume")
    if resume:
        check_checkpoint_readable(checkpoint, fix="start again with --restart")
    if not resume and checkpoint.exists():
        if not restart:
            raise CheckpointError(
                f"{checkpoint} holds an interrupted full-order run; continue it with --resume, "
                "or pass --restart to discard it"
            )
        checkpoint.unlink()
        (note or log_note)(f"note: discarded {checkpoint} (--restart)")
    return checkpoint


def comparison_output_bytes(setup, window_s: float, n_formulations: int = 5) -> float:
    """A generous estimate (bytes) of what a comparison writes into its folder: the full-order
    checkpoint (x, v and the predictor's body positions, (n,3) float64 each, with its sampled
    series), the comparison files (every formulation's samples) and 5 MB of figures and report."""
    interval, structure = getattr(setup, "sample_interval", None), getattr(setup, "structure", None)
    if interval is None or structure is None:  # not a full-order setup: nothing to estimate
        return 0.0
    samples = window_s / max(float(interval), 1e-12) + 1
    checkpoint = 3 * structure.n * 3 * 8 + samples * 16 * 8
    return 2 * checkpoint + 3 * (n_formulations + 1) * samples * 12 * 8 + 5e6


def check_checkpoint_key(checkpoint: Path, setup, option: str = "--resume") -> None:
    """Before the runs of a resume: raise :class:`CheckpointError` if ``checkpoint`` was
    written for another run case or model than ``setup``'s (the case edited since)."""
    import numpy as np

    from quadmodes.analysis.full_order_runs import checkpoint_key

    with np.load(checkpoint, allow_pickle=False) as data:
        stored = str(data["key"]) if "key" in data.files else ""
    if stored != checkpoint_key(setup):
        raise CheckpointError(
            f"{option}: the checkpoint {checkpoint} was made for another run case or model (the "
            "case was edited since it was written); start again with --restart"
        )


def prepare_comparison(run, window: float, damping_cutoff: float | None = None,
                       progress: Progress | None = None):  # fmt: skip
    """``(run, setup)``: ``run`` cut to ``window`` (s) with its modes resolved (``"auto"`` →
    N, the one :func:`~quadmodes.runs.mode_choice.resolve_modes` of a comparison) and the
    full order's setup (inflation, initial state, damping modes below ``damping_cutoff`` Hz;
    built once for the estimate and the run)."""
    from quadmodes.analysis import compare as cmp
    from quadmodes.analysis.full_order_runs import setup_for_run
    from quadmodes.runs.mode_choice import resolve_modes

    run, _ = resolve_modes(cmp.window_run(run, window), progress=progress)
    return run, setup_for_run(run, damping_cutoff=damping_cutoff)


def prepare_path_comparison(run, window: float, at: str, *, results=None,
                            damping_cutoff=None, progress=None):  # fmt: skip
    """``(run, setup, point)``: the run cut to ``window`` (s) with its modes resolved, the full
    order's setup started at the point ``at`` of its reduced path (read from ``results``, a
    results.nc of the run, if given) and that
    :class:`~quadmodes.analysis.path_point.PathPoint`. A spin-family path
    (:func:`prepare_family_comparison`): the run is its member's at the point."""
    from quadmodes.analysis.path_point import full_order_setup_at, path_point

    if run.reduced.path_model == "spin-family":  # its samples are in the charts of its members
        return prepare_family_comparison(run, window, at, results=results,
                                         damping_cutoff=damping_cutoff, progress=progress)  # fmt: skip
    run_w, setup0 = prepare_comparison(run, window, damping_cutoff, progress)
    point = path_point(run_w, at, model=setup0.model, results=results, progress=progress)
    return run_w, full_order_setup_at(setup0, point), point


def prepare_family_comparison(run, window: float, at: str, *, results=None,
                              damping_cutoff=None, progress=None):  # fmt: skip
    """:func:`prepare_path_comparison` of a spin-family run: the point on the family path
    (:func:`quadmodes.analysis.family_point.family_path_point`, in its member's chart), then
    the run of that member (:func:`quadmodes.runs.family_samples.member_run`: its model from
    the cache entry the path used) cut to ``window``, and the full order's setup of that run
    started at the point."""
    from quadmodes.analysis import compare as cmp
    from quadmodes.analysis.family_point import family_path_point
    from quadmodes.analysis.path_point import full_order_setup_at
    from quadmodes.runs.family_samples import member_run
    from quadmodes.runs.mode_choice import resolve_modes

    run_w, _ = resolve_modes(cmp.window_run(run, window), progress=progress)
    point = family_path_point(run_w, at, results=results, progress=progress)
    run_m, setup0 = prepare_comparison(member_run(run_w, point.member_spin), window,
                                       damping_cutoff, progress)  # fmt: skip
    return run_m, full_order_setup_at(setup0, point), point


def full_order_recorder(animation: Animation | None, setup, window_s: float, dt_s: float):
    """The :class:`~quadmodes.io.animation.FullOrderRecorder` of a comparison's motion (None
    without ``animation``): the expected number of samples from the window, the full-order
    step and the run's sampling interval."""
    if animation is None:
        return None
    from quadmodes.io.animation import FullOrderRecorder

    save_every = max(1, int(round(setup.sample_interval / dt_s)))
    expected = int(round(window_s / dt_s)) // save_every + 1
    return FullOrderRecorder(setup.model, setup.structure, expected, animation.frames)


def run_comparison(run, window: float, *, formulations: Sequence[str] | None = None,
                   full_order_dt: float | None = None, setup=None,
                   damping_cutoff: float | None = None, checkpoint: Path | None = None,
                   resume: bool = False, checkpoint_every: int = FULL_ORDER_CHECKPOINT_EVERY,
                   on_sample=None, progress: Progress | None = None, start=None):  # fmt: skip
    """The reduced runs of ``formulations`` and the full-order run (checkpointed every
    ``checkpoint_every`` steps into ``checkpoint``, continued from it if ``resume``) over
    ``[0, window]`` s (default: all of :data:`quadmodes.analysis.compare.FORMULATIONS`),
    scored: a :class:`quadmodes.analysis.compare.Comparison`. ``setup``: from
    :func:`prepare_comparison` (with ``run`` already cut and resolved), else built here.
    ``on_sample(t, x)``: every full-order sample (e.g. :func:`full_order_recorder`). Raises
    :class:`FullOrderIncomplete` if the full order stopped early (Ctrl-C in a reduced run
    raises KeyboardInterrupt). ``start``: the
    :class:`~quadmodes.analysis.path_point.PathPoint` of a comparison along a reduced path
    (``setup`` from :func:`prepare_path_comparison`)."""
    from quadmodes.analysis import compare as cmp
    from quadmodes.analysis.full_order_runs import full_order_for_run

    if setup is None:
        run, setup = prepare_comparison(run, window, damping_cutoff, progress)
    extra = {"on_sample": on_sample} if on_sample is not None else {}

    def full(r, dt):
        kept = (f"the last checkpoint is kept at {checkpoint}: continue with --resume"
                if checkpoint is not None and checkpoint.is_file() else "no checkpoint was saved")  # fmt: skip
        with disk_full_as_error(f"the full-order checkpoint {checkpoint}", kept):
            return complete_or_raise(full_order_for_run(
                r, dt=dt, progress=progress, setup=setup, checkpoint=checkpoint,
                checkpoint_every=checkpoint_every, resume=resume, **extra,
            ), checkpoint)  # fmt: skip

    names = cmp.FORMULATIONS if formulations is None else tuple(formulations)
    return cmp.compare(run, window, formulations=names, full_order_dt=full_order_dt,
                       full_order=full, progress=progress, start=start)  # fmt: skip


def _model_picture(setup, folder: Path) -> None:
    """The inflated mesh of the full-order ``setup`` (its structure's cells on the reduced
    model's reference positions) as ``model.png`` in ``folder``, for the report; nothing
    without a setup or a membrane."""
    from quadmodes.io.hub_ring import all_triangles, with_image_points
    from quadmodes.io.pictures import plot_mesh_png
    from quadmodes.io.run_report import MODEL_PICTURE

    model = getattr(setup, "model", None)
    structure = getattr(setup, "structure", None)
    if model is None or structure is None:
        return
    tri, lines, e_mat = all_triangles(structure)  # the hub ring's corners: extra points
    n = model.X.shape[0] + len(e_mat)
    if len(tri) and max(tri.max(), lines.max(initial=-1)) < n:
        points = with_image_points(model.X, e_mat)
        plot_mesh_png(folder / MODEL_PICTURE, points, tri, lines=lines if len(lines) else None,
                      title="the model")  # fmt: skip


def write_comparison_outputs(result, target: Path, *, plots: bool = True,
                             setup=None, recorder=None, animation: Animation | None = None,
                             checkpoint: Path | None = None, note: Note | None = None,
                             run=None) -> dict:  # fmt: skip
    """Everything ``quadmodes compare`` writes into ``target``: ``comparison.nc``, ``.json``,
    ``.csv`` all or nothing (the ``checkpoint`` is removed once they are in), then if ``plots``
    the overlay PNGs, the full order's recorded motion (``recorder``, ``animation``) and
    ``report.html`` (of ``run``, default the comparison's) of ``result`` (a
    :class:`quadmodes.analysis.compare.Comparison`). Ctrl-C after the data raises
    :class:`~quadmodes.runs.run_folder.OutputsInterrupted`. Returns the JSON payload."""
    from quadmodes.analysis import compare as cmp
    from quadmodes.io.animation import write_animation
    from quadmodes.io.run_report import write_compare_report

    note = note or log_note
    target = Path(target)

    def data(scratch: Path):
        return None, cmp.write_comparison(result, scratch, plots=False)

    def removed_checkpoint():  # after the data are in, before the figures
        if checkpoint is not None:
            checkpoint.unlink(missing_ok=True)

    kept = (f"the full-order checkpoint is kept at {checkpoint}: continue with --resume"
            if checkpoint is not None and checkpoint.is_file() else f"{target} is as it was")  # fmt: skip
    with disk_full_as_error(f"the comparison into {target}", kept):
        def draw(_, folder: Path):
            cmp.plot_comparison(result, folder)
            _model_picture(setup, folder)

        _, payload = commit(target, data, draw,
                            plots=plots, note=note, what="comparison",
                            saved="comparison.nc, .json, .csv", after_data=removed_checkpoint)  # fmt: skip
    if recorder is not None and recorder.times:
        guarded(target, "motion.xdmf", lambda: write_animation(
            recorder.motion(animation.frame), target, note))  # fmt: skip
    model = getattr(setup, "model", None)
    run = run if run is not None else result.run
    guarded(target, "report.html", lambda: write_compare_report(
        target, payload, run, run.model_case(), model))  # fmt: skip
    return payload
