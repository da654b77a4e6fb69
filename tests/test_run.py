"""Run cases and the ``reduce`` / ``run`` commands: case validation, the cached reduced model,
the results file (units, physics), the JSON summary, and early stops.

Fast: the small capsule of conftest (≈400 nodes, modes at 120–165 Hz) and runs of a few hundred
steps; the paper run cases are only loaded and validated.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SMALL_CAPSULE
from typer.testing import CliRunner

from quadmodes.case import (
    CaseError,
    builtin_case_names,
    builtin_run_case_names,
    load_case,
    load_run_case,
    run_case_from_toml,
)
from quadmodes.cli.app import app
from quadmodes.models import build as model_build
from quadmodes.models import cache as model_cache
from quadmodes.rom import artifact, integrators
from quadmodes.runs import chunked, simulate
from quadmodes.runs import results as res
from quadmodes.structure import pipeline

PAPER_RUNS = ["paper-0.5hz", "paper-41hz"]
SUMMARY_KEYS = {
    "H_relative_drift",
    "log_decrement",
    "cone_angle_start_deg",
    "cone_angle_end_deg",
    "spin_rate_start_hz",
    "spin_rate_end_hz",
    "energy_start_J",
    "energy_end_J",
    "dissipated_energy_J",
    "wall_s",
    "steps",
    "status",
}

def only_summary(stdout: str) -> dict:
    """The one summary of a `run --json` of one case (the payload is {case name: summary})."""
    payload = json.loads(stdout)
    assert isinstance(payload, dict) and len(payload) == 1, payload
    return next(iter(payload.values()))



def run_toml(
    *,
    spin: str = '"20 Hz"',
    cone: str = '"6 deg"',
    amplitude: str = '"0.2 in"',
    dt: str = '"0.2 ms"',
    duration: str = '"0.05 s"',
    method: str = '"midpoint"',
    formulation: str = '"Q"',
    save_every: str = "5",
    model: str = '"small.toml"',
) -> str:
    """A run case of the small capsule; keyword arguments are TOML source text."""
    return f"""
name = "small-run"
description = "small capsule, 20 Hz spin"
kind = "run"
model = {model}

[reduced]
modes = 5
formulation = {formulation}

[initial]
spin_rate = {spin}
cone_angle = {cone}
bending_amplitude = {amplitude}

[integration]
method = {method}
dt = {dt}
duration = {duration}
save_every = {save_every}
"""


@pytest.fixture
def workdir(tmp_path, monkeypatch, small_reduced_model) -> Path:
    """A folder with ``small.toml`` (the small capsule), a run case ``small-run.toml``, and a
    private cache (``$QUADMODES_CACHE``) seeded with the small capsule's reduced model."""
    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    (tmp_path / "small-run.toml").write_text(run_toml(), encoding="utf-8")
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    case = load_case(tmp_path / "small.toml")
    seeded = dataclasses.replace(
        small_reduced_model,
        provenance={"case": case.name, "content_key": model_cache.reduced_key(case, 5)},
    )
    artifact.save_reduced_model(seeded, model_cache.cache_path(case, 5))
    return tmp_path


@pytest.fixture
def many_chunks(monkeypatch):
    """The small runs (250–750 steps) chunked as longer ones are, without the floor of
    :data:`~quadmodes.runs.chunked.MIN_CHUNK_STEPS` steps a chunk (in this process), so that
    a test sees several chunks: progress and failures between them."""
    monkeypatch.setattr(chunked, "MIN_CHUNK_STEPS", 1)


def _undamped(model):
    return dataclasses.replace(
        model, C=np.zeros_like(model.C), damping_ratio=np.zeros_like(model.damping_ratio)
    )


# ----------------------------------------------------------------------------- run cases


