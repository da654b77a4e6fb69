"""The built-in cases: the TOML files shipped in ``quadmodes/case/builtin``.

A file with ``kind = "run"`` is a run case; every other file is a model case (membrane or
beam). Run cases with a ``[spinup]`` table are hub-driven spin-ups, the others free-body runs.
"""

from __future__ import annotations

import difflib
import functools
import tomllib
from importlib import resources
from typing import Any

from quadmodes.case.errors import CaseError


def _cases_dir() -> Any:
    return resources.files("quadmodes.case").joinpath("builtin")


@functools.cache
def _builtin_tables() -> dict[str, dict[str, Any] | None]:
    """``{name: parsed TOML (None if it does not parse)}`` of the built-in case files."""
    tables: dict[str, dict[str, Any] | None] = {}
    for entry in _cases_dir().iterdir():
        if entry.name.endswith(".toml") and entry.is_file():
            name = entry.name[: -len(".toml")]
            try:
                tables[name] = tomllib.loads(entry.read_text(encoding="utf-8"))
            except tomllib.TOMLDecodeError:
                tables[name] = None
    return tables


def _is_run(table: dict[str, Any] | None) -> bool:
    return table is not None and table.get("kind") == "run"


def builtin_case_names() -> list[str]:
    """Names of the built-in model cases (membrane and beam TOML files shipped in
    ``quadmodes/case/builtin``), sorted; run cases are listed by :func:`builtin_run_case_names`."""
    return sorted(name for name, table in _builtin_tables().items() if not _is_run(table))


def builtin_run_case_names(spinup: bool | None = False) -> list[str]:
    """Names of the built-in run cases (``kind = "run"``), sorted.

    ``spinup``: False (default) the free-body runs (``[initial]`` + ``[integration]``, e.g. the
    paper cases), True the hub-driven spin-ups (``[spinup]``, e.g. ``kane-spinup``), None both.
    Name look-ups (:func:`load_run_case`, ``show-case``) accept both kinds."""
    return sorted(
        name
        for name, table in _builtin_tables().items()
        if _is_run(table) and (spinup is None or ("spinup" in table) == spinup)
    )


def builtin_run_model(name: str) -> str:
    """The ``model`` of built-in run case ``name`` (a built-in model case name)."""
    table = _builtin_tables()[name]
    assert table is not None
    return str(table["model"])


def builtin_case_text(name: str) -> str:
    """TOML text of a built-in case (model or run); raises :class:`CaseError` for an unknown
    name."""
    if name not in builtin_case_names() and name not in builtin_run_case_names(None):
        names = builtin_case_names() + builtin_run_case_names(None)
        raise CaseError(unknown_name_message("case", name, names), field="case")
    return _cases_dir().joinpath(f"{name}.toml").read_text(encoding="utf-8")


def unknown_name_message(what: str, name: str, names: list[str]) -> str:
    """Message for an unknown built-in ``what`` ("case", "run case") ``name``, with the closest
    of ``names``."""
    close = difflib.get_close_matches(name, names, n=1)
    hint = f'did you mean "{close[0]}"? ' if close else ""
    return (
        f'unknown {what} "{name}"; {hint}built-in {what}s are: {", ".join(names)} '
        "(or give the path of a .toml file)"
    )
