"""The motion of a free-body run for ``--animate``: the reduced states of a
:class:`~quadmodes.runs.simulate.RunResult` turned into arrays (attitudes, modal coordinates,
times, the structure's cells) for :func:`quadmodes.io.motion.reduced_motion`; the files are
written by :mod:`quadmodes.io.animation`, which imports no model code. SI units: m, s."""

from __future__ import annotations

import numpy as np

from quadmodes.io.motion import FRAMES, Motion, body_cells, frame_indices, reduced_motion
from quadmodes.rom import system as rsys
from quadmodes.structure.pipeline import structure_for_case

__all__ = ["model_picture", "run_motion"]


def _structure_cells(model_case) -> tuple[np.ndarray, np.ndarray]:
    """Triangles and line cells of the finite-element structure of ``model_case`` (meshed
    again: cheap next to the inflation, and the node order is that of the reduced model)."""
    return body_cells(structure_for_case(model_case))


def run_motion(result, frames: int = FRAMES, frame: str = "inertial") -> Motion:
    """The :class:`~quadmodes.io.motion.Motion` of a free-body
    :class:`~quadmodes.runs.simulate.RunResult`: at most ``frames`` of its samples, evenly
    spread, the positions ``x = R(q)(X + Φs + Σ s_m s_n g^{mn})`` (centre of mass at the
    origin) in the inertial or the body frame."""
    sol, model = result.solution, result.model
    q, _, s, _ = rsys.split_state(result.system, sol.y)
    keep = frame_indices(len(sol.t), frames)
    tri, lines = _check_cells(model.X.shape[0], *_structure_cells(result.model_case))
    return reduced_motion(model, q[keep], s[keep], sol.t[keep], tri, lines, frame)


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
        tri, lines = _check_cells(model.X.shape[0], *_structure_cells(result.model_case))
        if not len(tri):
            return False
        plot_mesh_png(path, model.X, tri, lines=lines if len(lines) else None,
                      title=f"{result.model_case.name}: the model")  # fmt: skip
    except ValueError:
        return False
    return True
