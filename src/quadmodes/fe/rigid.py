"""Rigid end bodies as clusters of point masses tied to membrane nodes by stiff bars.

The reduced-model integrals need translational DOFs with an isotropic mass matrix, and the
quadratic modes need the attachment to stay rigid to second order. A cluster of seven point masses
(one at the centre, pairs at ±arm along the body axes) reproduces any mass and axisymmetric inertia
tensor exactly; Green-strain bars (exactly frame invariant) join every pair of cluster points and
every cluster point to every attached membrane node, which makes the assembly rigid for all finite
rotations up to the bars' (large) axial compliance.
"""

from __future__ import annotations

import numpy as np


def orthonormal_frame(axis: np.ndarray) -> np.ndarray:
    """Rows ``(3, 3)``: two unit vectors normal to ``axis`` and ``axis`` normalised."""
    e3 = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(e3[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, e3)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(e3, e1), e3])


def point_mass_cluster(
    centre: np.ndarray,
    axis: np.ndarray,
    mass: float,
    inertia_axial: float,
    inertia_transverse: float,
    arm: float,
    name: str = "end_body",
) -> tuple[np.ndarray, np.ndarray]:
    """Seven points ``(7, 3)`` (m) and masses ``(7,)`` (kg) with the given mass (kg) and inertias
    (kg m², about ``centre``, axial along ``axis``).

    With pair masses ``m_k`` at ``±arm e_k``: ``I_kk = 2 arm² (Σ_j m_j − m_k)``. Raises ValueError if
    the inertias need negative masses (the arm is too short, or ``I_axial > 2 I_transverse``).
    """
    i_diag = np.array([inertia_transverse, inertia_transverse, inertia_axial])
    a2 = arm * arm
    total_pairs = i_diag.sum() / (4.0 * a2)
    pair = total_pairs - i_diag / (2.0 * a2)
    centre_mass = mass - 2.0 * total_pairs
    if np.any(pair < -1e-15 * mass):
        raise ValueError(
            f"end_body {name}: inertia_axial must not exceed 2 × inertia_transverse "
            "for a physical body; lower inertia_axial"
        )
    if centre_mass < 0.0:
        need = np.sqrt(i_diag.sum() / (2.0 * mass))
        raise ValueError(
            f"end_body {name}: arm {arm:.4g} m is too short for these inertias; "
            f"use arm >= {need:.4g} m"
        )
    frame = orthonormal_frame(axis)
    offsets = np.concatenate([np.zeros((1, 3)), arm * frame, -arm * frame])
    masses = np.concatenate([[centre_mass], np.clip(pair, 0.0, None), np.clip(pair, 0.0, None)])
    return np.asarray(centre, float) + offsets, masses


def tie_connectivity(cluster: np.ndarray, attached: np.ndarray) -> np.ndarray:
    """Bar connectivity ``(m, 2)``: all pairs within ``cluster`` and every cluster–attached pair."""
    cluster = np.asarray(cluster)
    attached = np.asarray(attached)
    i, j = np.triu_indices(len(cluster), 1)
    inner = np.stack([cluster[i], cluster[j]], 1)
    outer = np.stack(np.meshgrid(cluster, attached, indexing="ij"), -1).reshape(-1, 2)
    return np.concatenate([inner, outer])
