"""Reduced equations of motion: Euler–Poincaré structure, invariants, variants, linearisation."""

import dataclasses

import numpy as np
import pytest

from quadmodes import rotations as rot
from quadmodes.rom import dynamics as dy
from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys
from quadmodes.rom.reduced import ReducedModel


def hand_model(J0, lam=(), zeta=0.0, free=True, **arrays):
    """A ReducedModel built by hand: inertia J0 (3,3), modal stiffness diag(lam), μ = I,
    ζ damping; other arrays zero unless given (J1, J2u, J2g, c, Cuu, Cxg)."""
    n = len(lam)
    z = np.zeros
    w = np.sqrt(np.asarray(lam, float))
    a = {
        "J1": z((n, 3, 3)), "J2u": z((n, n, 3, 3)), "J2g": z((n, n, 3, 3)), "c": z((n, 3)),
        "Cuu": z((n, n, 3)), "Cxg": z((n, n, 3)),
    }  # fmt: skip
    a.update(arrays)
    return ReducedModel(
        mass=1.0, free=free, frequencies_hz=w / (2 * np.pi), damping_ratio=np.full(n, zeta),
        labels=tuple(f"m{k}" for k in range(n)), J0=np.asarray(J0, float), S1=z((n, 3)),
        S2=z((n, n, 3)), mu=np.eye(n), Lam=np.diag(np.asarray(lam, float)),
        C=np.diag(2 * zeta * w), X=z((1, 3)), translational=np.ones(1, bool),
        weights=np.ones(1), Phi=z((n, 1, 3)), G=z((n, n, 1, 3)), **a,
    )  # fmt: skip


def synthetic_model(n=3, seed=0):
    """Generic arrays with the symmetries of the method (c ≠ 0, Cxg ≠ 0: every term active)."""
    rng = np.random.default_rng(seed)

    def sym33(a):
        return 0.5 * (a + np.swapaxes(a, -1, -2))

    j2u = sym33(rng.normal(size=(n, n, 3, 3)))
    j2g = sym33(rng.normal(size=(n, n, 3, 3)))
    cuu = rng.normal(size=(n, n, 3))
    cxg = rng.normal(size=(n, n, 3))
    return hand_model(
        np.diag([3.0, 4.0, 2.0]) + 0.1 * sym33(rng.normal(size=(3, 3))),
        lam=rng.uniform(50.0, 200.0, n) ** 2,
        zeta=0.05,
        J1=sym33(rng.normal(size=(n, 3, 3))),
        J2u=0.5 * (j2u + j2u.transpose(1, 0, 2, 3)),
        J2g=0.5 * (j2g + j2g.transpose(1, 0, 2, 3)),
        c=0.3 * rng.normal(size=(n, 3)),
        Cuu=0.5 * (cuu - cuu.transpose(1, 0, 2)),
        Cxg=0.5 * (cxg + cxg.transpose(1, 0, 2)),
    )


def random_state(sys, rng, spin=80.0, s_amp=2e-4, sd_amp=0.3):
    n = sys.n_modes
    return rsys.pack_state(
        sys,
        rng.normal(size=4),
        np.array([3.0, -2.0, spin]) + rng.normal(size=3),
        s_amp * rng.normal(size=n),
        sd_amp * rng.normal(size=n),
    )


