"""Reading case files: TOML text to a table, a file to text, a table to a validated model.

Every failure is a :class:`CaseError` with a one-line message naming the source (and, for TOML
syntax, the line and column).
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from quadmodes.case.builtin import unknown_name_message
from quadmodes.case.errors import CaseError, case_error

Model = TypeVar("Model", bound=BaseModel)

_TOML_POSITION = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """The table of TOML ``text``; a syntax error becomes a :class:`CaseError` naming
    ``source`` and the line and column."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc).splitlines()[0] if str(exc) else "invalid TOML"
        match = _TOML_POSITION.search(message)
        if match:
            line, column = match.groups()
            raise CaseError(
                f"line {line}, column {column}: invalid TOML: {message[: match.start()]}",
                source=source,
            ) from None
        raise CaseError(f"invalid TOML: {message}", source=source) from None


def validate_table(
    model: type[Model],
    data: dict[str, Any],
    source: str | None,
    base_dir: str | os.PathLike[str] | None,
) -> Model:
    """``data`` validated as a ``model``; ``base_dir`` anchors relative paths inside it."""
    context = {"base_dir": os.fspath(base_dir) if base_dir is not None else None}
    try:
        return model.model_validate(data, context=context)
    except ValidationError as exc:
        raise case_error(exc, source, model) from None


def looks_like_path(name_or_path: str | os.PathLike[str]) -> bool:
    """True unless ``name_or_path`` is a string without a path separator or ``.toml`` suffix
    (which may name a built-in case)."""
    text = os.fspath(name_or_path)
    return (
        not isinstance(name_or_path, str)
        or text.endswith(".toml")
        or os.sep in text
        or (os.altsep is not None and os.altsep in text)
    )


def read_case_file(
    name_or_path: str | os.PathLike[str], what: str, builtin_names: list[str]
) -> tuple[str, Path]:
    """Text of the ``what`` ("case", "run case") file ``name_or_path`` and its folder (which
    anchors relative paths inside it).

    A missing file is a :class:`CaseError`: "file not found" for something that looks like a
    path, else an unknown name with the closest of ``builtin_names``; so is an unreadable one.
    """
    text = os.fspath(name_or_path)
    path = Path(text).expanduser()
    if path.is_dir():
        inside = sorted(p.name for p in path.glob("*.toml"))[:3]
        hint = f" (it holds {', '.join(inside)})" if inside else ""
        raise CaseError(
            f"{text} is a folder, not a {what} file; give the path of a .toml file{hint}",
            field="case",
        )
    if not path.is_file():
        if looks_like_path(name_or_path):
            raise CaseError(f"{what} file not found: {text}", field="case")
        raise CaseError(unknown_name_message(what, text, builtin_names), field="case")
    try:
        return path.read_text(encoding="utf-8"), path.parent
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise CaseError(f"cannot read {what} file: {reason}", source=text) from None
