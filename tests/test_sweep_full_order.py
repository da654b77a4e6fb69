"""Full-order linearisation markers on the Campbell diagrams (``quadmodes campbell --full-order``,
``quadmodes sweep --full-order``), the sweep's spin axis (``--axis``) and its Zarr output
(``--format zarr``, automatic above a size).

The small capsule of conftest (free, prolate; its full order has 1.5k DOFs), so each
full-order linearisation takes seconds.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from conftest import SMALL_CAPSULE
from test_sweep import _sweep, folder  # noqa: F401  (the fixture)
from typer.testing import CliRunner

from quadmodes.analysis.campbell import campbell
from quadmodes.analysis.campbell_output import to_dataset, write_campbell
from quadmodes.analysis.full_order_markers import (
    FullOrderMarkers,
    from_record,
    full_order_markers,
    markers_from_dataset,
    relabel,
    to_record,
)
from quadmodes.case import case_from_toml, load_run_case
from quadmodes.cli.app import app
from quadmodes.sweeps import store
from quadmodes.sweeps.dataset import sweep_dataset
from quadmodes.sweeps.engine import SweepOutcome
from quadmodes.sweeps.points import run_point
from quadmodes.sweeps.run import plan_from_texts

runner = CliRunner()
TWO_PI = 2 * math.pi


@pytest.fixture(scope="module")
def markers(small_reduced_model) -> FullOrderMarkers:
    case = case_from_toml(SMALL_CAPSULE, source="small-capsule")
    return full_order_markers(case, small_reduced_model, [0.0, TWO_PI * 20.0])


def _one_line_error(result) -> str:
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1 and lines[0].startswith("error:"), result.output
    return lines[0]


def test_full_order_markers_at_rest_are_the_modal_frequencies(markers, small_reduced_model):
    """At rest the full-order linearisation is the modal problem the reduced model came from."""
    matched = markers.matched[0] & (markers.label[0] != "nutation")
    full = np.sort(markers.frequency[0][matched]) / TWO_PI
    np.testing.assert_allclose(full, np.sort(small_reduced_model.frequencies_hz), rtol=1e-6)


def test_full_order_markers_follow_the_reduced_branches(markers, small_reduced_model):
    """At 20 Hz every matched full-order root is within 1 % of the reduced branch of its label
    (the spinning-state comparison of docs/full-order.md, here on the small capsule)."""
    reduced = campbell(small_reduced_model, markers.spin)  # tracked from rest, as the labels
    by_label = dict(zip(reduced.labels, reduced.frequency[1], strict=True))
    matched = np.flatnonzero(markers.matched[1])
    assert matched.size >= small_reduced_model.n_modes  # every elastic branch and the nutation
    for j in matched:
        label = str(markers.label[1, j])
        assert label in by_label
        assert markers.frequency[1, j] == pytest.approx(by_label[label], rel=0.01), label
    assert set(markers.label[1][~markers.matched[1]]) <= {"tilt", "other", ""}
    again = from_record(json.loads(json.dumps(to_record(markers))))
    np.testing.assert_array_equal(again.label, markers.label)
    np.testing.assert_allclose(again.frequency, markers.frequency, equal_nan=True)


def test_campbell_files_carry_the_markers_with_units(markers, small_reduced_model, tmp_path):
    result = campbell(small_reduced_model, TWO_PI * np.linspace(0.0, 20.0, 3))
    paths = write_campbell(result, tmp_path, markers=markers)
    with xr.open_dataset(paths["nc"], engine="h5netcdf") as ds:
        assert ds["full_order_frequency"].dims == ("full_order_spin", "full_order_root")
        assert ds["full_order_frequency"].attrs["units"] == "rad/s"
        assert ds["full_order_spin"].attrs["units"] == "rad/s"
        for name in ds.variables:
            if str(name).startswith("full_order"):
                assert ds[name].attrs["units"] and ds[name].attrs["long_name"], name
        np.testing.assert_allclose(ds["full_order_frequency"].values, markers.frequency,
                                   equal_nan=True)  # fmt: skip
        back = markers_from_dataset(ds)
        assert list(back.label[1]) == list(markers.label[1])
    assert paths["png"].stat().st_size > 0
    assert "full_order_frequency" not in to_dataset(result)
    named = relabel(markers, result.spin, result.frequency, result.labels)  # the figure's names
    assert set(named.label[named.matched]) <= set(result.labels)


def test_campbell_full_order_bad_input_is_one_line(tmp_path):
    line = _one_line_error(runner.invoke(app, ["campbell", "kane-beam", "--spin-max", "6 rad/s",
                                               "--full-order", "1 rad/s", "-o", str(tmp_path / "k")]))  # fmt: skip
    assert "--full-order" in line and "clamped" in line
    line = _one_line_error(runner.invoke(app, ["campbell", "small.toml", "--full-order", "20",
                                               "-o", str(tmp_path / "u")]))  # fmt: skip
    assert "--full-order" in line
    assert not (tmp_path / "k").exists() and not (tmp_path / "u").exists()


def test_sweep_with_full_order_markers_to_zarr(folder):  # noqa: F811
    pytest.importorskip("zarr")
    result = _sweep("--param", "initial.spin_rate=10 Hz, 20 Hz", "--full-order", "20 Hz",
                    "--no-time-run", "--workers", "1", "--format", "zarr", "-o", "out", "--json")  # fmt: skip
    assert result.exit_code == 0, result.output
    info = json.loads(result.stdout)
    assert info["dataset"] == "sweep.zarr" and not (folder / "out" / "sweep.nc").exists()
    assert info["full_order"][0]["spin_hz"] == pytest.approx(20.0)
    ds = store.open_sweep(folder / "out")
    assert ds["full_order_frequency"].attrs["units"] == "rad/s"
    i = int(np.argmin(abs(ds["spin_rate"].values - TWO_PI * 20.0)))
    reduced = dict(zip(ds["branch_label"].values[i], ds["branch_frequency"].values[i], strict=True))
    for j in np.flatnonzero(ds["full_order_matched"].values[0]):
        f = float(ds["full_order_frequency"].values[0, j])
        nearest = min(reduced.values(), key=lambda v: abs(v - f))
        assert f == pytest.approx(nearest, rel=0.01)  # the sweep's own branch at 20 Hz
    assert len(list((folder / "out" / "points").glob("full-order-20Hz-*.json"))) == 1
    assert "Full-order linearisation" in (folder / "out" / "report.html").read_text()


def test_sweep_dataset_round_trips_through_zarr(folder, tmp_path, markers):  # noqa: F811
    pytest.importorskip("zarr")
    plan = plan_from_texts(load_run_case(folder / "small-run.toml"),
                           ["initial.spin_rate=10 Hz, 20 Hz, 30 Hz"], time_run=False)  # fmt: skip
    results = [{"branch_label": ["nutation", "bending"], "branch_frequency": [k, 2.0 * k],
                "branch_growth_undamped": [0.0, 0.0], "branch_growth": [-0.1, -0.2],
                "energy_sink_growth_rate": 1e-3 * k, "quasi_rigid": True} for k in (1, 2)]  # fmt: skip
    outcome = SweepOutcome(results + [None], failures={2: "spin_rate = 30 Hz: failed"},
                           full_order=markers)  # fmt: skip
    ds = sweep_dataset(plan, outcome, "quadmodes sweep …")
    back = store.open_sweep(store.write_dataset(ds, tmp_path, "zarr"))
    assert set(back.variables) == set(ds.variables) and back.attrs == ds.attrs
    for name in ds.variables:
        assert back[name].attrs == ds[name].attrs, name
        assert back[name].attrs.get("units"), name
        assert back[name].dims == ds[name].dims, name
        if ds[name].dtype.kind in "fi":
            np.testing.assert_allclose(back[name].values, ds[name].values, equal_nan=True)
        else:
            assert [str(v) for v in back[name].values.ravel()] == \
                [str(v) for v in ds[name].values.ravel()], name  # fmt: skip
    again = store.write_dataset(ds, tmp_path, "zarr")  # replacing an earlier store
    assert store.open_sweep(again)["failed"].values.tolist() == [0, 0, 1]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no leftovers


def test_format_choice_and_a_missing_zarr(folder, monkeypatch):  # noqa: F811
    assert store.choose_format(None, 1000) == "netcdf"
    assert store.choose_format("netcdf", 10 * store.ZARR_THRESHOLD_BYTES) == "netcdf"
    monkeypatch.setattr(store, "zarr_available", lambda: True)
    assert store.choose_format(None, store.ZARR_THRESHOLD_BYTES + 1) == "zarr"
    monkeypatch.setattr(store, "zarr_available", lambda: False)
    assert store.choose_format(None, store.ZARR_THRESHOLD_BYTES + 1) == "netcdf"
    line = _one_line_error(_sweep("--param", "initial.spin_rate=10 Hz, 20 Hz", "--format",
                                  "zarr", "-o", "z"))  # fmt: skip
    assert "zarr" in line and "quadmodes[zarr]" in line
    line = _one_line_error(_sweep("--param", "initial.spin_rate=10 Hz, 20 Hz", "--format",
                                  "parquet", "-o", "z"))  # fmt: skip
    assert "--format" in line
    line = _one_line_error(_sweep("--param", "initial.spin_rate=10 Hz, 20 Hz", "--axis",
                                  "sideways", "-o", "z"))  # fmt: skip
    assert "--axis" in line
    assert not (folder / "z").exists()


def test_sweep_axis_sets_the_points_spin_axis(folder, small_reduced_model):  # noqa: F811
    """About the minor axis the prolate capsule's cone grows; about its major axis (a stable,
    major-axis spinner) the energy-sink estimate and the damped nutation root both decay."""
    run = load_run_case(folder / "small-run.toml")
    signs = {}
    for axis in ("minor", "major"):
        plan = plan_from_texts(run, ["initial.spin_rate=20 Hz, 30 Hz"], time_run=False, axis=axis)
        case = plan.points[0].case
        assert case.run.initial.spin_axis == axis
        out = run_point(case, small_reduced_model, 5, time_run=False)
        signs[axis] = (np.sign(out["energy_sink_growth_rate"]),
                       np.sign(out["nutation_growth_rate"]))  # fmt: skip
    assert signs == {"minor": (1, 1), "major": (-1, -1)}