def test_paper_run_cases_load_and_validate():
    names = ["paper-0.5hz", "paper-0.5hz-large", "paper-41hz", "paper-41hz-coarse",
             "paper-41hz-seed"]
    assert builtin_run_case_names() == ["ikaros-sail-nutation", "ikaros-sail-nutation-large", *names,
                                        "spinning-annulus-nutation",
                                        "spinning-annulus-nutation-large",
                                        "spinning-disc-nutation"]  # fmt: skip
    coarse = load_run_case("paper-41hz-coarse")
    assert coarse.model == "paper-membrane-coarse" and coarse.initial.spin_rate > 0
    assert not set(PAPER_RUNS) & set(builtin_case_names())  # model cases are unchanged
    slow, fast = (load_run_case(n) for n in PAPER_RUNS)
    for run in (slow, fast):
        assert run.kind == "run" and run.model == "paper-membrane"
        assert run.reduced.formulation == "Q" and run.reduced.reference == "spinning"
        assert math.isclose(run.initial.cone_angle, math.radians(6.0))
        assert run.integration.method == "midpoint"
        assert run.integration.dt <= 0.5e-3  # resolves the 38 Hz bending pair
        assert run_case_from_toml(run.to_toml()) == run  # SI round trip
        assert run.model_case() == load_case("paper-membrane")
    assert (slow.reduced.modes, fast.reduced.modes) == (5, "auto")  # the seed's five at 0.5 Hz
    seed = load_run_case("paper-41hz-seed")  # the seed's own choice at 41 Hz, a baseline
    assert (seed.reduced.modes, seed.reduced.reference) == (5, "rest")
    assert math.isclose(slow.initial.spin_rate, 2 * math.pi * 0.5)
    assert math.isclose(fast.initial.spin_rate, 2 * math.pi * 41.0)
    assert slow.initial.bending_amplitude > 0.0 and fast.initial.bending_amplitude == 0.0


def test_cases_command_lists_run_cases():
    result = CliRunner().invoke(app, ["cases"])
    assert result.exit_code == 0, result.output
    for name in PAPER_RUNS:
        line = next(s for s in result.stdout.splitlines() if name in s)
        assert "run" in line.replace(name, "")


@pytest.mark.parametrize(
    ("change", "field", "needle"),
    [
        ({"formulation": '"X"'}, "reduced.formulation", "must be"),
        ({"dt": '"-1 ms"'}, "integration.dt", "must be positive"),
        ({"dt": "0.5"}, "integration.dt", "has no unit"),
        ({"dt": '"2 s"', "duration": '"1 s"'}, "integration.dt", "longer than the duration"),
        ({"spin": '"3 m"'}, "initial.spin_rate", "expected an angular rate"),
        ({"cone": '"95 deg"'}, "initial.cone_angle", "cone_angle < 90 deg"),
        ({"method": '"rk4"'}, "integration.method", "must be"),
        ({"save_every": "0"}, "integration.save_every", "at least 1"),
        ({"model": '"nowhere.toml"'}, "model", "not found"),
    ],
)
def test_run_case_errors_are_one_line_and_name_the_field(tmp_path, change, field, needle):
    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    with pytest.raises(CaseError) as info:
        run_case_from_toml(run_toml(**change), source="bad.toml", base_dir=tmp_path)
    message = str(info.value)
    assert "\n" not in message
    assert info.value.field == field
    assert message.startswith(f"bad.toml: {field}") or field in message
    assert needle in message


def test_run_and_model_cases_are_not_confused():
    with pytest.raises(CaseError, match="quadmodes run paper-41hz"):
        load_case("paper-41hz")
    with pytest.raises(CaseError, match="model case, not a run case"):
        load_run_case("paper-membrane")


# ----------------------------------------------------------------------------- reduced model


def test_reduced_model_cache_is_hit_and_rebuilt_when_corrupt(tmp_path, monkeypatch):
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    case = load_case(tmp_path / "small.toml")
    info: dict = {}
    first = model_build.reduced_model_for(case, 5, info=info)
    assert info["cache"] == "miss" and Path(info["path"]).is_file()
    assert first.n_modes == 5 and first.provenance["case"] == "small-capsule"
    assert first.provenance["content_key"] == model_cache.reduced_key(case, 5)
    assert "case_toml" in first.provenance and int(first.provenance["n_nodes"]) > 100
    assert np.allclose(first.damping_ratio, case.material.damping_ratio)

    real_build = pipeline.build_modal_model

    def no_fe(*args, **kwargs):
        raise AssertionError("the finite-element model was built again")

    monkeypatch.setattr(pipeline, "build_modal_model", no_fe)
    info = {}
    second = model_build.reduced_model_for(case, 5, info=info)
    assert info["cache"] == "hit"
    assert np.array_equal(second.G, first.G) and second.labels == first.labels

    # the CLI uses the same cache, and -o writes a loadable copy
    out_file = tmp_path / "reduced.nc"
    result = CliRunner().invoke(
        app, ["reduce", str(tmp_path / "small.toml"), "-o", str(out_file), "--json"]
    )
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["cache"] == "hit" and summary["n_modes"] == 5
    assert artifact.load_reduced_model(out_file).provenance["content_key"] == summary["content_key"]

    Path(info["path"]).write_bytes(b"not a netcdf file")  # corrupt cache entry: rebuilt
    monkeypatch.setattr(pipeline, "build_modal_model", real_build)
    info = {}
    third = model_build.reduced_model_for(case, 5, info=info)
    assert info["cache"] == "rebuilt"
    assert np.allclose(third.frequencies_hz, first.frequencies_hz)
    assert artifact.load_reduced_model(info["path"]).n_modes == 5


