"""The consistent fourth-order Lagrangian (experimental.manifold_lagrangian) on the small capsule,
N = 5: its kinetic energy is formulation Q's to the order Q keeps (the inertia to s², the
coupling to s, the modal mass at s = 0; the differences shrink as s³, s², s when s halves), its
∂T/∂s is the derivative of ½νᵀ𝕄(s)ν, and its equations conserve |H| and E + E_d."""

import numpy as np
import pytest

from quadmodes.experimental import manifold_lagrangian as ml
from quadmodes.rom import structured_mass as sm
from quadmodes.rom import system as rsys


@pytest.fixture(scope="module")
def lagrangian(small_modal_model, small_reduced_model):
    return ml.ManifoldLagrangian(small_reduced_model, small_modal_model.structure.mass_scalar)


def _direction(model, seed=4):
    t = np.asarray(model.translational, bool)
    scale = np.array([np.max(np.linalg.norm(p[t], axis=1)) for p in model.Phi])
    d = np.random.default_rng(seed).standard_normal(model.n_modes)
    return d / np.linalg.norm(d) / scale  # 1 m of nodal displacement per unit


def test_kinetic_energy_is_q_to_the_order_q_keeps(lagrangian, small_reduced_model):
    model = small_reduced_model
    blocks = rsys.reduced_system(model, "Q").mass_blocks
    d = _direction(model)
    errors = []
    for r in (2e-3, 1e-3):  # 2 and 1 mm of displacement
        s = r * d
        m_exact, m_q = lagrangian.mass_matrix(s), sm.mass_matrix(blocks, s)
        errors.append([np.max(np.abs(m_exact[:3, :3] - m_q[:3, :3])),
                       np.max(np.abs(m_exact[3:, :3] - m_q[3:, :3])),
                       np.max(np.abs(m_exact[3:, 3:] - m_q[3:, 3:]))])  # fmt: skip
    ratios = np.array(errors[0]) / np.array(errors[1])
    assert 7.0 < ratios[0] < 9.0 and 3.5 < ratios[1] < 4.5 and 1.8 < ratios[2] < 2.2, ratios
    zero = lagrangian.mass_matrix(np.zeros(model.n_modes))
    assert np.allclose(zero, sm.mass_matrix(blocks, np.zeros(model.n_modes)), rtol=0, atol=1e-12 * np.max(np.abs(zero)))


def test_kinetic_gradient_is_the_derivative_of_t(lagrangian, small_reduced_model):
    model = small_reduced_model
    s = 3e-3 * _direction(model)
    rng = np.random.default_rng(1)
    w, sd = np.array([3.0, -2.0, 300.0]), 0.5 * s * rng.standard_normal(model.n_modes) * 300

    def kinetic(x):
        nu = np.concatenate([w, sd])
        return 0.5 * nu @ lagrangian.mass_matrix(x) @ nu

    h = 1e-4 * np.linalg.norm(s)
    fd = np.array([(kinetic(s + h * e) - kinetic(s - h * e)) / (2 * h) for e in np.eye(model.n_modes)])
    got = lagrangian.kinetic_gradient(s, w, sd)
    assert np.max(np.abs(got - fd)) <= 1e-6 * np.max(np.abs(fd))


def test_equations_conserve_h_and_energy(lagrangian, small_reduced_model):
    """Spinning at 300 rad/s with a 0.05 rad/s tilt and 2 mm of deformation, 20 ms: |H| exact
    (the equations keep ḣ = −ω × h) and E + E_d to the integrator's tolerance."""
    model = small_reduced_model
    n = model.n_modes
    y0 = np.zeros(7 + 2 * n)
    y0[0], y0[4:7] = 1.0, [0.05, 0.0, 300.0]
    y0[7 : 7 + n] = 2e-3 * _direction(model)
    t, ys = ml.run(lagrangian, y0, 0.02, sample=1e-3, rtol=1e-10)
    h = np.linalg.norm(ys[:, 4:7], axis=1)
    assert np.max(np.abs(h - h[0])) <= 1e-9 * h[0]
    balance = np.array([lagrangian.energy(y) + y[-1] for y in ys])
    assert ys[-1, -1] > 0  # it dissipates
    assert np.max(np.abs(balance - balance[0])) <= 1e-8 * abs(balance[0])
