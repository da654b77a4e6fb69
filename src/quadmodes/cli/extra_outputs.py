"""The ``--animate`` options of ``run`` and ``compare``: the motion of the whole body as
``motion.xdmf`` + ``motion.h5`` (optionally ``motion.gif``), written after the data and the
figures, before ``report.html`` (:func:`quadmodes.runs.run_folder.write_run_outputs`,
:func:`quadmodes.analysis.comparison_run.write_comparison_outputs`)."""

from __future__ import annotations

from typing import Annotated

import typer

from quadmodes.cli.common import UserError, flag
from quadmodes.cli.completion import choices
from quadmodes.runs.run_folder import Animation

AnimateFlag = flag(
    "--animate",
    "also write the motion of the whole body as motion.xdmf + motion.h5 (ParaView; with "
    "pyvista installed also motion.gif)",
)
AnimateFrame = Annotated[
    str, typer.Option("--animate-frame", help="frame of --animate: inertial | body",
                      autocompletion=choices("inertial", "body"))
]
AnimateFrames = Annotated[
    int, typer.Option("--animate-frames", help="number of frames of --animate (evenly spread)")
]


def animation_choice(animate: bool, frame: str, frames: int) -> Animation | None:
    """The :class:`~quadmodes.runs.run_folder.Animation` of the options (None without
    ``--animate``); UserError for a bad frame or frame count (checked even without
    ``--animate``)."""
    from quadmodes.io.motion import MOTION_FRAMES

    if frame not in MOTION_FRAMES:
        raise UserError(f'--animate-frame: "{frame}" is not a frame; use inertial or body')
    if frames < 2:
        raise UserError(f"--animate-frames: {frames}; needs at least 2 frames, e.g. 100")
    return Animation(frame, frames) if animate else None
