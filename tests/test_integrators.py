"""Time integrators: rigid-body exact solutions, conservation, energy sink, order, seed numbers."""

import dataclasses

import numpy as np
import pytest
from scipy.special import ellipj

from quadmodes.rom import diagnostics as dg
from quadmodes.rom import dynamics as dy
from quadmodes.rom import integrators as it
from quadmodes.rom import system as rsys
from quadmodes.rom.backward_euler import BackwardEulerStep
from quadmodes.rom.midpoint import MidpointStep
from quadmodes.rom.reduced import ReducedModel


def hand_model(J0, lam=(), zeta=0.0):
    """ReducedModel by hand: inertia J0, modal stiffness diag(lam), μ = I, all couplings zero."""
    n = len(lam)
    z = np.zeros
    w = np.sqrt(np.asarray(lam, float))
    return ReducedModel(
        mass=1.0, free=True, frequencies_hz=w / (2 * np.pi), damping_ratio=np.full(n, zeta),
        labels=tuple(f"m{k}" for k in range(n)), J0=np.asarray(J0, float), J1=z((n, 3, 3)),
        J2u=z((n, n, 3, 3)), J2g=z((n, n, 3, 3)), c=z((n, 3)), Cuu=z((n, n, 3)),
        Cxg=z((n, n, 3)), S1=z((n, 3)), S2=z((n, n, 3)), mu=np.eye(n),
        Lam=np.diag(np.asarray(lam, float)), C=np.diag(2 * zeta * w), X=z((1, 3)),
        translational=np.ones(1, bool), weights=np.ones(1), Phi=z((n, 1, 3)),
        G=z((n, n, 1, 3)),
    )  # fmt: skip


def spinner_state(sys, spin, cone_deg, s_amp=0.0):
    """Minor-axis spinner with cone angle (rigid J0 definition) and a modal disturbance."""
    w = dy.coning_omega(sys.J0, spin, np.radians(cone_deg))
    n = sys.n_modes
    return rsys.pack_state(sys, omega=w, s=s_amp * (-1.0) ** np.arange(n))


def rel_h_drift(sys, sol):
    h = dy.momentum_inertial(sys, sol.y)
    return np.abs(h - h[0]).max() / np.linalg.norm(h[0])


@pytest.fixture(scope="module")
def capsule(small_reduced_model):
    return rsys.reduced_system(small_reduced_model, "Q")


@pytest.fixture(scope="module")
def capsule_undamped(small_reduced_model):
    return dataclasses.replace(small_reduced_model, C=0 * small_reduced_model.C)


# ------------------------------------------------------------------ Newton Jacobians


@pytest.mark.parametrize("formulation", ["Q", "P", "L", "Q4"])
@pytest.mark.parametrize("stepper", [MidpointStep, BackwardEulerStep])
def test_step_jacobian_matches_finite_differences(small_reduced_model, formulation, stepper):
    sys = rsys.reduced_system(small_reduced_model, formulation)
    rng = np.random.default_rng(1)
    n = sys.n_modes
    st = stepper(sys, 1e-3)
    x0 = np.r_[3.0, -2.0, 80.0, 0.3 * rng.normal(size=n)]
    st.begin(x0, 2e-4 * rng.normal(size=n))
    x = x0 + np.r_[rng.normal(size=3), 0.1 * rng.normal(size=n)]
    _, jac = st.residual(x, jac=True)
    fd = np.empty_like(jac)
    for j in range(len(x)):
        e = np.zeros_like(x)
        e[j] = 1e-6
        fd[:, j] = (st.residual(x + e) - st.residual(x - e)) / 2e-6
    assert np.abs(jac - fd).max() <= 1e-8 * np.abs(jac).max()


# ------------------------------------------------------------------ rigid limits


