"""Flat open membranes around a central hole (the hub): an annulus, a square sail with a
circular cut-out and radial strips (heliogyro blades), in the x-y plane (normal +z), centred on
the origin.

Both are ``K + 1`` closed node rings between the hole's circle (ring 0, radius ``b``, the nodes
clamped to the hub) and the outer boundary (ring K): ring k is the curve ``(1 − s_k) b û(θ) +
s_k B(θ)`` with ``s_k = k/K``, ``B(θ)`` the outer boundary along the ray at angle θ (a circle of
radius ``a``, or the square of side L) and ``K = ceil((max |B| − b) / h)``; each ring carries
nodes at equal arc length about ``h`` apart (every other ring turned by half a spacing). The
triangles are the Delaunay triangulation of the point set (convex: the circle or the square)
without the triangles in the hole (those whose three nodes are on ring 0), oriented along +z.
The square's outer ring has a multiple of 4 nodes starting at a corner, so the four corners are
nodes. Lengths in m.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from quadmodes.mesh.surface import TriangleSurface

__all__ = [
    "annulus_surface",
    "corner_nodes",
    "hub_ring_count",
    "hub_ring_nodes",
    "hub_surface_node_count",
    "square_surface",
    "strip_root_nodes",
    "strip_surface",
]

_SAMPLES = 4096  # points per ring polyline for the arc-length placement of the nodes


def hub_ring_count(inner_radius: float, outer_extent: float, edge_length: float) -> int:
    """Rings ``K`` (≥ 2) between the hole (radius m) and the farthest outer point (m)."""
    return max(2, int(np.ceil((outer_extent - inner_radius) / edge_length - 1e-9)))


def _square_boundary(theta: np.ndarray, side: float) -> np.ndarray:
    """Points ``(k, 2)`` (m) of the square of ``side`` (m) along the rays at ``theta`` (rad)."""
    c, s = np.cos(theta), np.sin(theta)
    return (0.5 * side / np.maximum(np.abs(c), np.abs(s)))[:, None] * np.column_stack([c, s])


def _ring_points(curve: np.ndarray, count: int, phase: float) -> np.ndarray:
    """``count`` points at equal arc length on the closed polyline ``curve`` (k, 2), starting
    ``phase`` (a fraction of a spacing) after its first point."""
    closed = np.vstack([curve, curve[:1]])
    length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    target = (np.arange(count) + phase) * length[-1] / count
    return np.column_stack([np.interp(target, length, closed[:, i]) for i in range(2)])


def _square_outer_ring(side: float, count: int) -> np.ndarray:
    """``count`` (a multiple of 4) points at equal spacing on the square's perimeter, starting
    at the corner (+L/2, +L/2) and running counter-clockwise: the corners are nodes."""
    h = 0.5 * side
    corners = np.array([[h, h], [-h, h], [-h, -h], [h, -h]])
    per_side = count // 4
    t = np.arange(per_side) / per_side
    return np.concatenate([c + t[:, None] * (corners[(i + 1) % 4] - c)
                           for i, c in enumerate(corners)])  # fmt: skip


def _rings(inner_radius: float, outer, extent: float, edge_length: float, square: float | None):
    """The node rings ``[(m_k, 2)]`` of the module docstring; ``outer(θ)`` the boundary."""
    k_rings = hub_ring_count(inner_radius, extent, edge_length)
    theta = 2.0 * np.pi * np.arange(_SAMPLES) / _SAMPLES + 0.25 * np.pi
    circle = inner_radius * np.column_stack([np.cos(theta), np.sin(theta)])
    boundary = outer(theta)
    rings = []
    for k in range(k_rings + 1):
        s = k / k_rings
        curve = (1.0 - s) * circle + s * boundary
        perimeter = np.sum(np.linalg.norm(np.diff(np.vstack([curve, curve[:1]]), axis=0), axis=1))
        count = max(6, int(np.ceil(perimeter / edge_length - 1e-9)))
        if k == 0:  # exactly on the hub's circle: equal angles
            angle = 0.25 * np.pi + 2.0 * np.pi * np.arange(count) / count
            rings.append(inner_radius * np.column_stack([np.cos(angle), np.sin(angle)]))
        elif k == k_rings and square is not None:
            rings.append(_square_outer_ring(square, 4 * int(np.ceil(count / 4))))
        else:
            rings.append(_ring_points(curve, count, 0.5 * (k % 2)))
    return rings


def _triangulate(rings: list[np.ndarray]) -> TriangleSurface:
    """Delaunay triangles of the rings' points without those on ring 0 only (the hole)."""
    xy = np.concatenate(rings)
    tri = Delaunay(xy).simplices.astype(np.int64)
    tri = tri[~np.all(tri < len(rings[0]), axis=1)]
    a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    tri[cross < 0.0] = tri[cross < 0.0][:, [0, 2, 1]]
    return TriangleSurface(np.column_stack([xy, np.zeros(len(xy))]), tri)


