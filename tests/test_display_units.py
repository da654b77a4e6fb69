"""Units a user chooses (issue 28 item 4): tables and figures of campbell, rotating and sweep in
Hz by default, rpm or rad/s with --units, the files SI; a Campbell figure that reads at a
glance (a colour per family that never repeats, the legend outside, critical speeds where a
branch meets f = kΩ)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from typer.testing import CliRunner

from quadmodes.analysis.campbell import CampbellResult
from quadmodes.analysis.campbell_figure import engine_order_crossings, plot_campbell
from quadmodes.cli.app import app
from quadmodes.io.display_units import HZ, RAD_S, RPM, family_colours, frequency_unit
from quadmodes.sweeps.plots import campbell_figure, sweep_figures


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))


def test_units_convert_by_their_definitions():
    # 1 Hz is one turn a second: 2π rad/s, 60 rpm
    assert HZ.from_rad_s(2 * math.pi) == pytest.approx(1.0)
    assert RPM.from_hz(1.0) == pytest.approx(60.0)
    assert RAD_S.from_hz(1.0) == pytest.approx(2 * math.pi)
    np.testing.assert_allclose(RPM.from_rad_s(np.array([0.0, math.pi])), [0.0, 30.0])
    assert frequency_unit("RPM") is RPM and frequency_unit(" hz ") is HZ
    assert frequency_unit("rad/s") is RAD_S
    with pytest.raises(ValueError, match="--units.*Hz, rpm or rad/s"):
        frequency_unit("deg/s")


def test_family_colours_never_repeat():
    for count in (3, 10, 11, 20, 25):
        labels = [f"family {i}" for i in range(count)] + [f"family {i} #2" for i in range(count)]
        colours = family_colours(labels)
        assert len(colours) == count  # "#2" joins its family
        assert len({to_rgba(c) for c in colours.values()}) == count


def _linear_result(divergence_at: float | None = None) -> CampbellResult:
    """Branches f = a + cΩ (rad/s) on 11 spins 0…25 rad/s; with ``divergence_at``, the rotating
    stiffness lost above it."""
    spin = np.linspace(0.0, 25.0, 11)
    branches = {"bending": (10.0, 0.5), "bending #2": (12.0, -0.2), "axial": (30.0, -0.3)}
    freq = np.array([[a + c * w for a, c in branches.values()] for w in spin])
    nb = len(branches)
    k_min = np.ones(spin.size) if divergence_at is None else divergence_at - spin
    return CampbellResult(
        spin=spin, axis=np.array([0.0, 0.0, 1.0]), formulation="Q", free=True,
        labels=tuple(branches), frequency=freq, growth=np.full(freq.shape, -1.0),
        mac=np.ones(freq.shape), min_stiffness=k_min, s_eq=np.zeros((spin.size, 2)),
        spin_axis=np.tile([0.0, 0.0, 1.0], (spin.size, 1)),
        vectors=np.zeros((spin.size, nb, 4), complex), start=np.zeros(nb, int),
        divergence=np.zeros(0) if divergence_at is None else np.array([divergence_at]),
    )  # fmt: skip


def test_engine_order_crossings_of_straight_branches():
    """f = a + cΩ meets kΩ at Ω = a / (k − c); 20 rad/s lies on a point of the grid; the
    crossing of "axial" with 1Ω (23.08 rad/s) is beyond the divergence at 24 rad/s."""
    found = engine_order_crossings(_linear_result(divergence_at=24.0))
    expected = sorted([(12.0 / 2.2, 2, "bending #2"), (10.0 / 1.5, 2, "bending"),
                       (12.0 / 1.2, 1, "bending #2"), (30.0 / 2.3, 2, "axial"),
                       (10.0 / 0.5, 1, "bending")])  # fmt: skip
    assert [(c.order, c.label) for c in found] == [(k, lab) for _, k, lab in expected]
    for c, (w, k, _) in zip(found, expected, strict=True):
        assert c.spin == pytest.approx(w, rel=1e-12) and c.frequency == pytest.approx(k * w)
    without = engine_order_crossings(_linear_result())
    assert any(c.label == "axial" and c.order == 1 for c in without)
    assert engine_order_crossings(_linear_result(), orders=(1,))[0].spin == pytest.approx(10.0)


def test_campbell_figure_in_rpm_reads_at_a_glance(tmp_path):
    result = _linear_result(divergence_at=24.0)
    fig = plot_campbell(result, tmp_path / "campbell.png", unit="rpm")
    assert (tmp_path / "campbell.png").stat().st_size > 0
    ax = fig.axes[0]
    assert "rpm" in ax.get_xlabel() and "rpm" in ax.get_ylabel()
    lines = {line.get_label(): line for line in ax.lines}
    branch = [line for line in ax.lines if line.get_linestyle() in ("-", "--")
              and len(line.get_xdata()) == result.spin.size]  # fmt: skip
    # a pair shares its family's colour; spin and frequency drawn in rpm
    assert to_rgba(branch[0].get_color()) == to_rgba(branch[1].get_color())
    np.testing.assert_allclose(branch[0].get_xdata(), result.spin * 60 / (2 * math.pi))
    np.testing.assert_allclose(branch[0].get_ydata(), result.frequency[:, 0] * 60 / (2 * math.pi))
    circles = [line for line in ax.lines if line.get_marker() == "o"]
    assert sorted(float(c.get_xdata()[0]) for c in circles) == pytest.approx(
        sorted(c.spin * 60 / (2 * math.pi) for c in engine_order_crossings(result)))
    assert "critical speed (branch = kΩ)" in lines
    legend = ax.get_legend()
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    assert legend.get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1
    names = [t.get_text() for t in legend.get_texts()]
    assert names.count("bending") == 1 and "bending #2" not in names  # one entry per family


def test_campbell_cli_in_rpm_keeps_its_files_si(runner, tmp_path):
    args = ["campbell", "kane-beam", "--spin-max", "6 rad/s", "--points", "3"]
    result = runner.invoke(app, [*args, "--units", "rpm", "-o", str(tmp_path)],
                           env={"COLUMNS": "200"})  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "spin (rpm)" in result.stdout and "(rpm)" in result.stdout
    assert "57.3" in result.stdout  # 6 rad/s = 57.3 rpm
    assert "critical speeds" in result.stdout
    with xr.open_dataset(tmp_path / "campbell.nc") as ds:
        assert ds["spin"].attrs["units"] == "rad/s" and float(ds["spin"].max()) == 6.0
    default = runner.invoke(app, args, env={"COLUMNS": "200"})
    assert "spin (Hz)" in default.stdout and "0.9549" in default.stdout  # 6 rad/s in Hz
    payload = json.loads(runner.invoke(app, [*args, "--units", "rpm", "--json"]).stdout)
    assert payload["spin_rate_rad_s"][-1] == 6.0  # JSON stays SI
    bad = runner.invoke(app, [*args, "--units", "deg/s"])
    assert bad.exit_code == 2 and "--units" in bad.stderr


def test_library_campbell_shows_the_cli_numbers_in_the_same_units(runner):
    """qm.campbell(units=) and campbell --units: the same table (one function makes both), its
    numbers the SI result's by the units' definitions (1 rad/s = 60/2π rpm)."""
    import quadmodes as qm

    lib = qm.campbell("kane-beam", "0 rad/s", "6 rad/s", points=3, units="rpm")
    tab = lib.table
    assert tab.unit == "rpm" and tab.title == "kane-beam: rotating-frame (rpm)"
    np.testing.assert_allclose(tab.spin, np.asarray(lib.spin) * 60 / (2 * math.pi), rtol=1e-14)
    np.testing.assert_allclose(tab.frequency, np.asarray(lib.frequency)[:, :6] * 60 / (2 * math.pi),
                               rtol=1e-14)  # fmt: skip
    crossings = engine_order_crossings(lib)
    assert crossings and [w for w, _, _ in tab.critical] == pytest.approx(
        [c.spin * 60 / (2 * math.pi) for c in crossings], rel=1e-14)
    cli = runner.invoke(app, ["campbell", "kane-beam", "--spin-max", "6 rad/s", "--points", "3",
                              "--units", "rpm"], env={"COLUMNS": "200"})  # fmt: skip
    assert cli.exit_code == 0, cli.output
    lines = [[c.strip() for c in line.split("│")[1:-1]] for line in cli.stdout.splitlines()]
    assert all(row in lines for row in tab.cells())  # every row, cell by cell
    for w, lab, k in tab.critical:
        assert [f"{w:.4g}", lab, f"{k}Ω"] in lines
    si = qm.campbell("kane-beam", "0 rad/s", "6 rad/s", points=3, units="rad/s").table
    np.testing.assert_array_equal(si.spin, lib.spin)
    with pytest.raises(qm.QuadmodesError, match="units"):
        qm.campbell("kane-beam", "0 rad/s", "6 rad/s", points=3, units="deg/s")


def test_rotating_table_in_rad_s(runner, tmp_path):
    """rotating.md in rad/s is 2π times the JSON's Hz, row by row."""
    result = runner.invoke(app, ["rotating", "paper-membrane-coarse", "--spin-rate", "0 Hz",
                                 "--modes", "3", "--formulation", "Q", "--units", "rad/s",
                                 "--json", "-o", str(tmp_path)])  # fmt: skip
    assert result.exit_code == 0, result.output
    rows = [r for r in json.loads(result.stdout)["rows"] if r["full_hz"]]
    text = (tmp_path / "rotating.md").read_text()
    assert "| spin (rad/s) | branch | full order (rad/s) |" in text
    cells = {c[1]: float(c[2]) for line in text.splitlines() if line.startswith("| 0 |")
             for c in [[x.strip() for x in line.strip("|").split("|")]]}  # fmt: skip
    for r in rows:
        assert cells[r["label"]] == pytest.approx(2 * math.pi * r["full_hz"], rel=1e-5)