def test_axisymmetric_rigid_body():
    """ω3 constant, ω1 + iω2 = ω⊥ e^{−int}, n = (I_t − I_a)ω3/I_t, cone angle constant."""
    i_t, i_a = 10.0, 4.0
    sys = rsys.reduced_system(hand_model(np.diag([i_t, i_t, i_a])), "rigid")
    w3 = 4 * np.pi
    w_perp = np.tan(np.radians(2.0)) * i_a * w3 / i_t
    y0 = rsys.pack_state(sys, omega=[w_perp, 0.0, w3])
    nut = (i_t - i_a) * w3 / i_t

    def error(sol):
        exact = w_perp * np.exp(-1j * nut * sol.t)
        e_perp = np.abs(sol.y[:, 4] + 1j * sol.y[:, 5] - exact).max() / w_perp
        return max(e_perp, np.abs(sol.y[:, 6] - w3).max() / w3)

    ref = it.integrate(sys, y0, (0, 10.0), "adaptive", rtol=1e-12, atol=1e-14, dt=0.1)
    assert error(ref) <= 1e-8
    d = dg.diagnostics(sys, ref)
    np.testing.assert_allclose(np.degrees(d.cone_angle), 2.0, rtol=1e-9)
    np.testing.assert_allclose(d.spin_rate, w3, rtol=1e-12)
    np.testing.assert_allclose(d.I_a, i_a, rtol=1e-14)
    np.testing.assert_allclose(d.I_t, i_t, rtol=1e-14)
    np.testing.assert_allclose(d.H_norm, d.H_norm[0], rtol=1e-10)
    # midpoint: second order, cone angle and H exact
    errs = []
    for dt in (2e-3, 1e-3):
        sol = it.integrate(sys, y0, (0, 2.0), "midpoint", dt=dt, save_every=50)
        errs.append(error(sol))
        assert rel_h_drift(sys, sol) <= 1e-13
        np.testing.assert_allclose(np.degrees(dg.diagnostics(sys, sol).cone_angle), 2.0, rtol=1e-10)
    assert errs[0] < 1e-3
    assert np.log2(errs[0] / errs[1]) == pytest.approx(2.0, abs=0.1)


def jacobi_solution(i1, i2, i3, w0, t):
    """Torque-free triaxial body (theory §6): ω(t) from cn, sn, dn; needs ω2(0) = 0, H² > 2EI2."""
    e2 = i1 * w0[0] ** 2 + i3 * w0[2] ** 2  # 2E
    h2 = (i1 * w0[0]) ** 2 + (i3 * w0[2]) ** 2
    assert h2 > e2 * i2
    tau = t * np.sqrt((i3 - i2) * (h2 - e2 * i1) / (i1 * i2 * i3))
    m = (i2 - i1) * (e2 * i3 - h2) / ((i3 - i2) * (h2 - e2 * i1))
    sn, cn, dn, _ = ellipj(tau, m)
    return np.stack(
        [
            np.sqrt((e2 * i3 - h2) / (i1 * (i3 - i1))) * cn,
            np.sqrt((e2 * i3 - h2) / (i2 * (i3 - i2))) * sn,
            np.sqrt((h2 - e2 * i1) / (i3 * (i3 - i1))) * dn,
        ],
        -1,
    )


def test_triaxial_rigid_body_jacobi():
    i1, i2, i3 = 1.0, 2.0, 3.0
    sys = rsys.reduced_system(hand_model(np.diag([i1, i2, i3])), "rigid")
    w0 = np.array([1.0, 0.0, 2.0])
    y0 = rsys.pack_state(sys, omega=w0)
    ref = it.integrate(sys, y0, (0, 10.0), "adaptive", rtol=1e-12, atol=1e-14, dt=0.05)
    exact = jacobi_solution(i1, i2, i3, w0, ref.t)
    assert np.abs(ref.y[:, 4:7] - exact).max() <= 1e-8 * np.linalg.norm(w0)
    errs = []
    for dt in (4e-3, 2e-3):
        sol = it.integrate(sys, y0, (0, 4.0), "midpoint", dt=dt, save_every=25)
        errs.append(np.abs(sol.y[:, 4:7] - jacobi_solution(i1, i2, i3, w0, sol.t)).max())
        assert rel_h_drift(sys, sol) <= 1e-13
    assert errs[1] < 1e-4
    assert np.log2(errs[0] / errs[1]) == pytest.approx(2.0, abs=0.1)


# ------------------------------------------------------------------ conservation


