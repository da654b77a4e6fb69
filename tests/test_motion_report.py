"""``run --animate`` (motion.xdmf), report.html of run and compare, and the full order's motion.

The motion file is checked against the reduced state of results.nc with formulas written out
here (quaternion → matrix, u = Φ s + Σ_m Σ_n s_m s_n g^{mn}), not with the package's own."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import re
from pathlib import Path

import meshio
import numpy as np
import pytest
from conftest import SMALL_CAPSULE
from typer.testing import CliRunner

from quadmodes.case import load_case, load_run_case
from quadmodes.cli.app import app
from quadmodes.models import cache as model_cache
from quadmodes.rom import artifact
from quadmodes.runs import results as res

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
bending_amplitude = "0.2 in"  # small for the 8 in capsule: its condensed start converges robustly
[integration]
method = "midpoint"
dt = "0.2 ms"
duration = "0.04 s"
save_every = 5
"""


@pytest.fixture
def workdir(tmp_path, monkeypatch, small_reduced_model) -> Path:
    """The small capsule, its run case and a private cache seeded with its reduced model."""
    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    (tmp_path / "small-run.toml").write_text(RUN_TOML, encoding="utf-8")
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    case = load_case(tmp_path / "small.toml")
    seeded = dataclasses.replace(
        small_reduced_model,
        provenance={"case": case.name, "content_key": model_cache.reduced_key(case, 5)},
    )
    artifact.save_reduced_model(seeded, model_cache.cache_path(case, 5))
    return tmp_path


def _rotation(q: np.ndarray) -> np.ndarray:
    """Body → inertial matrix of a unit quaternion (w, x, y, z), written out."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def _deformation(model, s: np.ndarray, linear: bool = True) -> np.ndarray:
    """u = Σ_k s_k Φ_k + Σ_m Σ_n s_m s_n g^{mn} (without the first sum if not ``linear``),
    with explicit loops."""
    u = np.zeros_like(model.X)
    for k in range(len(s)):
        u += s[k] * model.Phi[k] if linear else 0.0
        for n in range(len(s)):
            u += s[k] * s[n] * model.G[k, n]
    return u


def _kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The rotation R minimising Σ |R b_i − a_i|² (both centred)."""
    h = b.T @ a
    uu, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ uu.T))
    return vt.T @ np.diag([1.0, 1.0, d]) @ uu.T


def _read_motion(path: Path):
    with meshio.xdmf.TimeSeriesReader(path) as reader:
        points, cells = reader.read_points_cells()
        frames = [reader.read_data(k) for k in range(reader.num_steps)]
    return points, cells, frames


def test_run_animate_motion_matches_the_reduced_state(workdir, small_reduced_model):
    out = workdir / "out"
    args = ["run", str(workdir / "small-run.toml"), "-o", str(out), "--animate",
            "--animate-frames", "5"]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    folder = out / "small-run"
    assert (folder / "motion.xdmf").is_file() and (folder / "motion.h5").is_file()
    # the optional GIF: rendered with pyvista and imageio ([viz]), else one note line says why
    if importlib.util.find_spec("pyvista") is None:
        assert "motion.gif not rendered: pyvista" in result.output
        assert not (folder / "motion.gif").exists()
    elif importlib.util.find_spec("imageio") is not None:
        assert (folder / "motion.gif").is_file(), result.output
        assert "bad X server" not in result.output and "\x1b[" not in result.output
    points, cells, frames = _read_motion(folder / "motion.xdmf")
    model = small_reduced_model
    assert {c.type for c in cells} == {"triangle", "line"}  # membrane and end-body ties
    np.testing.assert_allclose(points, model.X, atol=1e-12)  # the mesh is X, about the CoM
    ds = res.load_results(folder / "results.nc")
    times = ds["time"].values
    assert len(frames) == 5 and frames[0][0] == 0.0 and frames[-1][0] == pytest.approx(times[-1])
    size = float(np.ptp(model.X, axis=0).max())
    w = model.weights
    for t, pdata, _ in (frames[0], frames[2], frames[-1]):
        i = int(np.argmin(np.abs(times - t)))
        assert times[i] == pytest.approx(t, abs=1e-12)
        q = ds["quaternion"].values[i]
        s = ds["modal_coordinates"].values[i]
        x = points + pdata["displacement"]
        # centre of mass: stays at the origin (free body, no momentum)
        assert np.linalg.norm(w @ x / w.sum()) < 1e-9 * size
        # attitude: x is a rigid rotation R(q) of X + u, u from the modal coordinates
        u = _deformation(model, s)
        rot = _rotation(q)
        np.testing.assert_allclose(_kabsch(x, model.X + u), rot, atol=1e-9)
        # modal part: R(q)ᵀ x − X is the elastic displacement, not zero (bending excited)
        body = x @ rot
        np.testing.assert_allclose(body - model.X, u, atol=1e-10 * size)
        assert np.abs(u).max() > 1e-4 * size
        np.testing.assert_allclose(pdata["elastic_displacement_magnitude"],
                                   np.linalg.norm(u, axis=1), atol=1e-12)  # fmt: skip
    # quadratic part present: without it the positions would differ (g^{mn} not negligible)
    s_end = ds["modal_coordinates"].values[-1]
    lin = sum(s_end[k] * model.Phi[k] for k in range(len(s_end)))
    assert np.abs(_deformation(model, s_end) - lin).max() > 1e-12