def euler_poincare_residuals(sys, y, eps=1e-6):
    """Residuals of ḣ + ω×h = 0 and ṗ_s − ∂L̃/∂s + Cṡ = 0 along the flow of ``rhs``, all
    derivatives by central finite differences of the Lagrangian quantities (independent of the
    b-terms in ``rhs``). Returns (res_ω, scale_ω, res_s, scale_s, |h − ∂L/∂ω| / |h|)."""
    n = sys.n_modes
    yd = dy.rhs(sys, 0.0, y)

    def ddt(f):
        return (f(y + eps * yd) - f(y - eps * yd)) / (2 * eps)

    h = dy.body_momentum(sys, y)
    w = y[4:7]
    gyro = np.cross(w, h)
    res_w = ddt(lambda z: dy.body_momentum(sys, z)) + gyro

    def grad(idx, step):
        g = np.empty(len(idx))
        for j, i in enumerate(idx):
            e = np.zeros_like(y)
            e[i] = step
            g[j] = (dy.lagrangian(sys, y + e) - dy.lagrangian(sys, y - e)) / (2 * step)
        return g

    dlds = grad(range(7, 7 + n), 1e-7)
    dp = ddt(lambda z: dy.modal_momentum(sys, z))
    damp = sys.C @ y[7 + n :]
    res_s = dp - dlds + damp
    h_fd = grad(range(4, 7), 1e-5)
    scale_s = max(np.abs(dp).max(), np.abs(dlds).max(), 1e-300) if n else 1.0
    return (
        np.abs(res_w).max(),
        np.abs(gyro).max(),
        np.abs(res_s).max() if n else 0.0,
        scale_s,
        np.abs(h_fd - h).max() / np.abs(h).max(),
    )


@pytest.mark.parametrize("formulation", ["Q", "L", "rigid"])
def test_euler_poincare_finite_difference_small_model(small_reduced_model, formulation):
    """rhs solves the Euler–Poincaré equations of the truncated Lagrangian (theory §4)."""
    sys = rsys.reduced_system(small_reduced_model, formulation)
    rng = np.random.default_rng(7)
    for _ in range(3):
        y = random_state(sys, rng)
        rw, sw, rs, ss, rh = euler_poincare_residuals(sys, y)
        assert rw <= 1e-6 * sw
        assert rs <= 1e-6 * ss
        assert rh <= 1e-6


@pytest.mark.parametrize("formulation", ["Q", "L"])
def test_euler_poincare_finite_difference_all_terms(formulation):
    """Same check with generic arrays: c, Cxg, J2g, Cuu all non-zero (every b-term active)."""
    sys = rsys.reduced_system(synthetic_model(), formulation)
    rng = np.random.default_rng(3)
    for _ in range(3):
        y = random_state(sys, rng, spin=5.0, s_amp=0.05, sd_amp=2.0)
        rw, sw, rs, ss, rh = euler_poincare_residuals(sys, y)
        assert rw <= 1e-6 * sw
        assert rs <= 1e-6 * ss
        assert rh <= 1e-6


def test_paper_variant_keeps_h_p_but_is_not_variational():
    """P: rotational row conserves h_P (ḣ_P + ω×h_P = 0), modal row as Q; h_P ≠ ∂L̃/∂ω."""
    model = synthetic_model()
    p = rsys.reduced_system(model, "P")
    q = rsys.reduced_system(model, "Q")
    rng = np.random.default_rng(5)
    y = random_state(p, rng, spin=5.0, s_amp=0.05, sd_amp=2.0)
    rw, sw, rs, ss, rh = euler_poincare_residuals(p, y)
    assert rw <= 1e-6 * sw  # h_P is the momentum of the P rotational row
    assert rs <= 1e-6 * ss  # modal row is the Q (variational) one
    assert rh > 1e-3  # but h_P is not ∂L̃/∂ω: P is not Euler–Poincaré
    # modal rows of 𝕄 identical, rotational rows differ (no J2g, no 2Cxg)
    s = y[7 : 7 + p.n_modes]
    mp, mq = dy.mass_matrix(p, s), dy.mass_matrix(q, s)
    np.testing.assert_allclose(mp[3:], mq[3:], rtol=1e-13, atol=1e-13)
    assert np.abs(mp[:3] - mq[:3]).max() > 1e-3


def test_energy_rate_equals_minus_dissipation(small_reduced_model):
    """Q: dE/dt = −ṡᵀCṡ exactly (FD along the flow); P: not."""
    rng = np.random.default_rng(11)
    for formulation, exact in (("Q", True), ("L", True), ("P", False)):
        sys = rsys.reduced_system(small_reduced_model, formulation)
        y = random_state(sys, rng, spin=300.0)
        yd = dy.rhs(sys, 0.0, y)
        eps = 1e-6
        de = (dy.energy(sys, y + eps * yd) - dy.energy(sys, y - eps * yd)) / (2 * eps)
        pd = dy.dissipation_rate(sys, y)
        if exact:
            assert abs(de + pd) <= 1e-6 * pd
        else:
            assert abs(de + pd) > 1e-3 * pd