def test_midpoint_conserves_h_and_bounds_energy(capsule_undamped):
    """Damping off, 100 spin periods: |H| to 1e-10, energy error bounded (no drift)."""
    sys = rsys.reduced_system(capsule_undamped, "Q")
    spin = 100.0
    y0 = spinner_state(sys, spin, 5.0, s_amp=1e-4)
    sol = it.integrate(sys, y0, (0, 100 * 2 * np.pi / spin), "midpoint", dt=1e-3)
    assert sol.status == 0 and sol.stats["n_steps"] == 6284
    d = dg.diagnostics(sys, sol)
    assert np.abs(d.H_norm / d.H_norm[0] - 1).max() <= 1e-10
    assert rel_h_drift(sys, sol) <= 1e-10
    de = np.abs(d.E - d.E[0]) / d.E[0]
    k = len(de) // 10
    first, last = de[:k].max(), de[-k:].max()
    assert last <= 2.0 * first  # bounded oscillation (measured 5.3e-7 / 4.8e-7)
    assert first < 1e-5


def test_energy_balance_q_and_drift_p(capsule_undamped, small_reduced_model):
    """Adaptive, rtol 1e-10/1e-11: Q keeps E + E_d (damped) and E (undamped) to round-off;
    P keeps |H| but not E (drift orders of magnitude larger)."""
    q = rsys.reduced_system(small_reduced_model, "Q")
    y0 = spinner_state(q, 300.0, 5.0, s_amp=1e-4)
    sol = it.integrate(q, y0, (0, 0.2), "adaptive", rtol=1e-10, atol=1e-14, dt=1e-3)
    d = dg.diagnostics(q, sol)
    assert d.E_d[-1] > 0
    bal = np.abs(d.E_balance - d.E_balance[0]).max()
    assert bal <= 1e-6 * d.E_d[-1]  # measured ≈ 1e-10 of E_d
    assert rel_h_drift(q, sol) <= 1e-10
    drift = {}
    for formulation in ("Q", "P"):
        sys = rsys.reduced_system(capsule_undamped, formulation)
        sol = it.integrate(sys, y0, (0, 0.2), "adaptive", rtol=1e-11, atol=1e-14, dt=1e-3)
        e = dy.energy(sys, sol.y)
        drift[formulation] = np.abs(e - e[0]).max() / e[0]
        assert rel_h_drift(sys, sol) <= 1e-10  # h_P is P's conserved momentum
    assert drift["Q"] < 1e-10
    assert drift["P"] > 1e4 * drift["Q"]  # measured 1.4e-4 vs 3e-14
    assert drift["P"] > 1e-5


# ------------------------------------------------------------------ energy sink


def test_energy_sink_minor_axis_spinner(capsule):
    """Damped minor-axis spinner: T decreases, cone angle grows at the quasi-rigid rate
    θ̇ = P_d / [H² sinθ cosθ (1/I_a − 1/I_t)], |H| constant."""
    y0 = spinner_state(capsule, 600.0, 10.0, s_amp=2e-5)
    sol = it.integrate(capsule, y0, (0, 1.0), "midpoint", dt=2e-4, save_every=5)
    d = dg.diagnostics(capsule, sol)
    assert np.abs(d.H_norm / d.H_norm[0] - 1).max() <= 1e-10
    t = sol.t
    early = (t > 0.3) & (t <= 0.4)  # after the initial modal transient (decay time 0.05 s)
    late = t > 0.9
    assert d.T[late].mean() < d.T[early].mean()
    assert d.E[-1] < d.E[0] and d.E_d[-1] > 0
    dtheta = d.cone_angle[late].mean() - d.cone_angle[early].mean()
    assert dtheta > 10 * d.cone_angle[late].std()  # growth well above the ripple
    p_d = dy.dissipation_rate(capsule, sol.y)[t > 0.3].mean()
    th = d.cone_angle[early | late].mean()
    i_a, i_t, h = d.I_a.mean(), d.I_t.mean(), d.H_norm[0]
    rate = p_d / (h**2 * np.sin(th) * np.cos(th) * (1 / i_a - 1 / i_t))
    assert dtheta == pytest.approx(rate * 0.6, rel=0.1)  # measured within 0.4 %


# ------------------------------------------------------------------ convergence order


@pytest.fixture(scope="module")
def order_case(capsule):
    y0 = spinner_state(capsule, 300.0, 5.0, s_amp=1e-4)
    ref = it.integrate(capsule, y0, (0, 0.01), "adaptive", rtol=1e-13, atol=1e-16)
    scale = np.concatenate(
        [np.ones(4), np.full(3, np.linalg.norm(y0[4:7])),
         np.full(5, np.abs(ref.y[:, 7:12]).max()), np.full(5, np.abs(ref.y[:, 12:]).max())]
    )  # fmt: skip

    def error(sol):
        return np.abs((sol.y[-1] - ref.y[-1]) / scale).max()

    return y0, error


