"""The motion of a free-body run for ``--animate``: the reduced states of a
:class:`~quadmodes.runs.simulate.RunResult` turned into arrays (attitudes, modal coordinates,
times, the structure's cells) for :func:`quadmodes.io.motion.reduced_motion`; the files are
written by :mod:`quadmodes.io.animation`, which imports no model code. SI units: m, s."""

from __future__ import annotations

import numpy as np

from quadmodes.io.hub_ring import all_triangles, extended_model, with_image_points
from quadmodes.io.motion import FRAMES, Motion, frame_indices, reduced_motion
from quadmodes.rom import system as rsys
from quadmodes.structure.pipeline import structure_for_case

__all__ = ["model_picture", "run_motion"]


def _structure_cells(model_case) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangles, line cells and the hub ring's extra points ``E``
    (:func:`quadmodes.io.hub_ring.all_triangles`) of the finite-element structure of
    ``model_case`` (meshed again: cheap next to the inflation, and the node order is that of
    the reduced model)."""
    return all_triangles(structure_for_case(model_case))


def run_motion(result, frames: int = FRAMES, frame: str = "inertial") -> Motion:
    """The :class:`~quadmodes.io.motion.Motion` of a free-body
    :class:`~quadmodes.runs.simulate.RunResult`: at most ``frames`` of its samples, evenly
    spread, the positions ``x = R(q)(X + Φs + Σ s_m s_n g^{mn})`` (centre of mass at the
    origin) in the inertial or the body frame; the hub ring's corners move with the hub."""
    sol, model = result.solution, result.model
    q, _, s, _ = rsys.split_state(result.system, sol.y)
    keep = frame_indices(len(sol.t), frames)
    tri, lines, e_mat = _structure_cells(result.model_case)
    tri, lines = _check_cells(model.X.shape[0] + len(e_mat), tri, lines)
    return reduced_motion(extended_model(model, e_mat), q[keep], s[keep], sol.t[keep], tri,
                          lines, frame)  # fmt: skip


def _check_cells(n: int, tri: np.ndarray, lines: np.ndarray):
    """The cells, if they index the n vector DOFs of the model (else ValueError)."""
    top = max(tri.max(initial=-1), lines.max(initial=-1))
    if top >= n:
        raise ValueError(f"the mesh has node {top} but the reduced model {n} vector DOFs")
    return tri, lines


def model_picture(result, path) -> bool:
    """Draw the model of a free-body run (its reduced model's reference positions ``X`` on the
    mesh of its model case, the end-body ties as lines) into the PNG ``path``; False (nothing
    written) when the model has no triangle to draw (a beam) or its mesh does not match."""
    from quadmodes.io.pictures import plot_mesh_png

    model = result.model
    try:
        tri, lines, e_mat = _structure_cells(result.model_case)
        tri, lines = _check_cells(model.X.shape[0] + len(e_mat), tri, lines)
        if not len(tri):
            return False
        points = with_image_points(model.X, e_mat)
        plot_mesh_png(path, points, tri, lines=lines if len(lines) else None,
                      title=f"{result.model_case.name}: the model")  # fmt: skip
    except ValueError:
        return False
    return True
