"""``quadmodes sweep``: parameter parsing and bad input, the energy-sink estimate against an
analytic case and against the damped linearisation, sweeps on a LocalCluster and on a scheduler
and worker started as separate processes, and resume.

Fast: the small capsule of conftest (modes at 115–165 Hz, about the state at rest, its reduced
model seeded into a private cache) and time runs of 0.05 s.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from conftest import SMALL_CAPSULE, assert_cf_file
from typer.testing import CliRunner

from quadmodes.case import load_case, load_run_case
from quadmodes.cli.app import app
from quadmodes.models import cache as model_cache
from quadmodes.rom import artifact
from quadmodes.rom import energy_sink as es
from quadmodes.rom import system as rsys
from quadmodes.sweeps.engine import plan_sweep
from quadmodes.sweeps.params import SweepError, grid, parse_param

pytest.importorskip("distributed")

RUN = """name = "small-run"
kind = "run"
model = "small.toml"
[reduced]
modes = 5
[initial]
spin_rate = "20 Hz"
cone_angle = "6 deg"
[integration]
dt = "0.2 ms"
duration = "0.05 s"
save_every = 5
"""

runner = CliRunner()


@pytest.fixture
def folder(tmp_path, monkeypatch, small_reduced_model) -> Path:
    """``small.toml``, ``small-run.toml`` and a private cache seeded with the small capsule's
    reduced model (N = 5, about the state at rest)."""
    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    (tmp_path / "small-run.toml").write_text(RUN, encoding="utf-8")
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    case = load_case(tmp_path / "small.toml")
    seeded = dataclasses.replace(
        small_reduced_model,
        provenance={"case": case.name, "content_key": model_cache.reduced_key(case, 5)},
    )
    artifact.save_reduced_model(seeded, model_cache.cache_path(case, 5))
    return tmp_path


# ------------------------------------------------------------------------ parameters


def test_ranges_lists_and_units_become_si_values():
    p = parse_param("initial.spin_rate=1 Hz:45 Hz:45")
    assert p.name == "spin_rate" and p.swept and len(p.values) == 45
    assert math.isclose(p.values[0], 2 * math.pi) and math.isclose(p.values[-1], 90 * math.pi)
    assert p.path.unit == "rad/s" and p.path.target == "run"
    q = parse_param("pressure.value=0.2 psi, 0.3 psi")
    assert q.path.target == "model" and q.path.unit == "Pa"
    assert np.allclose(q.values, [1378.95, 2068.43], rtol=1e-5)
    d = parse_param("integration.duration=2 s")
    assert not d.swept and d.values == (2.0,)
    m = parse_param("reduced.formulation=Q,L")
    assert m.values == ("Q", "L") and m.path.dimension is None


def test_end_body_by_index_or_name():
    case = load_case("paper-membrane-coarse")
    by_name = parse_param("end_body.rear.mass=0.1 kg, 0.2 kg", case)
    by_index = parse_param("end_body[1].mass=0.1 kg, 0.2 kg", case)
    assert by_name.path.keys == by_index.path.keys == ("end_body", 1, "mass")
    assert by_name.values == by_index.values == (0.1, 0.2)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("initial.spin_rat=1 Hz:4 Hz:4", 'did you mean "initial.spin_rate"'),
        ("presure.value=1 psi", 'did you mean "pressure.value"'),
        ("initial.spin_rate=1 Hz:45 Hz:0", "is empty"),
        ("initial.spin_rate=1:45:45", "has no unit"),
        ("initial.spin_rate=", "no values"),
        ("initial.spin_rate=1 Hz:45 m:4", "expected an angular rate"),
        ("initial=1 Hz", "is a table"),
        ("initial.spin_rate", "PATH=VALUES"),
    ],
)
def test_bad_parameters_are_one_line_errors(text, expected):
    with pytest.raises(SweepError) as info:
        parse_param(text)
    assert expected in str(info.value) and "\n" not in str(info.value)


def test_product_and_zip():
    a = parse_param("initial.spin_rate=1 Hz, 2 Hz, 3 Hz")
    b = parse_param("initial.cone_angle=1 deg, 2 deg")
    assert len(grid([a, b])) == 6
    with pytest.raises(SweepError, match="differ in length"):
        grid([a, b], zipped=True)
    c = parse_param("initial.cone_angle=1 deg, 2 deg, 3 deg")
    assert grid([a, c], zipped=True) == [(0, 0), (1, 1), (2, 2)]


def test_plan_applies_values_and_rejects_bad_ones(folder):
    run = load_run_case(folder / "small-run.toml")
    params = [parse_param("pressure.value=0.2 psi, 0.4 psi"),
              parse_param("initial.spin_rate=10 Hz")]  # fmt: skip
    plan = plan_sweep(run, params)
    assert len(plan.points) == 2
    assert all(math.isclose(p.case.run.initial.spin_rate, 20 * math.pi) for p in plan.points)
    assert [round(p.case.model_case.pressure.value) for p in plan.points] == [1379, 2758]
    with pytest.raises(SweepError, match="cone_angle"):
        plan_sweep(run, [parse_param("initial.cone_angle=10 deg, 95 deg")])


# ------------------------------------------------------------------------ energy sink


def test_energy_sink_of_a_damped_oscillator_on_a_spinning_rigid_body():
    """A point mass m on a spring k and damper c along body e1, at distance d along the spin
    axis e3 from the centre of mass, on a rigid body nutating at ω = Ω e3 + ω_t (cos νt e1 +
    sin νt e2). The e1 component of its acceleration in the body frame gives, to first order,
    m ẍ + c ẋ + (k − m Ω²) x = −m d (ω1 Ω + ω̇2) = −m d ω_t (Ω + ν) cos νt,
    so P = ½ c ν² F² / ((k − mΩ² − mν²)² + (cν)²), F = m d ω_t (Ω + ν)."""
    m, k, c, d = 0.05, 4.0e4, 0.3, 0.4
    ia, it = 0.02, 0.11  # a prolate (minor-axis) spinner
    spin, cone = 2 * math.pi * 20.0, math.radians(3.0)
    nu = (ia - it) / it * spin
    w_t = ia / it * spin * math.tan(cone)
    force = m * d * w_t * (spin + nu)
    s_hat = es.steady_response([[m]], [[c]], [[k - m * spin**2]], [-force], nu)
    power = es.mean_dissipated_power([[c]], s_hat, nu)
    exact = 0.5 * c * nu**2 * force**2 / ((k - m * spin**2 - m * nu**2) ** 2 + (c * nu) ** 2)
    assert math.isclose(power, exact, rel_tol=1e-12)
    # energy-sink law: θ̇ = −P / (dT/dθ) at constant H, T = H²/2 (cos²θ/I_a + sin²θ/I_t)
    h = ia * spin / math.cos(cone)
    kinetic = lambda th: 0.5 * h**2 * (math.cos(th) ** 2 / ia + math.sin(th) ** 2 / it)  # noqa: E731
    slope = (kinetic(cone + 1e-6) - kinetic(cone - 1e-6)) / 2e-6
    rate = es.energy_sink_cone_rate(power, ia, it, spin, cone)
    assert rate > 0 and math.isclose(rate, -power / slope, rel_tol=1e-6)
    assert es.energy_sink_cone_rate(power, it, ia, spin, cone) < 0  # major-axis spin: decays


@pytest.mark.parametrize("spin_hz", [10.0, 30.0])
def test_energy_sink_matches_the_damped_nutation_root(small_reduced_model, spin_hz):
    """Quasi-rigid (modes far above the nutation): the energy-sink coning rate equals the real
    part of the nutation root of the damped linearisation (two independent routes)."""
    from quadmodes.analysis.campbell import campbell

    sys_q = rsys.reduced_system(small_reduced_model, "Q")
    spin = 2 * math.pi * spin_hz
    res = campbell(small_reduced_model, [spin], damped=True)
    root = res.growth[0][res.labels.index("nutation")]
    sink = es.energy_sink(sys_q, res.s_eq[0], res.spin_axis[0] * spin, math.radians(1.0))
    assert sink.quasi_rigid and sink.growth_rate > 0 and root > 0
    assert math.isclose(sink.growth_rate, root, rel_tol=0.02)
    assert math.isclose(sink.time_constant, 1 / sink.growth_rate)


# ------------------------------------------------------------------------ sweeps


def _sweep(*args: str):
    return runner.invoke(app, ["sweep", "small-run.toml", *args])


def test_spin_sweep_on_a_local_cluster_and_resume(folder):
    args = ["--param", "initial.spin_rate=10 Hz:40 Hz:4", "--workers", "2", "-o", "out", "--json"]
    first = _sweep(*args)
    assert first.exit_code == 0, first.output
    info = json.loads(first.stdout)
    assert info["points"] == 4 and info["failed"] == 0 and info["resumed"] == 0
    ds = xr.open_dataset(folder / "out" / "sweep.nc")
    assert ds["spin_rate"].attrs["units"] == "rad/s" and ds.sizes["spin_rate"] == 4
    assert np.allclose(ds["spin_rate"].values, 2 * math.pi * np.array([10, 20, 30, 40]))
    cone = [v for v in ds.data_vars if "cone" in v and "rate" in v]
    assert "cone_growth_rate" in cone and any(v.startswith("critical_speed") for v in ds.data_vars)
    for name, var in ds.data_vars.items():
        assert "units" in var.attrs and "long_name" in var.attrs, name
    growth = ds["energy_sink_growth_rate"].values
    assert np.all(growth > 0) and np.all(np.diff(growth) > 0)  # minor-axis spinner: grows faster
    assert np.all(ds["complete"].values == 1)
    inside = ds["path_in_range"].values  # the path's validity per point, not only the start's
    assert set(np.unique(inside)) <= {0.0, 1.0} and np.all(ds["path_valid"].values == 0)
    assert np.all(np.isnan(ds["path_left_range_at"].values[inside == 1]))
    assert np.all(ds["path_left_range_at"].values[inside == 0] > 0)
    assert ds.attrs["Conventions"].startswith("CF-") and ds["branch"].values[0] == 1
    assert_cf_file(folder / "out" / "sweep.nc")
    page = (folder / "out" / "report.html").read_text()  # self-contained: no external resource
    assert "Critical speeds" in page and "Headline numbers per point" in page
    assert "time runs along their path" in page
    assert "data:image/png;base64," in page and "http://" not in page and "https://" not in page
    points = sorted((folder / "out" / "points").glob("point-*.json"))
    assert len(points) == 4
    kept = points[0].stat().st_mtime_ns
    points[-1].unlink()  # as if the sweep had stopped before its last point
    second = _sweep(*args)
    assert second.exit_code == 0, second.output
    assert json.loads(second.stdout)["resumed"] == 3
    assert points[0].stat().st_mtime_ns == kept and points[-1].is_file()
    again = xr.open_dataset(folder / "out" / "sweep.nc")
    assert np.allclose(again["energy_sink_growth_rate"].values, growth, rtol=1e-12)


def test_a_failing_point_is_reported_alone(folder):
    """One mode (an ovalling mode) cannot carry the initial bending deformation: that point
    fails with the case's message, the other is kept."""
    result = _sweep("--param", "reduced.modes=5,1", "--param", "initial.bending_amplitude=0.1 in",
                    "--no-time-run", "--workers", "1", "-o", "out", "--json")  # fmt: skip
    assert result.exit_code == 1, result.output
    info = json.loads(result.stdout)
    assert info["failed"] == 1 and "modes = 1" in next(iter(info["failures"].values()))
    ds = xr.open_dataset(folder / "out" / "sweep.nc")
    assert list(ds["failed"].values) == [0, 1] and np.isfinite(ds["nutation_growth_rate"][0])


