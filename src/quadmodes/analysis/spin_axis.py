"""Spin axes: the unit axis of a requested direction and the principal axes of a reduced model's
undeformed inertia J0, shared by the reduced-model Campbell sweep and the full-order
rotating-frame analysis."""

from __future__ import annotations

import numpy as np

from quadmodes.rom.reduced import ReducedModel
from quadmodes.rotations import unit_axis


def principal_axis(model: ReducedModel, index: int) -> np.ndarray:
    """Principal axis (3,) of J0, ``index`` into ascending moments (0: minor, 2: major)."""
    lam, vec = np.linalg.eigh(0.5 * (model.J0 + model.J0.T))
    e = vec[:, index]
    return e * np.sign(e[np.argmax(np.abs(e))])


def default_axis(model: ReducedModel) -> np.ndarray:
    """z for a hub-clamped body; the symmetry axis (the principal axis whose moment differs most
    from the other two) for a free body."""
    if not model.free:
        return np.array([0.0, 0.0, 1.0])
    lam = np.linalg.eigvalsh(0.5 * (model.J0 + model.J0.T))
    gaps = [min(abs(lam[i] - lam[j]) for j in range(3) if j != i) for i in range(3)]
    return principal_axis(model, int(np.argmax(gaps)))


def resolve_axis(model: ReducedModel, axis) -> np.ndarray:
    """Unit body-frame spin axis (3,) of a request: None gives :func:`default_axis`, an int the
    :func:`principal_axis` of that index, anything else :func:`unit_axis`."""
    if axis is None:
        return default_axis(model)
    if isinstance(axis, int | np.integer):
        return principal_axis(model, int(axis))
    return unit_axis(axis)
