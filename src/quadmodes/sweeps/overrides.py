"""Applying sweep values to a run case and its model case, validated like a case file.

A value is written back into the case's TOML table in SI (``"2068.4 Pa"``, ``"257.6 rad/s"``)
and the whole case is validated again (:func:`quadmodes.case.editing.edit`, which keeps the
run's model), so a value the case would reject (a negative mass, a cone
angle of 95 deg) is reported with the case's own one-line message, prefixed by the point.
"""

from __future__ import annotations

from dataclasses import dataclass

from quadmodes.case import Case, CaseError, RunCase
from quadmodes.case.editing import edit
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


def apply_values(run: RunCase, model_case: Case, values: list[tuple[FieldPath, object]],
                 label: str = "") -> PointCase:  # fmt: skip
    """``run`` and ``model_case`` with every (path, value) set; raises :class:`SweepError`
    (``label`` names the point in the message) for a value the case rejects."""
    run_changes = [(p.keys, _toml_value(p, v)) for p, v in values if p.target == "run"]
    model_changes = [(p.keys, _toml_value(p, v)) for p, v in values if p.target == "model"]
    where = f"{label}: " if label else ""
    try:
        run = edit(run, run_changes, "--param")
        model_case = edit(model_case, model_changes, "--param")
    except CaseError as exc:
        raise SweepError(f"{where}{exc}") from None
    return PointCase(run, model_case)
