"""Field annotations shared by every case table.

Dimensional fields are written in TOML as quantity strings ("0.3 psi", "60 in") and stored as
SI floats (m, kg, Pa, kg/m^3, kg m^2, m^2, m^4, s, rad, rad/s). Each field carries a
:class:`FieldMeta` (TOML example, unit dimension, display unit) that error messages and the TOML
writer read back with :func:`field_meta`. A check that fails raises a pydantic error whose kind
(``"quantity"``, ``"case_value"``, ``"case_rule"``) :mod:`quadmodes.case.errors` turns into one
line naming the field path and the fix.
"""

from __future__ import annotations

import numbers
import re
from collections.abc import Callable
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError, ValidationInfo
from pydantic_core import PydanticCustomError

from quadmodes.case.errors import case_error
from quadmodes.case.meta import FieldMeta, field_meta, nested_model, toml_value
from quadmodes.case.units import QuantityError, format_quantity, parse_quantity, si_unit, ureg
from quadmodes.limits import Limit, LimitError


class Section(BaseModel):
    """A case table: frozen, unknown keys rejected.

    :meth:`model_copy` with ``update`` validates the result like a case file (pydantic's own
    copy does not): quantity fields take quantity strings ("0.4 psi"), pint quantities or SI
    floats (see :func:`input_table`); a bad value raises :class:`~quadmodes.case.CaseError`."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    def model_copy(self, *, update: dict[str, Any] | None = None, deep: bool = False):
        """A copy of this table with ``update`` applied and validated (see the class)."""
        if not update:
            return super().model_copy(deep=deep)
        data = input_table(type(self), self.model_dump(mode="python", round_trip=True))
        data.update(input_table(type(self), dict(update)))
        try:
            return type(self).model_validate(data)
        except ValidationError as exc:
            raise case_error(exc, "model_copy", type(self)) from None


def field_error(kind: str, detail: str, sub: str | None = None) -> PydanticCustomError:
    """A validation error of ``kind`` with message ``detail``; ``sub`` is the path (below the
    failing table) of the field it is about, for checks that span several fields."""
    ctx: dict[str, Any] = {"detail": detail}
    if sub is not None:
        ctx["sub"] = sub
    return PydanticCustomError(kind, "{detail}", ctx)


def inch(si: float) -> str:
    """A length (m) as an inch quantity string, for messages."""
    return format_quantity(si, "in")


# --------------------------------------------------------------------------------------------
# value checks on SI floats: None if fine, else what is wrong


Check = Callable[[float], str | None]


def positive(x: float) -> str | None:
    """> 0"""
    return None if x > 0 else "must be positive"


def nonnegative(x: float) -> str | None:
    """≥ 0"""
    return None if x >= 0 else "must not be negative"


def ratio(x: float) -> str | None:
    """0 ≤ value < 1"""
    return None if 0 <= x < 1 else "must satisfy 0 <= ratio < 1"


def poisson(nu: float) -> str | None:
    """−1 < value < 0.5"""
    if nu >= 0.5:
        return "must be below 0.5 for an isotropic membrane"
    if nu <= -1:
        return "must be above -1 for an isotropic membrane"
    return None


def at_least_one(x: float) -> str | None:
    """≥ 1"""
    return None if x >= 1 else "must be at least 1"


# --------------------------------------------------------------------------------------------
# annotated field types


def quantity(
    dimension: str,
    example: str,
    check: Check | None = None,
    display: str | None = None,
    optional: bool = False,
    allowed: str | None = None,
) -> Any:
    """Annotated float field read from a quantity string and stored in SI; ``allowed``: the
    allowed values in words (default: the docstring of ``check``)."""
    dimensionless = dimension == "dimensionless"
    shown = example if dimensionless else f'"{example}"'

    def validate(value: Any, info: ValidationInfo) -> float | None:
        if value is None and optional:
            return None
        try:
            si = parse_quantity(value, dimension, info.field_name or "", example)
        except QuantityError as exc:
            raise field_error("quantity", exc.detail) from None
        problem = check(si) if check else None
        if problem:
            raise field_error("case_value", f"{problem}; use e.g. {shown}")
        return si

    meta = FieldMeta(shown, dimension, display, allowed or (check.__doc__ if check else None))
    if optional:
        return Annotated[float | None, BeforeValidator(validate), meta]
    return Annotated[float, BeforeValidator(validate), meta]


def whole_number(value: Any) -> int | None:
    """``value`` as an int if it is a whole number — a Python or numpy integer, or a float
    with no fraction (``5.0``) — else None (booleans, fractions such as 7.5, strings)."""
    if isinstance(value, (bool, np.bool_)):
        return None
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real) and float(value).is_integer():
        return int(value)
    return None


def integer(example: int, minimum: int, limit: Limit | None = None, optional: bool = False) -> Any:
    """Annotated whole-number field (no booleans, no fractions); at most ``limit`` (a bound of
    :mod:`quadmodes.limits`, read when the case is validated) when given; ``optional``: None
    allowed (the field left out)."""

    def validate(value: Any) -> int | None:
        if value is None and optional:
            return None
        value = whole_number(value)
        if value is None:
            raise field_error("case_value", f"must be a whole number; use e.g. {example}")
        if value < minimum:
            raise field_error("case_value", f"must be at least {minimum}; use e.g. {example}")
        if limit is not None:
            check_limit(value, limit, example)
        return value

    bound = f"; at most {limit.default:,.0f} (${limit.env})" if limit is not None else ""
    allowed = f"whole number ≥ {minimum}{bound}"
    meta = FieldMeta(str(example), None, None, allowed, minimum)
    return Annotated[int | None if optional else int, BeforeValidator(validate), meta]


def check_limit(value: int, limit: Limit, example: object) -> None:
    """Raise a ``case_value`` error when the whole number ``value`` exceeds ``limit``."""
    try:
        bound = limit.value()
    except LimitError as exc:
        raise field_error("case_value", exc.detail) from None
    if value > bound:
        raise field_error(
            "case_value",
            f"more than the limit of {bound:,.0f} {limit.what}; use e.g. {example}, "
            f"{limit.raise_hint(value)}",
        )


def text(example: str) -> Any:
    """Annotated string field."""
    return Annotated[str, FieldMeta(toml_value(example))]


def choice(*options: str) -> Any:
    """Annotated string field that must be one of ``options`` (the first is the example)."""
    allowed = ", ".join(toml_value(o) for o in options)
    return Annotated[Literal[options], FieldMeta(toml_value(options[0]), allowed=allowed)]  # type: ignore[valid-type]


_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


def valid_name(value: str, example: str) -> str:
    """``value`` if it is a valid case name (letters, digits, ".", "_", "-"), else an error that
    suggests ``example``."""
    if not _NAME.match(value):
        raise field_error(
            "case_value", f'use letters, digits, ".", "_" or "-" only; e.g. "{example}"'
        )
    return value


# --------------------------------------------------------------------------------------------
# inputs from Python: pint quantities and SI floats as quantity strings


def quantity_text(value: Any, dimension: str | None) -> Any:
    """``value`` as a case file would give it for a field of ``dimension`` (a key of
    :data:`quadmodes.case.units.DIMENSIONS`, or None for a field without units): a pint
    quantity becomes its quantity string (``"0.4 pound_force_per_square_inch"``; a
    dimensionless one its float), a bare int/float in a dimensional field the SI quantity
    string (``2.0`` for a length -> ``"2.0 m"``); anything else is returned unchanged."""
    if dimension is None:
        return value
    if hasattr(value, "magnitude") and hasattr(value, "units"):  # a pint quantity, any registry
        q = ureg.Quantity(float(value.magnitude), str(value.units))
        if dimension == "dimensionless":
            return float(q.to("dimensionless").magnitude)
        return f"{float(q.magnitude)!r} {q.units}"
    dimensional = dimension != "dimensionless"
    if dimensional and isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        return f"{float(value)!r} {si_unit(dimension)}"
    return value


def input_table(model: type[BaseModel], data: dict[str, Any]) -> dict[str, Any]:
    """``data`` (keys of table ``model``, nested tables as dicts or models) with every quantity
    given as a pint quantity or an SI float turned into a quantity string
    (:func:`quantity_text`), so that it validates like a case file. Unknown keys are kept (the
    validation names them)."""
    result: dict[str, Any] = {}
    for name, value in data.items():
        info = model.model_fields.get(name)
        inner = nested_model(info.annotation) if info is not None else None
        if info is None:
            result[name] = value
        elif inner is not None and isinstance(value, dict):
            result[name] = input_table(inner, value)
        elif inner is not None and isinstance(value, (list, tuple)):
            result[name] = [input_table(inner, v) if isinstance(v, dict) else v for v in value]
        else:
            result[name] = quantity_text(value, field_meta(model, name).dimension)
    return result
