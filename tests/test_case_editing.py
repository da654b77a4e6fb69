"""One case-editing module (quadmodes.case.editing) for the run overrides, the sweep points and
the API: fields by dotted path or key tuple, validated again, the run keeps its model."""

from __future__ import annotations

import pytest

import quadmodes as qm
from quadmodes.case import CaseError, load_case, load_run_case
from quadmodes.case.editing import edit, merge, nested, set_field
from quadmodes.runs.simulate import apply_overrides
from quadmodes.sweeps.overrides import apply_values
from quadmodes.sweeps.params import SweepError, resolve_path


def test_set_field_creates_tables_indexes_arrays_and_drops_the_margin_of_whole_modes():
    data = {"reduced": {"modes": "auto", "mode_margin": 3.0}, "end_body": [{"mass": 1.0}]}
    set_field(data, "reduced.modes", 7)
    set_field(data, ("end_body", 0, "mass"), 2.0)
    set_field(data, "initial.spin_rate", "20 Hz")
    assert data == {"reduced": {"modes": 7}, "end_body": [{"mass": 2.0}],
                    "initial": {"spin_rate": "20 Hz"}}  # fmt: skip
    assert nested({"a.b": 1, "a": {"c": 2}}) == {"a": {"b": 1, "c": 2}}
    assert merge({"a": {"b": 1, "c": 1}}, {"a.c": 2}) == {"a": {"b": 1, "c": 2}}


def test_edit_validates_like_a_case_file_and_keeps_the_model():
    body = qm.model_case("paper-membrane-coarse", pressure={"value": "0.4 psi"})
    run = qm.run_case("paper-41hz-coarse", model=body)
    edited = edit(run, {"integration.dt": "0.1 ms"}, "command line")
    assert edited.integration.dt == pytest.approx(1e-4) and edited.model == body
    assert edit(run, [], "command line") is run
    with pytest.raises(CaseError, match=r"^command line: integration.dt"):
        edit(run, {"integration.dt": "-1 ms"}, "command line")
    model = edit(load_case("paper-membrane-coarse"), {"pressure.value": "0.4 psi"}, "--param")
    assert model.pressure == body.pressure


def test_runs_sweeps_and_the_api_edit_a_run_alike():
    run = load_run_case("paper-41hz-coarse")
    by_cli = apply_overrides(run, dt="0.1 ms", modes="7")
    by_api = qm.changed(run, integration={"dt": "0.1 ms"}, reduced={"modes": 7})
    path = resolve_path("integration.dt", run.model_case(), "--param")
    by_sweep = apply_values(run, run.model_case(), [(path, 1e-4)]).run
    assert by_cli.integration == by_api.integration == by_sweep.integration
    assert by_cli.reduced.modes == by_api.reduced.modes == 7
    with pytest.raises(SweepError, match=r"^p1: --param: integration.dt"):
        apply_values(run, run.model_case(), [(path, -1.0)], "p1")
