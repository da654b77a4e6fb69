"""The full order's modal damping basis: which modes the damping force ``f_d = W C Wᵀ v``
(:func:`~quadmodes.fullorder.step.damping_force`, ``W = Π M 𝒬 Φ_d``) acts on.

Two choices:

* **independent** (the reference): every prestressed FE mode of the structure (free-free, or
  clamped for a hub-driven beam) below a cutoff frequency, with the case's damping ratio ζ and
  ``C = diag(2ζω)`` — the definition the reduced model uses on its retained modes
  (:func:`quadmodes.rom.reduced.reduce`). It does not depend on the reduced basis, and it sees
  dissipation in modes the reduced model leaves out. Degenerate pairs at the cutoff are kept
  whole. The modes are computed once per (model case, cutoff) and cached beside the reduced
  models (:func:`independent_damping_for`).
* **retained** (a baseline, the old reference): the reduced model's own modes Φ and C
  (:func:`retained_damping`).

SI units; shapes ``(K, n, 3)`` mass-normalised (``φᵀ M φ = 1``, 1/√kg).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.case import Case
from quadmodes.fe.model import Structure
from quadmodes.io import cf
from quadmodes.io.outputs import write_netcdf
from quadmodes.models import cache
from quadmodes.models.cache_entries import entry_name
from quadmodes.rom import artifact
from quadmodes.rom.reduced import ReducedModel
from quadmodes.structure.damping import CUTOFF_FACTOR, default_cutoff, modes_below, pairs_whole

#: Format version of the cached damping-mode files.
DAMPING_FORMAT_VERSION = 1
#: Damping choices of the full order (``False``/``"none"``: undamped).
CHOICES = ("independent", "retained", "none")


@dataclass(frozen=True, eq=False)
class DampingModes:
    """The modes the full-order damping force acts on.

    frequencies_hz (K,) Hz; shapes (K,n,3) 1/√kg mass-normalised; C (K,K) 1/s the modal damping
    matrix (``diag 2ζω`` for the independent basis); source "independent" or "retained";
    cutoff_hz Hz (NaN for "retained"); damping_ratio (K,) ζ; state: the modes' state, "rest"
    or "spinning" (a structure without stiffness at rest)."""

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    C: np.ndarray
    damping_ratio: np.ndarray
    source: str
    cutoff_hz: float = float("nan")
    state: str = "rest"

    @property
    def n_modes(self) -> int:
        return int(self.shapes.shape[0])

    def describe(self) -> str:
        """One line naming the damping basis (for notes and output attributes)."""
        zeta = f"ζ = {self.damping_ratio.max():.3g}" if self.n_modes else "no modes"
        top = f", up to {self.frequencies_hz.max():.1f} Hz" if self.n_modes else ""
        if self.source == "retained":
            return f"full-order damping: the reduced model's {self.n_modes} retained modes ({zeta})"
        where = "" if self.state == "rest" else f" of the {self.state} state"
        return (
            f"full-order damping: independent, {self.n_modes} FE modes{where} below the cutoff "
            f"{self.cutoff_hz:.4g} Hz{top} ({zeta})"
        )


def modal_damping(
    frequencies_hz: np.ndarray, shapes: np.ndarray, zeta: float, source: str, cutoff_hz: float
) -> DampingModes:
    """:class:`DampingModes` with ``C = diag(2ζω)`` (ω = 2π f rad/s, unit modal masses)."""
    f = np.asarray(frequencies_hz, float)
    z = np.full(f.shape, float(zeta))
    return DampingModes(f, np.asarray(shapes, float), np.diag(2.0 * z * 2.0 * np.pi * f), z,
                        source, float(cutoff_hz))  # fmt: skip


def retained_damping(model: ReducedModel) -> DampingModes:
    """The reduced model's own modal damping (Φ, C): the old reference, a baseline."""
    return DampingModes(
        np.asarray(model.frequencies_hz, float), np.asarray(model.Phi, float),
        np.asarray(model.C, float), np.asarray(model.damping_ratio, float), "retained",
    )  # fmt: skip








def damping_key(case: Case, cutoff_hz: float, state: str = "rest") -> str:
    """Content key of the damping modes of ``case`` below ``cutoff_hz`` (Hz) about ``state``
    ("rest", or "spinning <Ω rad/s>" for a structure without stiffness at rest)."""
    where = "" if state == "rest" else f"# damping.state = {state}\n"
    return artifact.content_key(
        cache.model_inputs(case)
        + f"\n# damping.cutoff_hz = {float(cutoff_hz)!r}\n"
        + f"# damping.format_version = {DAMPING_FORMAT_VERSION}\n"
        + where
    )


