"""Names of the modes of a flat membrane (a spinning disc): out-of-plane modes by their nodal
diameters n and nodal circles s, "disc (n=2, s=0)"; motion mostly in the plane "in-plane".

The out-of-plane displacement is split, in rings of nodes binned by radius, into circumferential
harmonics (only those a ring's nodes resolve: k below half its node count, so a coarse inner ring
cannot alias a high harmonic); n is the harmonic with the most kinetic energy, s the sign changes
of its radial profile among the rings above :data:`NODE_SIGNIFICANCE` of its largest. Lumped (row-sum)
masses weigh the nodes, so nothing depends on the mode's normalisation.
"""

from __future__ import annotations

import numpy as np

from quadmodes.rotations import unit_axis

#: Highest circumferential harmonic considered.
MAX_HARMONIC = 24
#: Rings whose amplitude is below this share of the largest are left out of the sign count
#: (near the centre a mode with n diameters goes as rⁿ).
NODE_SIGNIFICANCE = 0.03


def _radial_bins(rho: np.ndarray) -> np.ndarray:
    """Bin index (n,) of each node by radius ``rho`` (m): about √n/2 equal-width rings."""
    count = max(4, int(np.sqrt(rho.size) / 2))
    return np.clip((rho / (rho.max() + 1e-300) * count).astype(int), 0, count - 1)


def _closed_ring(theta: np.ndarray) -> bool:
    """True if the angles ``theta`` (rad) go round: no gap ten times the median gap between
    neighbours (a ring's nodes are about evenly spread). The rings of a square sail beyond its
    inscribed circle are only its corners, where every mode looks like n = 4; they are left out
    of the harmonic split."""
    if theta.size < 4:
        return False
    t = np.sort(theta)
    gaps = np.diff(np.concatenate([t, [t[0] + 2.0 * np.pi]]))
    return bool(gaps.max() < 10.0 * np.median(gaps))


def disc_harmonics(points, w, weights, axis, centre) -> tuple[np.ndarray, np.ndarray]:
    """``(energy (K+1,), coefficients (bins, K+1) complex)`` of the out-of-plane displacement
    ``w`` (n,) (m) of the flat membrane ``points`` (n, 3) (m) with node masses ``weights`` (n,)
    (kg): kinetic-energy share of each harmonic k = 0 … K (:data:`MAX_HARMONIC`) and its
    complex amplitude per radial bin (0 where a bin cannot resolve k)."""
    e3 = unit_axis(axis)
    e1 = np.cross([1.0, 0.0, 0.0] if abs(e3[0]) < 0.9 else [0.0, 1.0, 0.0], e3)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e3, e1)
    rel = np.asarray(points, float) - centre
    theta = np.arctan2(rel @ e2, rel @ e1)
    bins = _radial_bins(np.hypot(rel @ e1, rel @ e2))
    ks = np.arange(MAX_HARMONIC + 1)
    energy = np.zeros(ks.size)
    coef = np.zeros((bins.max() + 1, ks.size), complex)
    whole = [b for b in np.unique(bins) if _closed_ring(theta[bins == b])]
    for b in whole or np.unique(bins):
        sel = bins == b
        m = weights[sel]
        c = (np.exp(-1j * np.outer(ks, theta[sel])) * m) @ w[sel] / m.sum()
        c[ks >= max(1, sel.sum() // 2)] = 0.0  # harmonics this ring cannot resolve
        coef[b] = c
        energy += m.sum() * np.where(ks == 0, 1.0, 2.0) * np.abs(c) ** 2
    return energy, coef


def disc_mode_numbers(points, disp, weights, axis, centre) -> tuple[int, int, float]:
    """``(n, s, out-of-plane share)`` of a mode ``disp`` (n, 3) of the flat membrane ``points``:
    nodal diameters, nodal circles and the share of its kinetic energy out of the plane."""
    e3 = unit_axis(axis)
    w = np.asarray(disp, float) @ e3
    total = float(weights @ np.einsum("ij,ij->i", disp, disp))
    share = float(weights @ (w * w)) / total if total > 0 else 0.0
    energy, coef = disc_harmonics(points, w, weights, e3, centre)
    n = int(np.argmax(energy))
    c = coef[:, n]
    phase = np.exp(-1j * np.angle(c[np.argmax(np.abs(c))]))
    profile = (c * phase).real
    p = profile[np.abs(profile) >= NODE_SIGNIFICANCE * np.abs(profile).max()]
    return n, int(np.sum(np.diff(np.sign(p)) != 0)), share


def disc_label(points, disp, weights, axis, centre) -> str:
    """ "disc (n=…, s=…)" for a mode mostly out of the plane, else "in-plane"."""
    n, s, share = disc_mode_numbers(points, disp, weights, axis, centre)
    if share < 0.5:
        return "in-plane"
    return f"disc (n={n}, s={s})"
