"""A run case: a model (built-in name or case file) with the reduced model, initial conditions
and integration settings of one run, and its TOML text.

:func:`run_case_to_toml` writes a run case in SI units; the text loads back to an equal run.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Self

from pydantic import (
    BeforeValidator,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from quadmodes.case.builtin import builtin_case_names
from quadmodes.case.errors import CaseError, case_error
from quadmodes.case.fields import (
    FieldMeta,
    Section,
    choice,
    field_error,
    text,
    toml_value,
    valid_name,
)
from quadmodes.case.model_case import Case, case_tables
from quadmodes.case.model_loading import load_case
from quadmodes.case.run_sections import RunInitial, RunIntegration, RunReduced, RunSpinup
from quadmodes.case.toml_writing import section_lines, toml_document
from quadmodes.case.units import format_quantity


def _model_value(value: Any, info: ValidationInfo) -> Any:
    """``model`` given as a table (a whole model case inside the run case): validated as a
    :class:`Case`; an error names the field below ``model``."""
    if not isinstance(value, dict):
        return value
    try:
        return Case.model_validate(value, context=info.context)
    except ValidationError as exc:
        problem = case_error(exc, None, Case)
        detail = problem.detail
        if problem.field and detail.startswith(f"{problem.field}: "):
            detail = detail[len(problem.field) + 2 :]
        ctx = {"detail": detail, "sub": problem.field} if problem.field else {"detail": detail}
        raise PydanticCustomError("case_rule", "{detail}", ctx) from None


class RunCase(Section):
    """A run: integrate a model's reduced equations from given initial conditions.

    ``model`` is a built-in case name, the path of a case file (relative paths are taken from
    the run-case file) or the model case itself (a :class:`Case`; in TOML a ``[model]`` table
    with ``[model.geometry]`` ... below it), so that a run records exactly the model it ran. A free-body run has ``[initial]`` and ``[integration]``; a hub-driven
    spin-up of a clamped beam has ``[spinup]`` instead."""

    name: text("my-run")
    description: text("what this run is for") = ""
    kind: choice("run")
    model: Annotated[str | Case, BeforeValidator(_model_value), FieldMeta('"paper-membrane"')]
    reduced: RunReduced = Field(default_factory=RunReduced)
    initial: RunInitial | None = None
    integration: RunIntegration | None = None
    spinup: RunSpinup | None = None

    @model_validator(mode="after")
    def check_tables(self) -> Self:
        if self.spinup is not None:
            for table in ("initial", "integration"):
                if getattr(self, table) is not None:
                    raise field_error(
                        "case_rule",
                        f"not used with [spinup] (hub-driven spin-up); remove the [{table}] "
                        "table or the [spinup] table",
                        table,
                    )
            change = self.spinup.omega_0 > 0.0  # a spin change of a free body on a hub
            if self.reduced.reference == "spinning" and not change:
                raise field_error(
                    "case_rule",
                    'is for free-body runs (about the spin of [initial]) and spin changes from '
                    'spinup.omega_0 > 0; a [spinup] from rest is expanded about the state at '
                    'rest: use "rest"',
                    "reduced.reference",
                )
            if change and self.reduced.reference != "spinning":
                raise field_error(
                    "case_rule",
                    '"rest": a spin change from spinup.omega_0 > 0 is expanded about that '
                    'spinning state; use reference = "spinning"',
                    "reduced.reference",
                )
            if self.reduced.modes == "auto":
                raise field_error(
                    "case_rule",
                    '"auto" needs a free-body run\'s spin rate; a [spinup] takes a whole '
                    "number of modes, e.g. 2",
                    "reduced.modes",
                )
            return self
        for table in ("initial", "integration"):
            if getattr(self, table) is None:
                raise field_error(
                    "case_rule",
                    "missing; a free-body run needs [initial] and [integration] tables "
                    "(or [spinup] for a hub-driven spin-up of a clamped beam)",
                    table,
                )
        return self

    @field_validator("name")
    @classmethod
    def check_name(cls, value: str) -> str:
        return valid_name(value, "my-run")

    @field_validator("model")
    @classmethod
    def resolve_model(cls, value: str | Case, info: ValidationInfo) -> str | Case:
        if isinstance(value, Case):
            return value
        if not value.strip():
            raise field_error("case_value", 'must name a model case; use e.g. "paper-membrane"')
        if value in builtin_case_names():
            return value
        base = (info.context or {}).get("base_dir")
        path = Path(value).expanduser()
        if base is not None and not path.is_absolute():
            return str(Path(base) / path)
        return value

    def model_case(self) -> Case:
        """The model (membrane or beam case); raises :class:`CaseError` naming ``model``."""
        if isinstance(self.model, Case):
            return self.model
        try:
            return load_case(self.model)
        except CaseError as exc:
            raise CaseError(
                f"model = {toml_value(self.model)}: {exc}", source=f"{self.name}", field="model"
            ) from None

    @property
    def model_name(self) -> str:
        """The model's built-in name or file path, or the name of an embedded model case."""
        return self.model.name if isinstance(self.model, Case) else self.model

    def with_model(self, case: Case) -> RunCase:
        """This run case, recording ``case`` as its model: unchanged if ``model`` already loads
        to an equal case, else with ``case`` embedded (so that its TOML replays exactly)."""
        if isinstance(self.model, Case) and self.model == case:
            return self
        if isinstance(self.model, str):
            try:
                if self.model_case() == case:
                    return self
            except CaseError:
                pass
        return self.model_copy(update={"model": case})

    @property
    def reference_spin(self) -> float:
        """Spin (rad/s) of the state the reduced model is expanded about: the initial spin rate
        with ``reduced.reference = "spinning"``, else 0 (the prestressed state at rest)."""
        if self.reduced.reference != "spinning":
            return 0.0
        if self.spinup is not None:
            return float(self.spinup.omega_0)
        return float(self.initial.spin_rate)

    @property
    def reference_axis(self) -> str | None:
        """The body axis the spinning reference turns about: ``initial.spin_axis`` with
        ``reduced.reference = "spinning"`` (None: the minor axis, or a flat membrane's normal)."""
        if self.spinup is not None and self.reference_spin:
            return "major"  # a spin change turns a body on a hub about its major axis
        if not self.reference_spin or self.initial.spin_axis in (None, "minor"):
            return None
        return self.initial.spin_axis

    def to_toml(self) -> str:
        """This run case as TOML text in SI units (see :func:`run_case_to_toml`)."""
        return run_case_to_toml(self)


def _initial_lines(initial: RunInitial) -> list[str]:
    """``[initial]`` lines, the spin rate also in Hz as a comment."""
    hz = format_quantity(initial.spin_rate / (2.0 * math.pi), "Hz")
    return [
        f"{line}  # {hz}" if line.startswith("spin_rate") else line
        for line in section_lines(initial)
    ]


def run_case_to_toml(run: RunCase) -> str:
    """TOML text for ``run`` with quantities in SI units (comments give familiar units);
    ``run_case_from_toml(run_case_to_toml(run)) == run``. An embedded model case is written as
    a ``[model]`` table (and ``[model.geometry]`` ...) after the run's own tables."""
    tables = [
        (f"[{name}]", _initial_lines(section) if name == "initial" else section_lines(section))
        for name in ("reduced", "initial", "integration", "spinup")
        if (section := getattr(run, name)) is not None
    ]
    keys: dict[str, object] = {"name": run.name, "description": run.description, "kind": run.kind}
    if isinstance(run.model, Case):
        tables += case_tables(run.model, prefix="model")
    else:
        keys["model"] = run.model
    return toml_document(f"quadmodes run case {run.name!s}: quantities in SI units", keys, tables)
