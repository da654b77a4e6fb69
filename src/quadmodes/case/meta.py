"""Field metadata of the case tables, read by the validators, error messages and the TOML
writer: :class:`FieldMeta` (TOML example, unit dimension, display unit), :func:`field_meta`,
:func:`toml_value` (a scalar as TOML text) and :func:`nested_model` (the table type inside an
annotation)."""

from __future__ import annotations

import json
import typing
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel


@dataclass(frozen=True)
class FieldMeta:
    """Per-field metadata: TOML example, unit dimension (None if not a quantity), display unit,
    the allowed values in words (for the case reference) and a whole number's least value."""

    example: str
    dimension: str | None = None
    display: str | None = None
    allowed: str | None = None
    minimum: int | None = None


def toml_value(value: object) -> str:
    """A scalar as TOML source text (also used to echo inputs in error messages)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    return str(value)


def field_meta(model: type[BaseModel], name: str) -> FieldMeta:
    """The :class:`FieldMeta` of field ``name`` of ``model`` (a generic one if it has none)."""
    for item in model.model_fields[name].metadata:
        if isinstance(item, FieldMeta):
            return item
    return FieldMeta('"..."')


def nested_model(annotation: Any) -> type[BaseModel] | None:
    """The pydantic model inside an annotation such as ``Geometry | None`` or a tuple."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = nested_model(arg)
        if found is not None:
            return found
    return None
