"""Formulation "QM" (rom.manifold_kinetics, rom.manifold_midpoint) on the small capsule, N = 5:
its arrays reproduce the research prototype's mass matrix and ∂T/∂s; the midpoint step agrees
with the prototype integrated by DOP853 at rtol 1e-12 to second order in Δt; it conserves |H| to
round-off and E + E_d to the Newton tolerance (an exact discrete energy balance); and at small amplitude it is formulation Q4
(Q's kinetics) to the order Q keeps."""

import numpy as np
import pytest

from quadmodes.experimental import manifold_lagrangian as ml
from quadmodes.rom import manifold_kinetics as mk
from quadmodes.rom import manifold_midpoint as mm
from quadmodes.rom import system as rsys
from quadmodes.rom.fixed_step import run_fixed
from quadmodes.rom.midpoint import MidpointStep

WINDOW = 0.01  # s: about 1.5 periods of the slowest mode (122 Hz)


@pytest.fixture(scope="module")
def capsule(small_modal_model, small_reduced_model):
    model = small_reduced_model
    arrays = mk.manifold_arrays(model, small_modal_model.structure.mass_scalar, tol=0.0)
    return model, arrays, rsys.reduced_system(model, "Q4")


def _state(model, amplitude, seed=4):
    """Spin 300 rad/s, tilt 0.05 rad/s, ``amplitude`` m of nodal displacement at rest."""
    n = model.n_modes
    t = np.asarray(model.translational, bool)
    scale = np.array([np.max(np.linalg.norm(p[t], axis=1)) for p in model.Phi])
    d = np.random.default_rng(seed).standard_normal(n)
    y0 = np.zeros(7 + 2 * n)
    y0[0], y0[4:7] = 1.0, [0.05, 0.0, 300.0]
    y0[7 : 7 + n] = amplitude * d / np.linalg.norm(d) / scale
    return y0


def test_arrays_are_the_prototypes(capsule, small_modal_model):
    model, arrays, _ = capsule
    lag = ml.ManifoldLagrangian(model, small_modal_model.structure.mass_scalar)
    s = _state(model, 3e-3)[7 : 7 + model.n_modes]
    nu = np.concatenate([[3.0, -2.0, 300.0], 5e4 * s])
    m = lag.mass_matrix(s)
    assert np.max(np.abs(mk.mass_matrix(arrays, s) - m)) <= 1e-12 * np.max(np.abs(m))
    g = lag.kinetic_gradient(s, nu[:3], nu[3:])
    assert np.max(np.abs(mk.kinetic_gradient(arrays, s, nu) - g)) <= 1e-9 * np.max(np.abs(g))
    assert np.array_equal(mk.damping_matrix(arrays, s), model.C)


def test_truncated_particles_keep_the_quadratic_modes_contribution(capsule, small_modal_model):
    """The default pseudo-particles (the g node functions outside span(X, Φ) truncated at
    COMPLEMENT_TOL) move 𝕄(s) and ∂T/∂s by a small fraction of what the quadratic modes
    contribute at all (the exact manifold against the same model with g = 0), keep X and Φ
    exactly (the Q kinetics: 𝕄(0) to round-off) and use fewer particles than the exact set."""
    import dataclasses

    model, exact, _ = capsule
    mass = small_modal_model.structure.mass_scalar
    trunc = mk.manifold_arrays(model, mass)
    flat = mk.manifold_arrays(dataclasses.replace(model, G=np.zeros_like(model.G)), mass, tol=0.0)
    assert trunc.rank < exact.rank and trunc.n_linear == exact.n_linear
    s = _state(model, 3e-3)[7 : 7 + model.n_modes]
    nu = np.concatenate([[3.0, -2.0, 300.0], 5e4 * s])
    zero = np.zeros_like(s)
    m0 = mk.mass_matrix(exact, zero)
    assert np.max(np.abs(mk.mass_matrix(trunc, zero) - m0)) <= 1e-12 * np.max(np.abs(m0))
    for f in (lambda a: mk.mass_matrix(a, s), lambda a: mk.kinetic_gradient(a, s, nu)):
        err, effect = np.max(np.abs(f(trunc) - f(exact))), np.max(np.abs(f(exact) - f(flat)))
        assert effect > 0 and err <= 1e-2 * effect


def test_retained_damping_is_c_at_rest_and_dissipative(capsule, small_modal_model):
    """With the model's own modes as damping modes, C(0) is the model's C (ΦᵀMΦ = I) and C(s)
    is symmetric positive semi-definite; the step's dissipated energy closes E + E_d as with the
    constant C (exactly: to the Newton tolerance)."""
    model, _, sys4 = capsule
    mass = small_modal_model.structure.mass_scalar
    arrays = mk.manifold_arrays(model, mass, mk.retained_damping(model))
    c0 = mk.damping_matrix(arrays, np.zeros(model.n_modes))
    assert np.allclose(c0, model.C, rtol=0, atol=1e-9 * np.max(np.abs(model.C)))
    y0 = _state(model, 3e-3)
    cs = mk.damping_matrix(arrays, y0[7 : 7 + model.n_modes])
    assert np.allclose(cs, cs.T) and np.min(np.linalg.eigvalsh(cs)) > -1e-12 * np.max(np.abs(cs))
    assert np.max(np.abs(cs - c0)) > 1e-3 * np.max(np.abs(c0))  # it does depend on s
    _, y, ed = mm.run_manifold(sys4, arrays, y0, 5e-5, 200)
    e = np.array([mm.energy(sys4, arrays, row) for row in y]) + ed
    assert ed[-1] > 0 and np.max(np.abs(e - e[0])) < 1e-9 * ed[-1]


