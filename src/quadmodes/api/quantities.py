"""Dimensional arguments of the API: quantity strings, pint quantities or SI floats."""

from __future__ import annotations

from typing import Any

from quadmodes.case.fields import quantity_text
from quadmodes.case.units import parse_quantity

#: A dimensional input: a quantity string ("10 Hz"), a pint quantity or an SI float.
QuantityLike = str | float | Any


def si(value: QuantityLike, dimension: str, name: str) -> float:
    """``value`` in SI units (m, s, rad, rad/s, ...; ``dimension`` is a key of
    :data:`quadmodes.case.units.DIMENSIONS`, "frequency" is in Hz); ``name`` is the argument
    named in the error (:class:`~quadmodes.case.QuantityError`)."""
    return parse_quantity(quantity_text(value, dimension), dimension, name)
