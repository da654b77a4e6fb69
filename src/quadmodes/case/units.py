"""Quantity strings ("0.3 psi", "60 in", "2 %") to SI floats and back.

All dimensional inputs of a case are strings with a unit; :func:`parse_quantity` checks the
kind of unit and returns the magnitude in SI (m, kg, s, Pa, N, rad; frequency in Hz,
angular rate in rad/s). Problems raise :class:`QuantityError` with a one-line message.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from types import MappingProxyType

import pint

from quadmodes.errors import QuadmodesError

__all__ = [
    "DIMENSIONS",
    "QuantityError",
    "format_quantity",
    "parse_quantity",
    "si_unit",
    "ureg",
]

#: The single shared unit registry of the package.
ureg = pint.UnitRegistry()


class QuantityError(QuadmodesError, ValueError):
    """A quantity string that is unparsable, lacks a unit or has the wrong kind of unit.

    ``str(exc)`` is one line: ``"<field>: <detail>"``; ``detail`` is the part after the field.
    """

    def __init__(self, field: str, detail: str) -> None:
        self.field = field
        self.detail = detail
        super().__init__(f"{field}: {detail}" if field else detail)


@dataclass(frozen=True)
class _Dim:
    noun: str  # "a length"
    dims: tuple[tuple[str, int], ...]  # pint dimensionality, e.g. (("[length]", 1),)
    si: str  # SI unit the magnitude is returned in
    example: str  # example value with a unit
    # accepted powers of radian in the root units (rates may be given per cycle or per radian)
    radian: tuple[int, ...] = (0,)


_M, _L, _T = "[mass]", "[length]", "[time]"

#: Dimension names accepted by :func:`parse_quantity` (read-only).
DIMENSIONS = MappingProxyType(
    {
        "length": _Dim("a length", ((_L, 1),), "m", "60 in"),
        "pressure": _Dim("a pressure", ((_M, 1), (_L, -1), (_T, -2)), "Pa", "0.3 psi"),
        "density": _Dim("a density", ((_M, 1), (_L, -3)), "kg/m^3", "0.0335 lb/in^3"),
        "mass": _Dim("a mass", ((_M, 1),), "kg", "0.1 kg"),
        "inertia": _Dim("a moment of inertia", ((_M, 1), (_L, 2)), "kg*m^2", "1e-5 kg m^2"),
        "frequency": _Dim("a frequency", ((_T, -1),), "Hz", "41 Hz", (0, 1)),
        "angular_rate": _Dim("an angular rate", ((_T, -1),), "rad/s", "60 rpm", (0, 1)),
        "angle": _Dim("an angle", (), "rad", "6 deg", (1,)),
        "time": _Dim("a time", ((_T, 1),), "s", "10 s"),
        "area": _Dim("an area", ((_L, 2),), "m^2", "4e-4 m^2"),
        "second_moment": _Dim("a second moment of area", ((_L, 4),), "m^4", "2e-7 m^4"),
        "force": _Dim("a force", ((_M, 1), (_L, 1), (_T, -2)), "N", "10 N"),
        "stiffness_EA": _Dim("an axial stiffness EA", ((_M, 1), (_L, 1), (_T, -2)), "N", "2.8e7 N"),
        "stiffness_EI": _Dim(
            "a bending stiffness EI", ((_M, 1), (_L, 3), (_T, -2)), "N*m^2", "1.4e4 N m^2"
        ),
        "linear_density": _Dim("a mass per length", ((_M, 1), (_L, -1)), "kg/m", "1.2 kg/m"),
        "dimensionless": _Dim("a dimensionless number", (), "", "0.02", (0,)),
    }
)

_NUMBER_START = re.compile(r"^\s*[+-]?(\d|\.\d)")

# The strict grammar of a quantity string: a number (int, decimal or scientific, optional
# sign), then optionally a unit expression of unit names joined by "*", "/" or a space, each
# with an optional small exponent ("^2", "**3", "^-1", "^0.5", "^(1/2)"). No arithmetic on
# numbers: "10**10**10 psi" or "2*3 m" is refused before pint sees it (pint would evaluate it,
# and Python's big integers make that unbounded work).
_NUMBER = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?"
_EXPONENT = r"(?:[+-]?\d{1,2}(?:\.\d{1,3})?|\(\s*[+-]?\d{1,2}\s*/\s*\d{1,2}\s*\))"
_NAME = r"(?:[A-Za-z_%°µΩÅ][\w°µΩÅ]*|1)"  # "1" as in pint's own "1 / second"
_FACTOR = rf"{_NAME}(?:\s*(?:\^|\*\*)\s*{_EXPONENT})?"
_UNIT = rf"{_FACTOR}(?:(?:\s*[*/]\s*|\s+){_FACTOR})*"
_QUANTITY = re.compile(rf"\s*(?P<number>{_NUMBER})\s*(?P<unit>{_UNIT})?\s*")
#: Longest quantity string read (the longest in the project is about 45 characters).
MAX_QUANTITY_CHARS = 120


def si_unit(dimension: str) -> str:
    """SI unit string that :func:`parse_quantity` returns for ``dimension`` ("" if none)."""
    return _spec(dimension).si


def _spec(dimension: str) -> _Dim:
    try:
        return DIMENSIONS[dimension]
    except KeyError:
        names = ", ".join(DIMENSIONS)
        raise ValueError(f"unknown dimension {dimension!r}; use one of {names}") from None


def _show(value: object) -> str:
    """Show a given value as it would appear in TOML, on one line."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        text = value.replace("\\", "\\\\").replace('"', '\\"')
        return '"' + text.replace("\n", "\\n").replace("\r", "\\r") + '"'
    return str(value)


