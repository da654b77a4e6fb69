"""The reduced-model artifact: one self-describing NetCDF file (xarray + h5netcdf).

Every array of :class:`quadmodes.rom.reduced.ReducedModel` is a variable with ``units`` and
``long_name`` attributes; provenance (case TOML, package version, mesh size, content key) is
kept in global attributes. Files are written atomically and checked on load.

Format 2 adds the manifold-potential tensors V3, V4 and the global attribute
``manifold_potential`` (1 if they were computed). Format-1 files still load, with V3 = V4 = 0
and ``manifold_potential = False``: formulations Q, P, L and rigid are unchanged, "Q4" refuses
such a model (rebuild it with ``quadmodes reduce``). Format 3 adds the linear potential
coefficient F1, the reference spin axis and the attribute ``reference_spin_rad_s`` of a model
expanded about a spinning state; older files load as models about the state at rest (F1 = 0).

Every file written carries ``arrays_sha256``: the SHA-256 of its arrays, labels and content key
(:func:`arrays_checksum`); a file whose arrays do not match it (flipped bits, an edited key) is
refused on load (:class:`ArtifactError`), so the model cache rebuilds the entry. Files written
before the checksum load unchecked.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes._version import __version__
from quadmodes.errors import QuadmodesError
from quadmodes.io import cf
from quadmodes.io.outputs import write_netcdf
from quadmodes.rom.reduced import ReducedModel

FORMAT = "quadmodes-reduced-model"
FORMAT_VERSION = 3
READABLE_VERSIONS = (1, 2, 3)
_V2_VARIABLES = ("V3", "V4")  # absent from format-1 files
_V3_VARIABLES = ("F1", "reference_axis")  # absent from format-1 and -2 files


class ArtifactError(QuadmodesError, ValueError):
    """A reduced-model file that cannot be used; one-line message naming the file and the fix."""


# name -> (dims, units, long_name, mass-normalised units). ``units`` are UDUNITS-2 and pint
# alike, for modes normalised to a modal mass of 1 kg (phi dimensionless; quadmodes.io.cf); the
# fourth entry, when given, is the unit of the same number for phi^T M phi = 1 (phi in kg^-0.5,
# s in kg^0.5 m: the units of the code), stored as ``mass_normalised_units``.
_VARIABLES: dict[str, tuple[tuple[str, ...], str, str, str]] = {
    "frequencies_hz": (("mode",), "Hz", "natural frequencies of the retained modes", ""),
    "damping_ratio": (("mode",), "1", "modal damping ratio", ""),
    "J0": (("xyz", "xyz2"), "kg m^2", "reference inertia J(X, X) about the origin of X", ""),
    "J1": (("mode", "xyz", "xyz2"), "kg m", "2 J(X, u^k): first-order inertia", "kg^0.5 m"),
    "J2u": (("mode", "mode2", "xyz", "xyz2"), "kg", "J(u^m, u^n): spin softening", "1"),
    "J2g": (("mode", "mode2", "xyz", "xyz2"), "kg", "2 J(X, g^mn): spin stiffening", "1"),
    "c": (("mode", "xyz"), "kg m", "C(X, u^k): rigid-elastic coupling", "kg^0.5 m"),
    "Cuu": (("mode", "mode2", "xyz"), "kg", "C(u^m, u^n): gyroscopic coupling", "1"),
    "Cxg": (("mode", "mode2", "xyz"), "kg", "C(X, g^mn)", "1"),
    "S1": (("mode", "xyz"), "kg", "sum_j w_j u^k_j (centre-of-mass check)", "kg^0.5"),
    "S2": (("mode", "mode2", "xyz"), "kg/m", "sum_j w_j g^mn_j (centre-of-mass check)", "1/m"),
    "mu": (("mode", "mode2"), "kg", "modal mass Phi^T M Phi", "1"),
    "Lam": (("mode", "mode2"), "kg/s^2", "modal stiffness Phi^T K Phi", "1/s^2"),
    "C": (("mode", "mode2"), "kg/s", "modal damping matrix", "1/s"),
    "X": (("dof", "xyz"), "m", "prestressed reference vector DOFs", ""),
    "translational": (("dof",), "1", "1 where the vector DOF is a position, 0 for a slope", ""),
    "weights": (("dof",), "kg", "nodal mass weights w = M_s t", ""),
    "Phi": (("mode", "dof", "xyz"), "1", "mode shapes u^k (modal mass 1 kg)", "kg^-0.5"),
    "G": (("mode", "mode2", "dof", "xyz"), "1/m", "quadratic modes g^mn", "1/(kg m)"),
    "V3": (
        ("mode", "mode2", "mode3"),
        "J/m^3",
        "cubic manifold-potential coefficients (symmetric): V3_mnp s_m s_n s_p",
        "J/(kg^1.5 m^3)",
    ),
    "V4": (
        ("mode", "mode2", "mode3", "mode4"),
        "J/m^4",
        "quartic manifold-potential coefficients (symmetric): V4_mnpq s_m s_n s_p s_q",
        "J/(kg^2 m^4)",
    ),
    "F1": (("mode",), "J/m", "linear potential coefficient Phi^T f(X) (spinning reference)",
           "J/(kg^0.5 m)"),
    "reference_axis": (("xyz",), "1", "spin axis of the reference state (body frame)", ""),
}


def content_key(text: str) -> str:
    """Short hash of the inputs that determine a reduced model (plus the package version)."""
    return hashlib.sha256(f"{__version__}\n{text}".encode()).hexdigest()[:16]


def arrays_checksum(ds: xr.Dataset) -> str:
    """SHA-256 (hex) of the model arrays of ``ds`` (name, dtype, shape and bytes of each, in
    sorted order), its mode labels and its ``provenance_content_key``: written with the file
    and compared on load."""
    digest = hashlib.sha256()
    for name in sorted(v for v in _VARIABLES if v in ds):
        value = np.ascontiguousarray(ds[name].values)
        digest.update(f"{name}\0{value.dtype.str}\0{value.shape}\0".encode())
        digest.update(value.tobytes())
    labels = ds["label"].values if "label" in ds else ()
    digest.update("\0".join(str(v) for v in labels).encode())
    digest.update(str(ds.attrs.get("provenance_content_key", "")).encode())
    return digest.hexdigest()


def to_dataset(model: ReducedModel) -> xr.Dataset:
    """The model as an xarray Dataset with units and long names."""
    data = {}
    for name, (dims, units, desc, normalised) in _VARIABLES.items():
        value = np.asarray(getattr(model, name))
        if value.dtype == bool:
            value = value.astype(np.int8)
        attrs = {"units": units, "long_name": desc}
        if normalised:
            attrs["mass_normalised_units"] = normalised
        data[name] = xr.Variable(dims, value, attrs=attrs)
    mode = xr.Variable(("mode",), np.arange(model.n_modes) + 1,
                       {"units": "1", "long_name": "retained mode number"})  # fmt: skip
    ds = xr.Dataset(data, coords={"mode": mode})
    ds["label"] = xr.Variable(("mode",), np.array(model.labels, dtype=object),
                              {"units": "1", "long_name": "mode label"})  # fmt: skip
    attrs = {
        **cf.provenance("quadmodes reduced model"),
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "quadmodes_version": __version__,
        "mass_kg": float(model.mass),
        "free": int(model.free),
        "manifold_potential": int(model.manifold_potential),
        "reference_spin_rad_s": float(model.reference_spin),
        "conventions": "SI; modal coordinates s in m for modes normalised to a modal mass of 1 kg "
        "(kg^0.5 m for phi^T M phi = 1: the same numbers)",
        "modal_normalisation": cf.MODAL_NORMALISATION,
    }
    attrs.update({f"provenance_{k}": str(v) for k, v in model.provenance.items()})
    ds.attrs.update(attrs)
    ds.attrs["arrays_sha256"] = arrays_checksum(ds)
    return ds


def save_reduced_model(model: ReducedModel, path: str | os.PathLike) -> Path:
    """Write ``model`` to ``path`` (NetCDF4 via h5netcdf) atomically."""
    ds = to_dataset(model)
    return write_netcdf(ds, path, invalid_netcdf=False, encoding=cf.encoding(ds))  # ENOSPC: clean


def load_reduced_model(path: str | os.PathLike, require_checksum: bool = False) -> ReducedModel:
    """Read a reduced model, checking format, completeness and the arrays' checksum
    (``require_checksum``: a file without one is refused too, as the model cache does)."""
    path = Path(path)
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            ds = ds.load()
    except FileNotFoundError:
        raise ArtifactError(f"{path}: no such reduced-model file; run `quadmodes reduce`") from None
    except Exception as exc:  # corrupt or not NetCDF
        raise ArtifactError(
            f"{path}: not a readable reduced-model file ({type(exc).__name__}); rebuild it with "
            "`quadmodes reduce CASE -o FILE`"
        ) from None
    if ds.attrs.get("format") != FORMAT:
        raise ArtifactError(f"{path}: not a quadmodes reduced-model file; rebuild it")
    stored = ds.attrs.get("arrays_sha256")
    if (stored is not None or require_checksum) and stored != arrays_checksum(ds):
        raise ArtifactError(f"{path}: damaged reduced-model file (its arrays do not match their "
                            "checksum); rebuild it with `quadmodes reduce`")  # fmt: skip
    version = int(ds.attrs.get("format_version", -1))
    if version not in READABLE_VERSIONS:
        raise ArtifactError(
            f"{path}: written by quadmodes {ds.attrs.get('quadmodes_version')} in format "
            f"{ds.attrs.get('format_version')}, this version reads formats "
            f"{', '.join(map(str, READABLE_VERSIONS))}; rebuild it with `quadmodes reduce`"
        )
    expected = [
        v for v in _VARIABLES
        if (version >= 2 or v not in _V2_VARIABLES) and (version >= 3 or v not in _V3_VARIABLES)
    ]  # fmt: skip
    missing = [v for v in expected if v not in ds]
    if missing:
        raise ArtifactError(f"{path}: incomplete reduced-model file (missing {missing[0]}); rebuild")
    values = {name: np.asarray(ds[name].values) for name in expected}
    if not all(np.all(np.isfinite(v)) for v in values.values()):
        raise ArtifactError(f"{path}: reduced-model file contains NaN or inf; rebuild it")
    values["translational"] = values["translational"].astype(bool)
    provenance = {
        k.removeprefix("provenance_"): v for k, v in ds.attrs.items() if k.startswith("provenance_")
    }
    return ReducedModel(
        mass=float(ds.attrs["mass_kg"]),
        free=bool(int(ds.attrs["free"])),
        manifold_potential=version >= 2 and bool(int(ds.attrs.get("manifold_potential", 0))),
        labels=tuple(str(v) for v in ds["label"].values),
        provenance=provenance,
        reference_spin=float(ds.attrs.get("reference_spin_rad_s", 0.0)),
        **values,
    )