# ----------------------------------------------------------------------------- simulate


def test_results_file_units_and_conservation(workdir, small_reduced_model):
    run = load_run_case(workdir / "small-run.toml")
    result = simulate.simulate(run, _undamped(small_reduced_model))
    assert result.complete and result.reason == ""
    summary = res.write_outputs(result, workdir / "out", plots=False)
    ds = res.load_results(workdir / "out" / "results.nc")
    assert ds["time"].attrs["units"] == "s"
    assert math.isclose(float(ds["time"][-1]), 0.05, rel_tol=1e-12)
    for name, var in ds.data_vars.items():
        assert var.attrs.get("units"), name
        assert var.attrs.get("long_name"), name
    for name in (
        "angular_momentum_norm",
        "angular_momentum",
        "kinetic_energy",
        "potential_energy",
        "total_energy",
        "dissipated_energy",
        "spin_rate",
        "spin_rate_hz",
        "cone_angle",
        "cone_angle_deg",
        "modal_coordinates",
        "modal_velocities",
        "omega_body",
        "quaternion",
    ):
        assert name in ds, name
    assert ds["modal_coordinates"].attrs["units"] == "m"  # modes normalised to 1 kg (io.cf)
    assert ds["modal_coordinates"].attrs["mass_normalised_units"] == "kg^0.5 m"
    assert list(ds["mode_label"].values) == list(small_reduced_model.labels)
    assert ds.attrs["complete"] == 1 and ds.attrs["method"] == "midpoint"
    assert ds.attrs["formulation"] == "Q" and "case_toml" in ds.attrs
    # physics: midpoint, no damping: H conserved (vector and norm), energy bounded, nothing lost
    h = ds["angular_momentum"].values
    hn = ds["angular_momentum_norm"].values
    assert np.max(np.abs(hn - hn[0])) / hn[0] < 1e-10
    assert np.max(np.linalg.norm(h - h[0], axis=1)) / hn[0] < 1e-10
    e = ds["total_energy"].values
    assert np.max(np.abs(e - e[0])) / e[0] < 1e-6
    assert np.all(ds["dissipated_energy"].values == 0.0)
    # initial conditions: spin and cone angle about the minor axis of the deformed inertia,
    # deformation in the first bending mode with the requested largest nodal displacement
    assert math.isclose(float(ds["spin_rate_hz"][0]), 20.0, rel_tol=1e-12)
    assert math.isclose(float(ds["cone_angle_deg"][0]), 6.0, rel_tol=1e-10)
    pair = [int(k) for k in ds.attrs["bending_modes"]]
    assert pair and all("bending" in str(ds["mode_label"].sel(mode=k).values) for k in pair)
    s0 = ds["modal_coordinates"].values[0]
    scale = ds.attrs["bending_displacement_per_unit"]
    assert math.isclose(s0[pair[0] - 1] * scale, 0.2 * 0.0254, rel_tol=1e-12)
    assert np.count_nonzero(s0) == 1
    assert summary["H_relative_drift"] < 1e-10


def test_chunk_sizes_left_to_the_run_have_a_floor():
    """Chunks are whole multiples of save_every; left to the run (max_chunks None) at most
    MAX_CHUNKS of at least MIN_CHUNK_STEPS steps (300 steps saved every 2: one chunk of 256
    and the rest, not 150 of 2); a count given is honoured as before."""
    floor, most = chunked.MIN_CHUNK_STEPS, chunked.MAX_CHUNKS
    for n, every in ((300, 2), (3000, 2), (10**6, 5), (7, 3), (250, 5)):
        chunk = chunked._chunk_steps(n, every)
        assert chunk % every == 0 and chunk >= floor and math.ceil(n / chunk) <= most
        assert chunk - every < max(floor, n / most)  # the smallest such multiple
        given = chunked._chunk_steps(n, every, 20)
        assert given == every * max(1, math.ceil(n / every / 20))