def _signature(q: pint.Quantity) -> tuple[tuple[tuple[str, int], ...], int]:
    dims = tuple(sorted((str(k), int(v)) for k, v in q.dimensionality.items()))
    radian = int(dict(q.to_root_units().unit_items()).get("radian", 0))
    return dims, radian


def _accepts(spec: _Dim, sig: tuple[tuple[tuple[str, int], ...], int]) -> bool:
    return sig[0] == tuple(sorted(spec.dims)) and sig[1] in spec.radian


def _describe(sig: tuple[tuple[tuple[str, int], ...], int], q: pint.Quantity) -> str:
    for spec in DIMENSIONS.values():
        if _accepts(spec, sig):
            return spec.noun
    return f"in {q.units:~P} ({q.dimensionality})"


def parse_quantity(value: object, dimension: str, field: str, example: str | None = None) -> float:
    """Convert a quantity string such as ``"0.3 psi"`` to its SI magnitude (float).

    ``dimension`` is a key of :data:`DIMENSIONS`. Returns m, Pa, kg/m^3, kg, kg m^2, Hz
    ("frequency"; rad/s and rpm are divided by 2 pi), rad/s ("angular_rate"; Hz is multiplied
    by 2 pi), rad, s, m^2, m^4, N, N m^2, kg/m, or a plain number ("dimensionless"; "2 %" is
    0.02). ``field`` names the input in error messages; ``example`` overrides the suggested
    value. Signs are not checked. Raises :class:`QuantityError`.
    """
    spec = _spec(dimension)
    example = example or spec.example
    dimensionless = dimension == "dimensionless"
    fix = f'give {spec.noun} such as "{example}"'
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        kind = type(value).__name__
        raise QuantityError(field, f"{_show(value)} ({kind}) is not a quantity; {fix}")
    if isinstance(value, (int, float)):
        if not dimensionless:
            raise QuantityError(field, f"{value} has no unit; {fix}")
        number = float(value)
        if not math.isfinite(number):
            raise QuantityError(field, f"{value} is not a finite number; {fix}")
        return number
    q = _read(value, field, fix)
    if not math.isfinite(float(q.magnitude)):
        raise QuantityError(field, f"{_show(value)} is not a finite number; {fix}")
    sig = _signature(q)
    if not dimensionless and not dict(q.unit_items()):
        raise QuantityError(field, f"{_show(value)} has no unit; {fix}")
    if not _accepts(spec, sig):
        what = _describe(sig, q)
        expected = f'{spec.noun} such as "{example}"'
        raise QuantityError(field, f"{_show(value)} is {what}, expected {expected}")
    if dimensionless:
        return float(q.to("dimensionless").magnitude)
    if dimension == "frequency" and sig[1] == 1:  # rad/s, rpm -> Hz
        return float(q.to("rad/s").magnitude) / (2.0 * math.pi)
    if dimension == "angular_rate" and sig[1] == 0:  # Hz, 1/s -> rad/s
        return float(q.to("Hz").magnitude) * 2.0 * math.pi
    return float(q.to(spec.si).magnitude)


def _read(value: str, field: str, fix: str) -> pint.Quantity:
    """``value`` read by the strict grammar above: a number and a unit that pint parses."""
    shown = _show(value if len(value) <= 60 else value[:60] + "...")
    if len(value) > MAX_QUANTITY_CHARS:
        raise QuantityError(field, f"{shown} is too long for a quantity "
                                   f"(over {MAX_QUANTITY_CHARS} characters); {fix}")  # fmt: skip
    if not _NUMBER_START.match(value):
        raise QuantityError(field, f"{shown} does not start with a number; {fix}")
    match = _QUANTITY.fullmatch(value)
    if match is None:
        raise QuantityError(
            field,
            f"{shown} is not one number followed by a unit (no arithmetic such as \"2*3\" or "
            f"\"10**3\"; write 1e3 for a power of ten); {fix}",
        )
    try:
        unit = ureg.parse_units(match["unit"] or "dimensionless")
        q = ureg.Quantity(float(match["number"]), unit)
    except Exception as exc:  # pint raises many kinds of errors for bad strings
        reason = str(exc).splitlines()[0].split(". ")[0] if str(exc) else type(exc).__name__
        raise QuantityError(field, f"{shown} cannot be read ({reason}); {fix}") from None
    return q


def format_quantity(si_value: float, unit: str, digits: int | None = None) -> str:
    """Format an SI magnitude in ``unit``, e.g. ``format_quantity(2068.43, "psi") == "0.3 psi"``.

    ``si_value`` is in the coherent SI unit of ``unit`` (m for "in", Pa for "psi", Hz for "Hz",
    rad/s for "rpm", rad for "deg", a fraction for "%"). ``digits`` significant digits
    (default 6); ``digits=0`` gives the shortest text that reads back exactly.
    """
    target = ureg.Quantity(1.0, unit).units
    base = ureg.Quantity(1.0, target).to_base_units().units
    magnitude = float(ureg.Quantity(float(si_value), base).to(target).magnitude)
    if digits == 0:
        text = repr(magnitude)
    else:
        text = f"{magnitude:.{digits or 6}g}"
    return f"{text} {unit}" if unit.strip() not in ("", "dimensionless") else text
