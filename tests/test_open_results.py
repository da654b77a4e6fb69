"""``qm.open_results``: results read back from the files of ``run``, ``compare``, ``campbell`` and
``sweep``, and figures redrawn from them that equal the commands' PNGs pixel for pixel; the
figures' envelopes and plain axis numbers (issue 28, items 5 and 8)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest
import xarray as xr
from conftest import SMALL_CAPSULE
from typer.testing import CliRunner

import quadmodes as qm
from quadmodes.case import load_case
from quadmodes.cli.app import app
from quadmodes.io.figures import new_figure, save_png
from quadmodes.models import cache as model_cache
from quadmodes.rom import artifact

RUN_TOML = """
name = "small-run"
description = "small capsule, 20 Hz spin, bending excited"
kind = "run"
model = "small.toml"
[reduced]
modes = 5
formulation = "Q"
[initial]
spin_rate = "20 Hz"
cone_angle = "6 deg"
bending_amplitude = "0.2 in"
[integration]
method = "midpoint"
dt = "0.2 ms"
duration = "0.04 s"
save_every = 5
"""

runner = CliRunner()


@pytest.fixture
def workdir(tmp_path, monkeypatch, small_reduced_model) -> Path:
    """The small capsule, its run case and a private cache seeded with its reduced model."""
    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    (tmp_path / "small-run.toml").write_text(RUN_TOML, encoding="utf-8")
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    case = load_case(tmp_path / "small.toml")
    seeded = dataclasses.replace(
        small_reduced_model,
        provenance={"case": case.name, "content_key": model_cache.reduced_key(case, 5)},
    )
    artifact.save_reduced_model(seeded, model_cache.cache_path(case, 5))
    return tmp_path


def _invoke(*args: str) -> None:
    result = runner.invoke(app, list(args))
    assert result.exit_code == 0, result.output


def _same_pictures(back, folder: Path, files: dict[str, str], scratch: Path, unit="Hz") -> None:
    """Every figure of ``back`` saved as the command saves it has exactly the pixels of the
    command's PNG ``folder / files[name]``."""
    assert set(files) == set(back.figure_names)
    for name, file in files.items():
        mine = save_png(back.plot(name, unit), scratch / f"{name}.png")
        a, b = mpimg.imread(mine), mpimg.imread(folder / file)
        assert a.shape == b.shape and np.array_equal(a, b), name


def test_a_run_read_back_draws_its_own_figures(workdir):
    _invoke("run", "small-run.toml", "-o", "out")
    folder = workdir / "out" / "small-run"
    back = qm.open_results(folder)  # the folder: results.nc found in it
    assert back.kind == "run" and back.path == folder / "results.nc"
    assert back.summary == json.loads((folder / "summary.json").read_text())
    with xr.open_dataset(folder / "results.nc", engine="h5netcdf") as ds:
        xr.testing.assert_identical(back.data, ds.load())
    names = {"angular_momentum", "bending_mode", "bending_mode_early", "energy", "spin_rate",
             "cone_angle", "summary"}  # fmt: skip
    _same_pictures(back, folder, {n: f"{n}.png" for n in names}, workdir)
    assert back.plot().axes[0].get_ylabel() == "cone angle (degree)"  # the default: the answer
    # without summary.json, the summary is the one qm.summary makes from the same data
    (folder / "summary.json").unlink()
    alone = qm.open_results(folder / "results.nc")
    assert alone.summary["cone_angle_end_deg"] == back.summary["cone_angle_end_deg"]
    with pytest.raises(qm.InputError, match="no figure 'cone'.*cone_angle"):
        back.plot("cone")
    with pytest.raises(qm.InputError, match="rpm"):
        back.plot("cone_angle", unit="furlongs")


def test_a_comparison_a_campbell_diagram_and_a_sweep_read_back(workdir):
    _invoke("compare", "small-run.toml", "--window", "4 ms", "--formulation", "rigid,Q",
            "-o", "cmp")  # fmt: skip
    back = qm.open_results(workdir / "cmp" / "comparison.nc")
    assert back.kind == "comparison" and back.summary["case"] == "small-run"
    stems = ("modal_amplitude", "cone_angle", "spin_rate", "angular_momentum", "energy")
    _same_pictures(back, workdir / "cmp", {s: f"compare_{s}.png" for s in stems}, workdir)

    _invoke("campbell", "kane-beam", "--spin-max", "0.5 Hz", "--points", "3", "--units", "rpm",
            "-o", "cb")  # fmt: skip
    back = qm.open_results(workdir / "cb")
    assert back.kind == "campbell" and back.summary["points"] == 3
    assert back.summary["spin_max_hz"] == pytest.approx(0.5)
    _same_pictures(back, workdir / "cb", {"campbell": "campbell.png"}, workdir, unit="rpm")

    _invoke("sweep", "small-run.toml", "--param", "initial.spin_rate=10 Hz:30 Hz:3",
            "--workers", "1", "-o", "sw")  # fmt: skip
    back = qm.open_results(workdir / "sw")
    assert back.kind == "sweep" and back.summary["points"] == 3
    files = {n: f"{n}.png" for n in ("campbell", "stability", "energy_sink")}
    _same_pictures(back, workdir / "sw", files, workdir)