def test_run_animate_body_frame_and_bad_options(workdir, small_reduced_model):
    out = workdir / "body"
    args = ["run", str(workdir / "small-run.toml"), "-o", str(out), "--animate",
            "--animate-frame", "body", "--animate-frames", "3", "--no-plots"]  # fmt: skip
    assert CliRunner().invoke(app, args).exit_code == 0
    points, _, frames = _read_motion(out / "small-run" / "motion.xdmf")
    ds = res.load_results(out / "small-run" / "results.nc")
    s = ds["modal_coordinates"].values[-1]
    x = points + frames[-1][1]["displacement"]
    np.testing.assert_allclose(x - small_reduced_model.X, _deformation(small_reduced_model, s),
                               atol=1e-12)  # fmt: skip
    for bad, needle in ((["--animate-frame", "lab"], "--animate-frame"),
                        (["--animate-frames", "1"], "--animate-frames")):  # fmt: skip
        target = workdir / "bad"
        result = CliRunner().invoke(app, ["run", str(workdir / "small-run.toml"), "-o",
                                          str(target), "--animate", *bad])  # fmt: skip
        assert result.exit_code == 2 and needle in result.output
        assert not target.exists()


def test_run_report_is_self_contained(workdir):
    out = workdir / "out"
    result = CliRunner().invoke(app, ["run", str(workdir / "small-run.toml"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    folder = out / "small-run"
    page = (folder / "report.html").read_text(encoding="utf-8")
    summary = json.loads((folder / "summary.json").read_text())
    headings = re.findall(r"<h2>([^<]*)</h2>", page)
    assert headings[:2] == ["the answer", "figures"]  # the verdict first, then the figures
    for heading in ("model", "validity and convergence checks", "case", "all headline numbers"):
        assert heading in headings
    box = page[page.index('<div class="verdict'):page.index("</div>")]
    assert f'class="verdict {summary["spin_stability"]}"' in page
    for row in ("coning rate", "coning time constant", "valid at the start",
                "valid along the path", "the run"):  # fmt: skip
        assert f"<th>{row}" in box
    assert f"Spin {summary['spin_verdict']}"[:40] in box.replace("&#x27;", "'")
    assert "max |H(t) − H0| / |H0|" in page and f"<td>{summary['steps']}</td>" in page
    assert "retained modes (numbered from 1)" in page and "bending" in page
    text = re.sub(r"data:image/png;base64,[^\"]*", "", page)
    assert not re.search(r"Figs?\. ?\d", text)  # captions that stand alone: no figure numbers
    images = re.findall(r'<img [^>]*src="([^"]*)"', page)
    # each figure once: summary.png gathers the others' panels and stays out; the early times
    # of this 0.04 s run are the whole run; the model's picture is in
    pngs = {p.name for p in folder.glob("*.png")} - {"summary.png", "bending_mode_early.png"}
    assert "model.png" in pngs and len(images) == len(pngs) >= 6
    assert len(set(images)) == len(images)
    assert all(i.startswith("data:image/png;base64,") for i in images)
    assert not re.search(r"(src|href)=\"(https?:)?//", page) and "http://" not in page
    assert "https://" not in page and "<script" not in page


def test_full_order_recorder_motion(workdir):
    """The full order's recorded nodal positions on a short window: the first frame is the
    initial state, the centre of mass stays, and the elastic part in the best-fit frame
    projects onto the full order's own modal coordinates (Φᵀ M_s u = s to first order)."""
    from quadmodes.analysis.full_order_runs import full_order_for_run, setup_for_run
    from quadmodes.io.animation import FullOrderRecorder
    from quadmodes.runs import simulate

    run = simulate.apply_overrides(load_run_case(workdir / "small-run.toml"), duration="10 ms")
    setup = setup_for_run(run)
    recorder = FullOrderRecorder(setup.model, setup.structure, expected_samples=11, frames=5)
    sol = full_order_for_run(run, dt=2e-4, setup=setup, on_sample=recorder)
    full = recorder.motion()
    assert len(full.times) == 5 and full.times[-1] == pytest.approx(0.01)
    model = setup.model
    w, size = model.weights, float(np.ptp(model.X, axis=0).max())
    np.testing.assert_allclose(recorder.positions[0], setup.x0, atol=1e-12 * size)
    centres = np.array([w @ x / w.sum() for x in recorder.positions])
    assert np.abs(centres - centres[0]).max() < 1e-9 * size  # no momentum: the CoM stays
    for x in full.positions:  # written about the centre of mass, as the reduced motion
        assert np.linalg.norm(w @ x / w.sum()) < 1e-12 * size
    body = recorder.motion("body")
    np.testing.assert_allclose(body.positions, body.reference + body.elastic, atol=1e-15)
    ms = setup.structure.mass_scalar
    s_scale = np.abs(sol.modal_coordinates).max()
    for t, u in zip(body.times, body.elastic, strict=True):
        i = int(np.argmin(np.abs(sol.t - t)))
        lin = np.einsum("kia,ia->k", model.Phi, ms @ u)  # Φᵀ M_s u, and the quadratic part:
        s_fit = lin
        for _ in range(8):  # s = Φᵀ M_s (u − Σ s_m s_n g^{mn})
            s_fit = lin - np.einsum("kia,ia->k", model.Phi, ms @ _deformation(model, s_fit, False))
        np.testing.assert_allclose(s_fit, sol.modal_coordinates[i], atol=0.01 * s_scale)


def test_compare_animate_writes_the_full_order_motion_and_a_report(workdir):
    out = workdir / "cmp"
    args = ["compare", str(workdir / "small-run.toml"), "--window", "4 ms", "--formulation",
            "rigid,Q", "--animate", "--animate-frames", "3", "-o", str(out)]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    points, cells, frames = _read_motion(out / "motion.xdmf")
    assert [t for t, _, _ in frames] == pytest.approx([0.0, 0.002, 0.004])
    case = load_case(workdir / "small.toml")
    model = artifact.load_reduced_model(model_cache.cache_path(case, 5))
    np.testing.assert_allclose(points, model.X, atol=1e-12)
    w = model.weights
    for _, pdata, _ in frames:  # positions about the centre of mass, the body has moved
        x = points + pdata["displacement"]
        assert np.linalg.norm(w @ x / w.sum()) < 1e-9
    assert np.abs(frames[-1][1]["displacement"]).max() > 1e-3
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "errors relative to the full order" in page and "<td>Q</td>" in page
    assert len(list(out.glob("compare_*.png"))) == 5 and (out / "model.png").is_file()
    assert page.count("data:image/png;base64,") == len(list(out.glob("*.png"))) == 6
    assert re.findall(r"<h2>([^<]*)</h2>", page)[:2] == ["the answer", "figures"]
    assert "https://" not in page and "http://" not in page
