"""The model cache: finds and stores the reduced models and spectra of cases on disk; it builds
nothing (:mod:`quadmodes.models.build` does, and asks it first).

The cache folder is ``$QUADMODES_CACHE`` or the per-user cache folder (platformdirs:
``~/.cache/quadmodes`` on Linux); a reduced model is the file ``<case>-N<modes>-<key>.nc`` where
the key hashes the case TOML, the bytes of its mesh file, the package version, a hash of the
source code that builds the model (:func:`code_fingerprint`), the number of modes and the
artifact format version (:func:`reduced_key`). The spectrum of a case (frequencies and labels of
its lowest modes) is ``<case>-spectrum<count>-<key>.json`` beside it. A build holds a lock on
``<file>.lock`` (:func:`quadmodes.io.locking.file_lock`, in :func:`find_or_build`) so that
parallel runs of one case build it once. The entries are listed and cleared by
:mod:`quadmodes.models.cache_entries`.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import hashlib
import json
import logging
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np

from quadmodes._version import __version__
from quadmodes.case import Case
from quadmodes.io.atomic import write_text
from quadmodes.io.locking import file_lock
from quadmodes.models.cache_entries import entry_name
from quadmodes.rom import artifact
from quadmodes.rom.reduced import ReducedModel

log = logging.getLogger(__name__)

Progress = Callable[[str, float], None]
T = TypeVar("T")

#: Source files (relative to the package) whose code builds a reduced model: a change in any
#: of them changes every cache key (:func:`code_fingerprint`).
MODEL_CODE = ("fe", "structure", "mesh", "linalg", "rom/reduced.py", "rom/spinning_reduction.py",
              "rom/artifact.py", "models/build.py", "models/cache.py")  # fmt: skip

#: False inside :func:`caching_disabled` (``--no-cache``): nothing is read from or saved to
#: the cache.
_CACHING = contextvars.ContextVar("quadmodes_caching", default=True)


def cache_dir() -> Path:
    """Folder of cached reduced models: ``$QUADMODES_CACHE``, else the per-user cache folder
    of platformdirs (``~/.cache/quadmodes`` on Linux, ``$XDG_CACHE_HOME`` honoured), else
    ``~/.cache/quadmodes``."""
    env = os.environ.get("QUADMODES_CACHE")
    if env:
        return Path(env).expanduser()
    try:
        import platformdirs
    except ImportError:  # pragma: no cover - platformdirs is a dependency
        return Path.home() / ".cache" / "quadmodes"
    return Path(platformdirs.user_cache_dir("quadmodes", appauthor=False))


def caching_enabled() -> bool:
    """False inside :func:`caching_disabled`."""
    return _CACHING.get()


@contextlib.contextmanager
def caching_disabled(disabled: bool = True) -> Iterator[None]:
    """Within the block (if ``disabled``), reduced models and spectra are built, never read
    from nor saved to the cache (``--no-cache``)."""
    token = _CACHING.set(not disabled and _CACHING.get())
    try:
        yield
    finally:
        _CACHING.reset(token)


def fingerprint_files(root: Path, entries: tuple[str, ...]) -> str:
    """SHA-256 (hex) of the ``*.py`` files under ``root`` named by ``entries`` (folders or
    files, relative to ``root``): the relative path and bytes of each, in sorted order."""
    files: list[Path] = []
    for entry in entries:
        target = root / entry
        files.extend(sorted(target.rglob("*.py")) if target.is_dir() else [target])
    digest = hashlib.sha256()
    for path in sorted(files):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() if path.is_file() else b"missing")
        digest.update(b"\0")
    return digest.hexdigest()


@functools.cache
def code_fingerprint() -> str:
    """:func:`fingerprint_files` of the package's :data:`MODEL_CODE`, computed once per
    process (a few hundred kB of source)."""
    return fingerprint_files(Path(__file__).resolve().parents[1], MODEL_CODE)


# ---------------------------------------------------------------------------------------------
# keys and file names
# ---------------------------------------------------------------------------------------------


def model_inputs(case: Case) -> str:
    """Everything that determines the structural model of ``case``, as text for a cache key:
    the case in SI (its TOML), for a mesh-file geometry the SHA-256 of the file's bytes (a
    changed mesh under the same file name must not reuse models built from the old one), the
    package version and the :func:`code_fingerprint` (a new version of the code must not reuse
    models built by an old one)."""
    text = case.to_toml()
    text += f"\n# quadmodes version = {__version__}\n# model code sha256 = {code_fingerprint()}\n"
    geometry = getattr(case, "geometry", None)
    mesh_file = getattr(geometry, "file", None)
    if mesh_file:
        from quadmodes.mesh.io import check_mesh_file  # here: keeps the import block as it was

        path = Path(mesh_file)
        check_mesh_file(path)  # a regular file within the size bound, before its bytes are read
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        text += f"\n# geometry.file sha256 = {digest}\n"
    return text


def _axis_line(axis: str | None) -> str:
    """The key line of a spinning reference's axis request (none for the default axis)."""
    return f"# reference_axis = {axis!r}\n" if axis is not None else ""