def test_sweep_figures_in_the_unit_chosen(tmp_path, monkeypatch):
    spin = np.linspace(2 * math.pi, 2 * math.pi * 10, 4)  # 1…10 Hz
    freq = np.array([[30.0, 31.0, 80.0]]) + 0.0 * spin[:, None]
    labels = np.array([["bending", "bending #2", "axial"]] * spin.size, dtype=object)
    ds = xr.Dataset(
        {"branch_frequency": (("spin_rate", "branch"), freq),
         "branch_label": (("spin_rate", "branch"), labels),
         "critical_speed_hz": (("critical",), [5.0]),
         "critical_speed_kind": (("critical",), ["divergence"]),
         "critical_speed_branch": (("critical",), ["bending"]),
         "energy_sink_growth_rate": (("spin_rate",), [1e-3, 2e-3, 3e-3, 4e-3]),
         "nutation_growth_rate": (("spin_rate",), [1e-3, 2e-3, 3e-3, 4e-3]),
         "simulated_growth_rate": (("spin_rate",), [np.nan] * 4),
         "quasi_rigid": (("spin_rate",), [1.0] * 4)},
        coords={"spin_rate": spin},
    )  # fmt: skip
    paths = sweep_figures(ds, tmp_path, "rpm")
    assert [p.name for p in paths] == ["campbell.png", "stability.png"]
    assert all(p.stat().st_size > 0 for p in paths)
    drawn = {}
    original = Figure.savefig

    def keep(self, *args, **kwargs):  # the figure object, kept as it is saved
        drawn["fig"] = self
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    campbell_figure(ds, tmp_path / "c.png", "rpm")
    ax = drawn["fig"].axes[0]
    assert "rpm" in ax.get_xlabel()
    colours = {line.get_label(): to_rgba(line.get_color()) for line in ax.lines}
    assert set(colours) >= {"bending", "axial", "critical speed"}
    np.testing.assert_allclose(np.unique(ax.lines[0].get_xdata()), spin * 60 / (2 * math.pi))
    assert ax.lines[-1].get_xdata()[0] == pytest.approx(300.0)  # 5 Hz critical speed in rpm


