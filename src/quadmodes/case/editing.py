"""Editing a case: set fields on its TOML table and validate the whole case again, exactly as a
case file is validated. The one place where a case is changed: the command-line overrides of a
run (:func:`quadmodes.runs.simulate.apply_overrides`), the values of a sweep point
(:func:`quadmodes.sweeps.overrides.apply_values`) and the Python API
(:func:`quadmodes.api.cases.changed`, the keyword tables of ``model_case`` / ``run_case``).

A field is named by a dotted path (``"integration.dt"``) or a key tuple (``("end_body", 0,
"mass")``: an int indexes an array of tables). Values are written as a case file would hold
them (quantity strings such as ``"0.25 ms"``, or SI floats), so a value the case rejects is
reported with the case's own one-line message, prefixed by ``source`` (where the change came
from: "command line", "--param", "run_case").

Provenance: the edited case is rebuilt from the case's own TOML (``case.to_toml()``, which
embeds a model built in Python), and an edited run case keeps the model it names
(``run.model``: a name, a path or an embedded :class:`~quadmodes.case.Case`, passed on as it
is rather than read back from its TOML), so its TOML replays the same model.
"""

from __future__ import annotations

import tomllib
from collections.abc import Iterable, Mapping
from typing import Any

from quadmodes.case.model_case import Case
from quadmodes.case.model_loading import case_from_dict
from quadmodes.case.run_case import RunCase
from quadmodes.case.run_loading import run_case_from_dict

#: A field: a dotted path or a tuple of keys (ints index arrays of tables).
FieldKeys = str | tuple


def case_table(case: Case | RunCase) -> dict[str, Any]:
    """The TOML table of ``case`` (nested dicts, SI values)."""
    return tomllib.loads(case.to_toml())


def keys_of(path: FieldKeys) -> tuple:
    """The key tuple of a dotted path (a tuple is returned as it is)."""
    return tuple(path.split(".")) if isinstance(path, str) else tuple(path)


def set_field(data: dict, path: FieldKeys, value) -> None:
    """Set ``data[k0][k1]...`` (creating missing tables; ints index arrays of tables). Setting
    ``reduced.modes`` to a whole number drops ``reduced.mode_margin`` (read only with
    ``modes = "auto"``)."""
    keys = keys_of(path)
    node = data
    for key in keys[:-1]:
        if isinstance(key, int):
            node = node[key]
        else:
            node = node.setdefault(key, [] if key == "end_body" else {})
    node[keys[-1]] = value
    if keys[-1] == "modes" and keys[0] == "reduced" and value != "auto":
        node.pop("mode_margin", None)


def nested(changes: Mapping[str, Any]) -> dict[str, Any]:
    """``changes`` with dotted keys (``"pressure.value"``) turned into nested dicts."""
    out: dict[str, Any] = {}
    for key, value in changes.items():
        *parents, last = str(key).split(".")
        table = out
        for name in parents:
            table = table.setdefault(name, {})
        if isinstance(value, Mapping) and isinstance(table.get(last), dict):
            table[last] = merge(table[last], value)
        else:
            table[last] = dict(value) if isinstance(value, Mapping) else value
    return out


def merge(base: dict[str, Any], changes: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``changes`` merged in, table by table (a nested dict updates a table; any
    other value, e.g. a list of ``end_body`` tables or a :class:`Case`, replaces it)."""
    merged = dict(base)
    for key, value in nested(changes).items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = merge(merged[key], value)
        else:
            merged[key] = value
    return merged


def validated(kind: type, data: dict[str, Any], source: str) -> Case | RunCase:
    """``data`` validated as a case of ``kind`` (:class:`Case` or :class:`RunCase`) like a case
    file; raises :class:`~quadmodes.case.CaseError` (one line, prefixed by ``source``)."""
    if kind is RunCase:
        return run_case_from_dict(data, source=source)
    return case_from_dict(data, source=source)


def edit(
    case: Case | RunCase, changes: Iterable[tuple[FieldKeys, Any]] | Mapping[str, Any],
    source: str,
) -> Case | RunCase:  # fmt: skip
    """``case`` with every ``(field, value)`` of ``changes`` set on its TOML table and
    validated again (a run case keeps its model object, see the module docstring); ``case``
    itself when there is nothing to change. Raises :class:`~quadmodes.case.CaseError`."""
    items = list(changes.items() if isinstance(changes, Mapping) else changes)
    if not items:
        return case
    data = case_table(case)
    for path, value in items:
        set_field(data, path, value)
    if isinstance(case, RunCase):
        data["model"] = case.model
        return validated(RunCase, data, source)
    return validated(Case, data, source)
