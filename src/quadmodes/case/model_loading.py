"""Loading model cases: from a parsed table, TOML text, a built-in name or a case file."""

from __future__ import annotations

import os
from typing import Any

from quadmodes.case.builtin import (
    builtin_case_names,
    builtin_case_text,
    builtin_run_case_names,
    builtin_run_model,
)
from quadmodes.case.errors import CaseError
from quadmodes.case.model_case import Case
from quadmodes.case.toml_reading import looks_like_path, parse_toml, read_case_file, validate_table


def case_from_dict(
    data: dict[str, Any], source: str | None = None, base_dir: str | os.PathLike[str] | None = None
) -> Case:
    """Validate parsed TOML data into a :class:`Case`; raises :class:`CaseError`.

    ``base_dir`` anchors a relative ``geometry.file``; ``source`` prefixes error messages.
    """
    if not isinstance(data, dict):
        raise CaseError("a case must be a TOML table of keys", source=source)
    if data.get("kind") == "run":
        raise CaseError(
            'kind = "run": a run case, not a model; use it with `quadmodes run` or '
            "`quadmodes reduce`, or give its model case here",
            source=source,
            field="kind",
        )
    return validate_table(Case, data, source, base_dir)


def case_from_toml(
    text: str, source: str = "<string>", base_dir: str | os.PathLike[str] | None = None
) -> Case:
    """Parse TOML text into a :class:`Case`; raises :class:`CaseError` (one line)."""
    return case_from_dict(parse_toml(text, source), source=source, base_dir=base_dir)


def load_case(name_or_path: str | os.PathLike[str]) -> Case:
    """Load a built-in case by name or a case from a ``.toml`` file path.

    A string without a path separator or ``.toml`` suffix is looked up among the built-in
    cases first. Raises :class:`CaseError` with a one-line message.
    """
    text = os.fspath(name_or_path)
    is_path = looks_like_path(name_or_path)
    if not is_path and text in builtin_case_names():
        return case_from_toml(builtin_case_text(text), source=f"{text}.toml")
    if not is_path and text in builtin_run_case_names(None):
        raise CaseError(
            f'"{text}" is a run case (kind = "run"); use `quadmodes run {text}`, or its model '
            f'"{builtin_run_model(text)}" here',
            field="case",
        )
    names = builtin_case_names() + builtin_run_case_names(None)
    content, folder = read_case_file(name_or_path, "case", names)
    return case_from_toml(content, source=text, base_dir=folder)