def test_chunked_run_is_continuous(workdir, small_reduced_model):
    run = load_run_case(workdir / "small-run.toml")
    model = _undamped(small_reduced_model)
    one = simulate.simulate(run, model, max_chunks=1).solution
    many = simulate.simulate(run, model, max_chunks=7).solution
    assert np.array_equal(one.t, many.t)
    scale = np.abs(one.y).max(axis=0) + 1e-30
    assert np.max(np.abs(one.y - many.y) / scale) < 1e-9


def test_summary_keys_log_decrement_and_consistency(workdir, small_reduced_model, many_chunks):
    run = load_run_case(workdir / "small-run.toml")
    run = simulate.apply_overrides(run, duration="0.15 s")
    progress: list[float] = []
    result = simulate.simulate(
        run, small_reduced_model, lambda stage, f: progress.append(f) if stage == run.name else None
    )
    assert progress[0] == 0.0 and progress[-1] == 1.0 and len(progress) > 10
    summary = res.write_outputs(result, workdir / "out", plots=True)
    assert SUMMARY_KEYS <= set(summary)
    ds = res.load_results(workdir / "out" / "results.nc")
    assert json.loads((workdir / "out" / "summary.json").read_text()) == summary
    assert res.summary(ds) == summary  # recomputed from the file alone
    assert summary["status"] == "complete" and summary["steps"] == ds.attrs["n_steps"] == 750
    assert summary["energy_start_J"] == float(ds["total_energy"][0])
    assert summary["energy_end_J"] == float(ds["total_energy"][-1])
    assert summary["dissipated_energy_J"] == float(ds["dissipated_energy"][-1])
    assert summary["cone_angle_end_deg"] == float(ds["cone_angle_deg"][-1])
    assert summary["spin_rate_end_hz"] == float(ds["spin_rate_hz"][-1])
    # damping: energy lost = energy dissipated (exact discrete balance of the midpoint)
    assert summary["dissipated_energy_J"] > 0
    drop = summary["energy_start_J"] - summary["energy_end_J"]
    assert math.isclose(drop, summary["dissipated_energy_J"], rel_tol=1e-6)
    # the initial bending deformation decays with the log decrement of the 2 % damping
    assert summary["log_decrement"] == pytest.approx(2 * math.pi * 0.02, rel=0.05)
    for name in ("summary", "angular_momentum", "bending_mode", "bending_mode_early", "energy"):
        assert (workdir / "out" / f"{name}.png").stat().st_size > 1000
    assert (workdir / "out" / "cone_angle.png").is_file()
    assert (workdir / "out" / "spin_rate.png").is_file()


def test_log_decrement_of_a_damped_oscillation():
    zeta, f = 0.02, 38.0
    w = 2 * math.pi * f
    t = np.arange(0, 2.0, 1e-3)
    a = np.abs(np.exp(-zeta * w * t) * np.cos(w * math.sqrt(1 - zeta**2) * t))
    fit = res.log_decrement(t, a, f)
    assert fit["log_decrement"] == pytest.approx(2 * math.pi * zeta, rel=0.01)


def test_rigid_formulation_runs_without_modes(workdir, small_reduced_model):
    run = simulate.apply_overrides(load_run_case(workdir / "small-run.toml"), formulation="rigid")
    result = simulate.simulate(run, small_reduced_model)
    assert result.complete and result.system.n_modes == 0
    summary = res.write_outputs(result, workdir / "rigid", plots=False)
    assert summary["log_decrement"] is None
    # rigid and nearly axisymmetric (mesh): the cone angle stays at 6 deg
    assert summary["cone_angle_end_deg"] == pytest.approx(6.0, abs=1e-4)
    assert summary["energy_end_J"] == pytest.approx(summary["energy_start_J"], rel=1e-9)
    assert res.load_results(workdir / "rigid" / "results.nc").sizes["mode"] == 0


def test_absurd_step_stops_the_run_cleanly(workdir, small_reduced_model):
    # 50 ms steps at 50 Hz spin (2.5 turns per step) with 150 Hz modes: Newton cannot converge
    text = run_toml(spin='"50 Hz"', amplitude='"2 in"', dt='"50 ms"', duration='"1 s"')
    run = run_case_from_toml(text, base_dir=workdir)
    with pytest.raises(CaseError, match="integration.dt"):  # refused up front (issue 24)
        simulate.simulate(run, small_reduced_model)
    result = simulate.simulate(run, small_reduced_model, allow_coarse_step=True)
    assert not result.complete and "midpoint" in result.reason
    assert result.solution.t[-1] < 1.0
    assert np.all(np.isfinite(result.solution.y))


