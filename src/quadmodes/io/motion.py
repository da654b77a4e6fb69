"""The motion of the whole body for ParaView: one XDMF time series (``motion.xdmf`` + its HDF5
file ``motion.h5``, written with meshio's :class:`~meshio.xdmf.TimeSeriesWriter`).

A reduced state ``[q, ω, s, ṡ]`` gives the nodal positions (SI, metres)::

    x = p + R(q) (X + u),   u = Φ s + Σ_{m,n} s_m s_n g^{mn}     (no factor ½: m, n both run
                                                                   over all N modes, g symmetric)

with X (n, 3) the reduced model's reference positions (about the centre of mass for a free
body, as the cached model stores them; for a model about a spinning state, the centrifugal
relative equilibrium at that spin), Φ (N, n, 3), g (N, N, n, 3), R(q) body → inertial and p the
centre of mass (the origin: a free run has no translation). In the body frame (``frame =
"body"``) the positions are ``X + u``.

The file holds one mesh, the reference X (position rows only: beam slope rows are dropped), and
per frame the point fields

* ``displacement`` (n, 3) m: ``x(t) − X``; ParaView's *Warp By Vector* with scale factor 1
  moves the reference onto the body's position at that time;
* ``elastic_displacement`` (n, 3) m: the elastic part ``R u`` (``u`` in the body frame file);
* ``elastic_displacement_magnitude`` (n,) m: ``|u|``, the colour field.

Times are in seconds. Every file is moved into place only when complete.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from quadmodes.io.mesh_arrays import as_cells, as_points

__all__ = [
    "FRAMES",
    "Motion",
    "body_cells",
    "elastic_displacement",
    "frame_indices",
    "position_rows",
    "reduced_motion",
    "write_motion_xdmf",
]

#: Default number of frames of an animation (``--animate-frames``).
FRAMES = 100
#: The frames a motion can be written in.
MOTION_FRAMES = ("inertial", "body")


@dataclass(frozen=True)
class Motion:
    """Sampled motion of a body (k frames, n points; SI).

    reference (n, 3) m: the mesh the file is drawn on; times (k,) s; positions (k, n, 3) m;
    elastic (k, n, 3) m: the elastic displacement in the file's frame; triangles (nt, 3) and
    lines (nl, 2) int node indices into ``reference``; frame: "inertial" or "body"."""

    reference: np.ndarray
    times: np.ndarray
    positions: np.ndarray
    elastic: np.ndarray
    triangles: np.ndarray
    lines: np.ndarray
    frame: str = "inertial"


def frame_indices(n_samples: int, frames: int) -> np.ndarray:
    """Indices of at most ``frames`` samples out of ``n_samples``, evenly spread, always the
    first and the last (sorted, unique)."""
    if n_samples <= 0:
        return np.zeros(0, dtype=np.int64)
    count = max(1, min(int(frames), n_samples))
    if count == 1:
        return np.array([n_samples - 1], dtype=np.int64)
    return np.unique(np.round(np.linspace(0, n_samples - 1, count)).astype(np.int64))


def elastic_displacement(phi: np.ndarray, g: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``u = Φ s + Σ_{m,n} s_m s_n g^{mn}`` (k, n, 3) m for modal coordinates s (k, N) √kg·m,
    modes Φ (N, n, 3) 1/√kg and quadratic modes g (N, N, n, 3) 1/kg (sum over all m, n)."""
    s = np.atleast_2d(np.asarray(s, float))
    phi = np.asarray(phi, float)
    n_modes = s.shape[1]
    u = np.zeros((s.shape[0],) + phi.shape[1:])
    if n_modes == 0:
        return u
    u += np.tensordot(s, phi[:n_modes], axes=(1, 0))
    ss = np.einsum("tm,tn->tmn", s, s)
    u += np.tensordot(ss, np.asarray(g, float)[:n_modes, :n_modes], axes=([1, 2], [0, 1]))
    return u


