"""Writing the sweep dataset: NetCDF (``sweep.nc``, h5netcdf) or Zarr (``sweep.zarr``, a
folder), the same variables, units and long names in both.

``--format netcdf`` / ``--format zarr`` choose; without it the dataset goes to NetCDF unless it
is larger than :data:`ZARR_THRESHOLD_BYTES` in memory and zarr is installed, then to Zarr (a
chunked store that is read lazily, variable by variable). Zarr is the optional extra
``quadmodes[zarr]``. The store is written in the Zarr v2 format with consolidated metadata
(read by every Zarr implementation; v3 has no specification yet for fixed-length strings).
Both writes are atomic: NetCDF through :func:`quadmodes.io.outputs.write_netcdf` (serialised in
memory, so a full disk is a clean OSError), Zarr into a temporary folder beside the target that
is then renamed onto it.
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import shutil
import tempfile
from pathlib import Path

import xarray as xr

from quadmodes.io import cf
from quadmodes.sweeps.params import SweepError

#: Formats of ``--format``.
FORMATS = ("netcdf", "zarr")
#: Without ``--format``: datasets larger than this (bytes in memory) are written to Zarr.
ZARR_THRESHOLD_BYTES = 256 * 2**20
#: File name per format.
FILE_NAMES = {"netcdf": "sweep.nc", "zarr": "sweep.zarr"}


def zarr_available() -> bool:
    return importlib.util.find_spec("zarr") is not None


def check_format(fmt: str | None, option: str = "--format") -> str | None:
    """``fmt`` validated (None: automatic); :class:`SweepError` for an unknown format or for
    zarr when the optional package is missing."""
    if fmt is None:
        return None
    fmt = fmt.strip().lower()
    if fmt not in FORMATS:
        raise SweepError(f"{option}: {fmt!r} is not a format; use netcdf or zarr")
    if fmt == "zarr" and not zarr_available():
        raise SweepError(f'{option} zarr: the optional package zarr is not installed; install '
                         f'it with pip install "quadmodes[zarr]" or use {option} netcdf')  # fmt: skip
    return fmt


def choose_format(fmt: str | None, nbytes: int) -> str:
    """The format to write: ``fmt`` if given; else zarr for datasets over the threshold when
    zarr is installed, netcdf otherwise."""
    if fmt is not None:
        return fmt
    return "zarr" if nbytes > ZARR_THRESHOLD_BYTES and zarr_available() else "netcdf"


@contextlib.contextmanager
def _atomic_folder(path: Path):
    """Yield a temporary folder beside ``path``; on success it replaces ``path`` (an old store
    is moved aside first and removed after), on failure it is removed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent))
    try:
        yield tmp / path.name
        old = None
        if path.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old", dir=path.parent))
            os.replace(path, old / path.name)
        os.replace(tmp / path.name, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_dataset(ds: xr.Dataset, directory: Path, fmt: str) -> Path:
    """Write ``ds`` to ``directory/sweep.nc`` or ``directory/sweep.zarr`` (atomically);
    returns the path."""
    from quadmodes.io.outputs import write_netcdf

    path = Path(directory) / FILE_NAMES[fmt]
    if fmt == "netcdf":  # in memory first: a full disk is a clean OSError (ENOSPC)
        return write_netcdf(ds, path, encoding=cf.encoding(ds))
    with _atomic_folder(path) as tmp:
        ds.to_zarr(tmp, mode="w", zarr_format=2, consolidated=True)
    return path


def open_sweep(path: Path) -> xr.Dataset:
    """The sweep dataset at ``path`` (``sweep.nc`` or ``sweep.zarr``, or the folder that holds
    one), loaded into memory."""
    path = Path(path)
    if path.is_dir() and path.suffix != ".zarr":
        found = [path / n for n in ("sweep.zarr", "sweep.nc") if (path / n).exists()]
        if not found:
            raise FileNotFoundError(f"{path}: no sweep.nc or sweep.zarr in it")
        path = max(found, key=lambda p: p.stat().st_mtime)
    if path.suffix == ".zarr":
        with xr.open_zarr(path, consolidated=True) as ds:
            return ds.load()
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.load()
