"""Read and write triangulated surfaces through meshio (format chosen by file extension)."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import meshio
import numpy as np

from quadmodes.mesh.surface import TriangleSurface

__all__ = ["read_surface", "write_surface"]


def read_surface(path: str | Path) -> TriangleSurface:
    """Read the triangle cells of a mesh file (any meshio format) as a surface in metres.

    Only ``triangle`` cell blocks are used; other cells are ignored and nodes not used by any
    triangle are dropped (indices renumbered in order). 2-D points get z = 0. Coordinates are
    taken as metres, without unit conversion.

    Raises ``ValueError`` if the file cannot be read or holds no triangles.
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(
            f"mesh: surface file '{path}' (geometry.file) not found; check the path (a relative "
            "path is relative to the case file)"
        )
    if path.is_file() and path.stat().st_size == 0:
        raise ValueError(
            f"mesh: surface file '{path}' (geometry.file) is empty (0 bytes); export the surface "
            "mesh again"
        )
    try:  # meshio prints its own messages and may call sys.exit: keep them to ourselves
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            mesh = meshio.read(path)
    except (Exception, SystemExit) as exc:  # ReadError, KeyError, OSError, SystemExit, ...
        reason = " ".join(str(exc).split()) if not isinstance(exc, SystemExit) else "unreadable"
        raise ValueError(
            f"mesh: cannot read surface file '{path}' (geometry.file) as a triangle mesh "
            f"({reason or type(exc).__name__}); give a non-empty surface mesh file (.vtu, .stl, "
            ".obj, .ply, .msh)"
        ) from None
    blocks = [np.asarray(c.data, dtype=np.int64) for c in mesh.cells if c.type == "triangle"]
    if not blocks or sum(len(b) for b in blocks) == 0:
        types = sorted({c.type for c in mesh.cells}) or ["none"]
        raise ValueError(
            f"mesh: file '{path}' (geometry.file) has no triangle cells (found: "
            f"{', '.join(types)}); export the surface as triangles"
        )
    triangles = np.concatenate(blocks)
    points = np.asarray(mesh.points, dtype=float)
    if points.shape[1] < 3:
        points = np.hstack([points, np.zeros((len(points), 3 - points.shape[1]))])
    used, inverse = np.unique(triangles, return_inverse=True)
    return TriangleSurface(points[used, :3], inverse.reshape(triangles.shape))


def _per_item_data(
    kind: str, data: dict | None, count_name: str, count: int
) -> dict[str, np.ndarray]:
    """``data`` as arrays, each checked to have first dimension ``count`` (``ValueError`` naming
    ``kind`` and ``count_name`` otherwise)."""
    out = {}
    for name, value in (data or {}).items():
        arr = np.asarray(value)
        if arr.shape[:1] != (count,):
            raise ValueError(
                f"mesh: {kind} '{name}' has shape {arr.shape}; "
                f"its first dimension must be {count_name} = {count}"
            )
        out[name] = arr
    return out


def write_surface(
    path: str | Path,
    surface: TriangleSurface,
    point_data: dict | None = None,
    cell_data: dict | None = None,
) -> None:
    """Write a surface with meshio; the format follows the extension (``.vtu`` -> VTU).

    Parameters
    ----------
    path : output file name.
    surface : the surface (points in metres).
    point_data : name -> array with first dimension n_points (e.g. (n,) or (n, 3)).
    cell_data : name -> array with first dimension n_triangles.
    """
    path = Path(path)
    pdata = _per_item_data("point_data", point_data, "n_points", surface.n_points)
    cdata = _per_item_data("cell_data", cell_data, "n_triangles", surface.n_triangles)
    cdata = {name: [arr] for name, arr in cdata.items()}  # meshio wants one array per cell block
    mesh = meshio.Mesh(
        surface.points, [("triangle", surface.triangles)], point_data=pdata, cell_data=cdata
    )
    try:
        meshio.write(path, mesh)
    except Exception as exc:  # unknown extension, unwritable directory, ...
        raise ValueError(f"mesh: cannot write surface file '{path}': {exc}") from exc