def test_bad_input_is_one_line_and_writes_nothing(folder):
    for args in (["--param", "initial.spin_rat=1 Hz:4 Hz:4"],
                 ["--param", "initial.spin_rate=1 Hz:4 Hz:0"],
                 ["--param", "initial.spin_rate=1:4:4"],
                 ["--param", "initial.spin_rate=1 Hz,2 Hz", "--scheduler", "tcp://127.0.0.1:9"]):  # fmt: skip
        result = _sweep(*args, "-o", "bad")
        assert result.exit_code == 2, result.output
        lines = [line for line in result.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("error:"), result.stderr
        assert not (folder / "bad").exists()
    assert "did you mean" in _sweep("--param", "initial.spin_rat=1 Hz:4 Hz:4").stderr


def _wait_for(path: Path, seconds: float = 60.0) -> None:
    end = time.monotonic() + seconds
    while not path.is_file() and time.monotonic() < end:
        time.sleep(0.2)
    assert path.is_file(), f"{path} did not appear"


def test_sweep_on_a_scheduler_and_worker_in_separate_processes(folder):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), "OPENBLAS_NUM_THREADS": "1"}
    bindir = Path(sys.executable).parent
    info = folder / "scheduler.json"
    procs = [subprocess.Popen([str(bindir / "dask"), "scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file", str(info)],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]  # fmt: skip
    try:
        _wait_for(info)
        procs.append(subprocess.Popen([str(bindir / "dask"), "worker", "--scheduler-file",
                                       str(info), "--nthreads", "1", "--no-dashboard"],
                                      env=env, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL))  # fmt: skip
        address = json.loads(info.read_text())["address"]
        result = _sweep("--param", "initial.spin_rate=10 Hz, 30 Hz", "--scheduler", address,
                        "-o", "remote", "--json")  # fmt: skip
        assert result.exit_code == 0, result.output
        assert json.loads(result.stdout)["failed"] == 0
        ds = xr.open_dataset(folder / "remote" / "sweep.nc")
        assert np.all(ds["energy_sink_growth_rate"].values > 0)
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in procs:
            proc.wait(timeout=30)


def test_sweep_table_in_the_run_case_and_a_spin_pressure_map(folder):
    """A ``[sweep]`` table in the run-case file; two swept parameters give two dimensions and the
    stability colour map; a higher pressure stiffens the modes (the rotating frequencies rise)."""
    text = RUN + '\n[sweep]\nparam = ["initial.spin_rate=10 Hz, 30 Hz", ' \
        '"pressure.value=0.3 psi, 0.6 psi"]\n'
    (folder / "swept.toml").write_text(text, encoding="utf-8")
    result = runner.invoke(app, ["sweep", "swept.toml", "--no-time-run", "--workers", "1",
                                 "-o", "map", "--json"])  # fmt: skip
    assert result.exit_code == 0, result.output
    ds = xr.open_dataset(folder / "map" / "sweep.nc")
    assert dict(ds["energy_sink_growth_rate"].sizes) == {"spin_rate": 2, "value": 2}
    assert ds["value"].attrs["units"] == "Pa"
    top = ds["branch_frequency"].max("branch")
    assert np.all(top.isel(value=1) > top.isel(value=0))
    assert (folder / "map" / "stability.png").is_file()
    assert np.all(np.isnan(ds["cone_growth_rate"].values))  # no time runs


def test_zipped_dataset_has_one_dimension_and_the_other_lists_as_coordinates(folder):
    from quadmodes.sweeps.dataset import sweep_dataset
    from quadmodes.sweeps.engine import SweepOutcome

    run = load_run_case(folder / "small-run.toml")
    params = [parse_param("initial.spin_rate=10 Hz, 20 Hz, 30 Hz"),
              parse_param("initial.cone_angle=1 deg, 2 deg, 3 deg")]  # fmt: skip
    plan = plan_sweep(run, params, zipped=True)
    fake = {"branch_label": ["nutation"], "branch_frequency": [1.0],
            "branch_growth_undamped": [0.0], "branch_growth": [1e-3], "energy_sink_growth_rate": 2.0}  # fmt: skip
    ds = sweep_dataset(plan, SweepOutcome([fake, None, fake]))
    assert list(ds["energy_sink_growth_rate"].dims) == ["spin_rate"]
    assert ds["cone_angle"].dims == ("spin_rate",) and ds["cone_angle"].attrs["units"] == "rad"
    assert np.allclose(ds["cone_angle"].values, np.radians([1, 2, 3]))
    assert list(ds["failed"].values) == [0, 1, 0]
    assert np.isnan(ds["energy_sink_growth_rate"].values[1])


def test_a_worker_that_dies_costs_only_its_point(folder):
    """The task of the 20 Hz point kills its worker process on every try: after one retry on
    another worker that point is reported failed; the other points are computed and saved."""
    from quadmodes.sweeps import engine

    def crashing(case, group, position, time_run):  # pickled by value (a local function)
        import os as _os

        from quadmodes.sweeps.points import run_point

        if abs(case.run.initial.spin_rate - 40 * math.pi) < 1e-9:
            _os._exit(1)
        return run_point(case, group[0], group[1][position], time_run)

    run = load_run_case(folder / "small-run.toml")
    plan = plan_sweep(run, [parse_param("initial.spin_rate=10 Hz, 20 Hz, 30 Hz")], time_run=False)
    with engine.dask_client(2) as client:
        outcome = engine.execute(plan, folder / "out", client, point_task=crashing)
    assert list(outcome.failures) == [1] and "KilledWorker" in outcome.failures[1]
    assert outcome.results[0] is not None and outcome.results[2] is not None
    assert len(list((folder / "out" / "points").glob("point-*.json"))) == 2
