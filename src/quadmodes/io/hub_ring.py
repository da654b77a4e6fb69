"""The triangles whose corners are images of other DOFs, for pictures and animations: the ring
of membrane triangles touching a rigid hub (:class:`quadmodes.fe.hub_membrane.ImageSet`, found
by its attributes: this module imports no model code). Their corners on the hub are not vector
DOFs but the points ``x = c + Σ ρ_i a_i`` of the hub's DOFs, so a picture drawn on the vector
DOFs alone leaves a hole around the hub. Here each such corner becomes an extra point whose
position (and displacement in any mode or motion) is the same linear image of the DOFs,
``E @ x``: the hub-ring points move exactly as the hub does.

``E`` (nv, n): coefficients of the nv extra points over the n vector DOFs; triangles index
``[DOFs…, extra points…]``. SI units (m).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

#: Image coefficients below this are zeros, and a row within it of a unit vector selects a DOF.
COEFFICIENT_TOL = 1e-12


def _is_image_set(element_set) -> bool:
    return all(hasattr(element_set, a) for a in ("images", "inner", "conn")) and (
        type(element_set.inner).__name__ == "MembraneSet")  # fmt: skip


def _corner(row: np.ndarray, conn: np.ndarray, n: int, points: dict) -> int:
    """Index of one corner (image ``row`` (kk,) over the element's DOFs ``conn``): the DOF its
    row selects, else n + the index of its (shared) extra point in ``points``."""
    nz = np.flatnonzero(np.abs(row) > COEFFICIENT_TOL)
    if len(nz) == 1 and abs(row[nz[0]] - 1.0) <= COEFFICIENT_TOL:
        return int(conn[nz[0]])
    key = tuple(sorted((int(conn[b]), round(float(row[b]), 12)) for b in nz))
    return n + points.setdefault(key, len(points))


def image_points(structure) -> tuple[np.ndarray, np.ndarray]:
    """``(E (nv, n), triangles (nt, 3))`` of the image sets of ``structure``: its membrane
    triangles with corners on a hub, each corner a vector DOF or an extra point ``n + v`` at
    ``E[v] @ x`` (a hub-ring point shared by the triangles around it is one point)."""
    n = len(structure.translational)
    points: dict = {}
    triangles = []
    for es in (e for e in structure.elements if _is_image_set(e)):
        conn, images = np.asarray(es.conn), np.asarray(es.images, float)
        for e in range(len(conn)):
            triangles.append([_corner(images[e, a], conn[e], n, points)
                              for a in range(images.shape[1])])  # fmt: skip
    e_mat = np.zeros((len(points), n))
    for key, v in points.items():
        for dof, coef in key:
            e_mat[v, dof] += coef
    return e_mat, np.asarray(triangles, np.int64).reshape(-1, 3)


def with_image_points(a: np.ndarray, e_mat: np.ndarray) -> np.ndarray:
    """``a`` (..., n, 3) with the extra points' values ``E @ a`` appended: (..., n + nv, 3)."""
    a = np.asarray(a, float)
    return np.concatenate([a, np.einsum("vn,...na->...va", e_mat, a)], axis=-2)


def all_triangles(structure) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(triangles (nt, 3), lines (nl, 2), E)``: :func:`quadmodes.io.motion.body_cells` of
    ``structure`` and, after them, its hub-ring triangles on the extra points of ``E``."""
    from quadmodes.io.motion import body_cells

    tri, lines = body_cells(structure)
    e_mat, ring = image_points(structure)
    if len(ring) and not len(tri) and len(lines):  # no free membrane: only the hub ring
        lines = np.zeros((0, 2), np.int64)
    return np.concatenate([tri, ring]).astype(np.int64), lines, e_mat


def extended_model(model, e_mat: np.ndarray):
    """The arrays of a reduced model that a motion reads (X, Φ, G, translational), with the
    extra points appended (their displacement in every mode and quadratic mode is E's image)."""
    if not len(e_mat):
        return model
    return SimpleNamespace(
        X=with_image_points(model.X, e_mat),
        Phi=with_image_points(model.Phi, e_mat),
        G=with_image_points(model.G, e_mat),
        translational=np.concatenate([np.asarray(model.translational, bool),
                                      np.ones(len(e_mat), bool)]),
    )  # fmt: skip