@pytest.mark.parametrize(
    "method, dts, order",
    [("midpoint", (1e-4, 5e-5, 2.5e-5), 2), ("backward-euler", (2e-5, 1e-5, 5e-6), 1)],
)
def test_order_of_convergence(capsule, order_case, method, dts, order):
    y0, error = order_case
    errs = [error(it.integrate(capsule, y0, (0, 0.01), method, dt=dt)) for dt in dts]
    measured = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(measured - order) <= 0.3), measured


def test_adaptive_error_decreases_with_rtol(capsule, order_case):
    y0, error = order_case
    errs = [
        error(it.integrate(capsule, y0, (0, 0.01), "adaptive", rtol=rt, atol=rt * 1e-3))
        for rt in (1e-5, 1e-7, 1e-9)
    ]
    assert errs[0] > 10 * errs[1] > 100 * errs[2]
    radau = it.integrate(capsule, y0, (0, 0.01), "Radau", rtol=1e-7, atol=1e-10)
    assert radau.method == "adaptive/Radau" and error(radau) < 1e-6


# ------------------------------------------------------------------ seed's numbers (references §2)


def one_step_eigenvalue(method, f_hz, zeta, dt):
    """(ζ_eff, f_num) of the one-step map of a single damped mode, through the stepping code."""
    from quadmodes.validation.dynamics_checks import one_step_damping

    return one_step_damping(method, f_hz, zeta, dt)


@pytest.mark.parametrize(
    "method, zeta_ref, f_ref",
    [("backward-euler", 0.289, 33.9), ("midpoint", 0.0189, 36.92)],
)
def test_numerical_damping_single_38hz_mode(method, zeta_ref, f_ref):
    zeta, f = one_step_eigenvalue(method, 38.0, 0.02, 2.5e-3)
    assert zeta == pytest.approx(zeta_ref, rel=0.03)
    assert f == pytest.approx(f_ref, rel=0.03)


def test_numerical_damping_from_free_decay():
    """Same numbers from free-decay records: Prony fit s_{k+2} = a s_{k+1} + b s_k (exact for a
    linear two-state one-step map), eigenvalues z² = a z + b."""
    w = 2 * np.pi * 38.0
    sys = rsys.reduced_system(hand_model(np.eye(3), [w * w], 0.02))
    for method, zeta_ref, f_ref in (("backward-euler", 0.289, 33.9), ("midpoint", 0.0189, 36.92)):
        sol = it.integrate(sys, rsys.pack_state(sys, s=[1.0]), (0, 0.1), method, dt=2.5e-3)
        s = sol.y[:, 7]
        (a, b), *_ = np.linalg.lstsq(np.stack([s[1:-1], s[:-2]], 1), s[2:], rcond=None)
        z = np.roots([1.0, -a, -b])[0]
        lam = np.log(z) / 2.5e-3
        assert -lam.real / abs(lam) == pytest.approx(zeta_ref, rel=0.03)
        assert abs(lam.imag) / (2 * np.pi) == pytest.approx(f_ref, rel=0.03)


def test_rigid_minor_axis_spinner_backward_euler_vs_midpoint():
    """Transverse 10, axial 4, spin 4π, cone 2°, Δt = 2.5 ms: BE halves the cone angle about
    every 10 s (rate λ²Δt/2, λ = 7.54 rad/s) and loses |H| (≈ −6e-4 in 60 s); midpoint keeps
    2.000° and H."""
    i_t, i_a = 10.0, 4.0
    sys = rsys.reduced_system(hand_model(np.diag([i_t, i_t, i_a])), "rigid")
    y0 = spinner_state(sys, 4 * np.pi, 2.0)
    be = it.integrate(sys, y0, (0, 60.0), "backward-euler", dt=2.5e-3, save_every=400)
    d = dg.diagnostics(sys, be)
    th = np.degrees(d.cone_angle)
    lam = (i_t - i_a) / i_t * 4 * np.pi
    rate = lam**2 * 2.5e-3 / 2
    assert th[0] == pytest.approx(2.0, rel=1e-12)
    i10 = np.argmin(np.abs(be.t - 10.0))
    assert th[i10] == pytest.approx(2.0 * np.exp(-rate * 10.0), rel=0.05)  # ≈ 0.98°
    assert th[i10] == pytest.approx(1.0, rel=0.05)
    dh = d.H_norm[-1] / d.H_norm[0] - 1
    assert dh == pytest.approx(-6e-4, rel=0.1)  # measured −6.09e-4
    mp = it.integrate(sys, y0, (0, 20.0), "midpoint", dt=2.5e-3, save_every=400)
    dm = dg.diagnostics(sys, mp)
    np.testing.assert_allclose(np.degrees(dm.cone_angle), 2.0, rtol=1e-9)
    assert rel_h_drift(sys, mp) <= 1e-13


