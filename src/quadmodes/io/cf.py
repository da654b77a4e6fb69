"""CF conventions for the NetCDF files quadmodes writes: ``long_name`` and ``units`` on every
variable and coordinate, ``Conventions``, the provenance attributes, string labels as auxiliary
coordinates, no ``_FillValue`` on coordinates, and the check of all that (:func:`file_problems`).

Unit strings are read alike by pint and by UDUNITS-2 (cf_units, Iris, CDO, Panoply): products by
a space, integer powers by ``^`` (``kg m^2/s``, ``rad/s``, ``s^-2``); coordinates without a
physical unit (mode numbers, labels) get ``units = "1"``.

**Modal quantities.** Inside quadmodes the modes are mass-normalised (``φᵀMφ = 1``, φ in
kg^-0.5), so a modal coordinate s is in kg^0.5 m. UDUNITS-2 takes integer powers only and reads
``kg^0.5 m`` silently as 5 m (``kg^0`` times 5 m). The files therefore state every modal
quantity for modes normalised to a modal mass of 1 kg (``φᵀMφ = 1 kg``, φ dimensionless): the
same numbers, in units without a half power (s in m, ṡ in m/s, Λ in kg s^-2); each such
variable carries ``mass_normalised_units``, the unit of the same number in quadmodes' own
normalisation (pint syntax, ``kg^0.5 m``), and the file the global attribute
``modal_normalisation`` (:data:`MODAL_NORMALISATION`). docs/outputs.md, "Units".
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes._version import __version__

#: The CF version the files follow.
CONVENTIONS = "CF-1.10"

#: The global attribute ``modal_normalisation`` of a file with modal quantities.
MODAL_NORMALISATION = (
    "modal quantities are stated for modes normalised to a modal mass of 1 kg (phi^T M phi = "
    "1 kg, phi dimensionless): modal coordinates are lengths (m); mass_normalised_units gives "
    "the unit of the same number for quadmodes' own normalisation phi^T M phi = 1 (phi in "
    "kg^-0.5, modal coordinates in kg^0.5 m)"
)


def variable(dims, value, units: str, long_name: str) -> xr.Variable:
    """A data variable with CF ``units`` and ``long_name``."""
    return xr.Variable(dims, np.asarray(value), attrs={"units": units, "long_name": long_name})


def coordinate(dims, value, units: str, long_name: str) -> tuple:
    """A coordinate ``(dims, value, attrs)`` with CF ``units`` and ``long_name``."""
    return (dims, value, {"units": units, "long_name": long_name})


def modal_variable(dims, value, units: str, mass_normalised_units: str,
                   long_name: str) -> xr.Variable:  # fmt: skip
    """A data variable of a modal quantity: ``units`` for modes normalised to 1 kg (module
    docstring: ``"m"`` for a modal coordinate) and ``mass_normalised_units``, the unit of the
    same number for ``φᵀMφ = 1`` (``"kg^0.5 m"``)."""
    attrs = {"units": units, "long_name": long_name, "mass_normalised_units": mass_normalised_units}
    return xr.Variable(dims, np.asarray(value), attrs=attrs)


def label_coordinate(dim: str, labels, long_name: str) -> dict:
    """``{f"{dim}_label": (dim, labels, attrs)}``: string labels of a dimension as an auxiliary
    coordinate (CF coordinate variables are numeric; ``dim`` itself gets no string values)."""
    return {f"{dim}_label": (dim, np.array(list(labels), dtype=object),
                             {"units": "1", "long_name": long_name})}  # fmt: skip


def encoding(ds: xr.Dataset, compress: bool = False) -> dict:
    """The NetCDF ``encoding`` of ``ds``: no ``_FillValue`` on coordinates (CF: a coordinate is
    never missing; xarray would add NaN to every float one) and, with ``compress``, zlib on the
    non-empty float data variables."""
    out: dict = {name: {"_FillValue": None} for name in ds.coords}
    if compress:
        for name, var in ds.data_vars.items():
            if var.dtype.kind == "f" and var.size > 0:
                out[name] = {"zlib": True, "complevel": 4, "shuffle": True}
    return out


def spelling(units: str) -> str:
    """``units`` in the files' one spelling: products by a space, powers by ``^``, ``"1"`` for
    none (``"kg*m^2"`` -> ``"kg m^2"``, ``""`` -> ``"1"``)."""
    return " ".join(str(units).replace("**", "^").replace("*", " ").split()) or "1"


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


# ---------------------------------------------------------------------------------------------
# the check: units UDUNITS-2 reads as pint does, and the CF rules the files follow
# ---------------------------------------------------------------------------------------------

# A strict subset of the UDUNITS-2 grammar that both readers read alike: names (letters and
# "_"), numbers, integer powers by "^" or "**" right after a name or ")", products by a space
# or "*", quotients by "/", parentheses. "." (UDUNITS' product, and a decimal point) is refused
# next to a digit: "kg^0.5" is "kg^0" times 5 for UDUNITS.
_TOKEN = re.compile(
    r"(?P<name>[A-Za-z_]+)|(?P<power>(?:\^|\*\*)[+-]?\d+)(?![\d.])"
    r"|(?P<number>\d+(?:\.\d+)?(?:[eE][+-]?\d+)?)(?![\d.A-Za-z_])|(?P<op>[ */()])"
)


#: The unit names the check knows UDUNITS-2 to define as pint does (pint's "dimensionless" and
#: "deg" are not UDUNITS names: "1", "degree").
UDUNITS_NAMES = frozenset(
    "m mm km kg g s ms min h rad degree sr Hz N Pa J W K mol A V C".split()
)


def udunits_problem(units: str) -> str:
    """Why UDUNITS-2 would not read ``units`` as pint does ("" when it would): a string outside
    the strict subset above (a fractional or implicit power, a "." product), or one whose
    reading by that grammar differs from pint's."""
    from quadmodes.case.units import ureg

    text, pos, expr, prev = str(units).strip(), 0, [], "op"
    if re.search(r"(\^|\*\*|[A-Za-z])\(?[+-]?\d*[./]\d", text):
        return f"{text!r}: a fractional power; UDUNITS-2 takes integer powers only (kg^0.5 m: 5 m)"
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            return f"{text!r}: UDUNITS-2 reads {text[pos:]!r} otherwise (integer powers only)"
        kind, tok = m.lastgroup, m.group()
        if kind == "name" and tok not in UDUNITS_NAMES:
            return f"{text!r}: {tok!r} is not a UDUNITS-2 unit this check knows"
        if kind == "power" and prev not in ("name", ")"):
            return f"{text!r}: a power must follow a unit name or ')'"
        if kind in ("name", "number") and prev in ("name", "number", "power", ")"):
            expr.append("*")  # juxtaposition is a product in both grammars
        expr.append({"power": f"**({tok.lstrip('^*')})", "op": "*" if tok == " " else tok}
                    .get(kind, tok))  # fmt: skip
        prev = tok if tok in "()" else ("op" if kind == "op" else kind)
        pos = m.end()
    expr = [e for i, e in enumerate(expr) if not (e == "*" and i and expr[i - 1] in "*/(")]
    try:
        grammar = ureg.parse_expression("".join(expr) or "1")
        own = ureg.Quantity(1.0, text)
        if grammar.dimensionality != own.dimensionality or not np.isclose(
            float(ureg.Quantity(grammar).to_base_units().magnitude),
            float(own.to_base_units().magnitude), rtol=1e-12):
            return f"{text!r}: UDUNITS-2 reads it as {grammar:~}, pint as {own:~}"
    except Exception as exc:  # pint raises several kinds for bad strings
        return f"{text!r}: not a unit ({type(exc).__name__})"
    return ""


