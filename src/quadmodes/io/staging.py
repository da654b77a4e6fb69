"""All-or-nothing output folders: files are written into a hidden scratch folder
``.<name>.partial-<pid>-…/`` inside the output folder (beside it for a run's folder OUT/NAME,
whose parent OUT is the folder the user named) and moved in only when complete, with
Ctrl-C and SIGTERM held during the few renames; scratch folders of processes that no longer
run (killed while writing) are removed at the next start.

``note(text)`` callbacks receive one-line notes (the command line prints them on stderr); by
default they go to the module's logger.
"""

from __future__ import annotations

import contextlib
import glob
import logging
import os
import shutil
import signal
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from quadmodes.io.outputs import OutputPathError, check_replaceable, record

log = logging.getLogger(__name__)

#: ``note(text)``: a one-line note for the user.
Note = Callable[[str], None]


def log_note(text: str) -> None:
    """The default ``note``: the text on the module's logger (level INFO)."""
    log.info("%s", text)


def _staging_owner(folder: Path, prefix: str) -> int | None:
    """The process id in the name of staging folder ``folder`` (``<prefix><pid>-<random>``)."""
    head = folder.name[len(prefix):].partition("-")[0]
    return int(head) if head.isdigit() else None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. another user's process
        return True
    return True


def clean_stale_staging(directory: Path, note: Note | None = None) -> list[Path]:
    """Remove the hidden staging folders ``.<name>.partial-<pid>-…/`` inside or beside
    ``directory`` left by a process that no longer runs (e.g. killed while writing); returns
    those removed (a ``note`` names each)."""
    note = note or log_note
    directory = Path(os.path.abspath(directory))
    prefix = f".{directory.name}.partial-"
    removed = []
    places = [d for d in (directory.parent, directory) if d.is_dir() and not d.is_symlink()]
    for folder in sorted(f for d in places for f in d.glob(f"{glob.escape(prefix)}*")):
        pid = _staging_owner(folder, prefix)
        if not folder.is_dir() or (pid is not None and pid != os.getpid() and _alive(pid)):
            continue
        shutil.rmtree(folder, ignore_errors=True)
        removed.append(folder)
        note(f"note: removed the left-over staging folder {folder} (an earlier run stopped "
             "while writing)")  # fmt: skip
    return removed


@contextlib.contextmanager
def staged_output(directory: Path | None, note: Note | None = None,
                  announce: bool = True, *, beside: bool = False) -> Iterator[Path | None]:
    """Write into a hidden scratch folder ``.<name>.partial-<pid>-…/`` inside ``directory``
    (created if need be; with ``beside``, next to it: a run's folder OUT/NAME stages in OUT, so
    that an interrupted rerun never writes into OUT/NAME), never in a folder the user did not
    name (``-o .`` stages in the current folder, not its parent); move the files in only on
    success and list them in its manifest
    (:mod:`quadmodes.io.outputs`). Left-over scratch folders of dead processes are removed
    first (:func:`clean_stale_staging`). A ``directory`` that is a symbolic link, or a file
    in it that quadmodes did not write and a new file would replace, raises
    :class:`~quadmodes.io.outputs.OutputPathError` (nothing is moved). Files of an earlier
    result that are replaced are named in a ``note`` (unless not ``announce``)."""
    if directory is None:
        yield None
        return
    directory = Path(os.path.abspath(directory))
    if directory.is_symlink():  # never written through: the link's target is not ours
        raise OutputPathError(f"{directory} is a symbolic link; quadmodes writes only into real "
                              "folders: give its target or another folder")  # fmt: skip
    created = [p for p in (directory, *directory.parents) if not p.exists()]  # deepest first
    if beside:
        created = created[1:] if created and created[0] == directory else created
    (directory.parent if beside else directory).mkdir(parents=True, exist_ok=True)
    clean_stale_staging(directory, note)
    prefix = f".{directory.name}.partial-{os.getpid()}-"
    scratch = Path(tempfile.mkdtemp(prefix=prefix, dir=directory.parent if beside else directory))
    done = False
    try:
        yield scratch
        names = sorted(item.name for item in scratch.iterdir())
        check_replaceable(directory, names)  # a user's file of the same name: refused, kept
        replaced = [name for name in names if (directory / name).exists()]
        with deferred_interrupts():  # never half the new files beside half the old ones
            directory.mkdir(exist_ok=True)
            for name in names:
                target = directory / name
                if target.is_dir() and not target.is_symlink():
                    shutil.rmtree(target)
                (scratch / name).replace(target)
            record(directory, names)
            done = True
        if replaced and announce:  # never silently: the earlier result (quadmodes's own) is gone
            (note or log_note)(f"note: replaced the earlier {', '.join(replaced)} in {directory}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
        if not done:  # a failed run leaves no folders behind: remove the parents it made
            for folder in created:
                with contextlib.suppress(OSError):
                    folder.rmdir()


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Inside, Ctrl-C and SIGTERM are held and delivered at the end (a few renames that must not
    be cut in half). Outside the main thread nothing is held."""
    held: list[int] = []

    def hold(signum, frame):
        held.append(signum)

    try:
        previous = {s: signal.signal(s, hold) for s in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if held:
            signal.raise_signal(held[0])
