"""Name each mode from its motion: end-body rocking/axial/torsion, or the circumferential
harmonic of the shell motion (bending, axial, breathing — the uniform radial family only —,
axisymmetric radial with k meridional nodes, torsion, shell n), or beam bending.

All decisions use kinetic-energy shares with the lumped (row-sum) mass, so they do not depend on
the mode's normalisation.
"""

from __future__ import annotations

import numpy as np

from quadmodes.fe.model import Structure, centre_of_mass, inertia_tensor
from quadmodes.structure.blade_labels import blade_label
from quadmodes.structure.disc_labels import disc_label

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


#: Bins along the axis for the circumferential harmonics of a shell.
SHELL_BINS = 40
#: A bin whose axisymmetric radial amplitude is below this share of the largest does not count
#: for the meridional nodes (:func:`meridional_nodes`).
NODE_SIGNIFICANCE = 0.1
#: "breathing": the uniform outward displacement carries at least this share of the mode's
#: kinetic energy (:func:`uniform_share`). The built-in sphere (1 in mesh): the uniform radial
#: mode 0.91, its near-degenerate neighbour 0.03, the other axisymmetric radial modes ≤ 2e-4;
#: on a 2 in mesh 0.92; on a 1.5 in mesh it mixes with two n = 3 modes within 0.2 % in
#: frequency: 0.37, 0.09 and 0.08.
BREATHING_SHARE = 0.3


def uniform_share(profile: np.ndarray, bin_weights: np.ndarray, energy: float) -> float:
    """``(Σ w p)² / (Σ w · E)``: the share of the kinetic energy ``energy`` = Σ m |u|² (kg·m²
    per unit modal coordinate²) in the uniform part of the axisymmetric normal-displacement
    profile p (bins, NaN empty) with bin masses w (kg); 1 for uniform radial motion, 0 for
    motion with as much outward as inward or no axisymmetric part."""
    ok = np.isfinite(profile)
    p, w = profile[ok], bin_weights[ok]
    den = float(w.sum() * energy)
    return float(np.sum(w * p) ** 2 / den) if den > 0 else 0.0


def meridional_nodes(profile: np.ndarray) -> int:
    """Sign changes along the axis of an axisymmetric normal-displacement profile (bins,
    ascending position; NaN for empty bins), counting only bins above
    :data:`NODE_SIGNIFICANCE` × the largest."""
    p = profile[np.isfinite(profile)]
    if p.size == 0:
        return 0
    p = p[np.abs(p) >= NODE_SIGNIFICANCE * np.abs(p).max()]
    return int(np.sum(np.diff(np.sign(p)) != 0))


def _harmonic_energies(points, disp, weights, axis, centre):
    """Kinetic-energy shares (n_max + 1, 3) of the circumferential harmonics n = 0 … 8 of the
    (radial, hoop, axial) motion about ``axis``, and the n = 0 displacement along the outward
    normal per axial bin (:data:`SHELL_BINS`, NaN for empty bins) with the bin masses (kg)."""
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
    bins = np.clip(((z - z.min()) / (np.ptp(z) + 1e-300) * SHELL_BINS).astype(int), 0, SHELL_BINS - 1)
    n_max = 8
    energy = np.zeros((n_max + 1, 3))
    profile = np.full((SHELL_BINS, 2), np.nan)  # n = 0 (radial, axial) per bin
    meridian = np.full((SHELL_BINS, 2), np.nan)  # mean (radius, axial position) per bin
    bin_weights = np.zeros(SHELL_BINS)
    rho = np.linalg.norm(rel - np.outer(z, e3), axis=1)
    for b in np.unique(bins):
        sel = bins == b
        w = weights[sel]
        phase = np.exp(-1j * np.outer(np.arange(n_max + 1), theta[sel]))
        coef = (phase * w) @ comps[sel] / w.sum()
        factor = np.where(np.arange(n_max + 1) == 0, 1.0, 2.0)[:, None]
        energy += w.sum() * factor * np.abs(coef) ** 2
        profile[b] = coef[0, [0, 2]].real
        meridian[b] = (w @ rho[sel] / w.sum(), w @ z[sel] / w.sum())
        bin_weights[b] = w.sum()
    return energy, _normal_profile(profile, meridian), bin_weights


