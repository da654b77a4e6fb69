"""The initial deformation beside the FE model's condensed energy (runs.deformation_check)."""

import math
import tomllib

import pytest

from quadmodes.case import load_run_case, run_case_from_dict
from quadmodes.runs import simulate
from quadmodes.runs.validity import DEFORMATION_ENERGY_TOLERANCE


def bending_run(amplitude_in: float):
    """paper-0.5hz on the coarse mesh (5 modes about the 0.5 Hz state), ``amplitude_in``."""
    data = tomllib.loads(load_run_case("paper-0.5hz").to_toml())
    data["model"] = "paper-membrane-coarse"
    data["initial"]["bending_amplitude"] = f"{amplitude_in} in"
    return run_case_from_dict(data, source="test")


@pytest.fixture(scope="module")
def checked():
    return {a: simulate.prepare(bending_run(a), check_deformation=True).validity
            for a in (0.05, 0.1, 2.0)}  # fmt: skip


def test_small_deformation_agrees_and_error_grows_with_amplitude(checked):
    small, double, large = checked[0.05], checked[0.1], checked[2.0]
    assert small.deformation_energy_condensed > 0
    assert small.deformation_error < 2e-3 and small.valid
    # both energies agree to second order: the error is O(amplitude) relative (cubic terms)
    ratio = double.deformation_error / small.deformation_error
    assert 1.5 < ratio < 2.6
    assert large.deformation_error > DEFORMATION_ENERGY_TOLERANCE
    assert not large.valid and "initial.bending_amplitude" in large.message()
    d = large.as_dict()
    assert d["initial_deformation_energy_error"] == pytest.approx(large.deformation_error)


def test_no_deformation_no_check():
    run = bending_run(0.0)
    validity = simulate.prepare(run, check_deformation=True).validity
    assert math.isnan(validity.deformation_error) and validity.valid


def test_run_command_flags_a_large_initial_deformation(tmp_path):
    """`quadmodes run` checks the deformation, warns in one line and records both energies."""
    import json

    from typer.testing import CliRunner

    from quadmodes.cli import app

    case = tmp_path / "bend2.toml"
    case.write_text(bending_run(2.0).to_toml())
    result = CliRunner().invoke(app, ["run", str(case), "--duration", "0.02 s", "--no-plots",
                                      "-o", str(tmp_path / "out")])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "initial.bending_amplitude" in result.output
    summary = json.loads(next((tmp_path / "out").rglob("summary.json")).read_text())
    v = summary["validity"]
    assert summary["valid"] is False
    red, cond = v["initial_deformation_energy_reduced_J"], v["initial_deformation_energy_condensed_J"]
    assert red > cond > 0 and (red - cond) / cond > 0.02
    # 2 in is far beyond where the membrane first loses tension along the bending mode
    assert 0 < v["slack_onset_amplitude_m"] < 0.0254 * 0.5
    assert v["slack_onset_fraction_of_initial_deformation"] < 0.25


def test_slack_onset_is_a_property_of_the_direction_not_of_the_amplitude(checked):
    """The linearised onset of wrinkling along the bending mode is the same length whatever the
    initial amplitude; 2 in lies far beyond it and the warning says so."""
    small, large = checked[0.05], checked[2.0]
    assert small.slack_onset_amplitude == pytest.approx(large.slack_onset_amplitude, rel=1e-9)
    assert 0.0 < large.slack_onset_amplitude < 0.0254 * 0.5
    assert large.slack_onset_fraction < 1.0 and large.slack_fraction > small.slack_fraction
    assert "loses tension" in large.message()
    assert large.as_dict()["slack_onset_amplitude_m"] == pytest.approx(large.slack_onset_amplitude)
