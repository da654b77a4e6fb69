"""Bounded work and checked mesh files (issue 24, items 3 and 4; docs/reliability.md): quantity
strings read by a strict grammar (no arithmetic), the limits of quadmodes.limits, and the
checks of mesh files (regular file, size, unit, one closed body, duplicate nodes, plausible
strain and mass)."""

from __future__ import annotations

import time

import pytest

from quadmodes.case import QuantityError, parse_quantity

# ----------------------------------------------------------------------------- quantity grammar


@pytest.mark.parametrize(
    ("text", "dimension", "si"),
    [
        ("0.3 psi", "pressure", 2068.427187950509),
        ("60 in", "length", 1.524),
        ("5in", "length", 0.127),
        ("2 %", "dimensionless", 0.02),
        ("0.02", "dimensionless", 0.02),
        ("1e-5 kg m^2", "inertia", 1e-5),
        ("1e-5 kg*m^2", "inertia", 1e-5),
        ("1e-05 kilogram * meter ** 2", "inertia", 1e-5),  # pint's own spelling (API inputs)
        ("0.0335 lb/in^3", "density", 0.0335 * 0.45359237 / 0.0254**3),
        ("2.0 1 / second", "frequency", 2.0),
        ("+6 deg", "angle", 6 * 3.141592653589793 / 180),
        ("-1 psi", "pressure", -6894.757293168361),
        ("0.05 Mpsi", "pressure", 0.05e6 * 6894.757293168361),
    ],
)
def test_quantities_of_the_project_still_read(text, dimension, si):
    assert parse_quantity(text, dimension, "f") == pytest.approx(si, rel=1e-12)


@pytest.mark.parametrize(
    "text", ["10**10**10 psi", "2*3 m", "1 m**2**2**2", "(1+1) m", "1/2 m", "3 (m)", "1 m 2"]
)
def test_arithmetic_is_refused_at_once(text):
    start = time.perf_counter()
    with pytest.raises(QuantityError) as exc:
        parse_quantity(text, "length", "geometry.length")
    assert time.perf_counter() - start < 1.0  # refused by the grammar, not evaluated
    assert str(exc.value).startswith("geometry.length: ")
    assert "\n" not in str(exc.value)


def test_overlong_quantity_is_refused():
    with pytest.raises(QuantityError, match="too long"):
        parse_quantity("1" + " m" * 500, "length", "f")
