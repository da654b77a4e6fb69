"""Checked arrays of a surface mesh and its mode shapes, shared by the VTU writers
(:mod:`quadmodes.io.vtk`) and the PNG pictures (:mod:`quadmodes.io.pictures`).

All inputs are plain numpy arrays in SI units (metres):

* ``points``    (n, 3) float, node positions [m]
* ``triangles`` (nt, 3) int, node indices of the triangular facets
* ``lines``     (m, 2) int, optional extra line cells (ties, beam centre line, ...)
* ``shapes``    (N, n, 3) float, mode shapes at the nodes (any scale)
* ``frequencies_hz`` (N,) float [Hz], ``labels`` list of N strings
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def as_points(points) -> np.ndarray:
    """``points`` as a float (n, 3) array; ValueError for another shape."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {pts.shape}")
    return pts


def as_cells(cells, width: int, n_points: int, name: str) -> np.ndarray:
    """``cells`` as an int64 (m, width) array of node indices in 0..n_points-1 ((0, width) if
    empty); ValueError / TypeError naming ``name`` otherwise."""
    arr = np.asarray(cells)
    if arr.size == 0:
        return np.zeros((0, width), dtype=np.int64)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must have shape (m, {width}), got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"{name} must be an integer array, got dtype {arr.dtype}")
    arr = arr.astype(np.int64)
    if arr.min() < 0 or arr.max() >= n_points:
        raise ValueError(f"{name} reference nodes outside 0..{n_points - 1}")
    return arr


def as_lines(lines, n_points: int) -> np.ndarray | None:
    """Optional line cells: None, or ``lines`` checked by :func:`as_cells` ((m, 2) int64)."""
    return None if lines is None else as_cells(lines, 2, n_points, "lines")


def as_shapes(shapes, n_points: int) -> np.ndarray:
    """``shapes`` as a float (N, n_points, 3) array (one (n_points, 3) shape becomes N = 1)."""
    arr = np.asarray(shapes, dtype=float)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (n_points, 3):
        raise ValueError(f"shapes must have shape (N, {n_points}, 3), got {arr.shape}")
    return arr


def as_mode_set(
    pts: np.ndarray, shapes, frequencies_hz, labels: Sequence[str]
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(shapes (N, n, 3), frequencies (N,) Hz, labels) of N modes on the nodes ``pts`` (n, 3);
    ValueError if the counts disagree."""
    shp = as_shapes(shapes, len(pts))
    freqs = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    labels = list(labels)
    n_modes = shp.shape[0]
    if freqs.shape != (n_modes,) or len(labels) != n_modes:
        raise ValueError(f"got {n_modes} shapes, {freqs.size} frequencies and {len(labels)} labels")
    return shp, freqs, labels


def _bbox_diagonal(points: np.ndarray) -> float:
    if len(points) == 0:
        return 0.0
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def default_scale(points, shape, fraction: float = 0.1) -> float:
    """Display scale for a mode shape: ``fraction`` of the bounding-box diagonal of
    ``points`` (n, 3) [m] divided by the largest nodal |shape| ((n, 3) or (N, n, 3)).

    Returns a dimensionless factor (0.0 if the shape is identically zero).
    """
    pts = as_points(points)
    sh = np.asarray(shape, dtype=float).reshape(-1, 3)
    umax = float(np.max(np.linalg.norm(sh, axis=1))) if sh.size else 0.0
    if umax <= 0.0 or not np.isfinite(umax):
        return 0.0
    return fraction * _bbox_diagonal(pts) / umax
