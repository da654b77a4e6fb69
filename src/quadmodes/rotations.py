"""Rotations: the one home of the quaternion and rotation-matrix helpers (outside the compiled
midpoint kernel, which keeps its own scalar copies so numba can inline them).

Conventions: quaternions are ``(w, x, y, z)``, scalar first, and map body → inertial; rotation
vectors are in rad. :mod:`scipy.spatial.transform` (scalar last) is used where the call is not
in a hot loop.
"""

import math

import numpy as np
from scipy.spatial.transform import Rotation


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices ``[v]x`` of shape ``(..., 3, 3)`` with ``[v]x @ w = v × w``."""
    v = np.asarray(v)
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], -1),
            np.stack([v[..., 2], z, -v[..., 0]], -1),
            np.stack([-v[..., 1], v[..., 0], z], -1),
        ],
        -2,
    )


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` of quaternions (..., 4), scalar first."""
    a0, av = a[..., :1], a[..., 1:]
    b0, bv = b[..., :1], b[..., 1:]
    return np.concatenate(
        [a0 * b0 - np.sum(av * bv, -1, keepdims=True), a0 * bv + b0 * av + np.cross(av, bv)], -1
    )


def quat_exp(phi: np.ndarray) -> np.ndarray:
    """Unit quaternion (4,) of the rotation vector ``phi`` (3,) rad: ``(cos |φ|/2, sin(|φ|/2) φ/|φ|)``."""
    a = float(np.sqrt(phi @ phi))
    half = 0.5 * a
    k = 0.5 - a * a / 48.0 if a < 1e-4 else math.sin(half) / a
    return np.concatenate([[math.cos(half)], k * phi])


def rotation_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3), body → inertial, of quaternions q (..., 4) (normalised
    here)."""
    q = np.asarray(q, float)
    r = Rotation.from_quat(np.reshape(q[..., [1, 2, 3, 0]], (-1, 4))).as_matrix()
    return r.reshape(q.shape[:-1] + (3, 3))


def quat_rate(q: np.ndarray, w: np.ndarray, gain: float = 0.0) -> np.ndarray:
    """q̇ = ½ q ⊗ (0, ω) + k (1 − |q|²) q  (4,) 1/s; ω (3,) rad/s in the body frame, ``gain`` k
    (1/s) pulls |q| back to 1."""
    q0, q1, q2, q3 = q
    wx, wy, wz = w
    corr = gain * (1.0 - (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3))
    return np.array(
        [
            -0.5 * (q1 * wx + q2 * wy + q3 * wz) + corr * q0,
            0.5 * (q0 * wx + q2 * wz - q3 * wy) + corr * q1,
            0.5 * (q0 * wy + q3 * wx - q1 * wz) + corr * q2,
            0.5 * (q0 * wz + q1 * wy - q2 * wx) + corr * q3,
        ]
    )


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix (3,3) by ``angle`` (rad) about ``axis`` (3,) (normalised here)."""
    a = np.asarray(axis, float)
    return Rotation.from_rotvec(float(angle) * a / np.linalg.norm(a)).as_matrix()


def polar_rotation(a: np.ndarray) -> np.ndarray:
    """The proper rotation (3,3) nearest to ``a`` (3,3): ``R = U diag(1, 1, det) Vᵀ`` of the SVD."""
    u, _, vt = np.linalg.svd(a)
    d = np.sign(np.linalg.det(u @ vt)) or 1.0
    return (u * np.array([1.0, 1.0, d])) @ vt
