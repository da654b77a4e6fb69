"""Kane–Ryan–Banerjee spin-up of a hub-clamped beam (references.md §3) with the reduced model."""

import numpy as np
import pytest

from quadmodes.models.beam import kane_model
from quadmodes.rom.rotating_frame import rotating_stiffness_is_positive
from quadmodes.runs.spinup import KANE_REFERENCE_PEAKS, kane_rate, kane_spinup, tip_displacement

# DOP853 tolerance used here: the peaks agree with rtol = 1e-10 to 5 digits
FAST = {"rtol": 1e-8, "atol": 1e-10}
OMEGA_1 = 3.516 * np.sqrt(7e10 * 2e-7 / (3000 * 4e-4 * 10.0**4))  # 3.798 rad/s


@pytest.fixture(scope="module")
def model():
    """Four in-plane bending modes of the 20-element clamped ANCF beam."""
    return kane_model(n_modes=4, n_elements=20)


@pytest.fixture(scope="module")
def q_runs(model):
    return {ws: kane_spinup(ws, model=model, **FAST) for ws in KANE_REFERENCE_PEAKS}


def test_rate_profile():
    t = np.linspace(0.0, 20.0, 2001)
    rate, acc = kane_rate(t, 6.0, 15.0)
    assert rate[0] == 0.0 and kane_rate(15.0, 6.0, 15.0)[0] == pytest.approx(6.0)
    assert np.all(rate[t >= 15.0] == 6.0)
    assert kane_rate(0.0)[1] == 0.0 and kane_rate(15.0)[1] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(np.gradient(rate, t)[1:-1], acc[1:-1], atol=2e-4)


def test_model_keeps_pure_in_plane_bending(model):
    assert model.labels == tuple(f"in-plane bending {k}" for k in range(1, 5))
    scale = np.abs(model.Phi).max()
    assert np.abs(model.Phi[..., 2]).max() < 1e-12 * scale  # no out-of-plane content
    assert np.abs(model.Phi[..., 0]).max() < 1e-12 * scale  # no axial modes
    np.testing.assert_allclose(2 * np.pi * model.frequencies_hz[0], OMEGA_1, rtol=2e-4)
    # the quadratic modes of in-plane bending are pure foreshortening
    assert np.abs(model.G[..., 1:]).max() < 1e-9 * np.abs(model.G[..., 0]).max()
    assert np.all(model.G[0, 0, model.translational, 0] <= 1e-15)


@pytest.mark.parametrize("omega_s", sorted(KANE_REFERENCE_PEAKS))
def test_q_reproduces_published_peaks(q_runs, omega_s):
    r = q_runs[omega_s]
    v_ref, t_ref = KANE_REFERENCE_PEAKS[omega_s]
    assert r.status == "ok", r.message
    assert r.peak_deflection < 0.0  # the tip lags the accelerating hub
    assert abs(r.peak_deflection - v_ref) <= 0.03 * abs(v_ref)
    assert abs(r.peak_time - t_ref) <= 0.2
    # after the spin-up the beam is back near its (undeflected) steady state
    assert r.after_ramp_max < 0.01


def test_tip_reconstruction_includes_foreshortening(q_runs, model):
    r = q_runs[6.0]
    k = int(np.argmin(r.tip_inplane))
    linear = tip_displacement(model, r.s[k], quadratic=False)
    assert linear[0] == pytest.approx(0.0, abs=1e-12)  # linear modes: no axial tip motion
    np.testing.assert_allclose(linear[1], r.tip_inplane[k], rtol=1e-12)
    # g term: axial foreshortening ≈ −0.58097 v²/L of a first-mode-like shape
    expected = -0.58097 * r.tip_inplane[k] ** 2 / 10.0
    assert r.tip_axial[k] == pytest.approx(expected, rel=0.03)
    assert np.all(np.abs(r.tip_outofplane) < 1e-12)


def test_out_of_plane_modes_are_inert():
    both = kane_spinup(6.0, n_modes=2, out_of_plane=True, duration=10.0, **FAST)
    plane = kane_spinup(6.0, n_modes=2, duration=10.0, **FAST)
    assert len(both.model.labels) == 4
    assert np.abs(both.tip_outofplane).max() < 1e-12
    np.testing.assert_allclose(both.tip_inplane, plane.tip_inplane, atol=1e-6)


def test_linear_modes_diverge_above_first_frequency(model):
    r = kane_spinup(6.0, model=model, formulation="L", **FAST)
    assert r.status == "diverged" and r.diverged
    assert "exceeded" in r.message
    # stopped cleanly once the hub had passed ω1, before the end of the run
    assert OMEGA_1 < r.rate[-1] and r.time[-1] < 30.0
    assert np.all(np.isfinite(r.tip))


def test_linear_modes_bounded_below_first_frequency(model):
    r = kane_spinup(2.0, model=model, formulation="L", **FAST)
    assert r.status == "ok", r.message
    assert np.abs(r.tip_inplane).max() < 1.0


def test_rotating_stiffness_definiteness(model):
    """The divergence of L is physical for that model: Λ − ωᵀJ2ω loses definiteness at ω1."""
    below, above = 0.99 * OMEGA_1, 1.01 * OMEGA_1
    assert rotating_stiffness_is_positive(model, [0, 0, below], "L")
    assert not rotating_stiffness_is_positive(model, [0, 0, above], "L")
    for w in (above, 6.0, 10.0, 30.0):
        assert rotating_stiffness_is_positive(model, [0, 0, w], "Q")


def test_free_model_rejected(model):
    from dataclasses import replace

    with pytest.raises(ValueError, match="clamped"):
        kane_spinup(6.0, model=replace(model, free=True))
