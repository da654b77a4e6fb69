"""CF conventions (as far as they fit) for the NetCDF files quadmodes writes: ``long_name`` and
``units`` on every variable and coordinate, ``Conventions``, and the provenance attributes.

Unit strings are written so that pint parses them and, except for the fractional powers of the
mass-normalised modal coordinates (``kg^0.5 m``), UDUNITS too (``kg m^2/s``, ``rad/s``,
``s^-2``). Coordinates without a physical unit (mode numbers, axis and label coordinates) get
``units = "1"``.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from quadmodes._version import __version__

#: The CF version the files follow.
CONVENTIONS = "CF-1.10"


def variable(dims, value, units: str, long_name: str) -> xr.Variable:
    """A data variable with CF ``units`` and ``long_name``."""
    return xr.Variable(dims, np.asarray(value), attrs={"units": units, "long_name": long_name})


def coordinate(dims, value, units: str, long_name: str) -> tuple:
    """A coordinate ``(dims, value, attrs)`` with CF ``units`` and ``long_name``."""
    return (dims, value, {"units": units, "long_name": long_name})


def axis_label(data: xr.DataArray) -> str:
    """A plot axis label from the CF attributes: ``"cone angle (degree)"``."""
    name = data.attrs.get("long_name") or str(data.name).replace("_", " ")
    units = str(data.attrs.get("units", ""))
    return f"{name} ({units})" if units and units != "1" else name


def provenance(title: str, model_hash: str = "") -> dict:
    """Global attributes every file carries: ``Conventions``, ``title``, ``source`` (package and
    version), ``quadmodes_version`` and, when known, ``model_hash`` (content key of the reduced
    model the file was computed from)."""
    attrs = {
        "Conventions": CONVENTIONS,
        "title": title,
        "source": f"quadmodes {__version__}",
        "quadmodes_version": __version__,
    }
    if model_hash:
        attrs["model_hash"] = model_hash
    return attrs


def complete(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with the CF attributes filled in where missing: ``Conventions``; ``units = "1"``
    on coordinates without units; a ``long_name`` from the name (``mode_label`` -> "mode
    label"); an old ``description`` attribute becomes ``long_name``. Returns ``ds`` (changed
    in place)."""
    ds.attrs.setdefault("Conventions", CONVENTIONS)
    for name in [*ds.coords, *ds.data_vars]:
        attrs = ds[name].attrs
        if "description" in attrs:
            attrs.setdefault("long_name", attrs.pop("description"))
        attrs.setdefault("long_name", str(name).replace("_", " "))
        if name in ds.coords:
            attrs.setdefault("units", "1")
    return ds


def unit_problems(ds: xr.Dataset) -> list[str]:
    """Names of the variables and coordinates of ``ds`` without ``long_name`` or without a
    ``units`` that pint parses, each with the reason (empty when every one is fine)."""
    from quadmodes.case.units import ureg

    problems = []
    for name in [*ds.coords, *ds.data_vars]:
        attrs = ds[name].attrs
        if not attrs.get("long_name"):
            problems.append(f"{name}: no long_name")
        try:
            ureg.Unit(str(attrs["units"]))
        except KeyError:
            problems.append(f"{name}: no units")
        except Exception as exc:  # pint raises several kinds for bad strings
            problems.append(f"{name}: units {attrs['units']!r} ({type(exc).__name__})")
    return problems
