"""Full-order reference (quadmodes.fullorder): invariants, modal frequency and damping, order of
accuracy, checkpoints, agreement with the reduced model, and the hub-driven Kane spin-up.

All on the small capsule of conftest.py (≈400 nodes, ζ = 2 %) except the Kane beam."""

import math

import numpy as np
import pytest

from quadmodes.analysis.full_order_runs import kane_full_order
from quadmodes.fe.model import centre_of_mass
from quadmodes.fullorder import (
    FullOrderNewtonError,
    FullOrderOptions,
    initial_state_from_reduced,
    integrate_full_order,
)
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import integrators
from quadmodes.rom import system as rsys
from quadmodes.runs.initial import largest_nodal_displacement
from quadmodes.runs.spinup import KANE_REFERENCE_PEAKS

BENDING = 2  # first bending mode of the small capsule (148 Hz)


def _reduced_state(model, spin_hz=0.0, cone_deg=0.0, mode=BENDING, amplitude=1e-4):
    """ROM state y0: spin about the minor axis, mode ``mode`` displaced so that its largest
    nodal displacement is ``amplitude`` (m)."""
    system = rsys.reduced_system(model, "Q")
    omega = (
        dyn.coning_omega(model.J0, 2 * np.pi * spin_hz, math.radians(cone_deg))
        if spin_hz
        else np.zeros(3)
    )
    s0 = np.zeros(model.n_modes)
    s0[mode] = amplitude / largest_nodal_displacement(model, mode)
    return system, rsys.pack_state(system, omega=omega, s=s0)


def _full_state(modal, model, y0):
    return initial_state_from_reduced(model, y0, p=centre_of_mass(modal.structure, modal.x))


def _crossing_times(t, y):
    """Times of the zero crossings of y(t) (linear interpolation)."""
    k = np.flatnonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


@pytest.fixture(scope="module")
def spinning(small_modal_model, small_reduced_model):
    """Undamped free spin: 10 Hz about the minor axis, 5° cone, bending 1 mm; 30 ms."""
    _, y0 = _reduced_state(small_reduced_model, 10.0, 5.0, amplitude=1e-3)
    x0, v0 = _full_state(small_modal_model, small_reduced_model, y0)
    m = small_modal_model
    return integrate_full_order(
        m.structure, m.x, x0, v0, (0.0, 0.03), 2.5e-4,
        FullOrderOptions(model=small_reduced_model, damping=False),
    )


@pytest.fixture(scope="module")
def ringing(small_modal_model, small_reduced_model):
    """Damped (ζ = 2 %) free vibration in the first bending mode, no spin, 0.1 mm, 5 periods."""
    _, y0 = _reduced_state(small_reduced_model)
    x0, v0 = _full_state(small_modal_model, small_reduced_model, y0)
    m = small_modal_model
    period = 1.0 / small_reduced_model.frequencies_hz[BENDING]
    return integrate_full_order(
        m.structure, m.x, x0, v0, (0.0, 5 * period), period / 60,
        FullOrderOptions(model=small_reduced_model),
    ), y0


def test_initial_state_round_trip(small_modal_model, small_reduced_model, spinning):
    # the M-projection in the best-fit frame recovers the ROM's modal coordinates
    _, y0 = _reduced_state(small_reduced_model, 10.0, 5.0, amplitude=1e-3)
    s = spinning.modal_coordinates[0]
    np.testing.assert_allclose(s, y0[7 : 7 + small_reduced_model.n_modes], atol=1e-6 * abs(s).max())
    # the ROM's spin and cone angle at t = 0 (exact definitions agree to O(s²))
    assert spinning.spin_rate[0] == pytest.approx(2 * np.pi * 10.0, rel=1e-3)
    assert math.degrees(spinning.cone_angle[0]) == pytest.approx(5.0, rel=1e-3)


def test_free_spin_conserves_angular_momentum(spinning):
    hd = np.linalg.norm(spinning.H_discrete, axis=1)
    assert np.max(np.abs(hd / hd[0] - 1.0)) <= 1e-8  # the scheme's invariant
    # diagnostics of the physical state (end state mapped back by O(Δt²)) stay close too
    assert np.max(np.abs(spinning.H_norm / spinning.H_norm[0] - 1.0)) <= 1e-6
    assert spinning.status == 0 and spinning.stats["n_steps"] == 120


def test_free_spin_energy_bounded(spinning):
    e = spinning.E
    dev = np.abs(e - e[0]) / e[0]
    assert dev.max() <= 1e-5
    half = len(e) // 2  # no drift: the second half deviates no more than the first, ×2
    assert dev[half:].max() <= 2.0 * dev[: half + 1].max() + 1e-9


def test_free_vibration_frequency_and_damping(small_reduced_model, ringing):
    sol, _ = ringing
    s = sol.modal_coordinates[:, BENDING]
    f_modal = small_reduced_model.frequencies_hz[BENDING]
    zeta = small_reduced_model.damping_ratio[BENDING]
    tz = _crossing_times(sol.t, s)
    f_full = 0.5 * (len(tz) - 1) / (tz[-1] - tz[0])  # damped: ω√(1−ζ²), 2e-4 below ω
    assert f_full == pytest.approx(f_modal * math.sqrt(1 - zeta**2), rel=5e-3)
    # decay: log of the peak |s| between zero crossings against time
    peaks, times = [], []
    for a, b in zip(tz[:-1], tz[1:], strict=True):
        sel = (sol.t > a) & (sol.t < b)
        k = np.argmax(np.abs(s[sel]))
        peaks.append(abs(s[sel][k]))
        times.append(sol.t[sel][k])
    rate = -np.polyfit(times, np.log(peaks), 1)[0]
    assert rate == pytest.approx(zeta * 2 * np.pi * f_modal, rel=0.05)


