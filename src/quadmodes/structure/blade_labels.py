"""Names of the modes of radial membrane strips on a hub (heliogyro blades): "blade flap (n=…,
s=…)" or "blade twist (n=…, s=…)", "blade in-plane" for motion mostly in the plane.

Each blade's out-of-plane deflection w is split into its flap (w's mean across the width) and
its twist (w's first moment across the width, y the distance from the blade's axis); the larger
kinetic share names the kind. n is the harmonic of that amplitude around the blades (0: all
alike, B/2: alternating), s the sign changes of the dominant blade's radial profile (nodes
along the blade), among the profile's points above 3 % of its largest. Lumped masses weigh the
nodes.
"""

from __future__ import annotations

import numpy as np

from quadmodes.rotations import unit_axis


def _blade_frame(points: np.ndarray, e3: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The blade's unit axis (3,) (its centroid's direction in the plane) and its in-plane
    normal (3,)."""
    c = points.mean(axis=0)
    a = c - (c @ e3) * e3
    a /= np.linalg.norm(a)
    return a, np.cross(e3, a)


def blade_label(points, disp, weights, blades: list[np.ndarray], axis) -> str:
    """Label of the mode ``disp`` (n, 3) of the structure points ``points`` (n, 3) (m) with node
    masses ``weights`` (n,), blades given as node index arrays (module docstring). ``axis``
    (3,): the blades' normal if given, else the normal of their plane (a two-bladed body's
    symmetry axis may lie along its blades)."""
    idx = np.concatenate(blades)
    if axis is None:
        rel = points[idx] - points[idx].mean(axis=0)
        axis = np.linalg.svd(rel, full_matrices=False)[2][-1]
    e3 = unit_axis(axis)
    w = np.asarray(disp, float) @ e3
    total = float(weights[idx] @ np.einsum("ij,ij->i", disp[idx], disp[idx]))
    if total <= 0.0 or float(weights[idx] @ w[idx] ** 2) < 0.5 * total:
        return "blade in-plane"
    flap, twist, along = [], [], []
    for nodes in blades:
        a, n = _blade_frame(points[nodes], e3)
        m, y, x = weights[nodes], points[nodes] @ n, points[nodes] @ a
        flap.append(m @ w[nodes] / m.sum())
        twist.append((m * y) @ w[nodes] / max((m * y) @ y, 1e-300) * np.sqrt((m * y) @ y / m.sum()))
        along.append((x, w[nodes], y))
    flap, twist = np.array(flap), np.array(twist)
    kind, amp = ("flap", flap) if flap @ flap >= twist @ twist else ("twist", twist)
    count = len(blades)
    harmonics = np.abs(np.fft.rfft(amp)) ** 2
    n = int(np.argmax(harmonics))
    k = int(np.argmax(np.abs(amp)))
    x, wk, y = along[k]
    value = wk if kind == "flap" else wk * np.sign(y)
    bins = np.round((x - x.min()) / max(np.ptp(x), 1e-300) * max(4, int(np.sqrt(len(x))))).astype(int)
    profile = np.array([value[bins == b].mean() for b in np.unique(bins)])
    p = profile[np.abs(profile) >= 0.03 * np.abs(profile).max()]
    s = int(np.sum(np.diff(np.sign(p)) != 0))
    return f"blade {kind} (n={min(n, count // 2)}, s={s})"