# ------------------------------------------------------------------ interface contract


def test_sampling_and_solution_fields(capsule):
    y0 = spinner_state(capsule, 100.0, 5.0, s_amp=1e-4)
    sol = it.integrate(capsule, y0, (0, 0.01), "midpoint", dt=1e-3, save_every=3)
    np.testing.assert_allclose(sol.t, [0, 0.003, 0.006, 0.009, 0.01], atol=1e-15)
    assert sol.y.shape == (5, 17) and sol.dissipated.shape == (5,) and sol.dt == 1e-3
    assert sol.status == 0 and sol.success and sol.method == "midpoint"
    assert set(sol.stats) >= {"n_steps", "n_rhs", "n_newton", "n_jac", "wall_s"}
    assert sol.stats["n_steps"] == 10 and sol.stats["n_jac"] == 10
    np.testing.assert_array_equal(sol.y[0], y0)
    on_grid = it.integrate(capsule, y0, (0, 0.01), "midpoint", dt=1e-3, t_eval=[0.002, 0.005])
    np.testing.assert_allclose(on_grid.t, [0, 0.002, 0.005], atol=1e-15)
    with pytest.raises(ValueError, match="grid"):
        it.integrate(capsule, y0, (0, 0.01), "midpoint", dt=1e-3, t_eval=[0.0025])
    ad = it.integrate(capsule, y0, (0, 0.01), "adaptive", t_eval=np.linspace(0, 0.01, 7))
    np.testing.assert_allclose(ad.t, np.linspace(0, 0.01, 7))
    assert ad.stats["n_steps"] > 0 and ad.stats["n_rhs"] > ad.stats["n_steps"]
    with pytest.raises(ValueError, match="method"):
        it.integrate(capsule, y0, (0, 0.01), "euler", dt=1e-3)
    with pytest.raises(ValueError, match="dt"):
        it.integrate(capsule, y0, (0, 0.01), "midpoint")


@pytest.mark.parametrize("method", ["midpoint", "backward-euler"])
def test_newton_failure_is_reported(capsule, method):
    y0 = spinner_state(capsule, 100.0, 5.0, s_amp=1e-4)
    sol = it.integrate(capsule, y0, (0, 0.01), method, dt=1e-3, max_newton=1, newton_tol=1e-30)
    assert sol.status == 1 and not sol.success
    assert "step 1" in sol.message and "t = 0.001" in sol.message and "\n" not in sol.message
    assert len(sol.t) == len(sol.y) == 2 and sol.stats["n_steps"] == 0
    np.testing.assert_array_equal(sol.y[-1], y0)


def test_dissipated_energy_fallback_and_dict(capsule):
    """Without the integrator's own E_d, diagnostics integrate ṡᵀCṡ by the trapezoid rule."""
    y0 = spinner_state(capsule, 300.0, 5.0, s_amp=1e-4)
    sol = it.integrate(capsule, y0, (0, 0.02), "midpoint", dt=2e-5)
    bare = dataclasses.replace(sol, dissipated=np.zeros(0))
    own, trap = dg.diagnostics(capsule, sol).E_d, dg.diagnostics(capsule, bare).E_d
    assert own[-1] > 0 and trap[-1] == pytest.approx(own[-1], rel=1e-4)
    d = dg.diagnostics(capsule, sol).as_dict()
    assert d["cone_angle"].shape == sol.t.shape and d["H"].shape == (len(sol.t), 3)
