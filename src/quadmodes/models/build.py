"""The reduced model of a case: built from its structure, or found in the model cache.

Stages::

    Case ──modal_model_for──▶ ModalModel (inflated state, modes, labels; the last one of the
                              process reused)
         ──build_reduced_model──▶ ReducedModel (rom.reduced.reduce, or about the spinning
                                   state: rom.spinning_reduction.reduce_spinning)
    Case ──reduced_model_for──▶ ReducedModel (cache.find_or_build: the cache file if it
                                matches, else built and stored)
    Case ──mode_spectrum──▶ Spectrum (frequencies and labels of the lowest modes; cached)
    Case ──case_modes_model──▶ ReducedModel of every mode the case computes (the Campbell
                               diagram's model; not cached)

Every reduced model of a case is built here; :mod:`quadmodes.models.cache` only finds and stores
the files (keys, lock, code hash), and :mod:`quadmodes.models.beam` holds the hub-clamped beam
of a spin-up. A cut of the modes that splits a degenerate pair is refused (:func:`splits_pair`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from quadmodes._version import __version__
from quadmodes.case import Case, CaseError, Modes
from quadmodes.fe.model import inertia_tensor
from quadmodes.limits import REDUCED_MODES, check_count
from quadmodes.models import cache
from quadmodes.models.cache import Spectrum
from quadmodes.rom import reduced as red
from quadmodes.rom.spin_axis import axis_for_inertia
from quadmodes.rom.spinning_reduction import reduce_spinning, spinning_modes
from quadmodes.structure import pipeline
from quadmodes.structure.labels import DEGENERATE_TOLERANCE, PAIR_TOLERANCE

Progress = Callable[[str, float], None]

DEFAULT_MODES = 5

__all__ = [
    "DEFAULT_MODES",
    "Spectrum",
    "build_reduced_model",
    "case_modes_model",
    "damping_ratio_of",
    "labelled",
    "modal_model_for",
    "mode_spectrum",
    "reduced_model_for",
    "reference_spin",
    "splits_pair",
]


def damping_ratio_of(case: Case) -> float:
    """Modal damping ratio of a case (``material.damping_ratio`` or ``beam.damping_ratio``)."""
    return case.damping_ratio


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


def _provenance(case: Case, modal, n_modes: int, spin: float = 0.0,
                axis: str | None = None) -> dict:  # fmt: skip
    """Provenance of the reduced model: case, its TOML, node and mode counts, version, key."""
    return {
        "case": case.name,
        "case_toml": case.to_toml(),
        "n_nodes": int(modal.structure.n),
        "n_modes": n_modes,
        "quadmodes_version": __version__,
        "content_key": cache.reduced_key(case, n_modes, spin, axis),
    }


# ---------------------------------------------------------------------------------------------
# the modal model: inflated state and modes, the last one of the process reused
# ---------------------------------------------------------------------------------------------

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
    key = cache.model_inputs(case.model_copy(update={"modes": Modes(count=1)}))
    last = _LAST_MODAL[0] if _LAST_MODAL and _LAST_MODAL[0][0] == key else None
    if last is not None and len(last[1].modes.frequencies_hz) >= count:
        return last[1]
    if last is not None:
        old = last[1]
        if progress:
            progress("modes", 0.0)
        if old.spinning is not None:  # no modes at rest: those about its spinning state
            modes = pipeline.rotating_frame_modes(old.structure, old.spinning, count)
        else:
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


# ---------------------------------------------------------------------------------------------
# the reduced model
# ---------------------------------------------------------------------------------------------


def build_reduced_model(
    case: Case, n_modes: int = DEFAULT_MODES, progress: Progress | None = None, spin: float = 0.0,
    axis: str | None = None,
) -> red.ReducedModel:  # fmt: skip
    """Modal model of ``case`` (:func:`modal_model_for`), its lowest ``n_modes`` elastic modes,
    and :func:`quadmodes.rom.reduced.reduce` with the case's damping ratio and provenance; with
    ``spin`` ≠ 0 (rad/s) the model is expanded about the spinning state instead
    (:func:`_build_spinning`), about the body axis ``axis`` (a request as
    ``initial.spin_axis``; None: the minor axis).

    Raises :class:`CaseError` (field ``reduced.modes``) if the model has fewer modes or the cut
    splits a degenerate pair."""
    n_modes, spin = int(n_modes), reference_spin(case, spin)
    if n_modes < 1:
        raise CaseError(f"reduced.modes = {n_modes}: must be at least 1", field="reduced.modes")
    if spin:
        return _build_spinning(case, n_modes, float(spin), progress, axis)
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


def reference_spin(case: Case, spin: float = 0.0) -> float:
    """The spin (rad/s) a reduced model of ``case`` is expanded about: ``spin``, or for a
    membrane without stiffness at rest (a ``[spin]`` table) its spin when ``spin`` is 0 (its
    state at rest has no modes: the spinning state is its only reference)."""
    if not spin and getattr(case, "spin", None) is not None:
        return float(case.spin.rate)
    return float(spin)


def _spinning_modes_of(modal, count: int, spin: float, axis: str | None = None):
    """:func:`~quadmodes.rom.spinning_reduction.spinning_modes` of a modal model at ``spin``
    (rad/s): from its state at rest about the axis request ``axis`` (None: the minor axis;
    resolved against the principal axes at rest, :func:`~quadmodes.rom.spin_axis.
    axis_for_inertia`), or continued from its own spinning reference (a membrane without
    stiffness at rest, about its normal)."""
    e = None
    if axis is not None and modal.spinning is None:
        inertia = inertia_tensor(modal.structure, modal.x)
        e = axis_for_inertia(inertia, axis, "initial.spin_axis")
    return spinning_modes(modal.structure, modal.x, count, spin, e, start=modal.spinning)


def _build_spinning(case: Case, n_modes: int, spin: float, progress,
                    axis: str | None = None) -> red.ReducedModel:  # fmt: skip
    """:func:`build_reduced_model` about the centrifugal relative equilibrium at ``spin``
    (rad/s) about the axis request ``axis`` (None: the minor principal axis;
    :mod:`quadmodes.rom.spinning_reduction`)."""
    modal = modal_model_for(case, 1, progress)  # the inflated state at rest
    if progress:
        progress("spinning state", 0.0)
    try:
        eq, modes, labels = _spinning_modes_of(modal, n_modes + 1, spin, axis)
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
        damping_ratio_of(case), progress, _provenance(case, modal, n_modes, spin, axis),
        memo=modal.solved,  # the damping modes at rest: solved once for every spin
    )  # fmt: skip


def labelled(progress: Progress | None, label: str) -> Progress | None:
    """``progress`` with every stage named ``"<label>: <stage>"``, so the lines and bars of a
    command that builds several models say which model each stage belongs to (and a stage of
    the second build is a new stage, not one already at 100 %)."""
    if progress is None:
        return None
    return lambda stage, fraction: progress(f"{label}: {stage}", fraction)


def _spin_label(spin: float) -> str:
    """" about 41 Hz" for a model about a spinning state (``spin`` rad/s), "" at rest."""
    return f" about {spin / (2 * np.pi):.4g} Hz" if spin else ""


def stored_layout(model: red.ReducedModel) -> red.ReducedModel:
    """``model`` with every array C-contiguous, as a cache file gives it back: a model built in
    this process and the same one read from the cache then integrate alike, bit for bit (einsum
    and BLAS sum in an order that depends on the layout; built, G, S2, J2u, Cuu and S1 are
    transposed views, and a spin family's path departed at round-off, 5.6e-16 after 320 s of
    paper-41hz-coarse, between members built at the switch and members built ahead)."""
    changes = {f.name: np.ascontiguousarray(v) for f in dataclasses.fields(model)
               if isinstance(v := getattr(model, f.name), np.ndarray) and not v.flags.c_contiguous}  # fmt: skip
    return dataclasses.replace(model, **changes) if changes else model


def reduced_model_for(
    case: Case,
    n_modes: int = DEFAULT_MODES,
    progress: Progress | None = None,
    *,
    use_cache: bool = True,
    info: dict | None = None,
    spin: float = 0.0,
    axis: str | None = None,
) -> red.ReducedModel:
    """The reduced model of ``case`` with ``n_modes`` modes, expanded about the state spinning at
    ``spin`` (rad/s; 0: at rest) about the axis request ``axis`` (None: the minor axis;
    ``RunCase.reference_axis``): the cache file (:func:`~quadmodes.models.cache.cache_path`)
    if it matches, else :func:`build_reduced_model`, stored (:func:`~quadmodes.models.cache.
    find_or_build`: under the file's lock, a read-only cache is not an error). ``use_cache``
    False, or :func:`~quadmodes.models.cache.caching_disabled`, builds without reading or
    saving. ``info`` (optional dict) receives ``cache`` ("hit", "miss", "rebuilt", "off" or
    "not saved (...)") and ``path``."""
    check_count(REDUCED_MODES, n_modes, "n_modes (reduced.modes)", "use fewer modes")
    info, spin = ({} if info is None else info), reference_spin(case, spin)
    axis = axis if spin and getattr(case, "spin", None) is None else None  # else unused
    path = cache.cache_path(case, n_modes, spin, axis)
    info["path"] = str(path)
    return cache.find_or_build(
        path,
        lambda p: cache.find_model(case, n_modes, p, spin, axis),
        lambda: stored_layout(build_reduced_model(
            case, n_modes, labelled(progress, f"{case.name} N={n_modes}{_spin_label(spin)}"),
            spin, axis,
        )),
        cache.store_model,
        use_cache=use_cache, info=info, progress=progress,
        what=f"reduced model of {case.name} ({n_modes} modes)",
    )  # fmt: skip


def case_modes_model(case: Case, progress: Progress | None = None) -> red.ReducedModel:
    """Reduced model of every mode ``case`` computes (``modes.count``), with its damping ratio,
    built afresh (not cached; the Campbell diagram's model; a membrane without stiffness at
    rest: about its spinning state at ``spin.rate``); the degenerate y/z pairs of a
    straight beam are split into pure planes (:func:`quadmodes.models.beam.split_planes`)."""
    from quadmodes.models.beam import split_planes
    from quadmodes.structure.labels import label_modes

    mm = pipeline.build_modal_model(case, progress)
    shapes, labels = mm.modes.shapes, list(mm.labels)
    if mm.spinning is not None:  # no modes at rest: expanded about its spinning state
        return reduce_spinning(mm.structure, mm.x, mm.spinning, mm.modes.frequencies_hz, shapes,
                               labels, damping_ratio_of(case), progress, {"case": case.name})  # fmt: skip
    if case.kind == "beam":
        shapes, _, _ = split_planes(mm.structure, mm.modes.frequencies_hz, shapes)
        labels = label_modes(mm.structure, mm.x, shapes)
    return red.reduce(
        mm.structure,
        mm.x,
        mm.modes.frequencies_hz,
        shapes,
        labels,
        damping_ratio_of(case),
        progress=progress,
        provenance={"case": case.name},
    )


# ---------------------------------------------------------------------------------------------
# the spectrum of a case: frequencies and labels of its lowest elastic modes, cached as JSON
# ---------------------------------------------------------------------------------------------


def mode_spectrum(
    case: Case, count: int, progress: Progress | None = None, *, use_cache: bool = True,
    spin: float = 0.0, axis: str | None = None,
) -> Spectrum:  # fmt: skip
    """Frequencies (Hz) and labels of the lowest ``max(count, modes.count)`` elastic modes of
    ``case`` — with ``spin`` ≠ 0 (rad/s) those of the rotating-frame stiffness about the
    spinning state (:func:`~quadmodes.rom.spinning_reduction.spinning_modes`) —: from the cache
    file if present, else computed (and saved, under the file's lock as for
    :func:`reduced_model_for`)."""
    count, spin = max(int(count), case.modes.count), reference_spin(case, spin)
    axis = axis if spin and getattr(case, "spin", None) is None else None  # else unused
    return cache.find_or_build(
        cache.spectrum_path(case, count, spin, axis),
        lambda p: cache.find_spectrum(p, count),
        lambda: _compute_spectrum(
            case, count, labelled(progress, f"{case.name} spectrum{_spin_label(spin)}"), spin,
            axis,
        ),
        lambda spec, p: cache.store_spectrum(case, spec, p),
        use_cache=use_cache, progress=progress,
    )  # fmt: skip


def _compute_spectrum(case: Case, count: int, progress, spin: float,
                      axis: str | None = None) -> Spectrum:  # fmt: skip
    """The spectrum of :func:`mode_spectrum`, computed."""
    if not spin:
        return _spectrum_of(modal_model_for(case, count, progress))
    modal = modal_model_for(case, 1, progress)
    try:
        _, modes, labels = _spinning_modes_of(modal, count, spin, axis)
    except ValueError as exc:
        raise CaseError(str(exc), field="reduced.reference") from None
    return Spectrum(tuple(float(f) for f in modes.frequencies_hz), tuple(str(s) for s in labels))


def _spectrum_of(modal) -> Spectrum:
    """The :class:`Spectrum` of a modal model."""
    return Spectrum(
        tuple(float(f) for f in modal.modes.frequencies_hz), tuple(str(s) for s in modal.labels)
    )
