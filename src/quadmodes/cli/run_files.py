"""What ``run`` and ``compare`` say about their files: the notes on stderr, the exits after an
interruption, the command line that continues with --resume. The files themselves (folders,
checkpoints, partial results, staged data, figures, report) are the library's:
:mod:`quadmodes.runs.run_folder` and :mod:`quadmodes.analysis.comparison_run`.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import typer

from quadmodes.cli.common import UserError, note
from quadmodes.runs.run_folder import RunFolders, run_folders  # noqa: F401 (re-exported)


def check_folders(all_folders: list[RunFolders], *, resume: bool, restart: bool,
                  runs: list = ()) -> None:  # fmt: skip
    """:func:`quadmodes.runs.run_folder.check_folders` (free space for the outputs of ``runs``),
    its notes on stderr."""
    from quadmodes.runs.run_folder import check_folders as check
    from quadmodes.runs.run_folder import output_bytes

    check(all_folders, resume=resume, restart=restart, note=note,
          estimate_bytes=output_bytes(runs))  # fmt: skip


def resume_point(setup, folders: RunFolders, resume: bool):
    """:func:`quadmodes.runs.run_folder.resume_point`, its note on stderr."""
    from quadmodes.runs.run_folder import resume_point as point

    return point(setup, folders, resume, note)


def save_partial(result, folders: RunFolders, saved: bool) -> str:
    """:func:`quadmodes.runs.run_folder.save_partial`, its notes on stderr."""
    from quadmodes.runs.run_folder import save_partial as save

    return save(result, folders, saved, note)


def stop(message: str, code: int) -> typer.Exit:
    """Print ``message`` on stderr and return the exit to raise (status ``code``)."""
    note(message)
    return typer.Exit(code=code)


def stopped_message(all_folders: list[RunFolders], hint: str) -> str:
    """What an interruption outside the integration leaves: the checkpoints to continue."""
    kept = [str(f.partial) for f in all_folders if f.has_checkpoint]
    if kept:
        return f"stopped; checkpoints kept in {', '.join(kept)}: continue with {hint} --resume"
    return "stopped; nothing of the unfinished run was written"


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
