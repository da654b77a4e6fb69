"""Case errors: :class:`CaseError` and the one-line message for a pydantic validation error.

Every problem with a case is reported as one line that names the source, the field path
(``geometry.length``, ``end_body[0].mass``) and the fix; :func:`case_error` picks the most
telling of pydantic's errors and counts the rest.
"""

from __future__ import annotations

import difflib
import re
from typing import Any

from pydantic import BaseModel, ValidationError

from quadmodes.case.meta import field_meta, toml_value
from quadmodes.case.meta import nested_model as _unwrap_model
from quadmodes.errors import QuadmodesError


class CaseError(QuadmodesError, ValueError):
    """An invalid case: ``str(exc)`` is one line naming the source, field path and fix."""

    def __init__(self, message: str, *, source: str | None = None, field: str | None = None):
        self.source = source
        self.field = field
        self.detail = message
        super().__init__(f"{source}: {message}" if source else message)


def case_error(exc: ValidationError, source: str | None, root: type[BaseModel]) -> CaseError:
    """One :class:`CaseError` for the validation of a ``root`` table (:class:`Case`,
    :class:`RunCase`) from ``source``."""
    # an unknown (misspelt) key explains the "missing" error that usually comes with it
    errors = sorted(exc.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden")
    path, message = _describe_error(errors[0], root)
    if len(errors) > 1:
        message += f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})"
    return CaseError(message, source=source, field=path)


def _walk(loc: list[Any], root: type[BaseModel]) -> tuple[type[BaseModel] | None, str | None]:
    """(model owning the last key of ``loc`` below ``root``, that key)."""
    model: type[BaseModel] | None = root
    keys = [k for k in loc if isinstance(k, str)]
    for name in keys[:-1]:
        if model is None or name not in model.model_fields:
            return None, name
        model = _unwrap_model(model.model_fields[name].annotation)
    return model, keys[-1] if keys else None


def _path(loc: list[Any]) -> str:
    text = ""
    for key in loc:
        if isinstance(key, int):
            text += f"[{key}]"
        else:
            text += ("." if text else "") + str(key)
    return text


def _table_name(loc: list[Any]) -> str:
    keys = [k for k in loc if isinstance(k, str)]
    return ".".join(keys)


def _describe_error(error: Any, root: type[BaseModel]) -> tuple[str, str]:
    """(field path, one-line message) for one pydantic error dict (``root``: see _walk)."""
    loc = list(error["loc"])
    ctx = error.get("ctx") or {}
    if "sub" in ctx:
        loc += [int(k) if k.isdigit() else k for k in re.split(r"[.\[\]]+", ctx["sub"]) if k]
    path = _path(loc) or "(case)"
    kind = error["type"]
    value = error.get("input")
    scalar = isinstance(value, (str, int, float, bool))
    shown = f"{path} = {toml_value(value)}" if scalar else path
    if kind in ("quantity", "case_rule"):
        return path, f"{path}: {ctx['detail']}"
    if kind == "case_value":
        return path, f"{shown}: {ctx['detail']}"
    if kind == "missing":
        return path, _missing(loc, path, root)
    if kind == "extra_forbidden":
        return path, _unknown_key(loc, path, root)
    if kind == "literal_error":
        return path, f"{shown}: must be {ctx.get('expected', '').replace(chr(39), chr(34))}"
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return path, f"{shown}: must be a table; write it as [{_table_name(loc)}]"
    if kind in ("tuple_type", "list_type"):
        return path, f"{shown}: must be an array of tables; write each as [[{_table_name(loc)}]]"
    if kind == "string_type":
        key = path.split(".")[-1]
        return path, f'{shown}: must be a string in double quotes, e.g. {key} = "..."'
    message = " ".join(str(error.get("msg", "invalid value")).split())
    return path, f"{shown}: {message}"


def _missing(loc: list[Any], path: str, root: type[BaseModel]) -> str:
    """Message for a missing key, with an example value when the key is known."""
    model, key = _walk(loc, root)
    if model is not None and key in model.model_fields:
        example = field_meta(model, key).example
        return f"{path}: missing; add e.g. {key} = {example}"
    return f"{path}: missing"


def _unknown_key(loc: list[Any], path: str, root: type[BaseModel]) -> str:
    """Message for an unknown key: the closest allowed key and all keys of its table."""
    model, key = _walk(loc, root)
    if model is None:
        return f"{path}: unknown key; remove it"
    parent = _table_name(loc[:-1])
    allowed = list(model.model_fields)
    where = f"[{parent}]" if parent else "the top level"
    close = difflib.get_close_matches(str(key), allowed, n=1)
    hint = f'did you mean "{close[0]}"? ' if close else ""
    return f"{path}: unknown key; {hint}keys allowed in {where}: {', '.join(allowed)}"
