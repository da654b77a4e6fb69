"""Compiled midpoint kernel (numba backend of ``integrators.integrate``): agreement with the
numpy midpoint, conservation, energy balance, failure reporting, order of convergence, backend
selection, and Δt-convergence of the cone-angle growth of a run (the ``--dt-convergence`` path).

Skipped without numba (the ``[jit]`` extra). The first test pays the compilation (≈15 s) unless
the on-disk numba cache already holds it."""

import dataclasses
import re

import numpy as np
import pytest

pytest.importorskip("numba")

from test_run import run_toml, workdir  # noqa: E402, F401  (fixture)

from quadmodes.case import run_case_from_toml  # noqa: E402
from quadmodes.rom import diagnostics as dg  # noqa: E402
from quadmodes.rom import dynamics as dy  # noqa: E402
from quadmodes.rom import integrators as it  # noqa: E402
from quadmodes.rom import system as rsys  # noqa: E402
from quadmodes.runs import simulate  # noqa: E402
from quadmodes.runs.dt_convergence import dt_convergence  # noqa: E402


def spinner_state(sys, spin, cone_deg, s_amp=0.0):
    """Minor-axis spinner (rad/s, cone angle of the rigid J0) with a modal disturbance."""
    w = dy.coning_omega(sys.J0, spin, np.radians(cone_deg))
    return rsys.pack_state(sys, omega=w, s=s_amp * (-1.0) ** np.arange(sys.n_modes))


def both(sys, y0, t1, dt, **kw):
    """The same midpoint run with the numpy and the numba backends."""
    a = it.integrate(sys, y0, (0.0, t1), "midpoint", dt=dt, backend="numpy", **kw)
    b = it.integrate(sys, y0, (0.0, t1), "midpoint", dt=dt, backend="numba", **kw)
    return a, b


def rel_state_diff(a, b):
    """max over samples and components of |y_a − y_b| / max_t |y_a| (per component)."""
    scale = np.abs(a.y).max(axis=0)
    scale[scale == 0.0] = 1.0
    return float((np.abs(a.y - b.y) / scale).max())


@pytest.fixture(scope="module")
def capsule(small_reduced_model):
    return rsys.reduced_system(small_reduced_model, "Q")


# ------------------------------------------------------------------ agreement with numpy


@pytest.mark.parametrize("formulation", ["Q", "P", "L", "rigid"])
def test_numba_reproduces_numpy_midpoint(small_reduced_model, formulation):
    """2000 steps (19 turns at 300 rad/s), damped, with a modal disturbance: the
    same samples, states equal to 1e-10 relative (measured ≈1e-12), same dissipated energy and
    the same work counters (the same Newton iterations were taken)."""
    sys = rsys.reduced_system(small_reduced_model, formulation)
    y0 = spinner_state(sys, 300.0, 5.0, s_amp=1e-4)
    a, b = both(sys, y0, 0.4, 2e-4, save_every=10)
    assert a.status == b.status == 0
    assert a.stats["backend"] == "numpy" and b.stats["backend"] == "numba"
    assert b.stats["n_steps"] == 2000
    np.testing.assert_array_equal(a.t, b.t)
    assert a.y.shape == b.y.shape and a.dt == b.dt
    assert rel_state_diff(a, b) <= 1e-10
    np.testing.assert_allclose(b.dissipated, a.dissipated, rtol=1e-10, atol=1e-300)
    for key in ("n_steps", "n_newton", "n_jac", "n_rhs"):
        assert abs(a.stats[key] - b.stats[key]) <= 0.01 * a.stats[key], key


def test_sampling_with_t_eval_matches_numpy(capsule):
    y0 = spinner_state(capsule, 100.0, 5.0, s_amp=1e-4)
    a, b = both(capsule, y0, 0.01, 1e-3, t_eval=[0.002, 0.005])
    np.testing.assert_allclose(b.t, [0.0, 0.002, 0.005], atol=1e-15)
    assert rel_state_diff(a, b) <= 1e-12
    a, b = both(capsule, y0, 0.01, 1e-3, save_every=3)
    np.testing.assert_allclose(b.t, [0, 0.003, 0.006, 0.009, 0.01], atol=1e-15)
    assert b.stats["n_steps"] == 10 and b.stats["n_jac"] == 10
    np.testing.assert_array_equal(b.y[0], a.y[0])


# ------------------------------------------------------------------ physics with the kernel


