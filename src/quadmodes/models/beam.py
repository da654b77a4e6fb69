"""The reduced model of a beam clamped to a hub: the Kane–Ryan–Banerjee beam of the spin-up
(:mod:`quadmodes.runs.spinup`, the full-order Kane reference) and of a ``[spinup]`` run case.

Only the soft *bending* modes in the plane of rotation (hub-frame y) are kept by default, with
``out_of_plane`` as many out-of-plane (z) bending modes; never axial modes (theory.md §5 "Which
modes"). The clamped ANCF eigenvectors of a symmetric section come in degenerate y/z pairs that
the eigensolver returns as arbitrary mixtures; :func:`split_planes` rotates each degenerate set
into pure in-plane and out-of-plane members before selection (also for the Campbell model of a
beam case, :func:`quadmodes.models.build.case_modes_model`).
"""

from __future__ import annotations

import numpy as np

from quadmodes.fe.build import build_beam_structure
from quadmodes.rom.reduced import ReducedModel, reduce
from quadmodes.structure.labels import label_modes
from quadmodes.structure.modes import compute_modes

__all__ = ["KANE_BEAM", "kane_model", "split_planes"]

#: Kane–Ryan–Banerjee beam (references.md §3), SI.
KANE_BEAM = {
    "length": 10.0,  # m
    "youngs_modulus": 7.0e10,  # Pa
    "density": 3000.0,  # kg/m³
    "area": 4.0e-4,  # m²
    "second_moment": 2.0e-7,  # m⁴
}


def split_planes(
    structure, frequencies_hz: np.ndarray, shapes: np.ndarray, rtol: float = 1e-3
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Rotate degenerate sets of a straight beam along x into pure y / z members; classify.

    Within each set of modes whose frequencies agree within ``rtol`` the mass-normalised shapes are
    replaced by the orthogonal combinations that diagonalise their mass-weighted y–y inner
    product (so mass normalisation and Λ = diag ω² are kept). Returns the new shapes, the plane of
    each mode (``"in-plane"`` = y, ``"out-of-plane"`` = z, ``"axial"`` = x) by kinetic-energy share,
    and the frequency order (unchanged)."""
    shapes = np.array(shapes, float)
    w = np.asarray(structure.mass_scalar.sum(axis=1)).ravel()
    w = np.where(structure.translational, w, 0.0)
    f = np.asarray(frequencies_hz, float)
    i = 0
    while i < len(f):
        j = i + 1
        while j < len(f) and abs(f[j] - f[i]) <= rtol * abs(f[i]):
            j += 1
        if j - i > 1:
            block = shapes[i:j]
            gram = np.einsum("i,ai,bi->ab", w, block[:, :, 1], block[:, :, 1])
            _, vec = np.linalg.eigh(gram)
            vec = vec[:, ::-1]  # most in-plane first
            shapes[i:j] = np.einsum("ab,ai...->bi...", vec, block)
        i = j
    planes = []
    for shape in shapes:
        energy = np.einsum("i,ia->a", w, shape * shape)
        planes.append(("axial", "in-plane", "out-of-plane")[int(np.argmax(energy))])
    return shapes, f, planes


def kane_model(
    n_modes: int = 4,
    n_elements: int = 20,
    out_of_plane: bool = False,
    length: float = KANE_BEAM["length"],
    youngs_modulus: float = KANE_BEAM["youngs_modulus"],
    density: float = KANE_BEAM["density"],
    area: float = KANE_BEAM["area"],
    second_moment: float = KANE_BEAM["second_moment"],
    damping_ratio: float = 0.0,
    structure=None,
) -> ReducedModel:
    """Reduced model of the hub-clamped Kane beam (ANCF cable along +x from the hub point).

    Keeps the lowest ``n_modes`` bending modes in the plane of rotation (hub-frame y) and, with
    ``out_of_plane``, as many out-of-plane (z) bending modes; never axial modes. Mode labels read
    ``"in-plane bending k"`` / ``"out-of-plane bending k"`` (k = 1, 2, …). ``structure``: an
    already-built clamped beam :class:`~quadmodes.fe.model.Structure` (overrides the beam data)."""
    if n_modes < 1:
        raise ValueError("n_modes: keep at least one in-plane bending mode")
    if structure is None:
        structure = build_beam_structure(
            length,
            n_elements,
            youngs_modulus * area,
            youngs_modulus * second_moment,
            density * area,
            clamped=True,
        )
    if structure.is_free:
        raise ValueError("kane_model: the beam must be clamped at the hub")
    x = structure.reference
    modes = compute_modes(structure, x, 2 * n_modes + 2)
    shapes, freqs, planes = split_planes(structure, modes.frequencies_hz, modes.shapes)
    wanted = ("in-plane", "out-of-plane") if out_of_plane else ("in-plane",)
    keep, labels = [], []
    for plane in wanted:
        idx = [k for k, p in enumerate(planes) if p == plane][:n_modes]
        if len(idx) < n_modes:
            raise ValueError(f"kane_model: only {len(idx)} {plane} bending modes were found")
        keep += idx
        labels += [f"{plane} bending {j + 1}" for j in range(len(idx))]
    order = np.argsort(freqs[keep], kind="stable")
    keep = [keep[k] for k in order]
    labels = [labels[k] for k in order]
    provenance = {
        "model": "kane-beam",
        "n_elements": int(n_elements),
        "fe_labels": ", ".join(label_modes(structure, x, shapes[keep])),
    }
    return reduce(
        structure, x, freqs[keep], shapes[keep], labels, damping_ratio, provenance=provenance
    )
