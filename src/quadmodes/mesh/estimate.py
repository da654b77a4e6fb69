"""The node count of a revolution mesh, computed without meshing (resource guards).

:func:`revolution_node_count` places the rings exactly as
:func:`quadmodes.mesh.revolution.mesh_revolution` does and sums their node counts, in
O(features × 4000) work whatever the edge length: a case asking for millions of nodes is
known before any memory is spent on it.
"""

from __future__ import annotations

import numpy as np

from quadmodes.mesh.revolution import Profile, _ring_positions, local_edge_length


def revolution_node_count(
    profile: Profile,
    edge_length: float,
    elements_per_radius: float | None = None,
    refine_at: tuple[tuple[float, float], ...] = (),
) -> int:
    """Number of nodes :func:`~quadmodes.mesh.revolution.mesh_revolution` would create for
    these arguments (edge length m, as there): both poles and every ring."""

    def row_height(s_: np.ndarray) -> np.ndarray:
        h_ = local_edge_length(profile, s_, edge_length, elements_per_radius, refine_at)
        return h_ * np.sqrt(3) / 2

    s = _ring_positions(profile, row_height)
    r, _ = profile.point_at(s)
    h_ring = local_edge_length(profile, s, edge_length, elements_per_radius, refine_at)
    counts = np.maximum(3, np.rint(2.0 * np.pi * r[1:-1] / h_ring[1:-1]).astype(np.int64))
    return int(counts.sum()) + 2
