"""Flat open membranes: a disc in the x-y plane (normal +z, the body axis of every built-in shape),
meshed with near-equilateral triangles.

The disc is a centre node and ``K = ceil(R / h)`` equally spaced rings of radius ``r_k = k R / K``
with ``6k`` nodes each (edges ≈ π R / (3K) ≈ 1.05 h around a ring, R / K ≤ h across), every
other ring turned by half a spacing; the triangles are the Delaunay triangulation of the (convex)
point set, oriented so that ``(p1 − p0) × (p2 − p0)`` points along +z. Lengths in m.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from quadmodes.mesh.surface import TriangleSurface

__all__ = ["disc_node_count", "disc_surface", "ring_count"]


def ring_count(radius: float, edge_length: float) -> int:
    """Number of node rings ``K`` (≥ 2) of a disc of ``radius`` (m) at target ``edge_length`` (m)."""
    return max(2, int(np.ceil(radius / edge_length - 1e-9)))


def disc_node_count(radius: float, edge_length: float) -> int:
    """Node count ``1 + 3K(K + 1)`` of :func:`disc_surface` (no meshing: the resource guard)."""
    k = ring_count(radius, edge_length)
    return 1 + 3 * k * (k + 1)


def disc_surface(radius: float, edge_length: float) -> TriangleSurface:
    """Flat disc of ``radius`` (m) in the plane z = 0, centred on the origin, target edge
    ``edge_length`` (m): ``1 + 3K(K + 1)`` nodes (module docstring); the edge nodes lie exactly
    on the circle r = radius."""
    k_rings = ring_count(radius, edge_length)
    pts = [np.zeros((1, 2))]
    for k in range(1, k_rings + 1):
        m = 6 * k
        phase = 0.5 * (k % 2) * 2.0 * np.pi / m
        theta = phase + 2.0 * np.pi * np.arange(m) / m
        r = radius * k / k_rings
        pts.append(np.column_stack([r * np.cos(theta), r * np.sin(theta)]))
    xy = np.concatenate(pts)
    tri = Delaunay(xy).simplices.astype(np.int64)
    a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    tri[cross < 0.0] = tri[cross < 0.0][:, [0, 2, 1]]
    points = np.column_stack([xy, np.zeros(len(xy))])
    return TriangleSurface(points, tri)
