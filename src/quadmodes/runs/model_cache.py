"""The reduced model of a case, built once and cached on disk.

Stages::

    Case ──build_reduced_model──▶ ReducedModel ──artifact.save_reduced_model──▶ cache file
    Case ──reduced_model_for──▶ ReducedModel (from the cache file when its content key matches)

The cache folder is ``$QUADMODES_CACHE`` or the per-user cache folder (platformdirs:
``~/.cache/quadmodes`` on Linux); a file is named ``<case>-N<modes>-<key>.nc`` where the key
hashes the case TOML, the bytes of its mesh file, the package version, a hash of the source code
that builds the model (:func:`code_fingerprint`), the number of modes and the artifact format
version (:func:`reduced_key`). A build holds a lock on ``<file>.lock``
(:func:`quadmodes.io.locking.file_lock`) so that parallel runs of one case build it once. The spectrum of a case (frequencies and labels
of its lowest modes, :func:`mode_spectrum`, read by ``modes = "auto"`` and
``--mode-convergence``) is cached beside it as ``<case>-spectrum<count>-<key>.json``.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import functools
import hashlib
import json
import logging
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from quadmodes._version import __version__
from quadmodes.case import Case, CaseError, Modes
from quadmodes.io.atomic import write_text
from quadmodes.io.locking import file_lock
from quadmodes.rom import artifact
from quadmodes.rom import reduced as red
from quadmodes.rom.spinning_reduction import reduce_spinning, spinning_modes
from quadmodes.structure import pipeline
from quadmodes.structure.labels import DEGENERATE_TOLERANCE, PAIR_TOLERANCE

log = logging.getLogger(__name__)

Progress = Callable[[str, float], None]

DEFAULT_MODES = 5


#: Source files (relative to the package) whose code builds a reduced model: a change in any
#: of them changes every cache key (:func:`code_fingerprint`).
MODEL_CODE = ("fe", "structure", "mesh", "linalg", "rom/reduced.py", "rom/artifact.py",
              "runs/model_cache.py")  # fmt: skip

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


def damping_ratio_of(case: Case) -> float:
    """Modal damping ratio of a case (``material.damping_ratio`` or ``beam.damping_ratio``)."""
    return case.damping_ratio


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
        path = Path(mesh_file)
        digest = hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else "missing"
        text += f"\n# geometry.file sha256 = {digest}\n"
    return text


def reduced_key(case: Case, n_modes: int, spin: float = 0.0) -> str:
    """Content key of the reduced model of ``case`` with ``n_modes`` modes, expanded about the
    state spinning at ``spin`` (rad/s; 0: at rest) (includes the package version and the
    artifact format version, so that files of another format are not cache hits)."""
    reference = f"# reduced.reference_spin = {float(spin)!r}\n" if spin else ""
    return artifact.content_key(
        model_inputs(case)
        + f"\n# reduced.modes = {int(n_modes)}\n"
        + reference
        + f"# artifact.format_version = {artifact.FORMAT_VERSION}\n"
    )


def _spin_tag(spin: float) -> str:
    """File-name part of a model or spectrum about the spin ``spin`` (rad/s): "-spin41Hz", or ""
    at rest."""
    return f"-spin{spin / (2 * np.pi):.6g}Hz".replace(".", "p") if spin else ""


def cache_path(case: Case, n_modes: int, spin: float = 0.0) -> Path:
    """Cache file of the reduced model of ``case`` with ``n_modes`` modes (about ``spin``)."""
    tag = _spin_tag(spin)
    return cache_dir() / f"{case.name}-N{int(n_modes)}{tag}-{reduced_key(case, n_modes, spin)}.nc"


def splits_pair(labels, freqs, n_modes: int) -> bool:
    """True if keeping the lowest ``n_modes`` of the modes (labels, frequencies Hz ascending)
    separates two members of a (degenerate) pair: modes ``n_modes`` and ``n_modes + 1`` (1-based)
    have the same label within :data:`PAIR_TOLERANCE`, or any labels within
    :data:`DEGENERATE_TOLERANCE`. False when no mode beyond the cut is known."""
    if not 0 < n_modes < len(freqs):
        return False
    a, b = n_modes - 1, n_modes
    gap = abs(freqs[b] - freqs[a])
    same_label = labels[a] == labels[b] and gap <= PAIR_TOLERANCE * freqs[a]
    return bool(same_label or gap <= DEGENERATE_TOLERANCE * freqs[a])


def _whole_pair_counts(labels, freqs, n_modes: int) -> str:
    """The nearest mode counts below and above ``n_modes`` that keep pairs whole, among the
    ``len(freqs)`` modes known, as "use 4 or 6" (or "use 4" when none above is known)."""
    below = next((m for m in range(n_modes - 1, 0, -1) if not splits_pair(labels, freqs, m)), None)
    above = next((m for m in range(n_modes + 1, len(freqs)) if not splits_pair(labels, freqs, m)), None)
    choices = [str(m) for m in (below, above) if m is not None]
    return f"use {' or '.join(choices)}" if choices else "use fewer modes"


def _check_pair_not_split(labels, freqs, n_modes: int) -> None:
    """Raise :class:`CaseError` if keeping the lowest ``n_modes`` of the modes (labels,
    frequencies Hz, one more than kept) separates two members of a degenerate pair; the message
    suggests the nearest counts that keep pairs whole."""
    if splits_pair(labels, freqs, n_modes):
        a, b = n_modes - 1, n_modes
        raise CaseError(
            f"reduced.modes = {n_modes} splits the pair {labels[a]} / {labels[b]} at "
            f"{freqs[a]:.2f}/{freqs[b]:.2f} Hz (modes {a + 1} and {b + 1}); keep pairs whole: "
            f"{_whole_pair_counts(labels, freqs, n_modes)}",
            field="reduced.modes",
        )


def _provenance(case: Case, modal, n_modes: int, spin: float = 0.0) -> dict:
    """Provenance of the reduced model: case, its TOML, node and mode counts, version, key."""
    return {
        "case": case.name,
        "case_toml": case.to_toml(),
        "n_nodes": int(modal.structure.n),
        "n_modes": n_modes,
        "quadmodes_version": __version__,
        "content_key": reduced_key(case, n_modes, spin),
    }


#: The last modal model built in this process: (case key, ModalModel). A reduced model with
#: more modes of the same case (``run --mode-convergence``, ``modes = "auto"``) reuses its
#: inflated state and, when it has enough modes, its eigen-solution.
_LAST_MODAL: list = []


def modal_model_for(case: Case, count: int, progress: Progress | None = None):
    """:class:`quadmodes.structure.pipeline.ModalModel` of ``case`` with at least ``count``
    elastic modes (when the model has that many). The last one built in this process is
    reused: as it is if it has ``count`` modes, else its inflated state is kept and only the
    modes are computed again (no second inflation)."""
    from quadmodes.structure.labels import label_modes
    from quadmodes.structure.modes import compute_modes

    count = max(int(count), case.modes.count)
    key = model_inputs(case.model_copy(update={"modes": Modes(count=1)}))
    last = _LAST_MODAL[0] if _LAST_MODAL and _LAST_MODAL[0][0] == key else None
    if last is not None and len(last[1].modes.frequencies_hz) >= count:
        return last[1]
    if last is not None:
        old = last[1]
        if progress:
            progress("modes", 0.0)
        modes = compute_modes(old.structure, old.x, count)
        if progress:
            progress("modes", 1.0)
        labels = label_modes(old.structure, old.x, modes.shapes)
        modal = dataclasses.replace(old, modes=modes, labels=labels)
    else:
        work = case.model_copy(update={"modes": Modes(count=count)})
        modal = pipeline.build_modal_model(work, progress)
    _LAST_MODAL[:] = [(key, modal)]
    return modal


def build_reduced_model(
    case: Case, n_modes: int = DEFAULT_MODES, progress: Progress | None = None, spin: float = 0.0
) -> red.ReducedModel:
    """Modal model of ``case`` (:func:`modal_model_for`), its lowest ``n_modes`` elastic modes,
    and :func:`quadmodes.rom.reduced.reduce` with the case's damping ratio and provenance; with
    ``spin`` ≠ 0 (rad/s) the model is expanded about the spinning state instead
    (:func:`_build_spinning`).

    Raises :class:`CaseError` (field ``reduced.modes``) if the model has fewer modes or the cut
    splits a degenerate pair."""
    n_modes = int(n_modes)
    if n_modes < 1:
        raise CaseError(f"reduced.modes = {n_modes}: must be at least 1", field="reduced.modes")
    if spin:
        return _build_spinning(case, n_modes, float(spin), progress)
    modal = modal_model_for(case, n_modes + 2, progress)  # is a pair split? what count is not?
    freqs = np.asarray(modal.modes.frequencies_hz, float)
    labels = list(modal.labels)
    if len(freqs) < n_modes:
        raise CaseError(
            f"reduced.modes = {n_modes}: the model has only {len(freqs)} elastic modes; "
            f"use at most {len(freqs)}",
            field="reduced.modes",
        )
    _check_pair_not_split(labels, freqs, n_modes)
    return red.reduce(
        modal.structure,
        modal.x,
        freqs[:n_modes],
        modal.modes.shapes[:n_modes],
        labels[:n_modes],
        damping_ratio_of(case),
        progress,
        _provenance(case, modal, n_modes),
    )


def _cached_model(
    case: Case, n_modes: int, path: Path, spin: float = 0.0
) -> tuple[red.ReducedModel | None, str]:
    """The model in the cache file ``path`` and "hit" if it is there, readable and matches the
    key; else None and "miss" (no file) or "rebuilt" (corrupt or mismatching)."""
    if not path.is_file():
        return None, "miss"
    try:
        model = artifact.load_reduced_model(path)
    except artifact.ArtifactError:
        return None, "rebuilt"
    key = reduced_key(case, n_modes, spin)
    if model.provenance.get("content_key") == key and model.n_modes == n_modes:
        return model, "hit"
    return None, "rebuilt"


def _waiting_notice(progress: Progress | None, info: dict) -> Callable[[], None]:
    """Called when another process holds the cache lock: noted in ``info["waited"]`` and, with
    a progress callback, shown as the stage "cache lock"."""

    def waiting() -> None:
        info["waited"] = True
        if progress:
            progress("cache lock", 0.0)

    return waiting


def reduced_model_for(
    case: Case,
    n_modes: int = DEFAULT_MODES,
    progress: Progress | None = None,
    *,
    use_cache: bool = True,
    info: dict | None = None,
    spin: float = 0.0,
) -> red.ReducedModel:
    """The reduced model of ``case`` with ``n_modes`` modes, expanded about the state spinning at
    ``spin`` (rad/s; 0: at rest), from the cache if present.

    The cache file is keyed by :func:`reduced_key`; a missing, corrupt or mismatching file is
    (re)built and saved, under the lock of the file, so that parallel processes build it once
    (the second finds the first's file when it gets the lock). ``use_cache`` False, or
    :func:`caching_disabled`, builds without reading or saving. ``info`` (optional dict)
    receives ``cache`` ("hit", "miss", "rebuilt", "off" or "not saved (...)") and ``path``."""
    info = {} if info is None else info
    path = cache_path(case, n_modes, spin)
    info["path"] = str(path)
    if not (use_cache and caching_enabled()):
        info["cache"] = "off"
        return build_reduced_model(case, n_modes, progress, spin)
    model, info["cache"] = _cached_model(case, n_modes, path, spin)
    if model is not None:
        log.info("reduced model of %s (%d modes): cache hit, %s", case.name, n_modes, path)
        return model
    with file_lock(path, _waiting_notice(progress, info)):
        model, state = _cached_model(case, n_modes, path, spin)  # built meanwhile by another?
        if model is not None:
            info["cache"] = state
            return model
        start = time.perf_counter()
        model = build_reduced_model(case, n_modes, progress, spin)
        log.info("reduced model of %s (%d modes) built in %.1f s, saved to %s", case.name,
                 n_modes, time.perf_counter() - start, path)  # fmt: skip
        try:
            artifact.save_reduced_model(model, path)
        except OSError as exc:  # a read-only cache is not an error: the run goes on
            info["cache"] = f"not saved ({exc.strerror or type(exc).__name__})"
    return model


def _build_spinning(case: Case, n_modes: int, spin: float, progress) -> red.ReducedModel:
    """:func:`build_reduced_model` about the centrifugal relative equilibrium at ``spin``
    (rad/s) about the minor principal axis (:mod:`quadmodes.rom.spinning_reduction`)."""
    modal = modal_model_for(case, 1, progress)  # the inflated state at rest
    if progress:
        progress("spinning state", 0.0)
    try:
        eq, modes, labels = spinning_modes(modal.structure, modal.x, n_modes + 1, spin)
    except ValueError as exc:
        raise CaseError(str(exc), field="reduced.reference") from None
    if progress:
        progress("spinning state", 1.0)
    freqs = np.asarray(modes.frequencies_hz, float)
    if len(freqs) < n_modes:
        raise CaseError(f"reduced.modes = {n_modes}: only {len(freqs)} modes found about the "
                        "spinning state; use fewer", field="reduced.modes")  # fmt: skip
    _check_pair_not_split(labels, freqs, n_modes)
    return reduce_spinning(
        modal.structure, modal.x, eq, freqs[:n_modes], modes.shapes[:n_modes], labels[:n_modes],
        damping_ratio_of(case), progress, _provenance(case, modal, n_modes, spin),
    )  # fmt: skip


# ---------------------------------------------------------------------------------------------
# the spectrum of a case: frequencies and labels of its lowest elastic modes, cached as JSON
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Spectrum:
    """The lowest elastic modes of a case (not spinning): ``frequencies_hz`` (K,) ascending,
    ``labels`` (K,). K ≥ the count asked for (a split degenerate set is completed)."""

    frequencies_hz: tuple[float, ...]
    labels: tuple[str, ...]


def spectrum_path(case: Case, count: int, spin: float = 0.0) -> Path:
    """Cache file (JSON) of the spectrum of ``case`` with ``count`` modes (about ``spin``)."""
    reference = f"# spectrum reference_spin = {float(spin)!r}\n" if spin else ""
    key = artifact.content_key(
        model_inputs(case) + f"\n# spectrum count = {int(count)}\n" + reference
    )
    tag = _spin_tag(spin)
    return cache_dir() / f"{case.name}-spectrum{int(count)}{tag}-{key}.json"


def _cached_spectrum(path: Path, count: int) -> Spectrum | None:
    """The spectrum in the cache file ``path`` if it is readable and has ``count`` modes."""
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        freqs = tuple(float(f) for f in data["frequencies_hz"])
        labels = tuple(str(s) for s in data["labels"])
    except (OSError, ValueError, KeyError, TypeError):
        return None  # corrupt: computed again
    return Spectrum(freqs, labels) if len(freqs) == len(labels) >= count else None


def mode_spectrum(
    case: Case, count: int, progress: Progress | None = None, *, use_cache: bool = True,
    spin: float = 0.0,
) -> Spectrum:  # fmt: skip
    """Frequencies (Hz) and labels of the lowest ``max(count, modes.count)`` elastic modes of
    ``case`` — with ``spin`` ≠ 0 (rad/s) those of the rotating-frame stiffness about the
    spinning state (:func:`~quadmodes.rom.spinning_reduction.spinning_modes`) —: from the cache
    file if present, else computed (and saved, under the file's lock as for
    :func:`reduced_model_for`)."""
    count = max(int(count), case.modes.count)
    path = spectrum_path(case, count, spin)
    if not (use_cache and caching_enabled()):
        return _compute_spectrum(case, count, progress, spin)
    cached = _cached_spectrum(path, count)
    if cached is not None:
        return cached
    with file_lock(path, _waiting_notice(progress, {})):
        cached = _cached_spectrum(path, count)
        if cached is not None:
            return cached
        spec = _compute_spectrum(case, count, progress, spin)
        text = json.dumps({"case": case.name, "frequencies_hz": spec.frequencies_hz,
                           "frequencies_hz_units": "Hz", "labels": spec.labels}, indent=1)  # fmt: skip
        try:
            write_text(path, text + "\n")
        except OSError:
            pass  # a read-only cache is not an error
    return spec


def _compute_spectrum(case: Case, count: int, progress, spin: float) -> Spectrum:
    """The spectrum of :func:`mode_spectrum`, computed."""
    if not spin:
        return _spectrum_of(modal_model_for(case, count, progress))
    modal = modal_model_for(case, 1, progress)
    try:
        _, modes, labels = spinning_modes(modal.structure, modal.x, count, spin)
    except ValueError as exc:
        raise CaseError(str(exc), field="reduced.reference") from None
    return Spectrum(tuple(float(f) for f in modes.frequencies_hz), tuple(str(s) for s in labels))


def _spectrum_of(modal) -> Spectrum:
    """The :class:`Spectrum` of a modal model."""
    return Spectrum(
        tuple(float(f) for f in modal.modes.frequencies_hz), tuple(str(s) for s in modal.labels)
    )