def test_mass_matrix_and_batched_invariants_agree(small_reduced_model):
    """Tensor form 𝕄(s) = Σ z_i z_j Mt_ij equals the einsum forms; T = ½νᵀ𝕄ν; batching.

    (For the capsule 𝕄(s) stays positive definite only for |s| ≲ 0.01 √kg·m: J2g is large and
    negative, see docs/derivation.md; amplitudes here are 2e-4.)"""
    for model, amp in ((small_reduced_model, 2e-4), (synthetic_model(), 0.01)):
        sys = rsys.reduced_system(model, "Q")
        rng = np.random.default_rng(2)
        ys = np.stack([random_state(sys, rng, spin=20.0, s_amp=amp) for _ in range(4)])
        for y in ys:
            _, w, s, sd = rsys.split_state(sys, y)
            m = dy.mass_matrix(sys, s)
            np.testing.assert_allclose(m, m.T, rtol=0, atol=1e-14 * np.abs(m).max())
            assert np.linalg.eigvalsh(m).min() > 0
            np.testing.assert_allclose(m[:3, :3], dy.inertia_tensor(sys, s), rtol=1e-12)
            np.testing.assert_allclose(m[3:, :3], dy.coupling_rows(sys, s), atol=1e-14)
            nu = np.concatenate([w, sd])
            mom = m @ nu
            np.testing.assert_allclose(mom[:3], dy.body_momentum(sys, y), rtol=1e-12)
            np.testing.assert_allclose(mom[3:], dy.modal_momentum(sys, y), rtol=1e-10, atol=1e-14)
            assert dy.kinetic_energy(sys, y) == pytest.approx(0.5 * nu @ mom, rel=1e-12)
        batched = dy.energy(sys, ys)
        single = [dy.energy(sys, y) for y in ys]
        np.testing.assert_allclose(batched, single, rtol=1e-14)
        r = rot.rotation_matrix(ys[:, :4])
        h_in = dy.momentum_inertial(sys, ys)
        np.testing.assert_allclose(
            h_in, np.einsum("kab,kb->ka", r, dy.body_momentum(sys, ys)), rtol=1e-14
        )


def test_rigid_limit_is_euler_equations():
    """N = 0: J0 ω̇ + ω × J0 ω = 0 and q̇ = ½ q ⊗ (0, ω)."""
    j0 = np.array([[2.0, 0.1, 0.0], [0.1, 3.0, 0.2], [0.0, 0.2, 5.0]])
    sys = rsys.reduced_system(hand_model(j0), "rigid")
    assert sys.n_modes == 0 and sys.n_state == 7
    w = np.array([0.3, -1.2, 2.0])
    q = rot.quat_exp(np.array([0.2, 0.1, -0.4]))
    yd = dy.rhs(sys, 0.0, np.concatenate([q, w]))
    np.testing.assert_allclose(j0 @ yd[4:7], -np.cross(w, j0 @ w), rtol=1e-13)
    np.testing.assert_allclose(yd[:4], 0.5 * rot.quat_multiply(q, np.r_[0.0, w]), rtol=1e-13)


