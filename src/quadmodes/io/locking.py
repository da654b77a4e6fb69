"""An advisory lock beside a file, so that parallel processes build a cache entry once.

``with file_lock(path):`` holds an exclusive :func:`fcntl.flock` on ``<path>.lock`` (created when
missing, never removed: removing a lock file another process holds would let a third one in).
The kernel releases the lock when its holder exits, even when it is killed. Where ``flock`` is
not available (Windows, some network file systems) or the lock file cannot be created (a
read-only folder), the block runs without a lock: parallel runs then build twice, which costs
time but is still correct, because every cache file is written atomically under a unique
temporary name (:mod:`quadmodes.io.atomic`).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path

try:  # POSIX only
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

LOCK_SUFFIX = ".lock"


def lock_path(path: str | os.PathLike) -> Path:
    """The lock file of ``path``: ``<path>.lock`` in the same folder."""
    path = Path(path)
    return path.with_name(path.name + LOCK_SUFFIX)


def _open_lock(path: Path) -> int | None:
    """A file descriptor of the lock file of ``path`` (created), or None if that fails."""
    if fcntl is None:
        return None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return os.open(lock_path(path), os.O_RDWR | os.O_CREAT, 0o666)
    except OSError:
        return None


def _acquire(fd: int, waiting: Callable[[], None] | None) -> bool:
    """Take the exclusive lock on ``fd``; ``waiting()`` is called once if another process
    holds it (then this blocks until it is released). False if locking is not supported."""
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except BlockingIOError:
        pass
    except OSError:
        return False  # e.g. a file system without flock
    if waiting is not None:
        waiting()
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        return True
    except OSError:
        return False


@contextlib.contextmanager
def file_lock(
    path: str | os.PathLike, waiting: Callable[[], None] | None = None
) -> Iterator[bool]:
    """Hold an exclusive lock on ``<path>.lock`` for the block; yields True if it is locked,
    False if locking is unavailable here (the block runs anyway). ``waiting()`` is called
    once when another process holds the lock and this one waits for it."""
    fd = _open_lock(Path(path))
    if fd is None:
        yield False
        return
    try:
        locked = _acquire(fd, waiting)
        yield locked
    finally:
        os.close(fd)  # closing the descriptor releases the lock
