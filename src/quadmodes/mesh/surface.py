"""Closed triangulated surfaces: container, topology checks and geometric measures.

All lengths are in metres (SI). Triangles are oriented so that the right-hand normal
``(p1 - p0) x (p2 - p0)`` points out of the enclosed volume. Everything is vectorised over
triangles and edges; no Python loop runs over mesh entities.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "TriangleSurface",
    "enclosed_volume",
    "triangle_areas",
    "surface_area",
    "edges_of",
    "unique_edges",
    "boundary_edges",
    "non_manifold_edges",
    "is_watertight",
    "is_consistently_oriented",
    "triangle_angles_deg",
    "min_angle_deg",
    "degenerate_triangles",
    "check_closed_surface",
    "connected_parts",
    "orient_outward",
    "surface_report",
]

# A triangle counts as degenerate when its area is below this fraction of its longest edge
# squared (|sin| of its largest angle ~ 2e-10): only truly collapsed triangles are caught.
_DEGENERATE_REL_AREA = 1e-10


@dataclass(frozen=True, eq=False)
class TriangleSurface:
    """Triangulated surface.

    Attributes
    ----------
    points : (n, 3) float array, metres
        Node coordinates.
    triangles : (nt, 3) int array
        Node indices per triangle, oriented so that ``(p1 - p0) x (p2 - p0)`` points out of
        the enclosed volume.
    """

    points: np.ndarray
    triangles: np.ndarray

    def __post_init__(self) -> None:
        points = np.ascontiguousarray(self.points, dtype=float)
        triangles = np.ascontiguousarray(self.triangles, dtype=np.int64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"mesh: points must have shape (n, 3), got {points.shape}")
        if triangles.ndim != 2 or triangles.shape[1] != 3:
            raise ValueError(f"mesh: triangles must have shape (nt, 3), got {triangles.shape}")
        if triangles.size and (triangles.min() < 0 or triangles.max() >= len(points)):
            raise ValueError(
                f"mesh: triangle node indices must lie in [0, {len(points) - 1}]; "
                "fix the connectivity"
            )
        if not np.all(np.isfinite(points)):
            raise ValueError("mesh: points contain NaN or inf; fix the node coordinates")
        # Frozen dataclass: bypass __setattr__ to store the normalised arrays.
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "triangles", triangles)

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])


def _corners(points: np.ndarray, triangles: np.ndarray):
    p = np.asarray(points, dtype=float)
    t = np.asarray(triangles, dtype=np.int64)
    return p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]


def enclosed_volume(points: np.ndarray, triangles: np.ndarray) -> float:
    """Signed enclosed volume in m^3: sum of ``p0 . (p1 x p2) / 6`` over triangles.

    Positive for a closed surface with outward orientation. ``points`` (n, 3) m,
    ``triangles`` (nt, 3) int.
    """
    p0, p1, p2 = _corners(points, triangles)
    return float(np.einsum("ij,ij->", p0, np.cross(p1, p2)) / 6.0)


def triangle_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Triangle areas, shape (nt,), m^2."""
    p0, p1, p2 = _corners(points, triangles)
    return 0.5 * np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)


def surface_area(points: np.ndarray, triangles: np.ndarray) -> float:
    """Total surface area in m^2."""
    return float(triangle_areas(points, triangles).sum())


def edges_of(triangles: np.ndarray) -> np.ndarray:
    """Directed half-edges (p0,p1), (p1,p2), (p2,p0) of every triangle, shape (3 nt, 2) int."""
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    return np.stack([t, np.roll(t, -1, axis=1)], axis=-1).reshape(-1, 2)


