"""Tests for quadmodes.io.vtk (VTU/PVD) and quadmodes.io.pictures (PNG) on a small closed surface."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest
from matplotlib.image import imread

from quadmodes.io import pictures, vtk


def _sphere(n_theta: int = 6, n_phi: int = 10, radius: float = 0.5):
    """Coarse closed UV sphere, slightly flattened: points (n, 3) [m], triangles (nt, 3)."""
    theta = np.linspace(0.0, np.pi, n_theta + 1)[1:-1]
    phi = np.linspace(0.0, 2.0 * np.pi, n_phi, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.column_stack(
        [
            np.sin(t).ravel() * np.cos(p).ravel(),
            np.sin(t).ravel() * np.sin(p).ravel(),
            0.7 * np.cos(t).ravel(),
        ]
    )
    pts = radius * np.vstack([[0.0, 0.0, 0.7], ring, [0.0, 0.0, -0.7]])
    south = len(pts) - 1

    def idx(i, j):
        return 1 + i * n_phi + (j % n_phi)

    tris = []
    for j in range(n_phi):
        tris.append([0, idx(0, j), idx(0, j + 1)])
        tris.append([south, idx(n_theta - 2, j + 1), idx(n_theta - 2, j)])
    for i in range(n_theta - 2):
        for j in range(n_phi):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            tris.append([a, b, c])
            tris.append([a, c, d])
    return pts, np.array(tris, dtype=np.int64)


@pytest.fixture(scope="module")
def surface():
    pts, tri = _sphere()
    n = len(pts)
    x, y, z = pts.T
    shapes = np.stack(
        [
            np.column_stack([np.ones(n), np.zeros(n), np.zeros(n)]),  # translation
            np.column_stack([-y, x, np.zeros(n)]),  # rotation about z
            pts * z[:, None],  # "breathing" of the upper half
        ]
    )
    freqs = np.array([0.0, 12.5, 31.2])
    labels = ["translation x", "spin about z", "rocking (rear mass)"]
    lines = np.array([[0, len(pts) - 1], [1, 6]])
    return pts, tri, shapes, freqs, labels, lines


def _check_png(path: Path) -> None:
    assert path.is_file()
    with open(path, "rb") as fh:
        assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    img = imread(path)
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    assert float(img[..., :3].std()) > 0.0
    leftovers = [p for p in path.parent.iterdir() if p.name.endswith(".tmp")]
    assert not leftovers


def _triangles(mesh) -> np.ndarray:
    return np.vstack([c.data for c in mesh.cells if c.type == "triangle"])


def test_write_mesh_vtu_roundtrip(tmp_path, surface):
    pts, tri, shapes, _, _, lines = surface
    stress = np.linspace(-1.0, 3.0, len(tri))
    state = np.arange(len(tri)) % 3
    path = vtk.write_mesh_vtu(
        tmp_path / "mesh.vtu",
        pts,
        tri,
        lines=lines,
        point_data={"displacement": shapes[2]},
        cell_data={"stress_minor_N_per_m": stress, "wrinkle_state": state},
    )
    mesh = meshio.read(path)
    np.testing.assert_allclose(mesh.points, pts, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(_triangles(mesh), tri)
    lin = np.vstack([c.data for c in mesh.cells if c.type == "line"])
    np.testing.assert_array_equal(lin, lines)
    np.testing.assert_allclose(mesh.point_data["displacement"], shapes[2], rtol=0, atol=1e-12)
    blocks = [c.type for c in mesh.cells]
    s = mesh.cell_data["stress_minor_N_per_m"]
    np.testing.assert_allclose(s[blocks.index("triangle")], stress, atol=1e-12)
    assert np.all(np.isnan(s[blocks.index("line")]))
    w = mesh.cell_data["wrinkle_state"]
    np.testing.assert_array_equal(w[blocks.index("triangle")], state)
    np.testing.assert_array_equal(w[blocks.index("line")], 0)
    assert [p.name for p in tmp_path.iterdir()] == ["mesh.vtu"]


def test_write_mesh_vtu_rejects_bad_input(tmp_path, surface):
    pts, tri, *_ = surface
    with pytest.raises(ValueError):
        vtk.write_mesh_vtu(tmp_path / "bad.vtu", pts, tri, cell_data={"x": np.ones(3)})
    with pytest.raises(ValueError):
        vtk.write_mesh_vtu(tmp_path / "bad.vtu", pts, tri + len(pts))
    assert list(tmp_path.iterdir()) == []


def _pvd_files(path: Path) -> list[tuple[float, str]]:
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.attrib["type"] == "Collection"
    return [(float(d.attrib["timestep"]), d.attrib["file"]) for d in root.iter("DataSet")]


def test_write_modes_pvd(tmp_path, surface):
    pts, tri, shapes, freqs, labels, lines = surface
    frames = 8  # frame frames//4 is exactly a quarter period
    out = tmp_path / "modes_out"
    top = vtk.write_modes_pvd(out, pts, tri, shapes, freqs, labels, lines=lines, frames=frames)
    assert top == out / "modes.pvd"

    entries = _pvd_files(top)
    assert [t for t, _ in entries] == [1.0, 2.0, 3.0]  # modes numbered from 1, as everywhere
    for k, (_, fname) in enumerate(entries):
        assert fname == f"mode_{k + 1:02d}.vtu"
        mesh = meshio.read(out / fname)
        np.testing.assert_allclose(mesh.points, pts, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(_triangles(mesh), tri)
        np.testing.assert_allclose(mesh.point_data["displacement"], shapes[k], atol=1e-12)
        np.testing.assert_allclose(mesh.point_data["frequency_hz"], freqs[k], atol=1e-12)
        np.testing.assert_allclose(mesh.field_data["frequency_hz"], [freqs[k]], atol=1e-12)

        np.testing.assert_array_equal(mesh.field_data["mode_index"], [k + 1])

        anim = _pvd_files(out / f"mode_{k + 1:02d}.pvd")
        assert len(anim) == frames
        assert all((out / f).is_file() for _, f in anim)
        # every frame: undeformed points + its displacement (Warp By Vector applies it once)
        frame_meshes = [meshio.read(out / f) for _, f in anim]
        for m in frame_meshes:
            np.testing.assert_allclose(m.points, pts, rtol=0, atol=1e-12)
        # frame at a quarter period: full amplitude, default scale = 10 % of bbox diagonal
        quarter = frame_meshes[frames // 4].point_data["displacement"]
        amp = np.linalg.norm(quarter, axis=1).max()
        diag = np.linalg.norm(pts.max(0) - pts.min(0))
        np.testing.assert_allclose(amp, 0.1 * diag, rtol=1e-9)
        np.testing.assert_allclose(frame_meshes[0].point_data["displacement"], 0.0, atol=1e-12)
    numbers = [line.split("\t")[0] for line in (out / "modes.txt").read_text().splitlines()[1:]]
    assert numbers == ["1", "2", "3"]

    names = sorted(p.name for p in out.iterdir())
    assert len(names) == 1 + 1 + 3 * (2 + frames)  # modes.pvd, modes.txt, per mode
    assert not [n for n in names if n.endswith(".tmp")]


def test_write_modes_pvd_explicit_scale(tmp_path, surface):
    pts, tri, shapes, freqs, labels, _ = surface
    vtk.write_modes_pvd(
        tmp_path, pts, tri, shapes[:1], freqs[:1], labels[:1], frames=4, scale=0.01
    )
    quarter = meshio.read(tmp_path / "mode_01_frame_001.vtu")
    np.testing.assert_allclose(quarter.points, pts, atol=1e-12)
    np.testing.assert_allclose(quarter.point_data["displacement"], 0.01 * shapes[0], atol=1e-12)


@pytest.mark.parametrize("with_lines", [False, True])
@pytest.mark.parametrize("with_values", [False, True])
def test_plot_mesh_png(tmp_path, surface, with_lines, with_values):
    pts, tri, _, _, _, lines = surface
    path = pictures.plot_mesh_png(
        tmp_path / "mesh.png",
        pts,
        tri,
        title="test mesh",
        lines=lines if with_lines else None,
        cell_values=np.linspace(0.0, 1.0, len(tri)) if with_values else None,
        cell_label="stress_minor_N_per_m" if with_values else None,
    )
    _check_png(Path(path))


@pytest.mark.parametrize("with_lines", [False, True])
def test_plot_mode_png(tmp_path, surface, with_lines):
    pts, tri, shapes, freqs, labels, lines = surface
    path = pictures.plot_mode_png(
        tmp_path / "mode.png",
        pts,
        tri,
        shapes[2],
        freqs[2],
        labels[2],
        lines=lines if with_lines else None,
        index=2,
    )
    _check_png(Path(path))


def test_plot_mode_png_zero_shape(tmp_path, surface):
    pts, tri, *_ = surface
    _check_png(pictures.plot_mode_png(tmp_path / "z.png", pts, tri, np.zeros_like(pts), 1.0, "z"))


@pytest.mark.parametrize("with_lines", [False, True])
def test_plot_modes_overview_png(tmp_path, surface, with_lines):
    pts, tri, shapes, freqs, labels, lines = surface
    path = pictures.plot_modes_overview_png(
        tmp_path / "overview.png",
        pts,
        tri,
        shapes,
        freqs,
        labels,
        lines=lines if with_lines else None,
    )
    _check_png(Path(path))


def test_plot_failure_leaves_no_file(tmp_path, surface):
    pts, tri, *_ = surface
    with pytest.raises(ValueError):
        pictures.plot_mesh_png(tmp_path / "bad.png", pts, tri, cell_values=np.ones(2))
    assert list(tmp_path.iterdir()) == []


def test_write_mesh_vtu_of_lines_only(tmp_path):
    """A beam (no triangles, its centre line as line cells) is written and read back."""
    pts = np.column_stack([np.linspace(0.0, 1.0, 5), np.zeros(5), np.zeros(5)])
    lines = np.stack([np.arange(4), np.arange(1, 5)], 1)
    path = vtk.write_mesh_vtu(tmp_path / "beam.vtu", pts, np.zeros((0, 3), int), lines=lines)
    mesh = meshio.read(path)
    assert [c.type for c in mesh.cells] == ["line"]
    np.testing.assert_array_equal(mesh.cells[0].data, lines)


def test_mode_picture_fits_the_whole_body_with_little_white_space(tmp_path, surface):
    """The side view of a tall body with a tie sticking out above it: the picture is cropped to
    the drawing (no white border rows) and taller than wide, as the body."""
    pts, tri, shapes, freqs, labels, _ = surface
    tall = pts * np.array([0.4, 0.4, 2.0])
    top = np.vstack([tall, [[0.0, 0.0, tall[:, 2].max() + 0.5]]])  # an end-body point above
    lines = np.array([[0, len(top) - 1]])
    path = pictures.plot_mesh_png(tmp_path / "tall.png", top, tri, lines=lines)
    img = imread(path)[..., :3]
    assert img.shape[0] > img.shape[1]  # two tall panels side by side, still taller than wide
    ink = np.any(img < 0.95, axis=2)
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    assert rows[0] < 10 and rows[-1] > img.shape[0] - 10  # cropped: content from edge to edge
    assert cols[0] < 10 and cols[-1] > img.shape[1] - 10
