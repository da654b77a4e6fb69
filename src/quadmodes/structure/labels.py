"""Name each mode from its motion: end-body rocking/axial/torsion, or the circumferential
harmonic of the shell motion (bending, axial, breathing, torsion, shell n), or beam bending.

All decisions use kinetic-energy shares with the lumped (row-sum) mass, so they do not depend on
the mode's normalisation.
"""

from __future__ import annotations

import numpy as np

from quadmodes.fe.model import Structure, centre_of_mass, inertia_tensor

#: Two modes with the same label within this relative frequency gap form a (degenerate) pair.
PAIR_TOLERANCE = 0.05
#: Modes this close in frequency (relative) are degenerate, whatever their labels.
DEGENERATE_TOLERANCE = 1e-3

END_BODY_SHARE = 0.5  # an end body carrying this share of the kinetic energy names the mode


def body_axis(structure: Structure, x: np.ndarray) -> np.ndarray:
    """Unit symmetry axis ``(3,)``: the principal axis whose moment differs most from the others."""
    lam, vec = np.linalg.eigh(inertia_tensor(structure, x))
    gaps = [min(abs(lam[i] - lam[j]) for j in range(3) if j != i) for i in range(3)]
    axis = vec[:, int(np.argmax(gaps))]
    return axis if axis[np.argmax(np.abs(axis))] > 0 else -axis


def _rigid_fit(points: np.ndarray, disp: np.ndarray, masses: np.ndarray):
    """Least-squares translation ``t`` and small rotation ``θ`` with ``d ≈ t + θ × (p − p̄)``."""
    c = (masses @ points) / masses.sum()
    r = points - c
    a = np.zeros((3 * len(points), 6))
    for i, ri in enumerate(r):
        a[3 * i : 3 * i + 3, :3] = np.eye(3)
        a[3 * i : 3 * i + 3, 3:] = -np.array(
            [[0, -ri[2], ri[1]], [ri[2], 0, -ri[0]], [-ri[1], ri[0], 0]]
        )
    sol = np.linalg.lstsq(a, disp.ravel(), rcond=None)[0]
    return sol[:3], sol[3:], r


def _end_body_label(name, points, disp, masses, axis) -> str:
    t, theta, r = _rigid_fit(points, disp, masses)
    m = masses.sum()
    inertia = np.einsum("i,ij,ik->jk", masses, r, r)
    inertia = np.trace(inertia) * np.eye(3) - inertia
    t_ax = t @ axis
    th_ax = theta @ axis
    th_tr = theta - th_ax * axis
    shares = {
        "axial": m * t_ax**2,
        "rocking": m * (t @ t - t_ax**2) + th_tr @ inertia @ th_tr,
        "torsion": th_ax**2 * (axis @ inertia @ axis),
    }
    return f"{max(shares, key=shares.get)} ({name} mass)"


def _shell_label(points, disp, weights, axis, centre) -> str:
    e3 = axis
    e1 = np.cross([1.0, 0.0, 0.0] if abs(e3[0]) < 0.9 else [0.0, 1.0, 0.0], e3)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e3, e1)
    rel = points - centre
    z = rel @ e3
    theta = np.arctan2(rel @ e2, rel @ e1)
    radial_dir = np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2
    hoop_dir = np.cross(e3, radial_dir)
    comps = np.stack(
        [np.einsum("ij,ij->i", disp, radial_dir), np.einsum("ij,ij->i", disp, hoop_dir), disp @ e3],
        1,
    )
    bins = np.clip(((z - z.min()) / (np.ptp(z) + 1e-300) * 40).astype(int), 0, 39)
    n_max = 8
    energy = np.zeros((n_max + 1, 3))
    for b in np.unique(bins):
        sel = bins == b
        w = weights[sel]
        phase = np.exp(-1j * np.outer(np.arange(n_max + 1), theta[sel]))
        coef = (phase * w) @ comps[sel] / w.sum()
        factor = np.where(np.arange(n_max + 1) == 0, 1.0, 2.0)[:, None]
        energy += w.sum() * factor * np.abs(coef) ** 2
    n = int(np.argmax(energy.sum(1)))
    if n == 1:
        return "bending"
    if n == 0:
        return ("breathing", "torsion", "axial")[int(np.argmax(energy[0]))]
    return "ovalling (n=2)" if n == 2 else f"shell (n={n})"


def _beam_label(points, disp, axis) -> str:
    axial = disp @ axis
    transverse = disp - np.outer(axial, axis)
    if np.sum(axial**2) > np.sum(transverse**2):
        return "axial"
    u, s, vt = np.linalg.svd(transverse, full_matrices=False)
    direction = vt[0]
    plane = "xyz"[int(np.argmax(np.abs(direction)))]
    w = transverse @ direction
    order = np.argsort(points @ axis)
    w = w[order]
    significant = np.abs(w) > 1e-3 * np.abs(w).max()
    crossings = int(np.sum(np.diff(np.sign(w[significant])) != 0))
    return f"bending {plane} ({crossings} nodes)"


def label_modes(structure: Structure, x: np.ndarray, shapes: np.ndarray) -> list[str]:
    """Labels for mode shapes ``(N, n, 3)`` about state ``x`` ``(n, 3)``."""
    weights = np.asarray(structure.mass_scalar.sum(axis=1)).ravel()
    weights = np.where(structure.translational, weights, 0.0)
    axis = body_axis(structure, x)
    centre = centre_of_mass(structure, x)
    bodies = {k.split(":", 1)[1]: v for k, v in structure.groups.items() if k.startswith("body:")}
    labels = []
    for shape in shapes:
        ke = weights * np.einsum("ij,ij->i", shape, shape)
        total = ke.sum()
        label = None
        for name, idx in bodies.items():
            if ke[idx].sum() >= END_BODY_SHARE * total:
                label = _end_body_label(name, x[idx], shape[idx], weights[idx], axis)
        if label is None:
            if "membrane" in structure.groups:
                idx = structure.groups["membrane"]
                label = _shell_label(x[idx], shape[idx], weights[idx], axis, centre)
            else:
                idx = np.flatnonzero(structure.translational)
                label = _beam_label(x[idx], shape[idx], axis)
        labels.append(label)
    return labels