def test_damped_energy_balance(ringing):
    sol, _ = ringing
    assert sol.E_d[-1] > 0.5 * sol.E[0]  # most of the vibration energy is dissipated
    balance = sol.E + sol.E_d
    assert np.ptp(balance) <= 2e-3 * sol.E_d[-1]


def test_agrees_with_reduced_model_at_small_amplitude(small_reduced_model, ringing):
    sol, y0 = ringing
    system = rsys.reduced_system(small_reduced_model, "Q")
    rom = integrators.integrate(
        system, y0, (0.0, sol.t[-1]), "midpoint", dt=sol.dt, backend="numpy"
    )
    assert rom.t.shape == sol.t.shape
    s_rom = rom.y[:, 7 : 7 + system.n_modes]
    scale = np.abs(s_rom[:, BENDING]).max()
    assert np.abs(sol.modal_coordinates - s_rom).max() <= 0.02 * scale


def test_midpoint_second_order(small_modal_model, small_reduced_model):
    _, y0 = _reduced_state(small_reduced_model, 10.0, 5.0, amplitude=1e-3)
    x0, v0 = _full_state(small_modal_model, small_reduced_model, y0)
    m = small_modal_model
    ends = {}
    for h in (4e-4, 2e-4, 1e-4, 2.5e-5):
        sol = integrate_full_order(
            m.structure, m.x, x0, v0, (0.0, 3.2e-3), h,
            FullOrderOptions(model=small_reduced_model, damping=False),
        )
        ends[h] = sol.modal_coordinates[-1]
    e1 = np.linalg.norm(ends[4e-4] - ends[2.5e-5])
    e2 = np.linalg.norm(ends[2e-4] - ends[2.5e-5])
    e3 = np.linalg.norm(ends[1e-4] - ends[2.5e-5])
    assert 3.0 < e1 / e2 < 5.5 and 3.0 < e2 / e3 < 5.5


def test_checkpoint_resume_and_newton_failure(small_modal_model, small_reduced_model, tmp_path):
    _, y0 = _reduced_state(small_reduced_model, 10.0, 5.0, amplitude=1e-3)
    x0, v0 = _full_state(small_modal_model, small_reduced_model, y0)
    m = small_modal_model
    h = 2.5e-4

    def run(n_steps, path, **kw):
        return integrate_full_order(
            m.structure, m.x, x0, v0, (0.0, n_steps * h), h, FullOrderOptions(
                model=small_reduced_model, checkpoint=path, checkpoint_every=10, save_every=3,
                **kw),
        )  # fmt: skip

    whole = run(30, tmp_path / "a.npz")
    part = tmp_path / "b.npz"
    first = run(25, part)  # "interrupted": its last checkpoint is at step 20
    assert first.stats["n_steps"] == 25
    resumed = run(30, part, resume=True)
    for key in ("t", "H", "E", "E_d", "cone_angle", "spin_rate", "modal_coordinates"):
        np.testing.assert_allclose(getattr(resumed, key), getattr(whole, key), rtol=1e-12, atol=0)
    assert resumed.stats["n_steps"] == 30
    # a Newton failure keeps the checkpoint and says so in one line
    before = part.read_bytes()
    with pytest.raises(FullOrderNewtonError) as err:
        run(30, part, resume=True, max_newton=1, newton_tol=1e-30)
    msg = str(err.value)
    assert "\n" not in msg and "step 21" in msg and str(part) in msg
    assert part.read_bytes() == before


@pytest.mark.parametrize("omega_s", sorted(KANE_REFERENCE_PEAKS))
def test_kane_spinup_full_order_peaks(omega_s):
    v_ref, t_ref = KANE_REFERENCE_PEAKS[omega_s]
    r = kane_full_order(omega_s, duration=8.0)
    assert r.complete
    assert r.peak_deflection == pytest.approx(v_ref, rel=0.02)
    assert r.peak_time == pytest.approx(t_ref, abs=0.2)


def test_full_order_for_run_case_and_estimate():
    from quadmodes.analysis.full_order_runs import estimate_for_run, full_order_for_run

    # the run's initial state (41 Hz, 6° cone, no deformation) on the coarse model, 4 steps
    sol = full_order_for_run("paper-41hz-coarse", window=2e-3, save_every=1)
    assert sol.status == 0 and len(sol.t) == 5
    assert sol.spin_rate[0] == pytest.approx(2 * np.pi * 41.0, rel=2e-3)
    assert math.degrees(sol.cone_angle[0]) == pytest.approx(6.0, rel=2e-3)
    assert np.abs(sol.modal_coordinates[0]).max() < 1e-6  # retained modes start at rest
    hd = np.linalg.norm(sol.H_discrete, axis=1)
    assert np.max(np.abs(hd / hd[0] - 1.0)) <= 1e-9
    est = estimate_for_run("paper-41hz-coarse", window=1.0, n_probe=2)
    assert est["n_steps"] == 2000 and est["estimate_s"] > est["per_step_s"] > 0.0