def test_momentum_conserved_to_round_off(capsule):
    """20 000 damped steps: |H| and the inertial vector H = R h conserved to 1e-12 relative
    (the ω projection makes the discrete transport of h exact, not just Newton-tolerance)."""
    y0 = spinner_state(capsule, 600.0, 10.0, s_amp=1e-4)
    sol = it.integrate(capsule, y0, (0, 4.0), "midpoint", dt=2e-4, save_every=20, backend="numba")
    assert sol.status == 0 and sol.stats["n_steps"] == 20000
    d = dg.diagnostics(capsule, sol)
    assert np.abs(d.H_norm / d.H_norm[0] - 1.0).max() <= 1e-12
    h = dy.momentum_inertial(capsule, sol.y)
    assert np.abs(h - h[0]).max() <= 1e-12 * np.linalg.norm(h[0])


def test_damping_energy_balance(capsule):
    """E + E_d = E₀ up to the midpoint's O(Δt²) energy error: small against E_d, and four times
    smaller at Δt/2. The kernel's own E_d (Σ Δt ṡ½ᵀCṡ½) is independent of Δt to 1e-4 and
    agrees with the trapezoid integral of the sampled dissipation rate ṡᵀCṡ to that rule's
    O(Δt²) error (which shrinks fourfold per halving)."""
    y0 = spinner_state(capsule, 300.0, 5.0, s_amp=1e-4)
    errs, own, trap_gap = [], [], []
    for dt in (2e-4, 1e-4):
        sol = it.integrate(capsule, y0, (0, 0.4), "midpoint", dt=dt, backend="numba")
        d = dg.diagnostics(capsule, sol)
        assert d.E_d[-1] > 0 and np.all(np.diff(d.E_d) >= 0)
        errs.append(np.abs(d.E + d.E_d - d.E[0]).max())
        assert errs[-1] <= 1e-4 * d.E_d[-1]  # measured 3.7e-6 at 0.2 ms
        own.append(d.E_d[-1])
        trap = dg.diagnostics(capsule, dataclasses.replace(sol, dissipated=np.zeros(0))).E_d
        trap_gap.append(abs(trap[-1] / d.E_d[-1] - 1.0))
    assert np.log2(errs[0] / errs[1]) == pytest.approx(2.0, abs=0.2)
    assert own[1] == pytest.approx(own[0], rel=1e-4)  # measured 1e-5
    assert trap_gap[0] < 2e-2 and np.log2(trap_gap[0] / trap_gap[1]) == pytest.approx(2.0, abs=0.2)


def test_absurd_step_reports_newton_failure(capsule):
    """50 ms steps at 50 Hz spin (2.5 turns per step) past 120–165 Hz modes: Newton diverges
    after a few steps; status 1, a one-line message naming the step k and its time k·Δt, the
    k samples before it plus the last accepted state (all finite); the same as numpy."""
    y0 = spinner_state(capsule, 2 * np.pi * 50, 6.0, s_amp=1e-3)
    with np.errstate(all="ignore"):  # the numpy backend overflows on the diverging iterate
        a, b = both(capsule, y0, 1.0, 0.05)
    assert b.status == 1 and not b.success and "\n" not in b.message
    found = re.search(r"midpoint: Newton (did not converge|failed) at step (\d+) \(t = (\S+) s\)",
                      b.message)  # fmt: skip
    assert found, b.message
    k = int(found.group(2))
    assert 1 < k < 20 and float(found.group(3)) == pytest.approx(0.05 * k)
    assert b.stats["n_steps"] == k - 1 and len(b.t) == len(b.y) == len(b.dissipated) == k + 1
    np.testing.assert_allclose(b.t, 0.05 * np.r_[np.arange(k), k - 1], atol=1e-15)
    assert np.all(np.isfinite(b.y)) and np.all(np.isfinite(b.dissipated))
    assert (a.status, a.message, a.stats["n_steps"]) == (b.status, b.message, b.stats["n_steps"])
    assert rel_state_diff(a, b) <= 1e-10
    # a tolerance that cannot be met stops at the first step, as the numpy driver does
    c = it.integrate(capsule, y0, (0, 0.01), "midpoint", dt=1e-3, max_newton=1, newton_tol=1e-30,
                     backend="numba")  # fmt: skip
    assert c.status == 1 and "step 1" in c.message and "t = 0.001" in c.message
    assert c.stats["n_steps"] == 0 and len(c.t) == 2
    np.testing.assert_array_equal(c.y[-1], c.y[0])


