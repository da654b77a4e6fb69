"""What quadmodes owns in an output folder, and the checks of an output path before any work.

Every output folder quadmodes writes holds a manifest, the hidden file :data:`MANIFEST`: the names
(files and folders, one level) it wrote there. Only those are ever replaced or removed (old
figures, the data of an earlier run, ``modes/``); a file of the same name that is not in the
manifest (the user's own) is refused before any work (:func:`check_replaceable`), and is never
deleted. A symbolic link is never followed to write or delete: an output folder that is a link,
or a dangling link on the way to it, is refused (:func:`check_output_path`), as are names too
long for the file system once the partial (``<name>.partial``) and staging
(``.<name>.partial-<pid>-<random>``) suffixes are added, and a file system with less free space
than the estimated output.

Errors are :class:`OutputPathError` (a ValueError): one line naming the option and the fix. A
full disk while writing is :class:`DiskFullError` (an OSError, one line; what was saved before,
e.g. a checkpoint, is kept); NetCDF files are written through :func:`write_netcdf`.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
from collections.abc import Iterable, Iterator
from pathlib import Path

from quadmodes.errors import QuadmodesError
from quadmodes.io.atomic import atomic_path, write_text

#: The manifest of an output folder: the names quadmodes wrote in it (JSON list).
MANIFEST = ".quadmodes-outputs.json"

#: Characters the staging name ``.<name>.partial-<pid>-<random>`` adds to a folder's name
#: (pid up to 7 digits, 8 random characters).
STAGING_EXTRA = len("..partial-") + 7 + 1 + 8

#: Characters the partial folder ``<name>.partial`` adds, with its temporary checkpoint file
#: ``.checkpoint.npz.<random>`` inside counted as the folder's own length.
PARTIAL_EXTRA = len(".partial")


class OutputPathError(QuadmodesError, ValueError):
    """An output path quadmodes will not write (a link, too long, a user's file in the way,
    too little free space); one line naming the option and the fix."""


class DiskFullError(QuadmodesError, OSError):
    """The disk (or quota) filled while writing; one line saying what is kept where."""

    def __init__(self, message: str):
        super().__init__(message)
        self.errno = errno.ENOSPC


@contextlib.contextmanager
def disk_full_as_error(what: str, kept: str) -> Iterator[None]:
    """Inside, an OSError of a full disk (:func:`is_disk_full`) becomes one
    :class:`DiskFullError`: "disk full while writing ``what``; ``kept``; free some space"."""
    try:
        yield
    except DiskFullError:
        raise
    except OSError as exc:
        if not is_disk_full(exc):
            raise
        raise DiskFullError(f"disk full while writing {what}; {kept}; free some space (or "
                            "choose another -o) and run again") from None  # fmt: skip


# ---------------------------------------------------------------------------------------------
# the manifest
# ---------------------------------------------------------------------------------------------


def owned(directory: Path) -> set[str]:
    """The names quadmodes wrote in ``directory`` (empty: no manifest, or unreadable)."""
    path = Path(directory) / MANIFEST
    if path.is_symlink() or not path.is_file():
        return set()
    try:
        names = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    if not isinstance(names, list):
        return set()
    return {n for n in names if isinstance(n, str) and "/" not in n}


def record(directory: Path, names: Iterable[str]) -> None:
    """Add ``names`` to the manifest of ``directory`` (names no longer there are dropped)."""
    directory = Path(directory)
    keep = {n for n in owned(directory) | set(names) if os.path.lexists(directory / n)}
    keep.discard(MANIFEST)
    write_text(directory / MANIFEST, json.dumps(sorted(keep), indent=0) + "\n")


def foreign(directory: Path, names: Iterable[str]) -> list[str]:
    """Those of ``names`` that exist in ``directory`` (links included) and that quadmodes did
    not write there."""
    directory = Path(directory)
    if not directory.is_dir():
        return []
    mine = owned(directory)
    return sorted(n for n in names if os.path.lexists(directory / n) and n not in mine)


def check_replaceable(directory: Path, names: Iterable[str], option: str = "-o") -> None:
    """Raise :class:`OutputPathError` if a file or folder of ``names`` in ``directory`` would be
    replaced but quadmodes did not write it."""
    theirs = foreign(directory, names)
    if theirs:
        raise OutputPathError(
            f"{option}: {Path(directory) / theirs[0]} exists and quadmodes did not write it "
            f"(not in {MANIFEST}); move it away or choose another output folder"
        )


def remove_owned(directory: Path, suffix: str) -> list[str]:
    """Remove the files ending in ``suffix`` that quadmodes wrote in ``directory`` (never a
    link, never a file it did not write); returns their names."""
    directory = Path(directory)
    removed = []
    for name in sorted(owned(directory)):
        path = directory / name
        if name.endswith(suffix) and path.is_file() and not path.is_symlink():
            path.unlink(missing_ok=True)
            removed.append(name)
    return removed


# ---------------------------------------------------------------------------------------------
# the output path
# ---------------------------------------------------------------------------------------------


def _limits(path: Path) -> tuple[int, int]:
    base = nearest_existing(path)
    try:
        return os.pathconf(base, "PC_NAME_MAX"), os.pathconf(base, "PC_PATH_MAX")
    except (OSError, ValueError, AttributeError):
        return 255, 4096


def nearest_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists (a dangling link does not count)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path(path.anchor or ".")


def _check_links(directory: Path, option: str) -> None:
    for part in (directory, *directory.parents):
        if part.is_symlink() and not part.exists():
            raise OutputPathError(
                f"{option}: {part} is a dangling symbolic link (its target {os.readlink(part)} "
                "does not exist); create the target or choose another output folder"
            )
    if directory.is_symlink():
        raise OutputPathError(
            f"{option}: {directory} is a symbolic link; quadmodes writes only into real "
            f"folders: give its target ({directory.resolve()}) or another folder"
        )


def check_output_path(directory: Path, option: str = "-o", *, partial: bool = False,
                      estimate_bytes: float = 0.0) -> None:  # fmt: skip
    """Before any work: raise :class:`OutputPathError` unless quadmodes can write the output
    folder ``directory``: not a symbolic link, no dangling link on its way, its name with the
    staging suffix (and, if ``partial``, the partial folder's) within the file system's limits,
    and at least ``estimate_bytes`` free where it will be written."""
    directory = Path(directory).expanduser().absolute()
    _check_links(directory, option)
    name_max, path_max = _limits(directory)
    extra = STAGING_EXTRA + (PARTIAL_EXTRA if partial else 0)
    longest = max((len(os.fsencode(p)) for p in directory.parts[:-1]), default=0)
    name = len(os.fsencode(directory.name))
    if (max(longest, name + extra) > name_max
            or len(os.fsencode(str(directory))) + extra >= path_max):  # fmt: skip
        raise OutputPathError(
            f"{option}: {directory} is too long for the file system (a folder name up to "
            f"{name_max - extra} characters with the staging and partial folders beside it, a "
            f"path up to {path_max - extra}); use a shorter name or path"
        )
    check_free_space(directory, estimate_bytes, option)


def check_free_space(directory: Path, estimate_bytes: float, option: str = "-o") -> None:
    """Raise :class:`OutputPathError` if the file system of ``directory`` (or its nearest
    existing ancestor) has less than ``estimate_bytes`` free."""
    if not estimate_bytes > 0:
        return
    try:
        free = shutil.disk_usage(nearest_existing(Path(directory).absolute())).free
    except OSError:
        return
    if free < estimate_bytes:
        raise OutputPathError(
            f"{option}: {directory}: about {estimate_bytes / 1e6:.0f} MB of output expected, "
            f"{free / 1e6:.0f} MB free; free some space or choose another output folder"
        )


def is_disk_full(exc: BaseException) -> bool:
    """True for an OSError of a full disk or quota (ENOSPC, EDQUOT), also when h5py or netCDF
    wrap it in another OSError whose message says so."""
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, getattr(errno, "EDQUOT", -1)):
        return True
    text = str(exc).lower()
    return isinstance(exc, OSError) and ("no space left" in text or "disk quota" in text)


def _local_scheduler():
    """A context in which xarray sees no distributed dask scheduler: inside a sweep's worker
    it would take a cluster-wide lock named after the in-memory target, which the scheduler
    does not know (the arrays here are in memory; nothing is computed by dask)."""
    try:
        import dask
    except ImportError:
        return contextlib.nullcontext()
    return dask.config.set(scheduler="sync")


def write_netcdf(ds, path: str | os.PathLike, **options) -> Path:
    """Write the xarray Dataset ``ds`` to ``path`` (NetCDF4 via h5netcdf, ``options`` as for
    ``to_netcdf``) atomically: serialised in memory first, then written with plain file writes,
    so that a full disk is a clean ``OSError`` (ENOSPC) with the temporary file removed, never
    a failure inside the HDF5 library half-way through a file."""
    with _local_scheduler():
        data = ds.to_netcdf(engine="h5netcdf", **options)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(data)
    return Path(path)