def annulus_surface(outer_radius: float, inner_radius: float, edge_length: float) -> TriangleSurface:
    """Flat annulus between ``inner_radius`` and ``outer_radius`` (m) at target ``edge_length``
    (m); its first nodes are the hole's ring (exactly on r = inner_radius)."""
    def outer(theta):
        return outer_radius * np.column_stack([np.cos(theta), np.sin(theta)])

    return _triangulate(_rings(inner_radius, outer, outer_radius, edge_length, None))


def square_surface(side: float, inner_radius: float, edge_length: float) -> TriangleSurface:
    """Flat square sail of ``side`` (m) with a circular hole of ``inner_radius`` (m) at its
    centre, target ``edge_length`` (m); its first nodes are the hole's ring, its corners nodes."""
    extent = 0.5 * side * np.sqrt(2.0)
    return _triangulate(_rings(inner_radius, lambda t: _square_boundary(t, side), extent,
                               edge_length, side))  # fmt: skip


def hub_surface_node_count(shape: str, outer: float, inner_radius: float, edge_length: float) -> int:
    """Node count of :func:`annulus_surface` (``outer``: radius) or :func:`square_surface`
    (``outer``: side) without meshing (the resource guard): the rings' sizes."""
    if shape == "annulus":
        def boundary(t):
            return outer * np.column_stack([np.cos(t), np.sin(t)])

        rings = _rings(inner_radius, boundary, outer, edge_length, None)
    else:
        rings = _rings(inner_radius, lambda t: _square_boundary(t, outer),
                       0.5 * outer * np.sqrt(2.0), edge_length, outer)  # fmt: skip
    return int(sum(len(r) for r in rings))


def hub_ring_nodes(points: np.ndarray, inner_radius: float) -> np.ndarray:
    """Indices of the nodes of ``points`` (n, 3) on the hole's circle (m): the hub's ring."""
    r = np.hypot(points[:, 0], points[:, 1])
    return np.flatnonzero(np.abs(r - inner_radius) <= 1e-9 * max(inner_radius, 1.0))


def corner_nodes(points: np.ndarray, side: float) -> dict[str, int]:
    """The node at each corner of the square of ``side`` (m): ``{"+x+y": i, "-x+y": …,
    "-x-y": …, "+x-y": …}``; raises ValueError if a corner is not a node."""
    out = {}
    for name, sx, sy in (("+x+y", 1, 1), ("-x+y", -1, 1), ("-x-y", -1, -1), ("+x-y", 1, -1)):
        target = 0.5 * side * np.array([sx, sy])
        d = np.linalg.norm(points[:, :2] - target, axis=1)
        i = int(np.argmin(d))
        if d[i] > 1e-9 * side:
            raise ValueError(f"mesh: the corner {name} of the square is not a node")
        out[name] = i
    return out


def strip_surface(
    inner_radius: float, length: float, width: float, blades: int, edge_length: float
) -> TriangleSurface:
    """``blades`` flat rectangular strips (heliogyro blades) of ``length`` × ``width`` (m) at
    equal azimuths from the first along +x, each from ``inner_radius`` (m) outwards: a
    structured grid of ``ceil(length / h) × max(2, ceil(width / h))`` cells split into
    triangles by alternating diagonals (h = ``edge_length``, m). The root edge of each (its
    nodes at ``inner_radius`` along its axis) is clamped to the hub."""
    nx = max(2, int(np.ceil(length / edge_length - 1e-9)))
    ny = max(2, int(np.ceil(width / edge_length - 1e-9)))
    x = inner_radius + length * np.arange(nx + 1) / nx
    y = width * (np.arange(ny + 1) / ny - 0.5)
    gx, gy = np.meshgrid(x, y, indexing="ij")
    local = np.column_stack([gx.ravel(), gy.ravel()])
    node = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    a, b, c, d = node[i, j], node[i + 1, j], node[i + 1, j + 1], node[i, j + 1]
    flip = ((i + j) % 2).astype(bool)
    t1 = np.where(flip[..., None], np.stack([a, b, d], -1), np.stack([a, b, c], -1))
    t2 = np.where(flip[..., None], np.stack([b, c, d], -1), np.stack([a, c, d], -1))
    cells = np.concatenate([t1.reshape(-1, 3), t2.reshape(-1, 3)])
    points, triangles = [], []
    for k in range(blades):
        phi = 2.0 * np.pi * k / blades
        rot = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
        triangles.append(cells + k * len(local))
        points.append(local @ rot.T)
    xy = np.concatenate(points)
    return TriangleSurface(np.column_stack([xy, np.zeros(len(xy))]), np.concatenate(triangles))


def strip_root_nodes(points: np.ndarray, inner_radius: float, blades: int) -> np.ndarray:
    """Indices of the nodes of :func:`strip_surface` on a blade's root edge."""
    phi = 2.0 * np.pi * np.arange(blades) / blades
    axes = np.column_stack([np.cos(phi), np.sin(phi)])
    along = (points[:, :2] @ axes.T).max(axis=1)  # along the blade the node belongs to
    return np.flatnonzero(np.abs(along - inner_radius) <= 1e-9 * max(inner_radius, 1.0))