def unique_edges(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undirected edges and their use counts.

    Returns ``(edges, counts)``: edges (m, 2) int with ``edges[:, 0] < edges[:, 1]``
    (lexicographically sorted) and counts (m,) int, the number of triangles using each edge.
    """
    e = np.sort(edges_of(triangles), axis=1)
    if len(e) == 0:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
    keys, counts = np.unique(_edge_keys(e), return_counts=True)
    n = int(e.max()) + 1
    return np.column_stack([keys // n, keys % n]), counts


def _edge_keys(edges: np.ndarray) -> np.ndarray:
    """Encode (m, 2) node-index pairs as single int64 keys (1-D unique is much faster than
    ``np.unique(axis=0)``); order-preserving, so sorted keys give lexicographic pairs."""
    n = int(edges.max()) + 1
    return edges[:, 0] * n + edges[:, 1]


def boundary_edges(triangles: np.ndarray) -> np.ndarray:
    """Edges used by exactly one triangle, shape (m, 2) int, each sorted ascending."""
    edges, counts = unique_edges(triangles)
    return edges[counts == 1]


def non_manifold_edges(triangles: np.ndarray) -> np.ndarray:
    """Edges used by more than two triangles, shape (m, 2) int, each sorted ascending."""
    edges, counts = unique_edges(triangles)
    return edges[counts > 2]


def is_watertight(triangles: np.ndarray) -> bool:
    """True if the surface is closed: every edge is shared by exactly two triangles."""
    edges, counts = unique_edges(triangles)
    return bool(len(edges) > 0 and np.all(counts == 2))


def _n_same_direction_edges(triangles: np.ndarray) -> int:
    """Number of directed edges that occur more than once (orientation conflicts)."""
    d = edges_of(triangles)
    if len(d) == 0:
        return 0
    _, counts = np.unique(_edge_keys(d), return_counts=True)
    return int(np.count_nonzero(counts > 1))


def is_consistently_oriented(triangles: np.ndarray) -> bool:
    """True if every interior edge is traversed once in each direction.

    Equivalently, no directed edge occurs twice. Boundary edges (one use) are allowed;
    a non-manifold edge (three or more uses) always makes this False.
    """
    return _n_same_direction_edges(triangles) == 0


def triangle_angles_deg(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Interior angles in degrees, shape (nt, 3); column k is the angle at vertex k."""
    p0, p1, p2 = _corners(points, triangles)
    corners = np.stack([p0, p1, p2], axis=1)  # (nt, 3, 3)
    a = np.roll(corners, -1, axis=1) - corners  # to next vertex
    b = np.roll(corners, 1, axis=1) - corners  # to previous vertex
    # atan2(|a x b|, a . b) stays accurate for angles near 0 and 180 degrees, unlike arccos.
    sin = np.linalg.norm(np.cross(a, b), axis=2)
    cos = np.einsum("ijk,ijk->ij", a, b)
    return np.degrees(np.arctan2(sin, cos))


def min_angle_deg(points: np.ndarray, triangles: np.ndarray) -> float:
    """Smallest interior angle over all triangles, degrees (nan for no triangles)."""
    if len(triangles) == 0:
        return float("nan")
    return float(triangle_angles_deg(points, triangles).min())


def degenerate_triangles(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Indices of zero-area triangles (repeated node or collinear corners), shape (k,) int."""
    t = np.asarray(triangles, dtype=np.int64)
    p0, p1, p2 = _corners(points, t)
    area = 0.5 * np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
    lmax2 = np.max(
        [np.sum((p1 - p0) ** 2, axis=1), np.sum((p2 - p1) ** 2, axis=1),
         np.sum((p0 - p2) ** 2, axis=1)],
        axis=0,
    )
    repeated = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 2] == t[:, 0])
    return np.flatnonzero(repeated | (area <= _DEGENERATE_REL_AREA * lmax2))


def connected_parts(triangles: np.ndarray) -> np.ndarray:
    """The connected part (0, 1, ...) of each triangle, shape (nt,) int: triangles sharing a
    node are in one part."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    t = np.asarray(triangles, dtype=np.int64)
    if len(t) == 0:
        return np.zeros(0, dtype=np.int64)
    n = int(t.max()) + 1
    rows = np.repeat(np.arange(len(t)), 3)  # triangle-node incidence, as a bipartite graph
    graph = coo_matrix((np.ones(rows.size), (rows, len(t) + t.ravel())), (len(t) + n,) * 2)
    _, labels = connected_components(graph, directed=False)
    _, part = np.unique(labels[: len(t)], return_inverse=True)
    return part.astype(np.int64)


def check_closed_surface(surface: TriangleSurface) -> None:
    """Raise ``ValueError`` (one-line message naming problem and fix) unless the surface is
    a closed, manifold, consistently and outward-oriented triangulation without zero-area
    triangles. Returns None when all checks pass.
    """
    pts, tri = surface.points, surface.triangles
    if len(tri) == 0:
        raise ValueError("mesh: surface has no triangles; provide a closed triangulated surface")
    n_bad = len(degenerate_triangles(pts, tri))
    if n_bad:
        raise ValueError(
            f"mesh: surface has {n_bad} degenerate (zero-area) triangles; "
            "remove them or remesh the surface"
        )
    edges, counts = unique_edges(tri)
    n_open = int(np.count_nonzero(counts == 1))
    if n_open:
        raise ValueError(
            f"mesh: surface is open ({n_open} boundary edges); pressure needs a closed surface "
            "— close the surface (or use a closed built-in shape)"
        )
    n_nm = int(np.count_nonzero(counts > 2))
    if n_nm:
        raise ValueError(
            f"mesh: surface has {n_nm} non-manifold edges (shared by more than two triangles); "
            "split it into separate closed surfaces"
        )
    parts = connected_parts(tri)
    if parts.max() > 0:
        sizes = np.bincount(parts)
        shown = ", ".join(str(int(k)) for k in np.sort(sizes)[::-1][:4])
        raise ValueError(
            f"mesh: the surface has {len(sizes)} separate closed parts ({shown}"
            f"{', ...' if len(sizes) > 4 else ''} triangles); quadmodes models one connected "
            "body (several would float apart as extra zero-frequency modes): keep one part in "
            "the mesh file (geometry.file), or join them into one closed surface"
        )
    n_conflict = _n_same_direction_edges(tri)
    if n_conflict:
        raise ValueError(
            f"mesh: triangle orientation is inconsistent ({n_conflict} edges traversed twice "
            "in the same direction); reorient the triangles consistently (re-export or remesh)"
        )
    vol = enclosed_volume(pts, tri)
    if vol < 0.0:
        raise ValueError(
            f"mesh: triangles are oriented inward (enclosed volume {vol:.6g} m^3 < 0); "
            "reverse the vertex order of every triangle (flip the normals) in the mesh file "
            "(geometry.file) so that they face outward"
        )


def orient_outward(surface: TriangleSurface) -> TriangleSurface:
    """Return the surface with all triangles flipped if its signed volume is negative.

    Assumes a closed, consistently oriented surface; otherwise the sign is meaningless.
    """
    if enclosed_volume(surface.points, surface.triangles) >= 0.0:
        return surface
    return TriangleSurface(surface.points, surface.triangles[:, [0, 2, 1]])


def surface_report(surface: TriangleSurface) -> dict:
    """Summary of a surface: counts, topology flags and geometry (SI units).

    Keys: n_points, n_triangles, watertight, oriented, volume_m3, area_m2, min_angle_deg,
    max_edge_m, min_edge_m.
    """
    pts, tri = surface.points, surface.triangles
    edges, _ = unique_edges(tri)
    lengths = np.linalg.norm(pts[edges[:, 1]] - pts[edges[:, 0]], axis=1)
    return {
        "n_points": surface.n_points,
        "n_triangles": surface.n_triangles,
        "watertight": is_watertight(tri),
        "oriented": is_consistently_oriented(tri),
        "volume_m3": enclosed_volume(pts, tri),
        "area_m2": surface_area(pts, tri),
        "min_angle_deg": min_angle_deg(pts, tri),
        "max_edge_m": float(lengths.max()) if len(lengths) else float("nan"),
        "min_edge_m": float(lengths.min()) if len(lengths) else float("nan"),
    }
