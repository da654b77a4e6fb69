"""``quadmodes run CASE --step-tolerance 1e-4``: the controlled step of ``integration.step_tolerance``
set from the command line, through the same edit and validation as the case field (library =
CLI): the same run, bit for bit, as the case holding the field, |H| kept to round-off across the
step changes; bad values refused in one line naming the field, exit 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_run import run_toml, workdir  # noqa: F401  (fixture)
from typer.testing import CliRunner

from quadmodes.cli.app import app
from quadmodes.runs import results as res


def _run(workdir, case: str, out: str, *extra: str):  # noqa: F811
    got = CliRunner().invoke(app, ["run", str(workdir / case), "-o", str(workdir / out), "--json",
                                   "--no-plots", *extra])  # fmt: skip
    return got


def test_the_flag_runs_what_the_case_field_runs(workdir):  # noqa: F811
    base = run_toml(duration='"0.3 s"')
    (workdir / "flag.toml").write_text(base, encoding="utf-8")
    (workdir / "field.toml").write_text(base + "step_tolerance = 1e-4\n", encoding="utf-8")
    by_flag = _run(workdir, "flag.toml", "a", "--step-tolerance", "1e-4")
    by_field = _run(workdir, "field.toml", "b")
    assert by_flag.exit_code == 0 and by_field.exit_code == 0, by_flag.output + by_field.output
    s_flag = json.loads(by_flag.stdout)["small-run"]
    s_field = json.loads(by_field.stdout)["small-run"]
    assert s_flag["step_tolerance"] == s_field["step_tolerance"] == 1e-4
    # a controlled step: it changed the step and probed it, and kept |H| through the changes
    assert 0 < s_flag["dt_min_s"] <= s_flag["dt_max_s"] and s_flag["probe_steps"] > 0
    assert not s_flag["dt_min_s"] == s_flag["dt_max_s"] == 0.2e-3  # controlled from dt 0.2 ms
    assert s_flag["H_norm_relative_drift"] < 1e-12
    a = res.load_results(workdir / "a" / "small-run" / "results.nc")
    b = res.load_results(workdir / "b" / "small-run" / "results.nc")
    assert a.attrs["step_tolerance"] == 1e-4 and a.attrs["n_steps"] == b.attrs["n_steps"]
    np.testing.assert_array_equal(a["time"].values, b["time"].values)
    np.testing.assert_array_equal(a["modal_coordinates"].values, b["modal_coordinates"].values)


@pytest.mark.parametrize("extra, words", [
    (["--step-tolerance", "2"], "0 < value < 1"),
    (["--step-tolerance", "0"], "0 < value < 1"),
    (["--step-tolerance", "abc"], "number"),
    (["--step-tolerance", "1 s"], "dimensionless"),
    (["--step-tolerance", "1e-4", "--method", "backward-euler"], 'needs method "midpoint"'),
])  # fmt: skip
def test_a_bad_tolerance_is_one_line_naming_the_field(workdir, extra, words):  # noqa: F811
    got = _run(workdir, "small-run.toml", "out", *extra)
    assert got.exit_code == 2, got.output
    text = " ".join(got.output.split())
    assert "integration.step_tolerance" in text and words in text
    assert len(got.output.strip().splitlines()) == 1
    assert not (workdir / "out" / "small-run").exists()