def test_a_spinup_read_back(tmp_path):
    run = qm.run_case("kane-spinup", reduced={"modes": 2},
                      spinup={"duration": "1 s", "ramp_time": "0.5 s", "samples": 51})  # fmt: skip
    qm.write_results(qm.simulate(run), tmp_path / "spinup")
    back = qm.open_results(tmp_path / "spinup" / "results.nc")
    assert back.kind == "spin-up" and back.summary["case"] == "kane-spinup"
    _same_pictures(back, tmp_path / "spinup", {"tip_deflection": "tip_deflection.png"}, tmp_path)


def test_what_is_not_a_results_file_is_one_line(tmp_path):
    with pytest.raises(qm.InputError, match="does not exist"):
        qm.open_results(tmp_path / "nothing.nc")
    with pytest.raises(qm.InputError, match="holds no results.nc"):
        qm.open_results(tmp_path)
    xr.Dataset({"x": ("t", [1.0, 2.0])}).to_netcdf(tmp_path / "other.nc", engine="h5netcdf")
    with pytest.raises(qm.InputError, match="not a results file of quadmodes"):
        qm.open_results(tmp_path / "other.nc")
    (tmp_path / "text.nc").write_text("no NetCDF here", encoding="utf-8")
    with pytest.raises(qm.InputError, match="not a NetCDF file"):
        qm.open_results(tmp_path / "text.nc")


def _long_run(periods: float = 1000.0, f: float = 9.0) -> xr.Dataset:
    """A run dataset of ``periods`` periods of a bending coefficient whose amplitude decays as
    exp(−t/τ), sampled 20 times a period: the minimal variables the figures read."""
    t = np.linspace(0.0, periods / f, int(20 * periods) + 1)
    s = np.exp(-t / 40.0) * np.sin(2 * np.pi * f * t)
    mode = np.arange(1, 3)
    coords = {"time": t, "mode": mode, "mode_label": ("mode", ["bending", "bending"]),
              "mode_frequency_hz": ("mode", [f, f])}  # fmt: skip
    return xr.Dataset({"modal_coordinates": (("time", "mode"), np.stack([s, 0 * s], 1))},
                      coords, attrs={"case": "synthetic", "bending_modes": [1, 2]})  # fmt: skip


def test_a_long_oscillation_is_drawn_as_its_envelope():
    from quadmodes.io.plots import ENVELOPE_BINS, run_figure

    ds = _long_run()
    ax = run_figure(ds, "bending_mode").axes[0]
    lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]
    assert len(lines) == 2  # the max and the min, not the 20 000 samples
    s = ds["modal_coordinates"].values[:, 0]
    hi, lo = lines[0].get_ydata(), lines[1].get_ydata()
    assert len(hi) == ENVELOPE_BINS
    # each bin spans 2.5 periods, so its max and min are the decaying amplitude ±, within the
    # decay across one bin (0.28 s / 40 s) and the 20-samples-a-period sampling (1 − cos 9°)
    centres = np.asarray(lines[0].get_xdata())
    amplitude = np.exp(-centres / 40.0)
    assert np.allclose(hi, amplitude, rtol=0.02) and np.allclose(lo, -amplitude, rtol=0.02)
    assert hi.max() == s.max() and lo.min() == s.min()
    short = _long_run(periods=20.0)  # a few periods: the coefficient itself
    ax = run_figure(short, "bending_mode").axes[0]
    assert max(len(ln.get_xdata()) for ln in ax.get_lines()) == short.sizes["time"]


def test_no_axis_uses_offset_notation(tmp_path):
    fig = new_figure()
    ax = fig.add_subplot()
    ax.plot([0.0, 1.0], [41.0, 41.0003])  # matplotlib's default: "+4.1e1" and increments
    ax.secondary_yaxis("right")  # a secondary axis too
    save_png(fig, tmp_path / "f.png")
    for axis in (ax.xaxis, ax.yaxis, *(c.yaxis for c in ax.child_axes)):
        assert axis.get_major_formatter().get_offset() == ""
    labels = [t.get_text() for t in ax.get_yticklabels()]
    assert any(lab.startswith("41.000") for lab in labels), labels