def damping_cache_path(case: Case, cutoff_hz: float, state: str = "rest") -> Path:
    """Cache file of the damping modes, beside the reduced models
    (:func:`~quadmodes.models.cache.cache_dir`)."""
    name = entry_name("damping", case.name, cutoff_hz, damping_key(case, cutoff_hz, state))
    return cache.cache_dir() / name


def save_damping_modes(path: Path, freqs, shapes, labels, cutoff_hz: float, key: str) -> None:
    """Write the damping modes to ``path`` (NetCDF, atomically), with units and descriptions."""
    ds = xr.Dataset(
        {
            "frequency": xr.Variable(("mode",), np.asarray(freqs, float), {
                "units": "Hz", "long_name": "prestressed natural frequency of the damped mode"}),
            "shape": xr.Variable(("mode", "node", "component"), np.asarray(shapes, float), {
                "units": "1", "long_name": "mode shape (modal mass 1 kg)",
                "mass_normalised_units": "kg^-0.5"}),
            "label": xr.Variable(("mode",), np.asarray(list(labels), dtype=str), {
                "units": "1", "long_name": "mode label"}),
        },
        attrs={"cutoff_hz": float(cutoff_hz), "content_key": key,
               "format_version": DAMPING_FORMAT_VERSION,
               "title": "full-order independent damping modes below the cutoff",
               "Conventions": cf.CONVENTIONS, "modal_normalisation": cf.MODAL_NORMALISATION},
    )  # fmt: skip
    write_netcdf(ds, path, encoding=cf.encoding(ds))  # in memory first: a full disk is a clean OSError


def load_damping_modes(path: Path, key: str, n: int):
    """``(freqs, shapes)`` of a cache file, or None if it is missing, unreadable or stale."""
    if not path.is_file():
        return None
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            if ds.attrs.get("content_key") != key or ds["shape"].shape[1:] != (n, 3):
                return None
            return ds["frequency"].values.copy(), ds["shape"].values.copy()
    except (OSError, ValueError, KeyError):
        return None


def independent_damping_for(
    case: Case, structure: Structure, x: np.ndarray, cutoff_hz: float, zeta: float,
    *, use_cache: bool = True, info: dict | None = None, state: str = "rest",
) -> DampingModes:  # fmt: skip
    """The independent damping basis of ``case`` (its ``structure`` about ``x``, gas law
    included when the case has one): every mode below ``cutoff_hz`` (Hz, pairs whole) with
    ``C = diag(2ζω)``. From the cache when present (``info["cache"]``: hit, miss or off).
    ``state`` names ``x`` in the cache key ("rest", or "spinning …":
    :func:`~quadmodes.structure.damping.damping_state`)."""
    if not (cutoff_hz > 0 and math.isfinite(cutoff_hz)):
        raise ValueError(f"damping cutoff: {cutoff_hz!r} Hz; give a positive frequency, e.g. 150 Hz")
    info = {} if info is None else info
    use_cache = use_cache and cache.caching_enabled()  # --no-cache
    key, path = damping_key(case, cutoff_hz, state), damping_cache_path(case, cutoff_hz, state)
    info["path"], info["cache"] = str(path), "miss" if use_cache else "off"
    got = load_damping_modes(path, key, structure.n) if use_cache else None
    if got is not None:
        info["cache"] = "hit"
        freqs, shapes = got
    else:
        freqs, shapes, labels = modes_below(structure, x, cutoff_hz)
        if use_cache:
            try:
                save_damping_modes(path, freqs, shapes, labels, cutoff_hz, key)
            except OSError as exc:  # a read-only cache is not an error
                info["cache"] = cache.not_saved(path, exc, "the full order's damping modes")
    out = modal_damping(freqs, shapes, zeta, "independent", cutoff_hz)
    return replace(out, state=state.split()[0])


__all__ = [
    "CHOICES",
    "CUTOFF_FACTOR",
    "DampingModes",
    "default_cutoff",
    "independent_damping_for",
    "modal_damping",
    "modes_below",
    "pairs_whole",
    "retained_damping",
]
