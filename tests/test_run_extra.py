"""Run extras: the validity check of the reduced model at the run's spin (rotating-frame
stiffness), the hub-driven ``kane-spinup`` run case, and ``run --dt-convergence``.

The small capsule of conftest (modes at 122–165 Hz) loses rotating-frame stiffness for
formulation L between 100 and 150 Hz of spin and for Q only above 150 Hz, so a 150 Hz spin
separates the two. The Kane spin-up takes ≈ 3 s (Q) and ≈ 1 s (L, stopped when it diverges).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import SMALL_CAPSULE
from test_run import run_toml, workdir  # noqa: F401  (fixture)
from typer.testing import CliRunner

from quadmodes.case import (
    CaseError,
    builtin_run_case_names,
    load_run_case,
    run_case_from_toml,
)
from quadmodes.cli.app import app
from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys
from quadmodes.runs import results as res
from quadmodes.runs import simulate
from quadmodes.runs.spinup import KANE_REFERENCE_PEAKS

# ----------------------------------------------------------------------------- validity

def only_summary(stdout: str) -> dict:
    """The one summary of a `run --json` of one case (the payload is {case name: summary})."""
    payload = json.loads(stdout)
    assert isinstance(payload, dict) and len(payload) == 1, payload
    return next(iter(payload.values()))



@pytest.mark.parametrize("formulation", ["L", "Q"])
def test_validity_of_the_small_capsule_at_150_hz(tmp_path, small_reduced_model, formulation):
    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    text = run_toml(spin='"150 Hz"', formulation=f'"{formulation}"')
    run = run_case_from_toml(text, source="fast.toml", base_dir=tmp_path)
    setup = simulate.prepare(run, small_reduced_model)
    v = setup.validity
    assert v.spin_rate == pytest.approx(2 * math.pi * 150, rel=1e-2)
    if formulation == "L":
        assert not v.valid and v.min_eigenvalue < 0
        # the loss is bracketed: positive just below, not positive just above
        lost = v.lost_at
        assert 2 * math.pi * 100 < lost < 2 * math.pi * 150
        omega0 = rsys.split_state(setup.system, setup.initial.y0)[1]
        below = omega0 * (0.99 * lost / v.spin_rate)
        above = omega0 * (1.01 * lost / v.spin_rate)
        assert rf.rotating_stiffness_is_positive(setup.system, below)
        assert not rf.rotating_stiffness_is_positive(setup.system, above)
        assert "rad/s" in v.message() and "not positive definite" in v.message()
    else:
        assert v.valid and v.min_eigenvalue > 0 and v.lost_at is None and v.message() == ""


@pytest.mark.parametrize("formulation", ["L", "Q"])
def test_run_command_warns_and_json_says_so(workdir, formulation):  # noqa: F811
    (workdir / "spin150.toml").write_text(
        run_toml(
            spin='"150 Hz"',
            formulation=f'"{formulation}"',
            duration='"0.002 s"',
            amplitude='"0 in"',
        ),
        encoding="utf-8",
    )
    out_dir = workdir / "out"
    result = CliRunner().invoke(
        app, ["run", str(workdir / "spin150.toml"), "-o", str(out_dir), "--json", "--no-plots"]
    )
    warnings = [s for s in result.stderr.splitlines() if "outside its validity" in s]
    summary = only_summary(result.stdout)
    ds = res.load_results(out_dir / "small-run" / "results.nc")
    if formulation == "L":
        assert len(warnings) == 1 and "rad/s" in warnings[0]
        assert summary["valid"] is False and summary["rotating_stiffness_min_eigenvalue"] < 0
        assert summary["validity"]["lost_at_spin_rate_rad_s"] < 2 * math.pi * 150
        assert ds.attrs["valid"] == 0 and ds.attrs["rotating_stiffness_min_eigenvalue"] < 0
    else:
        assert not warnings
        # valid at its spin; along its path (the centrifugal transient of a model about the
        # state at rest started undeformed at 150 Hz) the FE model does not condense
        assert summary["valid_at_start"] is True and summary["valid"] is False
        assert summary["rotating_stiffness_min_eigenvalue"] > 0
        assert summary["validity"]["lost_at_spin_rate_rad_s"] is None
        assert ds.attrs["valid"] == 1 and np.isnan(ds.attrs["validity_lost_at_spin_rate"])


# ----------------------------------------------------------------------------- kane-spinup


def test_kane_spinup_case_loads_and_overrides():
    assert builtin_run_case_names(spinup=True) == ["heliogyro-spinup", "kane-spinup"]
    assert "kane-spinup" in builtin_run_case_names(None)
    assert "kane-spinup" not in builtin_run_case_names()  # the free-body runs (paper cases)
    run = load_run_case("kane-spinup")
    assert run.model == "kane-beam" and run.initial is None and run.integration is None
    assert run.spinup.omega_s == 6.0 and run.spinup.ramp_time == 15.0
    assert run_case_from_toml(run.to_toml()) == run
    fast = simulate.apply_overrides(run, spin_rate="10 rad/s", duration="20 s")
    assert fast.spinup.omega_s == 10.0 and fast.spinup.duration == 20.0
    with pytest.raises(CaseError, match="not used by a hub-driven spin-up"):
        simulate.apply_overrides(run, dt="1 ms")
    with pytest.raises(CaseError, match="spinup"):
        simulate.prepare(run)


def test_kane_spinup_cli_q_matches_kane(tmp_path):
    result = CliRunner().invoke(app, ["run", "kane-spinup", "-o", str(tmp_path / "out"), "--json"])
    assert result.exit_code == 0, result.output
    summary = only_summary(result.stdout)
    peak, when = KANE_REFERENCE_PEAKS[6.0]
    assert summary["status"] == "ok" and summary["valid"] is True
    assert summary["peak_tip_deflection_m"] == pytest.approx(peak, rel=0.03)
    assert abs(summary["peak_time_s"] - when) <= 0.2
    assert 0 <= summary["max_abs_after_spinup_m"] < 0.05
    folder = tmp_path / "out" / "kane-spinup"
    assert (folder / "tip_deflection.png").is_file() and (folder / "summary.json").is_file()
    ds = res.load_results(folder / "results.nc")
    assert ds.attrs["complete"] == 1
    assert ds["tip_inplane"].attrs["units"] == "m" and ds["tip_displacement"].shape[1] == 3
    assert ds["modal_coordinates"].shape == (ds.sizes["time"], 4)
    assert ds["time"].values[-1] == pytest.approx(30.0)


def test_kane_spinup_cli_l_diverges_with_exit_1(tmp_path):
    out_dir = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["run", "kane-spinup", "--formulation", "L", "-o", str(out_dir), "--json"]
    )
    assert result.exit_code == 1, result.output
    assert any("outside its validity" in s and "3.79" in s for s in result.stderr.splitlines())
    summary = only_summary(result.stdout)
    assert summary["status"] == "diverged" and summary["complete"] is False
    assert summary["valid"] is False
    assert summary["validity"]["lost_at_spin_rate_rad_s"] == pytest.approx(3.80, abs=0.02)
    ds = res.load_results(out_dir / "kane-spinup" / "results.nc")
    assert ds.attrs["complete"] == 0 and ds.attrs["status"] == "diverged"
    assert 0 < ds["time"].values[-1] < 30.0


# ----------------------------------------------------------------------------- dt convergence


def test_dt_convergence_table_and_json(workdir):  # noqa: F811
    out_dir = workdir / "out"
    result = CliRunner().invoke(
        app,
        [
            "run",
            str(workdir / "small-run.toml"),
            "-o",
            str(out_dir),
            "--duration",
            "0.01 s",
            "--dt-convergence",
            "--no-plots",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "time-step convergence" in result.stdout
    saved = json.loads((out_dir / "small-run" / "summary.json").read_text())
    rows = saved["dt_convergence"]["rows"]
    assert "verdict:" in result.stdout and saved["dt_convergence"]["text"]
    assert len(rows) == 3
    assert [r["dt_s"] for r in rows] == pytest.approx([2e-4, 1e-4, 5e-5])
    assert [r["steps"] for r in rows] == [50, 100, 200]
    assert rows[0]["rel_change_cone_angle_deg"] is None
    assert all(r["t_end_s"] == pytest.approx(0.01) for r in rows)
    # midpoint is second order: the change shrinks about fourfold per halving
    assert rows[2]["rel_change_spin_rate_hz"] < rows[1]["rel_change_spin_rate_hz"]
    json_run = CliRunner().invoke(
        app,
        [
            "run",
            str(workdir / "small-run.toml"),
            "-o",
            str(out_dir),
            "--duration",
            "0.01 s",
            "--dt-convergence",
            "--no-plots",
            "--json",
        ],
    )
    assert json_run.exit_code == 0
    assert len(only_summary(json_run.stdout)["dt_convergence"]["rows"]) == 3


def test_dt_convergence_rejects_adaptive_and_spinup(workdir):  # noqa: F811
    bad = CliRunner().invoke(
        app, ["run", str(workdir / "small-run.toml"), "--method", "adaptive", "--dt-convergence"]
    )
    assert bad.exit_code == 2 and "fixed-step" in bad.stderr
    bad = CliRunner().invoke(app, ["run", "kane-spinup", "--dt-convergence"])
    assert bad.exit_code == 2 and "DOP853" in bad.stderr