def file_problems(path) -> list[str]:
    """What a CF reader would find wrong in the NetCDF file ``path`` (empty when nothing):
    no ``Conventions``; a variable or coordinate without ``long_name`` or ``units``, with
    units pint does not parse, UDUNITS-2 reads otherwise (:func:`udunits_problem`) or spelled
    otherwise than the files' one way (:func:`spelling`; no negative power: ``1/s^2``), or a
    ``mass_normalised_units`` pint does not parse; ``_FillValue`` on a coordinate; a
    string-valued dimension coordinate."""
    from quadmodes.case.units import ureg

    with xr.open_dataset(Path(path), engine="h5netcdf", mask_and_scale=False) as ds:
        out = [] if str(ds.attrs.get("Conventions", "")).startswith("CF-") else ["no Conventions"]
        out += unit_problems(ds)
        for name in [*ds.coords, *ds.data_vars]:
            var = ds[name]
            units = str(var.attrs.get("units", "1"))
            if why := udunits_problem(units):
                out.append(f"{name}: {why}")
            elif units != spelling(units) or "^-" in units:
                out.append(f"{name}: units {units!r} spelled otherwise than the files' one way "
                           f"(spaces, positive powers by ^, '/': {spelling(units)!r})")
            if "mass_normalised_units" in var.attrs:
                try:
                    ureg.Unit(str(var.attrs["mass_normalised_units"]))
                except Exception as exc:  # pint raises several kinds for bad strings
                    out.append(f"{name}: mass_normalised_units ({type(exc).__name__})")
            if name in ds.coords and "_FillValue" in var.attrs:
                out.append(f"{name}: _FillValue on a coordinate")
            if name in ds.dims and var.dtype.kind not in "iuf":
                out.append(f"{name}: string-valued dimension coordinate")
    return out
