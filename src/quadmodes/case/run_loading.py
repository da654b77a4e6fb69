"""Loading run cases: from a parsed table, TOML text, a built-in name or a run-case file.

A run case loads only if its model loads too.
"""

from __future__ import annotations

import os
from typing import Any

from quadmodes.case.builtin import (
    builtin_case_names,
    builtin_case_text,
    builtin_run_case_names,
)
from quadmodes.case.errors import CaseError
from quadmodes.case.run_case import RunCase
from quadmodes.case.toml_reading import looks_like_path, parse_toml, read_case_file, validate_table


def run_case_from_dict(
    data: dict[str, Any], source: str | None = None, base_dir: str | os.PathLike[str] | None = None
) -> RunCase:
    """Validate parsed TOML data into a :class:`RunCase` and check that its model loads;
    raises :class:`CaseError` (one line naming the field). ``base_dir`` anchors a relative
    ``model`` path."""
    if not isinstance(data, dict):
        raise CaseError("a run case must be a TOML table of keys", source=source)
    kind = data.get("kind")
    if kind in ("membrane", "beam"):
        raise CaseError(
            f'kind = "{kind}": a model case, not a run case; a run case has kind = "run", '
            'model = "<this case>", [initial] and [integration] tables '
            "(see `quadmodes show-case paper-41hz`)",
            source=source,
            field="kind",
        )
    run = validate_table(RunCase, data, source, base_dir)
    try:
        run.model_case()
    except CaseError as exc:
        raise CaseError(exc.detail, source=source, field="model") from None
    return run


def run_case_from_toml(
    text: str, source: str = "<string>", base_dir: str | os.PathLike[str] | None = None
) -> RunCase:
    """Parse TOML text into a :class:`RunCase`; raises :class:`CaseError` (one line)."""
    return run_case_from_dict(parse_toml(text, source), source=source, base_dir=base_dir)


def load_run_case(name_or_path: str | os.PathLike[str]) -> RunCase:
    """Load a built-in run case by name or a run case from a ``.toml`` file path; raises
    :class:`CaseError` with a one-line message."""
    text = os.fspath(name_or_path)
    is_path = looks_like_path(name_or_path)
    if not is_path and text in builtin_run_case_names(None):
        return run_case_from_toml(builtin_case_text(text), source=f"{text}.toml")
    if not is_path and text in builtin_case_names():
        runs = ", ".join(builtin_run_case_names(None))
        raise CaseError(
            f'"{text}" is a model case, not a run case; built-in run cases are: {runs} '
            f'(or write a run case with model = "{text}")',
            field="case",
        )
    content, folder = read_case_file(name_or_path, "run case", builtin_run_case_names(None))
    return run_case_from_toml(content, source=text, base_dir=folder)