def test_kane_chordwise_critical_speed_against_the_reference():
    """Kane's in-plane (chordwise) branch meets 1Ω where ω(Ω) = Ω. From Kane's published
    rotating-frame frequencies at Ω = 4 and 6 rad/s and the Southwell form ω² = a + bΩ²:
    Ω* = √(a / (1 − b)) = 4.186 rad/s. The crossing on the diagram settles as the grid is
    refined (linear interpolation: an error below h²·|g''| / (8|g'|)) and agrees with it."""
    from quadmodes.analysis.campbell import campbell
    from quadmodes.analysis.campbell_output import model_for_case
    from quadmodes.runs.spinup import KANE_REFERENCE_CHORDWISE as kane

    b = (kane[6.0] ** 2 - kane[4.0] ** 2) / (36.0 - 16.0)
    reference = math.sqrt((kane[4.0] ** 2 - 16.0 * b) / (1.0 - b))
    model = model_for_case("kane-beam")
    found = []
    for points in (13, 49):
        crossings = engine_order_crossings(campbell(model, np.linspace(0.0, 6.0, points)), (1,))
        (chordwise,) = [c for c in crossings if c.label == "bending y (0 nodes)"]
        found.append(chordwise.spin)
    assert found[1] == pytest.approx(found[0], rel=3e-4)  # settled on the grid
    assert found[1] == pytest.approx(reference, rel=3e-3)  # 4.1894 rad/s measured


def test_sweep_report_tables_in_the_unit_chosen(tmp_path):
    from quadmodes.sweeps.report import write_sweep_report

    ds = xr.Dataset(coords={"spin_rate": [1.0, 2.0]})
    info = {"points": 2, "resumed": 0, "failed": 0, "wall_s": 1.0,
            "critical_speeds": [{"spin_hz": 5.0, "kind": "divergence", "branch": "bending",
                                 "partner": ""}]}  # fmt: skip
    html = write_sweep_report(tmp_path, ds, info, "quadmodes sweep …", "rpm").read_text()
    assert "spin (rpm)" in html and ">300<" in html  # 5 Hz