def reduced_key(case: Case, n_modes: int, spin: float = 0.0, axis: str | None = None) -> str:
    """Content key of the reduced model of ``case`` with ``n_modes`` modes, expanded about the
    state spinning at ``spin`` (rad/s; 0: at rest) about the axis request ``axis`` (None: the
    default) (includes the package version and the artifact format version, so that files of
    another format are not cache hits)."""
    reference = f"# reduced.reference_spin = {float(spin)!r}\n" if spin else ""
    reference += _axis_line(axis) if spin else ""
    return artifact.content_key(
        model_inputs(case)
        + f"\n# reduced.modes = {int(n_modes)}\n"
        + reference
        + f"# artifact.format_version = {artifact.FORMAT_VERSION}\n"
    )


def cache_path(case: Case, n_modes: int, spin: float = 0.0, axis: str | None = None) -> Path:
    """Cache file of the reduced model of ``case`` with ``n_modes`` modes (about ``spin``
    rad/s and ``axis``), named by :func:`~quadmodes.models.cache_entries.entry_name`."""
    name = entry_name("reduced", case.name, n_modes, reduced_key(case, n_modes, spin, axis),
                      spin / (2 * np.pi))  # fmt: skip
    return cache_dir() / name


def spectrum_path(case: Case, count: int, spin: float = 0.0, axis: str | None = None) -> Path:
    """Cache file (JSON) of the spectrum of ``case`` with ``count`` modes (about ``spin``,
    ``axis``)."""
    reference = f"# spectrum reference_spin = {float(spin)!r}\n" if spin else ""
    reference += _axis_line(axis) if spin else ""
    key = artifact.content_key(
        model_inputs(case) + f"\n# spectrum count = {int(count)}\n" + reference
    )
    return cache_dir() / entry_name("spectrum", case.name, count, key, spin / (2 * np.pi))


# ---------------------------------------------------------------------------------------------
# find and store
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Spectrum:
    """The lowest elastic modes of a case (not spinning): ``frequencies_hz`` (K,) ascending,
    ``labels`` (K,). K ≥ the count asked for (a split degenerate set is completed)."""

    frequencies_hz: tuple[float, ...]
    labels: tuple[str, ...]


def find_model(
    case: Case, n_modes: int, path: Path, spin: float = 0.0, axis: str | None = None
) -> tuple[ReducedModel | None, str]:
    """The model in the cache file ``path`` and "hit" if it is there, readable, its arrays match
    their checksum and it matches the key; else None and "miss" (no file) or "rebuilt" (corrupt,
    damaged or mismatching: a foreign file under the entry's name)."""
    if not path.is_file():
        return None, "miss"
    try:
        model = artifact.load_reduced_model(path, require_checksum=True)
    except artifact.ArtifactError:
        return None, "rebuilt"
    key = reduced_key(case, n_modes, spin, axis)
    built_from = model.provenance.get("case_toml", case.to_toml())  # another case's: foreign
    if (model.provenance.get("content_key") == key and model.n_modes == n_modes
            and built_from == case.to_toml()):  # fmt: skip
        return model, "hit"
    return None, "rebuilt"