def position_rows(
    translational: np.ndarray, triangles: np.ndarray, lines: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows (n_pos,) of the position DOFs, triangles and lines renumbered onto them): a beam's
    slope rows are not points. Cells touching a slope row are dropped."""
    rows = np.flatnonzero(np.asarray(translational, bool))
    new = np.full(len(translational), -1, dtype=np.int64)
    new[rows] = np.arange(len(rows))

    def renumber(cells, width):
        cells = np.asarray(cells, dtype=np.int64).reshape(-1, width)
        mapped = new[cells]
        return mapped[np.all(mapped >= 0, axis=1)]

    lines = np.zeros((0, 2), np.int64) if lines is None else lines
    return rows, renumber(triangles, 3), renumber(lines, 2)


def body_cells(structure) -> tuple[np.ndarray, np.ndarray]:
    """Triangles (nt, 3) of the membrane and line cells (nl, 2) of the bars (end-body ties) of a
    :class:`~quadmodes.fe.model.Structure`; a beam (no membrane) is drawn as the line through its
    consecutive position DOFs."""
    triangles, lines = [], []
    for element_set in structure.elements:
        kind = type(element_set).__name__
        if kind == "MembraneSet":
            triangles.append(np.asarray(element_set.conn))
        elif kind == "BarSet":
            lines.append(np.asarray(element_set.conn))
    if not triangles and not lines:
        pos = np.flatnonzero(structure.translational)
        lines.append(np.stack([pos[:-1], pos[1:]], 1))
    tri = np.concatenate(triangles) if triangles else np.zeros((0, 3), np.int64)
    lin = np.concatenate(lines) if lines else np.zeros((0, 2), np.int64)
    return tri.astype(np.int64), lin.astype(np.int64)


def reduced_motion(
    model,
    quaternions: np.ndarray,
    s: np.ndarray,
    times: np.ndarray,
    triangles: np.ndarray,
    lines: np.ndarray | None = None,
    frame: str = "inertial",
    origin: Sequence[float] | None = None,
) -> Motion:
    """The :class:`Motion` of reduced states: ``model`` a
    :class:`~quadmodes.rom.reduced.ReducedModel` (X, Φ, G, translational), quaternions (k, 4)
    (scalar first, body → inertial), s (k, N) √kg·m (N ≤ model.n_modes: its first N modes),
    times (k,) s, triangles / lines node indices of the vector DOFs; ``origin`` (3,) m: p, the
    centre of mass (default the origin)."""
    from quadmodes.rotations import rotation_matrix

    if frame not in MOTION_FRAMES:
        raise ValueError(f"--animate-frame: {frame!r}; use inertial or body")
    rows, tri, lin = position_rows(model.translational, triangles, lines)
    x_ref = np.asarray(model.X, float)[rows]
    s = np.asarray(s, float).reshape(len(times), -1)
    n_modes = s.shape[1]
    phi = np.asarray(model.Phi, float)[:n_modes][:, rows]
    g = np.asarray(model.G, float)[:n_modes, :n_modes][:, :, rows]
    u = elastic_displacement(phi, g, s)
    if frame == "body":
        return Motion(x_ref, np.asarray(times, float), x_ref + u, u, tri, lin, frame)
    rot = rotation_matrix(np.asarray(quaternions, float))  # (k, 3, 3)
    p = np.zeros(3) if origin is None else np.asarray(origin, float)
    positions = p + np.einsum("tab,tnb->tna", rot, x_ref + u)
    elastic = np.einsum("tab,tnb->tna", rot, u)
    return Motion(x_ref, np.asarray(times, float), positions, elastic, tri, lin, frame)


def _cell_blocks(triangles: np.ndarray, lines: np.ndarray, n_points: int) -> list:
    blocks = []
    tri = as_cells(triangles, 3, n_points, "triangles")
    lin = as_cells(lines, 2, n_points, "lines")
    if len(tri):
        blocks.append(("triangle", tri))
    if len(lin):
        blocks.append(("line", lin))
    if not blocks:
        blocks.append(("vertex", np.arange(n_points, dtype=np.int64)[:, None]))
    return blocks


def _writer_class():
    """meshio's TimeSeriesWriter with two fixes of meshio 5.3: the HDF5 file is opened beside
    the XDMF file (meshio opens it in the working directory), and a mesh of triangles and lines
    is written as one "Mixed" topology (meshio fails on the line cells)."""
    import h5py
    from meshio.xdmf import TimeSeriesWriter
    from meshio.xdmf.common import meshio_type_to_xdmf_index, numpy_to_xdmf_dtype

    class Writer(TimeSeriesWriter):
        def __enter__(self):
            self.h5_filename = str(self.filename.with_suffix(".h5"))
            self.h5_file = h5py.File(self.h5_filename, "w")
            return self

        def cells(self, cells, grid):
            if len(cells) == 1:
                return super().cells(cells, grid)
            parts = []
            for kind, conn in cells:  # XDMF Mixed: type index, (node count for a polyline), nodes
                head = [meshio_type_to_xdmf_index[kind]] + ([2] if kind == "line" else [])
                heads = np.tile(np.asarray(head, np.int64), (len(conn), 1))
                parts.append(np.hstack([heads, conn]).ravel())
            data = np.concatenate(parts)
            topo = ET.SubElement(grid, "Topology", TopologyType="Mixed",
                                 NumberOfElements=str(sum(len(c) for _, c in cells)))
            dt, prec = numpy_to_xdmf_dtype[data.dtype.name]
            item = ET.SubElement(topo, "DataItem", DataType=dt, Dimensions=str(len(data)),
                                 Format=self.data_format, Precision=prec)  # fmt: skip
            item.text = self.numpy_to_xml_string(data)

    return Writer


def write_motion_xdmf(path, motion: Motion) -> Path:
    """Write ``motion`` as an XDMF time series ``path`` (``motion.xdmf``) with its HDF5 file
    beside it (same stem, ``.h5``); fields: module docstring. Both files are written in a
    hidden staging folder beside ``path`` and moved into place (HDF5 first). Returns ``path``."""
    path = Path(path)
    ref = as_points(motion.reference)
    blocks = _cell_blocks(motion.triangles, motion.lines, len(ref))
    path.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{path.stem}.partial-{os.getpid()}-", dir=path.parent))
    try:
        xdmf, h5 = staging / path.name, staging / f"{path.stem}.h5"
        with _writer_class()(xdmf) as writer:
            writer.write_points_cells(ref, blocks)
            for t, x, u in zip(motion.times, motion.positions, motion.elastic, strict=True):
                writer.write_data(float(t), point_data={
                    "displacement": np.ascontiguousarray(x - ref),
                    "elastic_displacement": np.ascontiguousarray(u),
                    "elastic_displacement_magnitude": np.linalg.norm(u, axis=1),
                })  # fmt: skip
        os.replace(h5, path.parent / h5.name)
        os.replace(xdmf, path)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return path
