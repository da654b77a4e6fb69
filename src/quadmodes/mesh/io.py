"""Read and write triangulated surfaces through meshio (format chosen by file extension)."""

from __future__ import annotations

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
    try:
        mesh = meshio.read(path)
    except Exception as exc:  # meshio raises many types (ReadError, KeyError, OSError, ...)
        raise ValueError(f"mesh: cannot read surface file '{path}': {exc}") from exc
    blocks = [np.asarray(c.data, dtype=np.int64) for c in mesh.cells if c.type == "triangle"]
    if not blocks or sum(len(b) for b in blocks) == 0:
        types = sorted({c.type for c in mesh.cells}) or ["none"]
        raise ValueError(
            f"mesh: file '{path}' has no triangle cells (found: {', '.join(types)}); "
            "export the surface as triangles"
        )
    triangles = np.concatenate(blocks)
    points = np.asarray(mesh.points, dtype=float)
    if points.shape[1] < 3:
        points = np.hstack([points, np.zeros((len(points), 3 - points.shape[1]))])
    used, inverse = np.unique(triangles, return_inverse=True)
    return TriangleSurface(points[used, :3], inverse.reshape(triangles.shape))


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
    pdata = {}
    for name, value in (point_data or {}).items():
        arr = np.asarray(value)
        if arr.shape[:1] != (surface.n_points,):
            raise ValueError(
                f"mesh: point_data '{name}' has shape {arr.shape}; "
                f"its first dimension must be n_points = {surface.n_points}"
            )
        pdata[name] = arr
    cdata = {}
    for name, value in (cell_data or {}).items():
        arr = np.asarray(value)
        if arr.shape[:1] != (surface.n_triangles,):
            raise ValueError(
                f"mesh: cell_data '{name}' has shape {arr.shape}; "
                f"its first dimension must be n_triangles = {surface.n_triangles}"
            )
        cdata[name] = [arr]  # meshio wants one array per cell block
    mesh = meshio.Mesh(
        surface.points, [("triangle", surface.triangles)], point_data=pdata, cell_data=cdata
    )
    try:
        meshio.write(path, mesh)
    except Exception as exc:  # unknown extension, unwritable directory, ...
        raise ValueError(f"mesh: cannot write surface file '{path}': {exc}") from exc