# ----------------------------------------------------------------------------- the run command


def test_run_command_writes_results_and_json(workdir):
    out_dir = workdir / "out"
    result = CliRunner().invoke(
        app, ["run", str(workdir / "small-run.toml"), "-o", str(out_dir), "--json"]
    )
    assert result.exit_code == 0, result.output
    summary = only_summary(result.stdout)
    assert SUMMARY_KEYS <= set(summary) and summary["status"] == "complete"
    folder = out_dir / "small-run"
    ds = res.load_results(folder / "results.nc")
    assert ds.attrs["complete"] == 1
    assert summary == res.summary(ds)
    assert (folder / "summary.png").is_file() and (folder / "cone_angle.png").is_file()
    assert not list(out_dir.glob(".small-run.partial*"))


def test_run_command_overrides(workdir):
    out_dir = workdir / "out"
    result = CliRunner().invoke(
        app,
        [
            "run",
            str(workdir / "small-run.toml"),
            "-o",
            str(out_dir),
            "--json",
            "--dt",
            "0.1 ms",
            "--duration",
            "10 ms",
            "--method",
            "backward-euler",
            "--no-plots",
        ],
    )
    assert result.exit_code == 0, result.output
    summary = only_summary(result.stdout)
    assert summary["steps"] == 100 and summary["method"] == "backward-euler"
    assert summary["dt_s"] == pytest.approx(1e-4)


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--dt", "-1 ms"], "integration.dt"),
        (["--dt", "0.5"], "integration.dt"),
        (["--formulation", "X"], "reduced.formulation"),
        (["--method", "rk4"], "integration.method"),
    ],
)
def test_run_command_bad_input_exits_2_without_output(workdir, args, needle):
    out_dir = workdir / "out"
    result = CliRunner().invoke(
        app, ["run", str(workdir / "small-run.toml"), "-o", str(out_dir), *args]
    )
    assert result.exit_code == 2, result.output
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0]
    assert not out_dir.exists()


def test_run_command_unknown_case_exits_2(tmp_path):
    result = CliRunner().invoke(app, ["run", "paper-41h", "-o", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert 'did you mean "paper-41hz"' in result.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("failure", ["status", "nan"])
def test_integrator_failure_keeps_partial_results(workdir, monkeypatch, failure, many_chunks):
    real = integrators.integrate
    calls = {"n": 0}

    def failing(system, y0, t_span, *args, **kwargs):
        calls["n"] += 1
        sol = real(system, y0, t_span, *args, **kwargs)
        if calls["n"] < 3:
            return sol
        y = sol.y.copy()
        if failure == "nan":
            y[1:, 4] = np.nan
            return dataclasses.replace(sol, y=y)
        k = max(2, len(sol.t) // 2)
        return dataclasses.replace(
            sol,
            t=sol.t[:k],
            y=y[:k],
            dissipated=sol.dissipated[:k],
            status=1,
            message=f"midpoint: Newton did not converge at t = {sol.t[k - 1]:.6g} s (forced)",
        )

    monkeypatch.setattr(integrators, "integrate", failing)
    out_dir = workdir / "out"
    plots = ["--plots"] if failure == "status" else ["--no-plots"]
    result = CliRunner().invoke(
        app, ["run", str(workdir / "small-run.toml"), "-o", str(out_dir), "--json", *plots]
    )
    assert result.exit_code == 1, result.output
    warning = [s for s in result.stderr.splitlines() if s.startswith("warning:")]
    assert len(warning) == 1 and "stopped early" in warning[0]
    ds = res.load_results(out_dir / "small-run" / "results.nc")
    assert ds.attrs["complete"] == 0 and ds.attrs["status"] == "incomplete"
    reason = ds.attrs["incomplete_reason"]
    assert ("forced" in reason) if failure == "status" else ("non-finite" in reason)
    t = ds["time"].values
    assert 0.0 < t[-1] < 0.05 and np.all(np.diff(t) > 0)
    assert np.all(np.isfinite(ds["modal_coordinates"].values))
    summary = only_summary(result.stdout)
    assert summary["status"] == "incomplete" and summary["incomplete_reason"] == reason
    assert (out_dir / "small-run" / "summary.png").is_file() == (failure == "status")
