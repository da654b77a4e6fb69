"""What ``run`` and ``compare`` write after their data and figures: ``--animate`` (the motion as
``motion.xdmf`` + ``motion.h5``, optionally ``motion.gif``) and the one-page ``report.html``.

Both are written after the data are in place, so an interruption or a failure here never costs
the results; the run's wall time (``wall_s``) counts the integration only.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import typer

from quadmodes.cli.common import UserError, flag
from quadmodes.cli.run_files import note, stop

AnimateFlag = flag(
    "--animate",
    "also write the motion of the whole body as motion.xdmf + motion.h5 (ParaView; with "
    "pyvista installed also motion.gif)",
)
AnimateFrame = Annotated[
    str, typer.Option("--animate-frame", help="frame of --animate: inertial | body")
]
AnimateFrames = Annotated[
    int, typer.Option("--animate-frames", help="number of frames of --animate (evenly spread)")
]


@dataclass(frozen=True)
class Animation:
    """``--animate`` choices: the frame ("inertial" or "body") and the number of frames."""

    frame: str = "inertial"
    frames: int = 100


def animation_choice(animate: bool, frame: str, frames: int) -> Animation | None:
    """The :class:`Animation` of the options (None without ``--animate``); UserError for a bad
    frame or frame count (checked even without ``--animate``)."""
    from quadmodes.io.motion import MOTION_FRAMES

    if frame not in MOTION_FRAMES:
        raise UserError(f'--animate-frame: "{frame}" is not a frame; use inertial or body')
    if frames < 2:
        raise UserError(f"--animate-frames: {frames}; needs at least 2 frames, e.g. 100")
    return Animation(frame, frames) if animate else None


def _guarded(target: Path, what: str, signals: dict, write) -> None:
    """Run ``write()``; Ctrl-C says the data are saved and exits with ``signals["exit"]``."""
    try:
        write()
    except KeyboardInterrupt:
        raise stop(f"stopped while writing {what}; the data are saved in {target}",
                   signals["exit"]) from None  # fmt: skip


def finish_run(result, target: Path, summary: dict, opts) -> dict:
    """``--animate`` files of a free-body run (a spin-up says it has none), then report.html;
    ``opts``: the run's options (``animation``: :class:`Animation` or None, ``signals``).
    Returns ``summary``."""
    from quadmodes.io.animation import write_animation
    from quadmodes.io.run_report import write_run_report
    from quadmodes.runs.run_motion import run_motion

    animation, signals = opts.animation, opts.signals
    if animation is not None and not hasattr(result, "system"):
        note(f"note: --animate: {result.run.name} is a hub-driven spin-up; no motion file")
    elif animation is not None:
        def motion():
            write_animation(run_motion(result, animation.frames, animation.frame), target, note)

        _guarded(target, "motion.xdmf", signals, motion)
    _guarded(target, "report.html", signals, lambda: write_run_report(target, summary, result))
    return summary


def full_order_recorder(animation: Animation | None, setup, window_s: float, dt_s: float):
    """The :class:`~quadmodes.io.animation.FullOrderRecorder` of ``compare --animate`` (None
    without it): the expected number of samples from the window, the full-order step and the
    run's sampling interval."""
    if animation is None:
        return None
    from quadmodes.io.animation import FullOrderRecorder

    save_every = max(1, int(round(setup.sample_interval / dt_s)))
    expected = int(round(window_s / dt_s)) // save_every + 1
    return FullOrderRecorder(setup.model, setup.structure, expected, animation.frames)


def finish_compare(target: Path, payload: dict, plan, setup, recorder, animation,
                   signals: dict) -> None:  # fmt: skip
    """``compare --animate``: the full order's recorded motion; then report.html."""
    from quadmodes.io.animation import write_animation
    from quadmodes.io.run_report import write_compare_report

    if recorder is not None and recorder.times:
        _guarded(target, "motion.xdmf", signals, lambda: write_animation(
            recorder.motion(animation.frame), target, note))  # fmt: skip
    model = getattr(setup, "model", None)
    report = lambda: write_compare_report(target, payload, plan.run, plan.run.model_case(),  # noqa: E731
                                          model)  # fmt: skip
    _guarded(target, "report.html", signals, report)
