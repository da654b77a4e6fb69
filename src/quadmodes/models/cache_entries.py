"""The entries of the model cache (:func:`quadmodes.models.cache.cache_dir`): listed and
cleared by ``quadmodes cache list | clear``.

An entry is a file written by :mod:`quadmodes.models.cache` or
:mod:`quadmodes.fullorder.damping`, recognised by its name. This module is the one home of the
naming scheme: the writers name their files with :func:`entry_name` and the listing parses them
with the same table (:data:`_FORMATS`), so every file the cache writes is listed:

- ``<case>-N<modes>[-spin<f>Hz]-<key>.nc``: a reduced model with ``modes`` modes (about the
  state spinning at f Hz, "." written "p");
- ``<case>-spectrum<count>[-spin<f>Hz]-<key>.json``: the spectrum (lowest ``count`` modes);
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
_NUMBER = r"[0-9pe+-]+"  # a "%.6g" number with "." written "p"
_SPIN = rf"(?:-spin(?P<spin>{_NUMBER})Hz)?"
#: kind -> (name format, pattern): ``size`` is the mode count or the damping cutoff (Hz),
#: ``spin`` the optional reference spin tag.
_FORMATS = {
    "reduced": ("{case}-N{size}{spin}-{key}.nc",
                rf"^(?P<case>.+)-N(?P<size>\d+){_SPIN}-(?P<key>{_KEY})\.nc$"),
    "spectrum": ("{case}-spectrum{size}{spin}-{key}.json",
                 rf"^(?P<case>.+)-spectrum(?P<size>\d+){_SPIN}-(?P<key>{_KEY})\.json$"),
    "damping": ("{case}-damping-{size}Hz-{key}.nc",
                rf"^(?P<case>.+)-damping-(?P<size>{_NUMBER})Hz-(?P<key>{_KEY})\.nc$"),
}  # fmt: skip
_PATTERNS = tuple((kind, re.compile(pattern)) for kind, (_, pattern) in _FORMATS.items())


def _number_tag(value: float) -> str:
    """A file-name number: "%.6g" with "." written "p" (41.5 → "41p5")."""
    return f"{float(value):.6g}".replace(".", "p")


def entry_name(kind: str, case: str, size: float, key: str, spin_hz: float = 0.0) -> str:
    """File name of a cache entry of ``kind`` ("reduced", "spectrum", "damping") for the case
    named ``case``: ``size`` the mode count (reduced, spectrum) or the cutoff in Hz (damping),
    ``key`` its 16-hex-digit content key, ``spin_hz`` (Hz) the reference spin of a model or
    spectrum about a spinning state (0: at rest, no tag)."""
    fmt = _FORMATS[kind][0]
    size_text = _number_tag(size) if kind == "damping" else str(int(size))
    spin = f"-spin{_number_tag(spin_hz)}Hz" if spin_hz and kind != "damping" else ""
    return fmt.format(case=case, size=size_text, spin=spin, key=key)


@dataclass(frozen=True)
class CacheEntry:
    """One file of the cache: ``kind`` (reduced, spectrum, damping, lock or partial), the
    ``case`` name, ``modes`` (mode count of a reduced model or spectrum, the cutoff "150Hz" of
    damping modes, "" otherwise), ``key`` (content key), ``size_bytes``, ``age_s`` (seconds
    since it was written) and ``spin`` (the reference spin of a model or spectrum about a
    spinning state, "41 Hz"; "" at rest)."""

    path: Path
    kind: str
    case: str
    modes: str
    key: str
    size_bytes: int
    age_s: float
    spin: str = ""


def _classify(name: str) -> tuple[str, str, str, str, str] | None:
    """(kind, case, modes, key, spin) of a cache file name, or None if it is not one of ours."""
    if name.endswith(LOCK_SUFFIX):
        inner = _classify(name.removesuffix(LOCK_SUFFIX))
        return None if inner is None else ("lock", *inner[1:])
    if name.startswith(".") and ".partial" in name:
        inner = _classify(name[1:].split(".partial")[0].rsplit(".", 1)[0])
        return None if inner is None else ("partial", *inner[1:])
    for kind, pattern in _PATTERNS:
        match = pattern.match(name)
        if match:
            size = match["size"].replace("p", ".")
            modes = f"{size} Hz" if kind == "damping" else size
            spin = match.groupdict().get("spin")
            spin = f"{spin.replace('p', '.')} Hz" if spin else ""
            return kind, match["case"], modes, match["key"], spin
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
        kind, case, modes, key, spin = found
        entries.append(CacheEntry(path, kind, case, modes, key, stat.st_size,
                                  max(0.0, now - stat.st_mtime), spin))  # fmt: skip
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