def test_order_of_convergence_two(capsule):
    """Final-state error against DOP853 at rtol 1e-13 falls fourfold per halving of Δt."""
    y0 = spinner_state(capsule, 300.0, 5.0, s_amp=1e-4)
    ref = it.integrate(capsule, y0, (0, 0.01), "adaptive", rtol=1e-13, atol=1e-16)
    scale = np.abs(ref.y).max(axis=0)
    scale[scale == 0.0] = 1.0
    errs = [
        np.abs((it.integrate(capsule, y0, (0, 0.01), "midpoint", dt=dt, backend="numba").y[-1]
                - ref.y[-1]) / scale).max()
        for dt in (1e-4, 5e-5, 2.5e-5)
    ]  # fmt: skip
    measured = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(measured - 2.0) <= 0.3), measured


# ------------------------------------------------------------------ backend selection


def test_backend_selection_and_errors(capsule, monkeypatch):
    y0 = spinner_state(capsule, 100.0, 5.0)
    auto = it.integrate(capsule, y0, (0, 0.002), "midpoint", dt=1e-3)
    assert auto.stats["backend"] == "numba"
    be = it.integrate(capsule, y0, (0, 0.002), "backward-euler", dt=1e-3)
    assert be.stats["backend"] == "numpy"
    with pytest.raises(ValueError, match="midpoint"):
        it.integrate(capsule, y0, (0, 0.002), "backward-euler", dt=1e-3, backend="numba")
    with pytest.raises(ValueError, match="backend"):
        it.integrate(capsule, y0, (0, 0.002), "midpoint", dt=1e-3, backend="cuda")
    monkeypatch.setattr(it, "_KERNEL", [None])  # as if numba were not installed
    with pytest.raises(ValueError, match="cannot be imported"):
        it.integrate(capsule, y0, (0, 0.002), "midpoint", dt=1e-3, backend="numba")
    fallback = it.integrate(capsule, y0, (0, 0.002), "midpoint", dt=1e-3)
    assert fallback.stats["backend"] == "numpy"


# ------------------------------------------------------------------ Δt convergence of a run


def test_dt_convergence_of_cone_angle_growth(workdir, small_reduced_model, monkeypatch):  # noqa: F811
    """Minor-axis spinner with an energy sink (small capsule, 100 Hz spin, 10° cone, 1 s):
    through ``dt_convergence`` (what ``run --dt-convergence`` calls) at 0.2, 0.1 and
    0.05 ms, the cone-angle growth θ(1 s) − θ₀ changes by under 2 % from Δt/2 to Δt/4 and the
    change shrinks about fourfold per halving (second order); every chunk used the kernel."""
    backends = []
    real = it.integrate

    def spy(*args, **kwargs):
        sol = real(*args, **kwargs)
        backends.append(sol.stats["backend"])
        return sol

    monkeypatch.setattr(it, "integrate", spy)
    text = run_toml(spin='"100 Hz"', cone='"10 deg"', amplitude='"0 in"', dt='"0.2 ms"',
                    duration='"1 s"', save_every="10")  # fmt: skip
    setup = simulate.prepare(run_case_from_toml(text, base_dir=workdir), small_reduced_model)
    conv = dt_convergence(setup)
    rows = conv["rows"]
    assert [r["steps"] for r in rows] == [5000, 10000, 20000] and all(r["complete"] for r in rows)
    assert set(backends) == {"numba"}
    growth = np.array([r["cone_angle_deg"] for r in rows]) - 10.0  # θ₀ is exactly 10°
    assert np.all(growth > 1e-3)  # the energy sink opens the cone (measured ≈ 6e-3°)
    changes = np.abs(np.diff(growth))
    assert changes[1] < 0.02 * growth[2]
    assert changes[0] / changes[1] == pytest.approx(4.0, rel=0.5)
    # the verdict judges the headline: the cone growth (significant here), not the end angle
    assert conv["judged"] == ["cone_growth_rate_deg_per_s", "cone_angle_change_deg"]
    assert all(r["cone_growth_significant"] for r in rows)
    # ... which changes more than the end angle θ(T) = θ₀ + growth, which understates it
    assert rows[1]["rel_change_cone_angle_change_deg"] > 10 * rows[1]["rel_change_cone_angle_deg"]


def test_kernel_is_checked_against_the_rotation_leaves_it_compiles():
    """numba reloads the cached loop as long as midpoint_kernel.py is unchanged, even if a leaf
    of quadmodes.rotations compiled into it has changed: after editing a leaf, update
    LEAVES_DIGEST (which also invalidates the cache)."""
    from quadmodes.rom import midpoint_kernel as k

    assert k.leaves_digest() == k.LEAVES_DIGEST, (
        f"a rotation leaf changed: set LEAVES_DIGEST = {k.leaves_digest()!r} in midpoint_kernel.py"
    )