def test_quaternion_drift_correction():
    sys = rsys.reduced_system(hand_model(np.eye(3)), "rigid")
    y = np.r_[1.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    assert dy.rhs(sys, 0.0, y)[0] == pytest.approx(sys.quat_gain * (1 - 1.21) * 1.1)


def test_rotations_consistent():
    phi = np.array([0.3, -0.5, 0.9])
    r1 = rot.rotation_matrix(rot.quat_exp(phi))
    np.testing.assert_allclose(r1, rot.so3_exp(phi), atol=1e-15)
    np.testing.assert_allclose(r1 @ r1.T, np.eye(3), atol=1e-15)
    d = 1e-7 * np.array([1.0, 2.0, -1.0])
    lhs = rot.so3_exp(phi + d)
    rhs = rot.so3_exp(rot.so3_left_jacobian(phi) @ d) @ rot.so3_exp(phi)
    np.testing.assert_allclose(lhs, rhs, atol=1e-13)


def test_prescribed_rotation_matches_free_modal_row(small_reduced_model):
    """The prescribed-rotation modal equation, fed ω and ω̇ of the free motion, gives the
    same s̈ as the free equations (both Q)."""
    for model in (small_reduced_model, synthetic_model()):
        sys = rsys.reduced_system(model, "Q")
        n = sys.n_modes
        y = random_state(sys, np.random.default_rng(4), spin=30.0, s_amp=1e-3)
        yd = dy.rhs(sys, 0.0, y)
        w, wd = y[4:7], yd[4:7]
        d = dy.prescribed_rhs(sys, 0.0, y[7:], lambda t, w=w: w, lambda t, wd=wd: wd)
        np.testing.assert_allclose(d[:n], y[7 + n :])
        np.testing.assert_allclose(d[n:], yd[7 + n :], rtol=1e-8, atol=1e-10 * np.abs(d).max())


def test_rotating_frame_matrices(small_reduced_model):
    """Γ antisymmetric, stiffness symmetric; Q stiffens (J2g), L only softens; Campbell at 0."""
    model = small_reduced_model
    m, g, k = rf.rotating_frame_matrices(model, [0, 0, 0])
    np.testing.assert_allclose(k, model.Lam, rtol=1e-12)
    np.testing.assert_allclose(g, model.C, atol=1e-12)
    lam0 = rf.rotating_eigenvalues(model, [0, 0, 0])
    np.testing.assert_allclose(
        np.sort(np.abs(lam0.imag))[::2] / (2 * np.pi), np.sort(model.frequencies_hz), rtol=1e-6
    )
    omega = np.array([0.0, 0.0, 500.0])
    _, gq, kq = rf.rotating_frame_matrices(model, omega, "Q")
    _, gl, kl = rf.rotating_frame_matrices(model, omega, "L")
    gam = gq - model.C
    np.testing.assert_allclose(gam, -gam.T, atol=1e-12 * np.abs(gam).max())
    np.testing.assert_allclose(kq, kq.T)
    j2g = np.einsum("a,mnab,b->mn", omega, model.J2g, omega)
    np.testing.assert_allclose(kl - kq, 0.5 * (j2g + j2g.T), rtol=1e-9, atol=1e-6)
    # spin stiffening: the lowest rotating stiffness is higher with Q than with L
    assert np.linalg.eigvalsh(kq).min() > np.linalg.eigvalsh(kl).min() * 1.5
    assert rf.rotating_stiffness_is_positive(model, omega, "Q")
    # linear modes: an in-plane mode (u along x, J2u = 𝒥(u,u) = diag(0,1,1)) softens as
    # ω0² − Ω² and loses stiffness once the spin Ω about z exceeds ω0 = 10 rad/s
    j2u = np.diag([0.0, 1.0, 1.0])[None, None]
    one = hand_model(np.eye(3), lam=[100.0], J2u=j2u)
    assert rf.rotating_stiffness_is_positive(one, [0, 0, 9.0], "L")
    assert not rf.rotating_stiffness_is_positive(one, [0, 0, 11.0], "L")


def test_unknown_formulation_rejected(small_reduced_model):
    with pytest.raises(ValueError, match="formulation"):
        rsys.reduced_system(small_reduced_model, "X")


def test_damping_free_copy(small_reduced_model):
    m0 = dataclasses.replace(small_reduced_model, C=0 * small_reduced_model.C)
    sys = rsys.reduced_system(m0)
    assert np.all(sys.C == 0) and sys.formulation == "Q"
    assert np.all(rsys.with_damping(sys, small_reduced_model.C).C == small_reduced_model.C)
