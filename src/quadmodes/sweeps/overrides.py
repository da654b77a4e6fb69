"""Applying sweep values to a run case and its model case, validated like a case file.

A value is written back into the case's TOML table in SI (``"2068.4 Pa"``, ``"257.6 rad/s"``)
and the whole case is validated again (:func:`quadmodes.case.run_case_from_dict`,
:func:`quadmodes.case.case_from_dict`), so a value the case would reject (a negative mass, a cone
angle of 95 deg) is reported with the case's own one-line message, prefixed by the point.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass

from quadmodes.case import Case, CaseError, RunCase, case_from_dict, run_case_from_dict
from quadmodes.sweeps.params import FieldPath, SweepError


@dataclass(frozen=True, eq=False)
class PointCase:
    """The inputs of one sweep point: the run case and its model case with the point's values."""

    run: RunCase
    model_case: Case


def _toml_value(path: FieldPath, value):
    """``value`` as it would be written in the TOML file (a quantity string in SI)."""
    if path.dimension is None:
        return value
    if path.dimension == "dimensionless":
        return float(value)
    return f"{float(value)!r} {path.unit}"


def _set(data: dict, keys: tuple, value) -> None:
    """Set ``data[k0][k1]...`` (creating missing tables; ints index arrays of tables)."""
    node = data
    for key in keys[:-1]:
        if isinstance(key, int):
            node = node[key]
        else:
            node = node.setdefault(key, [] if key == "end_body" else {})
    node[keys[-1]] = value
    if keys[-1] == "modes" and keys[0] == "reduced" and value != "auto":
        node.pop("mode_margin", None)  # read only with modes = "auto"


def apply_values(run: RunCase, model_case: Case, values: list[tuple[FieldPath, object]],
                 label: str = "") -> PointCase:  # fmt: skip
    """``run`` and ``model_case`` with every (path, value) set; raises :class:`SweepError`
    (``label`` names the point in the message) for a value the case rejects."""
    run_data = tomllib.loads(run.to_toml()) if any(p.target == "run" for p, _ in values) else None
    model_data = (tomllib.loads(model_case.to_toml())
                  if any(p.target == "model" for p, _ in values) else None)  # fmt: skip
    for path, value in values:
        _set(run_data if path.target == "run" else model_data, path.keys, _toml_value(path, value))
    where = f"{label}: " if label else ""
    try:
        if run_data is not None:
            run_data["model"] = run.model
            run = run_case_from_dict(run_data, source="--param")
        if model_data is not None:
            model_case = case_from_dict(model_data, source="--param")
    except CaseError as exc:
        raise SweepError(f"{where}{exc}") from None
    return PointCase(run, model_case)
