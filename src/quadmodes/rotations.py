"""Rotations: the one home of the quaternion and rotation-matrix helpers.

Conventions: quaternions are ``(w, x, y, z)``, scalar first, and map body → inertial; rotation
vectors are in rad. :mod:`scipy.spatial.transform` (scalar last) is used where the call is not
in a hot loop.

Two levels:

* numpy level (arrays in, arrays out): :func:`skew`, :func:`quat_multiply`, :func:`quat_exp`,
  :func:`rotation_matrix`, :func:`quat_rate`, :func:`axis_rotation`, :func:`polar_rotation`,
  :func:`so3_exp`, :func:`so3_left_jacobian`, and the step helpers of the numpy integrators,
  :func:`rotate` and :func:`quat_step`;
* scalar level (Python floats in, tuples of floats out, no numpy, no calls to other helpers):
  :func:`half_angle_coefficients`, :func:`rodrigues_coefficients`,
  :func:`left_jacobian_coefficients`, :func:`rodrigues_rotate`, :func:`quat_times_exp`. They are
  written once and serve both backends of the midpoint integrator: the numpy steppers call them
  directly, the compiled kernel (:mod:`quadmodes.rom.midpoint_kernel`) compiles these same
  functions with ``numba.njit`` (so each must stay a leaf in numba's nopython subset).
"""

import math

import numpy as np
from scipy.spatial.transform import Rotation

# ---------------------------------------------------------------------------------------------
# scalar level (numba-compatible leaves)
# ---------------------------------------------------------------------------------------------


def half_angle_coefficients(a):
    """``(cos(a/2), sin(a/2)/a)`` for a rotation angle ``a = |φ|`` ≥ 0 (rad): the unit quaternion
    of φ is ``(c, k φ)``. Series ``k = ½ − a²/48`` below 1e-4 (no 0/0)."""
    half = 0.5 * a
    k = 0.5 - a * a / 48.0 if a < 1e-4 else math.sin(half) / a
    return math.cos(half), k


def rodrigues_coefficients(a2):
    """``(sin a / a, (1 − cos a)/a²)`` for ``a2 = |θ|²`` (rad²): ``exp(θ̂) = I + s θ̂ + c θ̂²``.
    Series below 1e-12 (avoids 0/0 and the cancellation in 1 − cos)."""
    if a2 < 1e-12:
        return 1.0 - a2 / 6.0, 0.5 - a2 / 24.0
    a = math.sqrt(a2)
    return math.sin(a) / a, (1.0 - math.cos(a)) / a2


def left_jacobian_coefficients(a2):
    """``(c, d)`` of the SO(3) left Jacobian ``J_l(θ) = I + c θ̂ + d θ̂²`` for ``a2 = |θ|²``:
    ``c = (1 − cos a)/a²``, ``d = (a − sin a)/a³`` (series below 1e-12)."""
    if a2 < 1e-12:
        return 0.5 - a2 / 24.0, 1.0 / 6.0 - a2 / 120.0
    a = math.sqrt(a2)
    return (1.0 - math.cos(a)) / a2, (a - math.sin(a)) / (a2 * a)


def rodrigues_rotate(sa, ca, tx, ty, tz, vx, vy, vz):
    """``exp(θ̂) v = v + sa θ×v + ca θ×(θ×v)`` as 3 floats, with ``(sa, ca)`` of
    :func:`rodrigues_coefficients` (|θ|²); θ = (tx, ty, tz) rad, v = (vx, vy, vz)."""
    cx, cy, cz = ty * vz - tz * vy, tz * vx - tx * vz, tx * vy - ty * vx  # θ × v
    ex, ey, ez = ty * cz - tz * cy, tz * cx - tx * cz, tx * cy - ty * cx  # θ × (θ × v)
    return vx + sa * cx + ca * ex, vy + sa * cy + ca * ey, vz + sa * cz + ca * ez


def quat_times_exp(q0, q1, q2, q3, c, k, px, py, pz):
    """``q ⊗ exp(φ/2)``, normalised, as 4 floats; q = (q0, q1, q2, q3) scalar first, φ = (px, py,
    pz) rad and ``(c, k)`` of :func:`half_angle_coefficients` (|φ|)."""
    bx, by, bz = k * px, k * py, k * pz
    r0 = q0 * c - q1 * bx - q2 * by - q3 * bz
    r1 = q0 * bx + c * q1 + q2 * bz - q3 * by
    r2 = q0 * by + c * q2 + q3 * bx - q1 * bz
    r3 = q0 * bz + c * q3 + q1 * by - q2 * bx
    nrm = 1.0 / math.sqrt(r0**2 + r1**2 + r2**2 + r3**2)
    return r0 * nrm, r1 * nrm, r2 * nrm, r3 * nrm


# ---------------------------------------------------------------------------------------------
# numpy level
# ---------------------------------------------------------------------------------------------


def cross_matrix(x: float, y: float, z: float) -> np.ndarray:
    """Cross-product matrix (3,3) ``[v]x`` of one vector v = (x, y, z)."""
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices ``[v]x`` of shape ``(..., 3, 3)`` with ``[v]x @ w = v × w``."""
    v = np.asarray(v)
    if v.ndim == 1:
        return cross_matrix(*v.tolist())
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
    c, k = half_angle_coefficients(float(np.sqrt(phi @ phi)))
    return np.concatenate([[c], k * phi])


def quat_step(q: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``q ⊗ exp(φ/2)`` (4,), normalised; q (4,), φ (3,) rotation vector (rad) of the step."""
    px, py, pz = phi.tolist()
    c, k = half_angle_coefficients(math.sqrt(px * px + py * py + pz * pz))
    return np.array(quat_times_exp(*q.tolist(), c, k, px, py, pz))


def rotate(theta: np.ndarray, v: np.ndarray) -> tuple[float, float, float]:
    """``exp(θ̂) v`` (Rodrigues) as a tuple of 3 floats; θ (3,) rad, v (3,). Scalar arithmetic:
    cheaper than numpy for one 3-vector."""
    tx, ty, tz = theta.tolist()
    sa, ca = rodrigues_coefficients(tx * tx + ty * ty + tz * tz)
    return rodrigues_rotate(sa, ca, tx, ty, tz, *v.tolist())


def so3_exp(theta: np.ndarray) -> np.ndarray:
    """Rotation matrix (3,3) ``exp(θ̂)`` (Rodrigues), θ (3,) rad."""
    x, y, z = np.asarray(theta, float).tolist()
    s, c = rodrigues_coefficients(x * x + y * y + z * z)
    th = cross_matrix(x, y, z)
    return np.eye(3) + s * th + c * (th @ th)


def so3_left_jacobian(theta: np.ndarray) -> np.ndarray:
    """Left Jacobian J_l(θ) (3,3) of SO(3): ``exp((θ+δ)^) = exp((J_l δ)^) exp(θ̂) + O(δ²)``."""
    x, y, z = np.asarray(theta, float).tolist()
    c, d = left_jacobian_coefficients(x * x + y * y + z * z)
    th = cross_matrix(x, y, z)
    return _EYE3 + c * th + d * (th @ th)


_EYE3 = np.eye(3)


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


def unit_axis(axis) -> np.ndarray:
    """The unit vector (3,) along ``axis``; raises ValueError for a zero or malformed axis."""
    e = np.asarray(axis, float)
    norm = np.linalg.norm(e)
    if e.shape != (3,) or not norm > 0.0:
        raise ValueError("axis: give a non-zero 3-vector")
    return e / norm