def _normal_profile(profile: np.ndarray, meridian: np.ndarray) -> np.ndarray:
    """Axisymmetric displacement (bins,) along the outward normal of the meridian (ρ(z) from
    the bins' mean radius and position; NaN for empty bins) from its (radial, axial) parts."""
    out = np.full(profile.shape[0], np.nan)
    ok = np.flatnonzero(np.isfinite(meridian[:, 0]))
    if ok.size < 2:
        return np.where(np.isfinite(profile[:, 0]), profile[:, 0], np.nan)
    rho, z = meridian[ok, 0], meridian[ok, 1]
    t_rho, t_z = np.gradient(rho), np.gradient(z)
    n_rho, n_z = t_z, -t_rho
    norm = np.maximum(np.hypot(n_rho, n_z), 1e-300)
    sign = np.where(n_rho * rho + n_z * (z - z.mean()) >= 0.0, 1.0, -1.0)
    out[ok] = sign * (profile[ok, 0] * n_rho + profile[ok, 1] * n_z) / norm
    return out


def _shell_label(points, disp, weights, axis, centre) -> str:
    """Label of a shell motion by its dominant circumferential harmonic n about ``axis``: n = 1
    "bending", n = 2 "ovalling (n=2)", n ≥ 3 "shell (n=…)"; n = 0 by its dominant component,
    "torsion" (hoop), "axial", or radial: "breathing" only for the uniform radial family, whose
    uniform outward displacement carries most of the kinetic energy (:func:`uniform_share` at
    least :data:`BREATHING_SHARE`), else "axisymmetric radial (k nodes)", k its meridional nodes
    (:func:`meridional_nodes`)."""
    energy, profile, bin_weights = _harmonic_energies(points, disp, weights, axis, centre)
    n = int(np.argmax(energy.sum(1)))
    if n == 1:
        return "bending"
    if n == 0:
        kind = ("radial", "torsion", "axial")[int(np.argmax(energy[0]))]
        if kind != "radial":
            return kind
        total = float(weights @ np.einsum("ij,ij->i", disp, disp))
        if uniform_share(profile, bin_weights, total) >= BREATHING_SHARE:
            return "breathing"
        return f"axisymmetric radial ({meridional_nodes(profile)} nodes)"
    return "ovalling (n=2)" if n == 2 else f"shell (n={n})"


def _beam_label(points, disp, axis, spin_axis=None) -> str:
    """"axial", or "bending y (k nodes)" by the body axis nearest the bending direction; with a
    ``spin_axis`` (3,) across the beam "flap bending (k nodes)" when the bending direction is
    within 45° of the spin axis (motion out of the plane of rotation) and "lag bending (k nodes)"
    when it lies nearer the plane of rotation."""
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
    if spin_axis is not None:
        across = np.asarray(spin_axis, float) - (np.asarray(spin_axis, float) @ axis) * axis
        if np.linalg.norm(across) > 0.5:  # the beam is not along the spin axis
            flap = abs(direction @ across) / np.linalg.norm(across) >= np.sqrt(0.5)
            return f"{'flap' if flap else 'lag'} bending ({crossings} nodes)"
    return f"bending {plane} ({crossings} nodes)"


def _is_flat(points: np.ndarray, axis: np.ndarray) -> bool:
    """True for a flat membrane normal to ``axis`` (a disc, a sail): its extent along the
    axis is below 1e-6 of its extent across (its modes are named by
    :func:`quadmodes.structure.disc_labels.disc_label`)."""
    h = points @ axis
    return bool(np.ptp(h) <= 1e-6 * float(np.ptp(points, axis=0).max()))


def label_modes(
    structure: Structure, x: np.ndarray, shapes: np.ndarray, spin_axis=None
) -> list[str]:
    """Labels for mode shapes ``(N, n, 3)`` about state ``x`` ``(n, 3)``; ``spin_axis`` (3,),
    optional: beam bending named "flap" (along the spin axis) or "lag" (in the plane of
    rotation) instead of by body axis (:func:`_beam_label`)."""
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
        blades = [v for k, v in sorted(structure.groups.items()) if k.startswith("blade:")]
        if label is None and blades:  # heliogyro blades on a hub (structure/blade_labels.py)
            label = blade_label(x, shape, weights, blades, None)
        if label is None:
            if "membrane" in structure.groups:
                idx = structure.groups["membrane"]
                shell = disc_label if _is_flat(x[idx], axis) else _shell_label
                label = shell(x[idx], shape[idx], weights[idx], axis, centre)
            else:
                idx = np.flatnonzero(structure.translational)
                label = _beam_label(x[idx], shape[idx], axis, spin_axis)
        labels.append(label)
    return labels
