"""The entries of the model cache (:func:`quadmodes.models.cache.cache_dir`): listed and
cleared by ``quadmodes cache list | clear``.

An entry is a file written by :mod:`quadmodes.models.cache` or
:mod:`quadmodes.fullorder.damping`, recognised by its name:

- ``<case>-N<modes>-<key>.nc``: a reduced model with ``modes`` modes;
- ``<case>-spectrum<count>-<key>.json``: the spectrum (lowest ``count`` modes);
- ``<case>-damping-<cutoff>Hz-<key>.nc``: full-order damping modes below ``cutoff`` Hz.

Lock files (``<entry>.lock``) and temporary files of interrupted writes (``.<entry>.*.partial*``)
are listed as ``lock`` and ``partial``. Other files in the folder are neither listed nor removed.
"""

from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass
from pathlib import Path

from quadmodes.io.locking import LOCK_SUFFIX

try:  # POSIX only
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

_KEY = r"[0-9a-f]{16}"
#: (kind, pattern) of the entry names; the pattern's group ``size`` is the mode count or cutoff.
_PATTERNS = (
    ("reduced", re.compile(rf"^(?P<case>.+)-N(?P<size>\d+)-(?P<key>{_KEY})\.nc$")),
    ("spectrum", re.compile(rf"^(?P<case>.+)-spectrum(?P<size>\d+)-(?P<key>{_KEY})\.json$")),
    ("damping", re.compile(rf"^(?P<case>.+)-damping-(?P<size>[0-9pe+-]+)Hz-(?P<key>{_KEY})\.nc$")),
)


@dataclass(frozen=True)
class CacheEntry:
    """One file of the cache: ``kind`` (reduced, spectrum, damping, lock or partial), the
    ``case`` name, ``modes`` (mode count of a reduced model or spectrum, the cutoff "150Hz" of
    damping modes, "" otherwise), ``key`` (content key), ``size_bytes`` and ``age_s`` (seconds
    since it was written)."""

    path: Path
    kind: str
    case: str
    modes: str
    key: str
    size_bytes: int
    age_s: float


def _classify(name: str) -> tuple[str, str, str, str] | None:
    """(kind, case, modes, key) of a cache file name, or None if it is not one of ours."""
    if name.endswith(LOCK_SUFFIX):
        inner = _classify(name.removesuffix(LOCK_SUFFIX))
        return None if inner is None else ("lock", inner[1], inner[2], inner[3])
    if name.startswith(".") and ".partial" in name:
        inner = _classify(name[1:].split(".partial")[0].rsplit(".", 1)[0])
        return None if inner is None else ("partial", inner[1], inner[2], inner[3])
    for kind, pattern in _PATTERNS:
        match = pattern.match(name)
        if match:
            size = match["size"].replace("p", ".")
            modes = f"{size} Hz" if kind == "damping" else size
            return kind, match["case"], modes, match["key"]
    return None


def cache_entries(
    folder: Path, now: float | None = None, *, locks: bool = False
) -> list[CacheEntry]:
    """The cache entries in ``folder`` (none if it does not exist), by case, kind and name;
    lock files only if ``locks``."""
    if not folder.is_dir():
        return []
    now = time.time() if now is None else now
    entries = []
    for path in folder.iterdir():
        found = _classify(path.name) if path.is_file() else None
        if found is None or (found[0] == "lock" and not locks):
            continue
        try:
            stat = path.stat()
        except OSError:
            continue  # removed meanwhile
        entries.append(CacheEntry(path, *found, stat.st_size, max(0.0, now - stat.st_mtime)))
    return sorted(entries, key=lambda e: (e.case, e.kind, e.path.name))


def _lock_is_free(path: Path) -> bool:
    """True if no process holds the lock file ``path`` (or locks are not supported)."""
    if fcntl is None:
        return True
    try:
        fd = os.open(path, os.O_RDWR)
    except OSError:
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except OSError:
        return False
    finally:
        os.close(fd)


def clear_entries(entries: list[CacheEntry]) -> tuple[int, int]:
    """Remove ``entries`` (a lock a running process holds is kept); returns (files removed,
    bytes freed)."""
    removed = freed = 0
    for entry in entries:
        if entry.kind == "lock" and not _lock_is_free(entry.path):
            continue
        try:
            entry.path.unlink()
        except FileNotFoundError:
            continue
        removed += 1
        freed += entry.size_bytes
    return removed, freed


def format_size(size_bytes: int) -> str:
    """``size_bytes`` as "512 B", "41.6 kB", "12.3 MB" or "1.2 GB"."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if size_bytes >= scale:
            return f"{size_bytes / scale:.1f} {unit}"
    return f"{size_bytes} B"


def format_age(age_s: float) -> str:
    """``age_s`` (seconds) as "45 s", "12 min", "3.5 h" or "6 d"."""
    if age_s < 60:
        return f"{age_s:.0f} s"
    if age_s < 3600:
        return f"{age_s / 60:.0f} min"
    if age_s < 86400:
        return f"{age_s / 3600:.1f} h"
    return f"{age_s / 86400:.0f} d"
