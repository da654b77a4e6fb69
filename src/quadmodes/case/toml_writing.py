"""Writing case tables back as TOML text in SI units.

Quantities are written as ``"<repr of the SI float> <SI unit>"`` so that the text loads back to
an exactly equal case, with the value in the field's familiar display unit as a comment
(``length = "1.524 m"  # 60 in``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from pydantic import BaseModel

from quadmodes.case.fields import field_meta, toml_value
from quadmodes.case.units import format_quantity, si_unit


def section_lines(section: BaseModel) -> list[str]:
    """``key = value`` lines of one table, in field order; fields that are None are left out."""
    lines = []
    for name in type(section).model_fields:
        value = getattr(section, name)
        if value is None:
            continue
        meta = field_meta(type(section), name)
        if meta.dimension is None or meta.dimension == "dimensionless":
            lines.append(f"{name} = {toml_value(value)}")
            continue
        unit = si_unit(meta.dimension)
        line = f'{name} = "{value!r} {unit}"'
        if meta.display and meta.display != unit and math.isfinite(value):
            line += f"  # {format_quantity(value, meta.display)}"
        lines.append(line)
    return lines


def toml_document(
    comment: str, keys: Mapping[str, object], tables: Iterable[tuple[str, list[str]]]
) -> str:
    """A TOML file: a ``# comment`` line, top-level ``keys``, then each ``(header, lines)`` table
    (header ``[name]`` or ``[[name]]``) after a blank line."""
    lines = [f"# {comment}", *(f"{key} = {toml_value(value)}" for key, value in keys.items())]
    for header, body in tables:
        lines += ["", header, *body]
    return "\n".join(lines) + "\n"