def test_midpoint_agrees_with_the_prototype_to_second_order(capsule, small_modal_model):
    """Errors of the final (ω, ṡ) against DOP853 (rtol 1e-12) fall by 4 when Δt halves."""
    model, arrays, sys4 = capsule
    n = model.n_modes
    y0 = _state(model, 2e-3)
    lag = ml.ManifoldLagrangian(model, small_modal_model.structure.mass_scalar)
    _, ys = ml.run(lag, y0, WINDOW, sample=WINDOW, rtol=1e-12)
    ref = lag.reduced_states(ys)[-1]
    errors = []
    for dt in (1e-4, 5e-5):
        _, y, _ = mm.run_manifold(sys4, arrays, y0, dt, int(round(WINDOW / dt)), save_every=10)
        errors.append([np.max(np.abs(y[-1, 4:7] - ref[4:7])) / 300.0,
                       np.max(np.abs(y[-1, 7 + n :] - ref[7 + n :])) / np.max(np.abs(ref[7 + n :]))])  # fmt: skip
    ratios = np.array(errors[0]) / np.array(errors[1])
    assert np.all((3.6 < ratios) & (ratios < 4.4)), ratios  # measured 3.98, 4.0
    assert np.max(errors[1]) < 2e-2  # measured ω 1.3e-6, ṡ ≈ 1e-2 at Δt = 50 µs


def test_h_conserved_and_energy_balance(capsule):
    """|R h| to round-off; E + E_d constant to the Newton tolerance at every Δt (the kinetic
    force is a discrete gradient: the step's energy balance is exact), where without the
    correction it moves at O(Δt²); the correction does not change the order (see the order test)."""
    model, arrays, sys4 = capsule
    y0 = _state(model, 2e-3)
    for dt in (2e-4, 1e-4):
        _, y, ed = mm.run_manifold(sys4, arrays, y0, dt, int(round(WINDOW / dt)))
        h = np.array([mm.angular_momentum(arrays, row) for row in y])
        assert np.max(np.abs(h - h[0])) <= 1e-13 * np.linalg.norm(h[0])
        e = np.array([mm.energy(sys4, arrays, row) for row in y]) + ed
        assert ed[-1] > 1e-4 * abs(e[0])  # a balance with something in it
        assert np.max(np.abs(e - e[0])) <= 1e-11 * abs(e[0])


def test_small_amplitude_is_q4(capsule):
    """The same midpoint with Q's kinetics (formulation Q4) from the same state, spinning slowly
    (3 rad/s: at 300 rad/s the centrifugal load, not the initial amplitude, sets |s|): the modal
    trajectories differ, relative to their amplitude, by O(|s|) (the kinetic terms Q leaves out
    are one order higher than those it keeps): halving the amplitude halves the difference."""
    model, arrays, sys4 = capsule
    n, dt, steps = model.n_modes, 5e-5, 200
    save = np.arange(steps + 1)
    rel = []
    for amplitude in (1e-3, 5e-4):
        y0 = _state(model, amplitude)
        y0[4:7] *= 0.01
        _, y, _ = mm.run_manifold(sys4, arrays, y0, dt, steps)
        yq = run_fixed(MidpointStep(sys4, dt), sys4, y0, steps, dt, save, 1e-12, 20, 0.0, "Q4")[0]
        s, sq = y[:, 7 : 7 + n], yq[:, 7 : 7 + n]
        rel.append(np.max(np.abs(s - sq)) / np.max(np.abs(sq)))
    assert 1.7 < rel[0] / rel[1] < 2.4, rel  # measured 0.078, 0.038
    assert rel[1] < 0.06


def test_integrate_and_diagnostics_take_a_qm_system(capsule):
    """``integrate`` of a QM system (``manifold_system``) runs the QM step (the same samples as
    ``run_manifold``); the diagnostics' |H| and energy are QM's (|H| to round-off, E + E_d to
    the Newton tolerance); the explicit equations are refused (the compiled backend:
    tests/test_manifold_kernel.py)."""
    from quadmodes.rom import dynamics as dyn
    from quadmodes.rom.diagnostics import diagnostics
    from quadmodes.rom.integrators import integrate

    model, arrays, sys4 = capsule
    sys_qm = mk.manifold_system(model, arrays)
    y0 = _state(model, 2e-3)
    sol = integrate(sys_qm, y0, (0.0, WINDOW), dt=5e-5, save_every=10, newton_tol=1e-12,
                    max_newton=20, backend="numpy")  # fmt: skip
    _, y, ed = mm.run_manifold(sys4, arrays, y0, 5e-5, 200, save_every=10)
    assert sol.method == "midpoint-QM" and np.array_equal(sol.y, y) and np.allclose(sol.dissipated, ed)
    d = diagnostics(sys_qm, sol)
    h = np.linalg.norm(dyn.momentum_inertial(sys_qm, sol.y), axis=1)
    assert np.max(np.abs(h - h[0])) <= 1e-13 * h[0]
    e = dyn.energy(sys_qm, sol.y) + sol.dissipated
    assert np.max(np.abs(e - e[0])) < 1e-9 * sol.dissipated[-1]
    assert np.all(np.isfinite(d.cone_angle))
    with pytest.raises(ValueError, match="QM"):
        dyn.generalised_system(sys_qm, y0[7:12], y0[4:7], y0[12:])


def test_reduced_system_refuses_qm_with_a_pointer(capsule):
    model = capsule[0]
    with pytest.raises(ValueError, match="manifold_system"):
        rsys.reduced_system(model, "QM")
