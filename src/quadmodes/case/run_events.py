"""``integration.until``: the event that ends a free-body run before its duration.

Grammar (case-insensitive; the quantity as every case quantity, :mod:`quadmodes.case.units`):

* ``"cone 60 deg"`` (or ``"cone angle …"``): the cone angle (between H and the tracked spin
  axis) reaches the angle, 0 < θ < 90 deg;
* ``"spin 30 Hz"`` (or ``"spin rate …"``): the spin rate about the tracked axis reaches the rate
  (from either side), > 0;
* ``"time 10 s"`` (or ``"t 10 s"``): the time reaches the value, > 0;
* ``"flat spin"`` or ``"flat spin 0.5 deg"``: the angle between H and the major principal axis
  falls below the angle (default :data:`FLAT_SPIN_ANGLE_DEG`).

The text is stored as written (stripped, spaces collapsed): it is the run case's own record;
:func:`parse_until` gives its (kind, SI level).
"""

from __future__ import annotations

import math
import re
from typing import Any

from quadmodes.case.fields import field_error
from quadmodes.case.units import QuantityError, parse_quantity

#: Default angle (deg) between H and the major principal axis below which "flat spin" is reached:
#: the residual nutation of a flat spin decays exponentially and never reaches zero.
FLAT_SPIN_ANGLE_DEG = 1.0

#: kind → (dimension, example, words accepted).
_KINDS = {
    "cone": ("angle", "60 deg", ("cone", "cone angle", "cone_angle")),
    "spin": ("angular_rate", "30 Hz", ("spin", "spin rate", "spin_rate")),
    "time": ("time", "10 s", ("time", "t")),
    "flat spin": ("angle", "1 deg", ("flat spin", "flat_spin", "flat")),
}
_USE = 'use e.g. "cone 60 deg", "spin 30 Hz", "time 10 s" or "flat spin"'
_SPLIT = re.compile(r"^\s*([a-z_ ]*?[a-z])\s*([-+.0-9].*)?$", re.IGNORECASE)


def _kind(word: str) -> str | None:
    word = " ".join(word.lower().split())
    return next((k for k, (_, _, words) in _KINDS.items() if word in words), None)


def parse_until(text: str) -> tuple[str, float]:
    """``(kind, level)`` of an ``until`` text: kind "cone" (level rad), "spin" (rad/s), "time"
    (s) or "flat spin" (rad); raises ValueError (one line, with an example) otherwise."""
    match = _SPLIT.match(text or "")
    kind = _kind(match[1]) if match else None
    if kind is None:
        raise ValueError(f"{text!r} is not an event; {_USE}")
    dimension, example, _ = _KINDS[kind]
    number = (match[2] or "").strip()
    if not number:
        if kind != "flat spin":
            raise ValueError(f'{text!r} has no value; use e.g. "{kind} {example}"')
        return kind, math.radians(FLAT_SPIN_ANGLE_DEG)
    try:
        level = parse_quantity(number, dimension, "until", example)
    except QuantityError as exc:
        raise ValueError(f"{kind}: {exc.detail}") from None
    if not level > 0.0:
        raise ValueError(
            f'{text!r}: the {kind} level must be positive; use e.g. "{kind} {example}"'
        )
    if kind in ("cone", "flat spin") and not level < 0.5 * math.pi:
        raise ValueError(f'{text!r}: the angle must be below 90 deg; use e.g. "{kind} {example}"')
    return kind, level


def until_field(value: Any) -> str | None:
    """The validator of ``integration.until``: the text (spaces collapsed) if
    :func:`parse_until` reads it; a case field error otherwise."""
    if value is None:
        return None
    if not isinstance(value, str):
        raise field_error("case_value", f"{value!r} is not an event; {_USE}")
    try:
        parse_until(value)
    except ValueError as exc:
        raise field_error("case_value", str(exc)) from None
    return " ".join(value.split())
