"""One command line (issue 13): --version, ``python -m quadmodes``, --quiet/--verbose, progress
without a terminal, --json on cases/calibrate/rotating, quantities for every dimensional option
(bare numbers still read in the documented unit, with a note), -o the output folder everywhere,
``run --help`` keeps ``[spinup]``."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from quadmodes import __version__
from quadmodes.case import builtin_case_names, builtin_run_case_names
from quadmodes.cli.analysis_commands import _parse_spins_hz
from quadmodes.cli.app import app
from quadmodes.cli.common import UserError, frequency_option


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))


def test_version_option_and_python_dash_m(runner):
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.stdout.strip() == f"quadmodes {__version__}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    run = subprocess.run([sys.executable, "-m", "quadmodes", "--help"], capture_output=True,
                         text=True, timeout=120, check=False, env=env)  # fmt: skip
    assert run.returncode == 0, run.stderr
    for command in ("run", "modes", "campbell", "compare", "--version", "--quiet", "--verbose"):
        assert command in run.stdout


def test_run_help_keeps_spinup_table_name(runner):
    result = runner.invoke(app, ["run", "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0 and "[spinup] table" in result.stdout


def test_cases_json_lists_every_builtin(runner):
    result = runner.invoke(app, ["cases", "--json"])
    assert result.exit_code == 0
    listing = json.loads(result.stdout)["cases"]
    names = [c["name"] for c in listing]
    assert names == builtin_case_names() + builtin_run_case_names(spinup=None)
    assert all(set(c) == {"name", "kind", "description"} for c in listing)


def test_progress_lines_without_a_terminal_and_quiet(runner, tmp_path):
    """Every command shows its stages when stderr is not a terminal; --quiet silences them."""
    out = tmp_path / "reduced"
    result = runner.invoke(app, ["reduce", "kane-beam", "--modes", "4", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "100 %" in result.stderr and (out / "reduced_model.nc").is_file()  # -o: a folder
    quiet = runner.invoke(app, ["--quiet", "reduce", "kane-beam", "--modes", "4", "--no-cache",
                                "-o", str(tmp_path / "old.nc")])  # fmt: skip
    assert quiet.exit_code == 0 and quiet.stderr == ""
    assert (tmp_path / "old.nc").is_file()  # a file name still works (deprecated)
    verbose = runner.invoke(app, ["--verbose", "reduce", "kane-beam", "--modes", "4", "--json"])
    assert verbose.exit_code == 0 and "cache hit" in verbose.stderr
    assert json.loads(verbose.stdout)["n_modes"] == 4


def test_file_name_for_o_is_deprecated_but_works(runner, tmp_path):
    result = runner.invoke(app, ["reduce", "kane-beam", "--modes", "4", "-o",
                                 str(tmp_path / "model.nc")])  # fmt: skip
    assert result.exit_code == 0 and (tmp_path / "model.nc").is_file()
    assert "-o takes the output folder" in " ".join(result.stderr.split())


def test_frequency_options_take_quantities_and_bare_hz(capsys):
    assert frequency_option("31.2 Hz", "--rocking") == pytest.approx(31.2)
    assert frequency_option("120 rpm", "--bending") == pytest.approx(2.0)
    assert frequency_option(f"{2 * math.pi * 5} rad/s", "--axial") == pytest.approx(5.0)
    assert frequency_option("38", "--bending") == 38.0  # as before, Hz
    assert "deprecated" in capsys.readouterr().err
    with pytest.raises(ValueError, match="--rocking.*a length"):
        frequency_option("3 m", "--rocking")


def test_spins_take_quantities_and_bare_hz():
    assert _parse_spins_hz("0 Hz, 20 Hz, 2460 rpm") == pytest.approx((0.0, 20.0, 41.0))
    assert _parse_spins_hz("0,20,41") == (0.0, 20.0, 41.0)
    for bad in ("a,b", "-5", "5 m", ""):
        with pytest.raises(UserError, match="--spin-rate"):
            _parse_spins_hz(bad)


def test_calibrate_and_rotating_offer_json(runner):
    for command in ("calibrate", "rotating", "cases", "campbell", "modes", "reduce", "run",
                    "compare"):  # fmt: skip
        result = runner.invoke(app, [command, "--help"], env={"COLUMNS": "200"})
        assert result.exit_code == 0 and "--json" in result.stdout, command
    result = runner.invoke(app, ["calibrate", "--help"], env={"COLUMNS": "200"})
    assert "31.2 Hz" in result.stdout and "folder" in result.stdout


def test_rotating_json_has_a_stable_shape(runner, tmp_path):
    """At rest the full-order linearisation is the modal analysis: Q matches the full order."""
    result = runner.invoke(app, ["rotating", "paper-membrane-coarse", "--spin-rate", "0 Hz", "--modes", "2", "--json",
                                 "--units", "rpm", "-o", str(tmp_path)])  # fmt: skip
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert set(payload) == {"case", "formulations", "spins_hz", "n_nodes", "rows",
                            "unmatched_full_order_roots", "text", "text_units"}  # fmt: skip
    # the numbers stay in Hz (keys *_hz); the printed table follows --units (1 Hz = 60 rpm)
    assert payload["text_units"] == "rpm" and "full order (rpm)" in payload["text"]
    first = next(r for r in payload["rows"] if r["full_hz"])
    assert f"{60.0 * first['full_hz']:.6g}" in payload["text"]
    assert payload["spins_hz"] == [0.0] and payload["formulations"] == ["Q", "L"]
    elastic = [r for r in payload["rows"] if r["label"] != "nutation" and r["full_hz"]]
    assert elastic and all(r["rom_hz"]["Q"] == pytest.approx(r["full_hz"], rel=1e-6)
                           for r in elastic)  # fmt: skip
    assert (tmp_path / "rotating.md").is_file()


def test_calibrate_json_and_output_folder(runner, tmp_path, monkeypatch):
    """calibrate --json: a stable JSON object; -o DIR writes DIR/calibrated.toml, which loads
    back to the calibrated case. The fit itself (minutes) is replaced by a stub that records
    the targets it was given (Hz, from quantities)."""
    import numpy as np

    from quadmodes.case import load_case
    from quadmodes.structure import calibrate as cal

    case = load_case("paper-membrane")
    seen = {}

    def fit(c, rocking_hz, bending_hz, axial_hz, progress=None):
        seen.update(rocking=rocking_hz, bending=bending_hz, axial=axial_hz)
        return cal.CalibrationResult(c, {b.name: b.mass for b in c.end_body},
                                     np.array([31.2, 31.2, 38.0, 38.0]), ["r", "r", "b", "b"],
                                     31.2, 38.0, None, 1)  # fmt: skip

    monkeypatch.setattr(cal, "calibrate_end_masses", fit)
    result = runner.invoke(app, ["calibrate", "--rocking", "1872 rpm", "--bending", "38",
                                 "--no-axial", "--json", "-o", str(tmp_path)])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert seen == {"rocking": pytest.approx(31.2), "bending": 38.0, "axial": None}
    payload = json.loads(result.stdout)
    assert set(payload) == {"case", "masses_kg", "end_bodies", "frequencies_hz", "labels",
                            "rocking_hz", "bending_hz", "axial_hz", "output", "case_toml"}  # fmt: skip
    assert payload["output"] == str(tmp_path / "calibrated.toml")
    assert load_case(tmp_path / "calibrated.toml") == case


def test_show_case_and_validate_offer_json(runner):
    """show-case --json is the TOML's content; validate --json gives {suite: [rows]}."""
    import tomllib

    toml_text = runner.invoke(app, ["show-case", "paper-0.5hz"]).stdout
    as_json = runner.invoke(app, ["show-case", "paper-0.5hz", "--json"])
    assert as_json.exit_code == 0 and json.loads(as_json.stdout) == tomllib.loads(toml_text)
    help_text = runner.invoke(app, ["validate", "--help"], env={"COLUMNS": "200"}).stdout
    assert "--json" in help_text
