"""Labels for the modes of a hub with booms: which booms move, how, and in what pattern.

For each mode the booms' translational kinetic energy is split into the components along each
boom's own axis ``t``, its section director ``d₂`` ("out-of-plane": normal to the plane of the
boom and the hub's z axis for a radial boom) and ``d₃`` ("in-plane"); torsion is the share of
the section directors' motion about ``t``. The dominant one names the motion; the bending order
is the number of sign changes of that component along the boom plus one. The pattern over
equally spaced booms is the azimuthal harmonic n of the booms' signed amplitudes (n = 0:
"collective", all booms alike in their own frames; n = 1 tilts the plane; n = 2 …), or
"boom <name>" when one boom carries most of the energy. A mode with most of its energy in the
hub's rigid motion relative to the booms is "hub".
"""

from __future__ import annotations

import numpy as np

from quadmodes.fe.model import Structure

#: A single boom carrying this share of the energy names the mode after itself.
SINGLE_BOOM_SHARE = 0.8


def _boom_frames(structure: Structure, x: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Rows ``[t, d₂, d₃]`` ``(3, 3)`` of a boom from its first node's vector DOFs."""
    first = idx[0]
    return np.stack([x[first + k] / np.linalg.norm(x[first + k]) for k in (1, 2, 3)])


def _component_profile(
    shape: np.ndarray, x: np.ndarray, idx: np.ndarray, frame: np.ndarray
) -> np.ndarray:
    """Displacements of the boom's nodes ``(nn, 3)`` relative to the hub's rigid motion
    (``δc + Σ ξ_i δa_i`` at the node's hub coordinates ξ), in the boom frame (axial, out-,
    in-plane)."""
    axes = x[1:4]
    xi = (x[idx] - x[0]) @ np.linalg.inv(axes)  # x − c = Σ ξ_i a_i
    rigid = shape[0] + xi @ shape[1:4]
    return (shape[idx] - rigid) @ frame.T


def _order(values: np.ndarray) -> int:
    """Sign changes along the boom of a component (ignoring tiny values) plus one."""
    big = values[np.abs(values) > 1e-3 * np.max(np.abs(values), initial=0.0)]
    return int(np.sum(np.diff(np.sign(big)) != 0)) + 1


def _pattern(amplitudes: np.ndarray, azimuths: np.ndarray) -> str:
    """Dominant azimuthal harmonic of the booms' signed amplitudes."""
    count = len(azimuths)
    best, power = 0, -1.0
    for n in range(count // 2 + 1):
        c = np.sum(amplitudes * np.cos(n * azimuths))
        s = np.sum(amplitudes * np.sin(n * azimuths))
        p = (c * c + s * s) / (count if n in (0, count / 2) else count / 2)
        if p > power * (1 + 1e-9):
            best, power = n, p
    return "collective" if best == 0 else f"n={best}"


def boom_labels(structure: Structure, x: np.ndarray, shapes: np.ndarray) -> list[str]:
    """Labels for mode shapes ``(N, n, 3)`` of a hub-with-booms structure about ``x`` ``(n, 3)``."""
    weights = np.asarray(structure.mass_scalar.diagonal()).ravel()
    booms = {k.split(":", 1)[1]: v for k, v in structure.groups.items() if k.startswith("boom:")}
    frames = {name: _boom_frames(structure, x, idx) for name, idx in booms.items()}
    azimuths = np.array([np.arctan2(f[0, 1], f[0, 0]) for f in frames.values()])
    labels = []
    for shape in shapes:
        energy = {name: 0.0 for name in booms}
        parts = np.zeros(4)  # axial, out-of-plane, in-plane, torsion
        profiles = {}
        for name, idx in booms.items():
            prof = _component_profile(shape, x, idx, frames[name])
            w = weights[idx]
            comp = np.einsum("i,ia->a", w, prof * prof)
            directors = shape[idx + 2] @ frames[name][2] - shape[idx + 3] @ frames[name][1]
            twist = float(np.sum(weights[idx + 2] * directors**2))
            parts += np.concatenate([comp, [twist]])
            energy[name] = float(comp.sum())
            profiles[name] = prof
        total = sum(energy.values())
        hub = float(weights[0] * shape[0] @ shape[0])
        if total <= hub:
            labels.append("hub")
            continue
        kind = int(np.argmax(parts))
        what = ("axial", "out-of-plane bending", "in-plane bending", "torsion")[kind]
        comp = min(kind, 2)
        main = max(energy, key=energy.get)
        order = _order(profiles[main][:, comp]) if kind in (1, 2) else 1
        if energy[main] >= SINGLE_BOOM_SHARE * total:
            pattern = f"boom {main}"
        else:
            amps = np.array([profiles[n][-1, comp] for n in booms])
            pattern = _pattern(amps, azimuths)
        labels.append(f"{what} {order}, {pattern}" if kind in (1, 2) else f"{what}, {pattern}")
    return labels

