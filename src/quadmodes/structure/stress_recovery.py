"""Nodal (recovered) stress resultants of constant-strain membrane triangles.

A constant-strain triangle's stress is one value per element: the largest element value of a
field with a steep gradient (the IKAROS-like sail's tip-mass corners) converges slowly and
unevenly, element by element. The usual recovery — at each node the area-weighted mean of the
elements around it — is a continuous field whose largest value converges (docs/sails.md, "The
tip-mass corner": within 0.3 % between 0.088 and 0.0625 m where the element value moves 1.9 %).
Nodes are found by position, so the virtual corners of the triangles touching a hub
(:class:`quadmodes.fe.hub_membrane.ImageSet`) count as nodes too. SI units: N/m, m.
"""

from __future__ import annotations

import numpy as np


def element_corners(element_set, x: np.ndarray) -> np.ndarray:
    """Corner positions ``(ne, 3, 3)`` (m) of a membrane set (or an image set's) at ``x``."""
    if hasattr(element_set, "inner"):  # fe.hub_membrane.ImageSet: its virtual node positions
        return element_set._virtual(x).reshape(len(element_set.conn), -1, 3)
    return x[element_set.conn]


def nodal_average(corners: np.ndarray, values: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Area-weighted mean of the element ``values`` (ne,) over the elements around each node,
    the nodes being the distinct ``corners`` (ne, 3, 3) (m; equal to 1e-9 of the body's size)."""
    pts = corners.reshape(-1, 3)
    size = float(np.ptp(pts, axis=0).max()) or 1.0
    _, node = np.unique(np.round(pts / (1e-9 * size)), axis=0, return_inverse=True)
    node = node.reshape(-1)
    w = np.repeat(np.asarray(area, float), corners.shape[1])
    num = np.bincount(node, w * np.repeat(np.asarray(values, float), corners.shape[1]))
    return num / np.bincount(node, w)


def largest_nodal_resultant(sets, x: np.ndarray, resultants: np.ndarray, area: np.ndarray) -> float:
    """Largest nodal (recovered) major principal resultant (N/m) of the membrane ``sets`` at
    ``x`` from their elements' principal resultants ``(ne, 2)`` and areas ``(ne,)``."""
    corners = np.concatenate([element_corners(e, x) for e in sets])
    return float(nodal_average(corners, resultants[:, 1], area).max())