def store_model(model: ReducedModel, path: Path) -> None:
    """Save ``model`` to the cache file ``path`` (atomically; OSError if the folder is read-only)."""
    artifact.save_reduced_model(model, path)


def find_spectrum(path: Path, count: int) -> tuple[Spectrum | None, str]:
    """The spectrum in the cache file ``path`` and "hit" if it is readable and has ``count``
    modes; else None and "miss" (a corrupt file is computed again)."""
    if not path.is_file():
        return None, "miss"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        freqs = tuple(float(f) for f in data["frequencies_hz"])
        labels = tuple(str(s) for s in data["labels"])
    except (OSError, ValueError, KeyError, TypeError):
        return None, "miss"
    if len(freqs) == len(labels) >= count:
        return Spectrum(freqs, labels), "hit"
    return None, "miss"


def store_spectrum(case: Case, spec: Spectrum, path: Path) -> None:
    """Save the spectrum of ``case`` to the cache file ``path`` (JSON, atomically)."""
    text = json.dumps({"case": case.name, "frequencies_hz": spec.frequencies_hz,
                       "frequencies_hz_units": "Hz", "labels": spec.labels}, indent=1)  # fmt: skip
    write_text(path, text + "\n")


def _waiting_notice(progress: Progress | None, info: dict) -> Callable[[], None]:
    """Called when another process holds the cache lock: noted in ``info["waited"]`` and, with
    a progress callback, shown as the stage "cache lock"."""

    def waiting() -> None:
        info["waited"] = True
        if progress:
            progress("cache lock", 0.0)

    return waiting


def find_or_build(
    path: Path,
    find: Callable[[Path], tuple[T | None, str]],
    build: Callable[[], T],
    store: Callable[[T, Path], None],
    *,
    use_cache: bool = True,
    info: dict | None = None,
    progress: Progress | None = None,
    what: str | None = None,
) -> T:
    """The entry ``path`` of the cache: ``find(path)`` → ``(value or None, state)``, else
    ``build()`` and ``store(value, path)``, under the lock of the file so that parallel
    processes build it once (the second finds the first's file when it gets the lock).
    ``use_cache`` False, or :func:`caching_disabled`, builds without finding or storing.
    ``info`` (optional dict) receives ``cache`` ("hit", "miss", "rebuilt", "off" or "not saved
    (...)") and, while waiting for the lock, ``waited``; ``what`` (e.g. "reduced model of
    paper-membrane (5 modes)") names the entry in log lines (none without it)."""
    info = {} if info is None else info
    if not (use_cache and caching_enabled()):
        info["cache"] = "off"
        return build()
    value, info["cache"] = find(path)
    if value is not None:
        if what:
            log.info("%s: cache hit, %s", what, path)
        return value
    with file_lock(path, _waiting_notice(progress, info)):
        value, state = find(path)  # built meanwhile by another process?
        if value is not None:
            info["cache"] = state
            return value
        start = time.perf_counter()
        value = build()
        took = time.perf_counter() - start
        try:
            store(value, path)
        except OSError as exc:  # a read-only cache is not an error: the run goes on
            info["cache"] = not_saved(path, exc, what)
        else:
            if what:
                log.info("%s built in %.1f s, saved to %s", what, took, path)
    return value


def not_saved(path: Path, exc: OSError, what: str | None = None) -> str:
    """Warn (one log line, shown without ``--verbose``) that the cache entry ``path`` could not
    be written, so the next command builds it again, and say how to fix it; returns the
    ``info["cache"]`` state ``"not saved (reason)"``."""
    reason = exc.strerror or type(exc).__name__
    log.warning("%s not saved to the model cache (%s: %s): the next command builds it again; "
                "set QUADMODES_CACHE to a writable folder", what or "a model", path, reason)  # fmt: skip
    return f"not saved ({reason})"
