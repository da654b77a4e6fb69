"""The files of a modal model (what ``quadmodes modes -o DIR`` and
:func:`quadmodes.modal_model` with ``output_dir`` write): the mesh and the modes as VTU/PVD
(ParaView), PNG pictures of the mesh, the prestress and every mode, and ``modes.json``
(:func:`quadmodes.structure.pipeline.modes_summary`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from quadmodes.io.atomic import write_text

#: The files and folders :func:`write_modal_outputs` writes (``modes -o``): checked against a
#: user's files of the same names before any work.
MODAL_OUTPUTS = ("mesh.vtu", "modes", "mesh.png", "prestress.png", "modes.png", "modes.json")


def mesh_for_output(model) -> tuple[np.ndarray, np.ndarray | None, dict, np.ndarray]:
    """Triangles (n_tri, 3), line segments (n_lines, 2) or None, per-triangle cell data and the
    hub ring's extra points ``E`` (nv, n) of a modal model (:func:`quadmodes.io.hub_ring.
    all_triangles`: the triangles touching a hub come last, on the points ``n + v`` at
    ``E[v] @ x``; their cell data NaN); a beam is drawn as the centreline through its position
    DOFs."""
    from quadmodes.io.hub_ring import image_points

    s = model.structure
    tri, lines, cell_data = None, None, {}
    for e in s.elements:
        kind = type(e).__name__
        if kind == "MembraneSet":
            tri = e.conn
        elif kind in ("BarSet",):
            lines = e.conn
    e_mat, ring = image_points(s)
    if model.prestress is not None:
        res = model.prestress.stress_resultants
        pad = np.full(len(ring), np.nan)
        cell_data = {
            "stress_resultant_minor_N_per_m": np.concatenate([res[:, 0], pad]),
            "stress_resultant_major_N_per_m": np.concatenate([res[:, 1], pad]),
            "wrinkle_state": np.concatenate([model.prestress.wrinkle_state(), pad]),
        }
    if tri is None:  # beam: draw the centreline of the position DOFs as lines
        pos = np.flatnonzero(s.translational)
        lines = np.stack([pos[:-1], pos[1:]], 1)
        tri = np.zeros((0, 3), int)
    return np.concatenate([np.asarray(tri), ring]).astype(int), lines, cell_data, e_mat


def write_modal_outputs(model, directory: Path) -> None:
    """Mesh and modes as VTU/PVD (ParaView), PNG pictures and ``modes.json`` in ``directory``."""
    from quadmodes.io import pictures, vtk
    from quadmodes.io.hub_ring import with_image_points
    from quadmodes.structure.pipeline import modes_summary

    tri, lines, cell_data, e_mat = mesh_for_output(model)
    x = with_image_points(model.x, e_mat)  # the hub ring's corners move with the hub
    shapes = with_image_points(model.modes.shapes, e_mat)
    freqs = model.modes.frequencies_hz
    labels = model.labels
    vtk.write_mesh_vtu(directory / "mesh.vtu", x, tri, lines=lines, cell_data=cell_data or None)
    vtk.write_modes_pvd(directory / "modes", x, tri, shapes, freqs, labels, lines=lines)
    if len(tri):
        pictures.plot_mesh_png(directory / "mesh.png", x, tri, title=model.case.name, lines=lines)
        if cell_data:
            pictures.plot_mesh_png(
                directory / "prestress.png",
                x,
                tri,
                title=f"{model.case.name}: minor principal stress resultant after inflation",
                cell_values=cell_data["stress_resultant_minor_N_per_m"],
                cell_label="N/m",
            )
    for k in range(len(freqs)):
        pictures.plot_mode_png(
            directory / f"mode_{k + 1:02d}.png", x, tri, shapes[k], freqs[k], labels[k],
            lines=lines, index=k + 1,
        )  # fmt: skip
    pictures.plot_modes_overview_png(directory / "modes.png", x, tri, shapes, freqs, labels, lines)
    write_text(directory / "modes.json", json.dumps(modes_summary(model), indent=2))
