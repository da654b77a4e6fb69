"""quadmodes.rotations: the quaternion and rotation-matrix helpers against their physics
(scipy's Rotation as the reference), numpy level and scalar level."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from quadmodes import rotations as rot

RNG = np.random.default_rng(7)
ROTVECS = [np.array([0.3, -0.5, 0.9]), np.array([1e-6, 2e-6, -1e-6]), np.zeros(3), 2.5 * np.ones(3)]


def _scalar_last(q):
    return np.r_[q[1:], q[0]]


@pytest.mark.parametrize("phi", ROTVECS)
def test_quat_exp_is_the_rotation_of_the_rotation_vector(phi):
    q = rot.quat_exp(phi)
    ref = Rotation.from_rotvec(phi)
    np.testing.assert_allclose(np.linalg.norm(q), 1.0, atol=1e-15)
    np.testing.assert_allclose(
        Rotation.from_quat(_scalar_last(q)).as_matrix(), ref.as_matrix(), atol=1e-15
    )
    np.testing.assert_allclose(rot.rotation_matrix(q), ref.as_matrix(), atol=1e-15)
    np.testing.assert_allclose(rot.so3_exp(phi), ref.as_matrix(), atol=1e-14)


def test_rotation_matrix_is_proper_orthogonal():
    q = RNG.normal(size=(5, 4))  # not normalised: rotation_matrix normalises
    r = rot.rotation_matrix(q)
    assert r.shape == (5, 3, 3)
    np.testing.assert_allclose(
        r @ np.swapaxes(r, -1, -2), np.broadcast_to(np.eye(3), r.shape), atol=1e-14
    )
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=1e-14)


def test_quat_multiply_composes_like_matrix_products():
    a, b = rot.quat_exp(RNG.normal(size=3)), rot.quat_exp(RNG.normal(size=3))
    ab = rot.quat_multiply(a, b)
    np.testing.assert_allclose(
        rot.rotation_matrix(ab), rot.rotation_matrix(a) @ rot.rotation_matrix(b), atol=1e-14
    )
    # batched over leading axes
    qa, qb = RNG.normal(size=(4, 4)), RNG.normal(size=(4, 4))
    np.testing.assert_allclose(
        rot.quat_multiply(qa, qb)[2], rot.quat_multiply(qa[2], qb[2]), atol=0
    )


def test_quat_rate_is_half_q_times_omega():
    q = rot.quat_exp(np.array([0.2, 0.1, -0.4]))
    w = np.array([0.3, -1.2, 2.0])
    np.testing.assert_allclose(
        rot.quat_rate(q, w), 0.5 * rot.quat_multiply(q, np.r_[0.0, w]), atol=1e-15
    )
    # the drift correction k (1 − |q|²) q pulls |q| back to 1
    q2 = 1.1 * q
    corr = rot.quat_rate(q2, w, gain=2.0) - rot.quat_rate(q2, w)
    np.testing.assert_allclose(corr, 2.0 * (1.0 - 1.21) * q2, atol=1e-14)
    # and the rate of R(q) is R ω̂ (body-frame angular velocity)
    h = 1e-6
    dr = (
        rot.rotation_matrix(q + h * rot.quat_rate(q, w))
        - rot.rotation_matrix(q - h * rot.quat_rate(q, w))
    ) / (2 * h)
    np.testing.assert_allclose(dr, rot.rotation_matrix(q) @ rot.skew(w), atol=1e-8)


def test_axis_rotation_fixes_the_axis_and_turns_perpendiculars_by_the_angle():
    axis = np.array([1.0, 2.0, -2.0])  # not unit: normalised inside
    angle = 0.7
    r = rot.axis_rotation(axis, angle)
    e = axis / np.linalg.norm(axis)
    np.testing.assert_allclose(r @ e, e, atol=1e-15)
    u = np.cross(e, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    ru = r @ u
    np.testing.assert_allclose(ru @ u, np.cos(angle), atol=1e-15)
    np.testing.assert_allclose(np.cross(u, ru), np.sin(angle) * e, atol=1e-15)  # right-handed


def test_polar_rotation_recovers_the_rotation_of_r_times_spd():
    r = Rotation.from_rotvec([0.4, -1.1, 0.3]).as_matrix()
    a = RNG.normal(size=(3, 3))
    s = a @ a.T + 0.5 * np.eye(3)  # symmetric positive definite stretch
    np.testing.assert_allclose(rot.polar_rotation(r @ s), r, atol=1e-13)
    # a reflection is never returned: det +1
    assert np.linalg.det(rot.polar_rotation(-r @ s)) == pytest.approx(1.0)


def test_skew_is_the_cross_product():
    v, w = RNG.normal(size=3), RNG.normal(size=3)
    np.testing.assert_allclose(rot.skew(v) @ w, np.cross(v, w), atol=1e-15)
    vs, ws = RNG.normal(size=(6, 3)), RNG.normal(size=(6, 3))
    np.testing.assert_allclose(
        np.einsum("kab,kb->ka", rot.skew(vs), ws), np.cross(vs, ws), atol=1e-15
    )
    np.testing.assert_array_equal(rot.skew(v), rot.cross_matrix(*v))


@pytest.mark.parametrize("phi", ROTVECS)
def test_step_helpers_match_the_matrix_forms(phi):
    """rotate(θ, v) = exp(θ̂) v; quat_step(q, φ) = q ⊗ exp(φ/2); the left Jacobian maps a small
    change of the rotation vector to the left-multiplied rotation."""
    v = np.array([0.5, -2.0, 1.5])
    np.testing.assert_allclose(rot.rotate(phi, v), Rotation.from_rotvec(phi).apply(v), atol=1e-14)
    q = rot.quat_exp(np.array([0.1, 0.2, 0.3]))
    np.testing.assert_allclose(
        rot.quat_step(q, phi), rot.quat_multiply(q, rot.quat_exp(phi)), atol=1e-15
    )
    d = 1e-7 * np.array([1.0, 2.0, -1.0])
    lhs = rot.so3_exp(phi + d)
    rhs = rot.so3_exp(rot.so3_left_jacobian(phi) @ d) @ rot.so3_exp(phi)
    np.testing.assert_allclose(lhs, rhs, atol=1e-13)


def test_scalar_leaves_are_numba_compatible():
    """The kernel compiles the scalar leaves: they give the same floats compiled and not."""
    numba = pytest.importorskip("numba")
    args = {
        rot.half_angle_coefficients: (0.3,),
        rot.rodrigues_coefficients: (0.09,),
        rot.left_jacobian_coefficients: (1e-14,),
        rot.rodrigues_rotate: (0.9, 0.4, 0.1, 0.2, 0.3, 1.0, -1.0, 2.0),
        rot.quat_times_exp: (0.9, 0.1, -0.2, 0.3, 0.99, 0.49, 0.1, 0.2, 0.3),
    }
    for fn, a in args.items():
        assert numba.njit(fn)(*a) == pytest.approx(fn(*a), rel=1e-15, abs=0)
