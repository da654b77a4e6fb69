"""``--animate``: the motion of a run (reduced states, turned into a
:class:`~quadmodes.io.motion.Motion` by :func:`quadmodes.runs.run_motion.run_motion`) or of the
full order of ``compare`` (recorded nodal positions) as ``motion.xdmf`` + ``motion.h5``
(:mod:`quadmodes.io.motion`), and, when pyvista and an off-screen GL back end are available, a
rendered ``motion.gif``. Model objects are read by their arrays only (X, weights, mass, the
structure's mass and cells); nothing here imports the model code.

Free runs only (a hub-driven spin-up has its own outputs). SI units: m, s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from quadmodes.io.hub_ring import all_triangles, with_image_points
from quadmodes.io.motion import FRAMES, Motion, position_rows, write_motion_xdmf

__all__ = ["FullOrderRecorder", "render_motion", "write_animation"]

MOTION_FILE = "motion.xdmf"
MOVIE_FILE = "motion.gif"


class FullOrderRecorder:
    """Sample observer for the full order (``on_sample(t, x)`` of
    :func:`~quadmodes.fullorder.integrator.integrate_full_order`): keeps the nodal positions
    x (n, 3) m of every ``stride``-th sample and of the last one.

    model: the reduced model of the run (X about the centre of mass, weights, node order);
    structure: the full-order :class:`~quadmodes.fe.model.Structure` (cells, mass);
    expected_samples: the number of samples the run will take (sets the stride)."""

    def __init__(self, model, structure, expected_samples: int, frames: int = FRAMES):
        self.model, self.structure = model, structure
        self.stride = max(1, math.ceil(max(int(expected_samples), 1) / max(int(frames), 1)))
        self.count = 0
        self.times: list[float] = []
        self.positions: list[np.ndarray] = []
        self.last: tuple[float, np.ndarray] | None = None

    def __call__(self, t: float, x: np.ndarray) -> None:
        if self.count % self.stride == 0:
            self.times.append(float(t))
            self.positions.append(np.array(x, float))
            self.last = None
        else:
            self.last = (float(t), np.array(x, float))
        self.count += 1

    def motion(self, frame: str = "inertial") -> Motion:
        """The recorded :class:`~quadmodes.io.motion.Motion`: positions about the centre of
        mass (fixed for a free body; the reduced motion has it at the origin too), the elastic
        part the position in the mass-weighted best-fit (mean-axes) frame minus X."""
        from quadmodes.rotations import polar_rotation

        times, xs = list(self.times), list(self.positions)
        if self.last is not None:
            times.append(self.last[0])
            xs.append(self.last[1])
        model = self.model
        x_ref = np.asarray(model.X, float)
        t_rows = np.asarray(model.translational, float)
        w = np.asarray(model.weights, float)
        mx = self.structure.mass_scalar @ x_ref
        tri, lines, e_mat = all_triangles(self.structure)  # the hub ring's on extra points
        trans = np.concatenate([np.asarray(model.translational, bool), np.ones(len(e_mat), bool)])
        rows, tri, lines = position_rows(trans, tri, lines)
        positions, elastic = [], []
        for x in xs:
            p = (w @ x) / float(model.mass)
            r = x - np.outer(t_rows, p)
            rot = polar_rotation(r.T @ mx)
            u = with_image_points(r @ rot - x_ref, e_mat)
            r = with_image_points(r, e_mat)
            if frame == "body":
                positions.append((x_ref + u)[rows])
                elastic.append(u[rows])
            else:  # about the centre of mass, as the reduced motion (which has p = 0)
                positions.append(r[rows])
                elastic.append((u @ rot.T)[rows])
        x_ref = with_image_points(x_ref, e_mat)
        return Motion(x_ref[rows], np.asarray(times), np.asarray(positions),
                      np.asarray(elastic), tri, lines, frame)  # fmt: skip


def render_motion(motion: Motion, path: Path, note: Callable[[str], None]) -> Path | None:
    """Render ``motion`` off screen to the GIF ``path`` with pyvista and imageio (``[viz]``
    extra), coloured by |u|; without them or a GL back end: ``note`` one line, None."""
    import importlib.util

    missing = [m for m in ("pyvista", "imageio") if importlib.util.find_spec(m) is None]
    if missing:
        note(f"note: {path.name} not rendered: {' and '.join(missing)} "
             f"{'is' if len(missing) == 1 else 'are'} not installed (pip install "
             "'quadmodes[viz]'); open motion.xdmf in ParaView")  # fmt: skip
        return None
    try:
        _quiet_vtk()
        import pyvista as pv

        return _render_gif(pv, motion, path)
    except Exception as exc:  # no GL back end, no imageio, ...: the XDMF file is enough
        first = " ".join(str(exc).split())[:160]
        note(f"note: {path.name} not rendered (pyvista: {type(exc).__name__}: {first}); "
             "open motion.xdmf in ParaView")  # fmt: skip
        return None


def _quiet_vtk() -> None:
    """Silence VTK's log on stderr: off screen without a display it warns "bad X server
    connection" (with raw ANSI colour codes, even into a pipe or a log file) before it falls
    back to EGL or OSMesa by itself; a back end that really fails still raises, and the caller
    turns that into its one-line note."""
    from vtkmodules.vtkCommonCore import vtkLogger

    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)


def _render_gif(pv, motion: Motion, path: Path) -> Path:  # pragma: no cover - needs pyvista
    """One GIF frame per motion frame: the surface coloured by |u| (range: its largest value on
    the surface), the end-body ties as lines, seen from the side (along +y, 15° above), the
    camera fixed on the bounds of the whole motion."""
    from quadmodes.io.atomic import atomic_path

    tri, lines = motion.triangles, motion.lines
    faces = np.hstack([np.full((len(tri), 1), 3), tri]).ravel()
    surface = pv.PolyData(motion.positions[0].copy(), faces)
    ties = pv.PolyData(motion.positions[0].copy(), lines=np.hstack(
        [np.full((len(lines), 1), 2), lines]).ravel()) if len(lines) else None  # fmt: skip
    colour = np.linalg.norm(motion.elastic, axis=2)
    on_surface = colour[:, np.unique(tri)] if len(tri) else colour
    surface.point_data["elastic displacement (m)"] = colour[0]
    plotter = pv.Plotter(off_screen=True, window_size=(720, 720))
    plotter.add_mesh(surface, scalars="elastic displacement (m)", clim=(0.0, float(on_surface.max()) or 1.0),
                     cmap="plasma", show_edges=True, edge_color="#555555", line_width=0.3)  # fmt: skip
    if ties is not None:
        plotter.add_mesh(ties, color="crimson", line_width=2)
    lo, hi = motion.positions.min(axis=(0, 1)), motion.positions.max(axis=(0, 1))
    plotter.camera_position = "xz"
    plotter.camera.elevation = 15.0
    plotter.reset_camera(bounds=np.column_stack([lo, hi]).ravel())
    with atomic_path(path) as tmp:
        plotter.open_gif(str(tmp))
        for t, x, c in zip(motion.times, motion.positions, colour, strict=True):
            surface.points = x
            surface.point_data["elastic displacement (m)"] = c
            if ties is not None:
                ties.points = x
            plotter.add_text(f"t = {float(t):.4f} s", name="time", font_size=10)
            plotter.write_frame()
        plotter.close()
    return path


def write_animation(motion: Motion, folder: Path, note: Callable[[str], None],
                    render: bool = True) -> list[Path]:  # fmt: skip
    """Write ``motion.xdmf`` (+ ``motion.h5``) into ``folder`` and, if ``render``, try
    ``motion.gif``; returns the paths written."""
    folder = Path(folder)
    paths = [write_motion_xdmf(folder / MOTION_FILE, motion)]
    if render:
        gif = render_motion(motion, folder / MOVIE_FILE, note)
        if gif is not None:
            paths.append(gif)
    return paths
