"""The reduced model's validity along a run's path: the departure of the centrifugal load in
closed form, the path leaving the range where the spin leaves it, and what `quadmodes run`
writes about the path and its `--until` event."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from test_run import run_toml, workdir  # noqa: F401  (fixture)
from test_run_events import rigid_system
from typer.testing import CliRunner

from quadmodes.cli.app import app
from quadmodes.rom import system as rsys
from quadmodes.runs import results as res
from quadmodes.runs.path_validity import (
    CENTRIFUGAL_LIMIT,
    centrifugal_departure,
    path_validity,
    spin_range,
)

E1 = np.array([1.0, 0.0, 0.0])


@pytest.mark.parametrize("eps", [-0.1, -0.01, 0.003, 0.05])
def test_departure_of_a_spin_change_is_the_relative_change_of_its_square(eps):
    """ω = (1 + ε) Ω e: C(ω) − C(Ω e) = ((1 + ε)² − 1) Ω² (eeᵀ − I), norm |(1 + ε)² − 1| Ω²."""
    omega = 30.0
    got = centrifugal_departure((1 + eps) * omega * E1, omega * E1)
    assert got[0] == pytest.approx(abs((1 + eps) ** 2 - 1), rel=1e-12)


@pytest.mark.parametrize("beta_deg", [0.5, 1.0, 5.0, 30.0])
def test_departure_of_a_tilt_is_its_sine(beta_deg):
    """|ω| = Ω tilted by β: C(ω) − C(Ω e) = Ω² (nnᵀ − eeᵀ), eigenvalues ±sin β and 0."""
    b = math.radians(beta_deg)
    n = np.array([math.cos(b), math.sin(b), 0.0])
    assert centrifugal_departure(7.0 * n, 7.0 * E1)[0] == pytest.approx(math.sin(b), rel=1e-12)


def _even_part_norm(omega, omega_ref):
    """‖½(D(ω_t) + D(−ω_t))‖₂ / Ω_ref² with D(x) = C(Ωe + x) − C(ω_ref): the part of the
    departure even in the tilt ω_t (what lasts in the body: its odd part turns with ω_t),
    computed from the matrices, not from the closed form."""
    e = omega_ref / np.linalg.norm(omega_ref)
    axial = (omega @ e) * e
    tilt = omega - axial

    def c(v):
        return np.outer(v, v) - (v @ v) * np.eye(3)

    even = 0.5 * (c(axial + tilt) + c(axial - tilt)) - c(omega_ref)
    return np.abs(np.linalg.eigvalsh(even)).max() / (omega_ref @ omega_ref)


@pytest.mark.parametrize("beta_deg", [0.5, 1.75, 8.0, 30.0])
def test_a_tilt_at_fixed_spin_lasts_by_its_square(beta_deg):
    """ω = Ω(e + tan β t), t ⊥ e: C(ω) − C(Ωe) = Ω²tanβ (etᵀ + teᵀ) [odd in the tilt: it turns
    with ω_t in the body, zero mean over a turn] + Ω²tan²β (ttᵀ − I) [even: what lasts, norm
    tan²β]. The quasi-static departure is tan²β, the even part's norm, and the mean over a turn
    of ω_t is no larger; the whole departure is larger than the odd part's tan β·(norm 1)."""
    from quadmodes.runs.centrifugal_load import quasi_static_departure, tilt_departure

    b, omega = math.radians(beta_deg), 40.0
    phase = np.linspace(0.0, 2 * math.pi, 73)[:-1]
    w = omega * np.c_[np.ones(len(phase)), math.tan(b) * np.cos(phase), math.tan(b) * np.sin(phase)]
    ref = omega * E1
    got = quasi_static_departure(w, ref)
    np.testing.assert_allclose(got, math.tan(b) ** 2, rtol=1e-12)
    np.testing.assert_allclose(tilt_departure(w, ref), math.tan(b) ** 2, rtol=1e-12)
    np.testing.assert_allclose(got, [_even_part_norm(wk, ref) for wk in w], rtol=0, atol=1e-14)

    def c(v):
        return np.outer(v, v) - (v @ v) * np.eye(3)

    mean = np.mean([c(wk) - c(ref) for wk in w], axis=0) / omega**2
    assert np.abs(np.linalg.eigvalsh(mean)).max() == pytest.approx(math.tan(b) ** 2, rel=1e-12)
    assert np.all(centrifugal_departure(w, ref) >= math.tan(b) - 1e-12)


@pytest.mark.parametrize("eps", [-0.1, -0.01, 0.003, 0.05])
def test_a_spin_change_lasts_whole(eps):
    """A pure spin change has no tilt: its quasi-static departure is the whole, |(1+ε)² − 1|."""
    from quadmodes.runs.centrifugal_load import quasi_static_departure, tilt_departure

    got = quasi_static_departure((1 + eps) * 30.0 * E1, 30.0 * E1)
    assert got[0] == pytest.approx(abs((1 + eps) ** 2 - 1), rel=1e-12)
    assert got[0] == pytest.approx(centrifugal_departure((1 + eps) * 30.0 * E1, 30.0 * E1)[0], rel=1e-12)
    assert tilt_departure((1 + eps) * 30.0 * E1, 30.0 * E1)[0] == 0.0


def test_quasi_static_departure_is_the_even_part_for_any_angular_velocity():
    """Spin change and tilt together (random ω about a random axis): the closed form
    max(|Ω² − Ω_ref²|, ||ω|² − Ω_ref²|, |ω_t|²)/Ω_ref² is the norm of the even part."""
    from quadmodes.runs.centrifugal_load import quasi_static_departure

    rng = np.random.default_rng(7)
    for _ in range(20):
        ref = rng.normal(size=3) * 10.0
        w = ref * (1 + 0.1 * rng.normal()) + rng.normal(size=3) * rng.uniform(0.01, 5.0)
        assert quasi_static_departure(w, ref)[0] == pytest.approx(_even_part_norm(w, ref), rel=1e-10)


@pytest.mark.parametrize("axial,transverse", [(0.0175, 1.0), (2.0, 1.0), (1.0, 0.95)])
def test_nutation_ratio_of_an_axisymmetric_body(axial, transverse):
    """ν = |I_a − I_t| / I_t (torque-free, body frame), whatever the frame J0 is given in; about
    the intermediate axis the tilt grows: NaN."""
    from quadmodes.runs.centrifugal_load import NUTATION_RATIO, nutation_ratio, tilt_turns

    rot = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))[0]
    body = SimpleNamespace(reference_omega=rot @ (5.0 * E1),
                           J0=rot @ np.diag([axial, transverse, transverse]) @ rot.T)  # fmt: skip
    nu = abs(axial - transverse) / transverse
    assert nutation_ratio(body) == pytest.approx(nu, rel=1e-10)
    assert tilt_turns(body) == (nu >= NUTATION_RATIO)
    middle = SimpleNamespace(reference_omega=5.0 * E1, J0=np.diag([2.0, 1.0, 3.0]))
    assert math.isnan(nutation_ratio(middle)) and not tilt_turns(middle)


def test_spin_range_ends_on_the_limit():
    lo, hi = spin_range(100.0)
    d = centrifugal_departure(np.array([lo * E1, hi * E1]), 100.0 * E1)
    assert d == pytest.approx([CENTRIFUGAL_LIMIT, CENTRIFUGAL_LIMIT], rel=1e-12)


def test_valid_flag_flips_where_the_spin_leaves_the_range():
    """A body about a model expanded at Ω_ref whose spin falls by 0, 0.5, …, 2.5 %: valid up
    to the sample past Ω_ref √(1 − 2 %) (0.99 Ω_ref), where the path leaves the range."""
    base = rigid_system()
    omega_ref = 50.0
    sys = dataclasses.replace(base, reference_omega=omega_ref * E1)  # as if expanded there
    fall = np.array([0.0, 0.005, 0.0099, 0.0101, 0.02, 0.025])
    y = np.array([rsys.pack_state(sys, omega=(1 - f) * omega_ref * E1) for f in fall])
    t = 0.1 * np.arange(len(fall))
    sol = SimpleNamespace(t=t, y=y)
    diag = SimpleNamespace(spin_rate=(1 - fall) * omega_ref, cone_angle=np.zeros(len(t)))
    setup = SimpleNamespace(system=sys)
    inside = path_validity(setup, SimpleNamespace(t=t[:3], y=y[:3]), diag)
    assert inside.valid and inside.left_at is None and inside.checked[0] == "centrifugal load"
    out = path_validity(setup, sol, diag)
    assert not out.valid and out.left_at == pytest.approx(0.3)
    assert out.left_spin == pytest.approx(0.9899 * omega_ref)
    assert "centrifugal load" in out.message() and "0.3 s" in out.message()
    assert out.centrifugal_max == pytest.approx(1 - 0.975**2)


def test_run_writes_the_path_and_its_event(workdir):  # noqa: F811
    """`quadmodes run --until "time …"`: the event in the summary and results.nc (with units),
    the path's checks, the times to cone angles; a bad event is one line and exit 2."""
    (workdir / "r.toml").write_text(run_toml(duration='"0.05 s"'), encoding="utf-8")
    out_dir = workdir / "out"
    got = CliRunner().invoke(app, ["run", str(workdir / "r.toml"), "-o", str(out_dir), "--json",
                                   "--no-plots", "--until", "time 0.0123 s"])  # fmt: skip
    assert got.exit_code == 0, got.output
    summary = res.json.loads(got.stdout)["small-run"]
    assert summary["until"]["reached"] and summary["until"]["time_s"] == pytest.approx(0.0123)
    assert summary["t_end_s"] == pytest.approx(0.013)  # the saved sample after it (5 steps)
    path = summary["path_validity"]
    assert "rotating-frame stiffness" in path["checked"] and "modal amplitudes" in path["checked"]
    assert summary["valid"] == (summary["valid_at_start"] and path["valid"])
    ds = res.load_results(out_dir / "small-run" / "results.nc")
    assert ds.attrs["until"] == "time 0.0123 s" and ds.attrs["until_time_units"] == "s"
    assert ds["time_to_cone"].attrs["units"] == "s" and ds["cone_mark"].attrs["units"] == "degree"
    assert ds["modal_amplitude"].attrs["units"] == "m" and "long_name" in ds["model_in_range"].attrs
    bad = CliRunner().invoke(app, ["run", str(workdir / "r.toml"), "-o", str(out_dir / "b"),
                                   "--until", "cone 100 deg"])  # fmt: skip
    assert bad.exit_code == 2 and "integration.until" in bad.output
    assert len([line for line in bad.output.splitlines() if line.strip()]) == 1


def test_rotating_frequencies_of_uncoupled_modes_are_their_own():
    """Modes with no rotation coupling (J2 = D = 0): the rotating-frame frequencies are √Λ/2π
    at any angular velocity."""
    from test_integrators import hand_model

    from quadmodes.runs.spin_check import frequency_difference, rotating_frequencies

    sys = rsys.reduced_system(hand_model(np.diag([1.0, 2.0, 3.0]), lam=[4.0, 9.0, 100.0]), "Q")
    got = rotating_frequencies(sys, np.array([3.0, 0.1, 0.0]))
    assert got == pytest.approx(np.array([2.0, 3.0, 10.0]) / (2 * math.pi), rel=1e-12)
    assert frequency_difference(got, got) == 0.0
    assert frequency_difference(1.01 * got, got) == pytest.approx(0.01)


@pytest.mark.parametrize("eps", [0.004, 0.05])
def test_measured_range_replaces_the_bound(monkeypatch, eps):
    """Past the a-priori bound, the range is what the rebuilt model measures: the whole path when
    its frequencies agree within 1 % at the largest departure, else δ_ext × 1 % / ε."""
    from quadmodes.runs import path_validity as pv
    from quadmodes.runs import spin_check

    base = rigid_system()
    sys = dataclasses.replace(base, reference_omega=50.0 * E1)
    fall = np.linspace(0.0, 0.08, 9)
    y = np.array([rsys.pack_state(sys, omega=(1 - f) * 50.0 * E1) for f in fall])
    t = np.arange(len(fall), dtype=float)
    sol, setup = SimpleNamespace(t=t, y=y), SimpleNamespace(system=sys)
    diag = SimpleNamespace(spin_rate=(1 - fall) * 50.0, cone_angle=np.zeros(len(t)))
    monkeypatch.setattr(spin_check, "measured_error", lambda s, w: (float(w @ E1), eps))
    monkeypatch.setattr(spin_check, "sink_error", lambda s, w, c: 0.0)  # the frequencies decide
    bound = path_validity(setup, sol, diag)
    assert bound.left_at == 2.0  # a 1 % spin fall is δ = 1.99 % ≤ 2 %, 2 % is past it
    out = pv.with_measured_range(bound, setup, sol, diag)
    d_ext = 1 - 0.92**2
    assert out.measured_spin == pytest.approx(0.92 * 50.0) and out.measured_error == eps
    if eps <= pv.FREQUENCY_TOLERANCE:
        assert out.left_at is None and out.centrifugal_limit == pytest.approx(d_ext)
    else:
        limit = d_ext * pv.FREQUENCY_TOLERANCE / eps
        assert out.centrifugal_limit == pytest.approx(limit)
        k = int(np.argmax(1 - (1 - fall) ** 2 > limit))
        assert out.left_at == t[k] and "measured" in out.left_reason


def _falling_spin(fall_end: float, n: int = 41):
    """A rigid path about 50 rad/s along E1 whose spin falls linearly by ``fall_end`` (fraction)."""
    sys = dataclasses.replace(rigid_system(), reference_omega=50.0 * E1)
    fall = np.linspace(0.0, fall_end, n)
    y = np.array([rsys.pack_state(sys, omega=(1 - f) * 50.0 * E1) for f in fall])
    t = np.arange(n, dtype=float)
    diag = SimpleNamespace(spin_rate=(1 - fall) * 50.0, cone_angle=np.full(n, 0.2))
    return SimpleNamespace(system=sys), SimpleNamespace(t=t, y=y), diag, fall


def test_coning_rate_flags_a_spin_departure_the_frequencies_pass(monkeypatch):
    """A path whose spin falls by 5 %: the rebuilt model's frequencies agree within 0.1 %
    (passes), its energy-sink coning rate moves by 1.1 × the spin's relative change (the
    sensitivity measured on paper-41hz-coarse). The path leaves its range where that reaches
    2 %: a spin fall of 2 / 1.1 %, in Ω² 1 − (1 − 0.02/1.1)², located by the second measurement
    (interpolated between the two measured spins in δ ∝ Ω², to the curvature of Ω² over that
    interval: 1e-3). Without the coning rate (not measurable) the frequencies pass it."""
    from quadmodes.runs import path_validity as pv
    from quadmodes.runs import spin_check

    setup, sol, diag, fall = _falling_spin(0.05)
    spins = []
    monkeypatch.setattr(spin_check, "measured_error", lambda s, w: (float(w @ E1), 1e-3))

    def sink(s, w, cone):
        spins.append(float(np.linalg.norm(w)))
        return 1.1 * abs(1.0 - float(np.linalg.norm(w)) / 50.0)

    monkeypatch.setattr(spin_check, "sink_error", sink)
    bound = path_validity(setup, sol, diag)
    out = pv.with_measured_range(bound, setup, sol, diag)
    assert len(spins) == 2 and spins[0] == pytest.approx(0.95 * 50.0)  # two rebuilt models
    expect = 1.0 - (1.0 - 0.02 / 1.1) ** 2
    assert out.centrifugal_limit == pytest.approx(expect, rel=1e-3)
    k = int(np.argmax(1 - (1 - fall) ** 2 > expect))
    assert out.left_at == sol.t[k] and "coning rate" in out.left_reason and not out.valid
    assert out.measured_error == 1e-3  # the second spin: the first sample past the prediction
    assert out.measured_sink_error == pytest.approx(spin_check.SINK_TOLERANCE, rel=0.05)
    monkeypatch.setattr(spin_check, "sink_error", lambda s, w, c: math.nan)
    freq_only = pv.with_measured_range(bound, setup, sol, diag)
    assert freq_only.left_at is None and math.isnan(freq_only.measured_sink_error)


def test_a_path_within_the_bound_is_not_measured(monkeypatch):
    """A spin falling by 0.5 % (δ ≤ 1 %, inside the a-priori 2 %): no model is rebuilt and the
    centrifugal check passes (a spin-family member's departure is at most 0.41 %)."""
    from quadmodes.runs import path_validity as pv
    from quadmodes.runs import spin_check

    def never(*_):
        raise AssertionError("no rebuilt model inside the a-priori bound")

    monkeypatch.setattr(spin_check, "measured_error", never)
    monkeypatch.setattr(spin_check, "sink_error", never)
    setup, sol, diag, _ = _falling_spin(0.005)
    out = pv.with_measured_range(path_validity(setup, sol, diag), setup, sol, diag)
    assert out.left_at is None and math.isnan(out.measured_sink_error)


def test_api_simulate_until(workdir):  # noqa: F811
    """qm.simulate(..., until=...): the event and the path on the result; the run case records
    it (integration.until in its TOML, so results.nc replays it)."""
    import quadmodes as qm

    (workdir / "r.toml").write_text(run_toml(duration='"0.05 s"'), encoding="utf-8")
    result = qm.simulate(str(workdir / "r.toml"), until="time 0.0071 s", check_deformation=False)
    assert result.complete and result.event.time == pytest.approx(0.0071)
    assert result.event.step == 36 and result.solution.t[-1] == pytest.approx(0.008)
    assert 'until = "time 0.0071 s"' in result.run.to_toml()
    assert result.path is not None and result.path.unchecked == ("modal amplitudes",)
    assert not result.path.valid  # amplitudes not checked against the FE model: not valid


def _nutating(j0, beta_deg: float, omega_ref: float = 1.0, samples: int = 9):
    """A body whose angular velocity keeps its spin Ω_ref about e = e1 and is tilted by β, its
    transverse part turning (as a free flat disc's in its body frame): (setup, solution, diag)."""
    sys = dataclasses.replace(rigid_system(), reference_omega=omega_ref * E1, J0=np.asarray(j0))
    phase = np.linspace(0.0, 2 * math.pi, samples)
    tb = math.tan(math.radians(beta_deg)) * omega_ref
    w = np.c_[np.full(samples, omega_ref), tb * np.cos(phase), tb * np.sin(phase)]
    y = np.array([rsys.pack_state(sys, omega=wk) for wk in w])
    t = np.arange(samples, dtype=float)
    diag = SimpleNamespace(spin_rate=np.linalg.norm(w, axis=1), cone_angle=np.zeros(samples))
    return SimpleNamespace(system=sys), SimpleNamespace(t=t, y=y), diag


PLANAR = np.diag([2.0, 1.0, 1.0])  # a lamina normal to e1: I_axis = I_1 + I_2
TALL = np.diag([2.0, 1.2, 1.2])  # the same with height along e1 (Σ m x₁² = 0.2), ν = 0.67
ROUND = np.diag([1.0, 0.95, 0.95])  # nearly spherical: its tilt turns slowly (ν = 0.053)


@pytest.mark.parametrize("beta_deg", [1.0, 6.0, 9.92])
def test_planar_departure_is_second_order_in_the_tilt(beta_deg):
    """A planar body with a spin Ω about its normal tilted by β: its in-plane block of C(ω)
    departs by tan²β (the out-of-plane part, (ω·e)(ω_t·r) e on the plane, is a rigid rotation's
    field), against the sine of the whole departure."""
    from quadmodes.runs.path_validity import is_planar, load_departure

    setup, sol, _ = _nutating(PLANAR, beta_deg)
    w = rsys.split_state(setup.system, sol.y)[1]
    tb = math.tan(math.radians(beta_deg))
    assert is_planar(setup.system)
    np.testing.assert_allclose(load_departure(setup.system, w), tb**2, rtol=1e-12)
    tall = dataclasses.replace(setup.system, J0=TALL)
    assert not is_planar(tall)  # its tilt turns: the quasi-static part, tan²β as well
    np.testing.assert_allclose(load_departure(tall, w), tb**2, rtol=1e-12)
    round_ = dataclasses.replace(setup.system, J0=ROUND)  # its tilt stands nearly still
    assert load_departure(round_, w)[0] > math.sin(math.radians(beta_deg))


def test_a_planar_body_is_not_out_of_range_by_its_rigid_tilt(monkeypatch):
    """The free disc's 5° cone (β = 9.92°): a 3° cone (β ≈ 6°, tan²β = 1.1 %) is inside the a-priori
    bound for a planar body and for a body with height whose tilt turns in the body (its
    quasi-static part, tan²β), outside for a nearly round one (sin β = 10 %); at 5° the
    planar body's δ = tan²β = 3.06 % is measured against the model rebuilt about |ω| (the spin
    of the largest in-plane departure), which decides; a body with height stays out at t = 0
    (its tilt's second-order part, 3.06 % > 2 %, is judged a priori), and so does the planar
    body when the rebuilt model disagrees."""
    from quadmodes.runs import path_validity as pv
    from quadmodes.runs import spin_check

    setup, sol, diag = _nutating(PLANAR, 6.0)
    assert path_validity(setup, sol, diag).left_at is None
    tall = SimpleNamespace(system=dataclasses.replace(setup.system, J0=TALL))
    assert path_validity(tall, sol, diag).left_at is None
    round_ = SimpleNamespace(system=dataclasses.replace(setup.system, J0=ROUND))
    out = path_validity(round_, sol, diag)
    assert out.left_at == 0.0 and "in the body's plane" not in out.left_reason

    setup, sol, diag = _nutating(PLANAR, 9.92)
    monkeypatch.setattr(spin_check, "sink_error", lambda s, w, c: 0.0)  # the frequencies decide
    bound = path_validity(setup, sol, diag)
    assert bound.left_at == 0.0 and "in the body's plane" in bound.left_reason
    monkeypatch.setattr(spin_check, "measured_error", lambda s, w: (float(np.linalg.norm(w)), 1e-9))
    measured = pv.with_measured_range(bound, setup, sol, diag)
    assert measured.left_at is None and measured.valid
    assert measured.measured_spin == pytest.approx(1.0 / math.cos(math.radians(9.92)))
    monkeypatch.setattr(spin_check, "measured_error", lambda s, w: (float(np.linalg.norm(w)), 0.05))
    assert pv.with_measured_range(bound, setup, sol, diag).left_at == 0.0  # the model disagrees
    tall = SimpleNamespace(system=dataclasses.replace(setup.system, J0=TALL))
    monkeypatch.setattr(spin_check, "measured_error", lambda s, w: (float(abs(w @ E1)), 0.0))
    still = pv.with_measured_range(path_validity(tall, sol, diag), tall, sol, diag)
    assert still.left_at == 0.0 and "tilted by 9.92 deg" in still.left_reason
    assert "second-order" in still.left_reason


@pytest.fixture(scope="module")
def capsule_models(small_modal_model):
    """The small capsule about 300, 309 and 304.5 rad/s, N = 5."""
    from test_spinning_reference import spinning_model

    return tuple(spinning_model(small_modal_model, 5, f * 300.0) for f in (1.0, 1.03, 1.015))


@pytest.mark.parametrize("spin", [300.0, 309.0])
def test_coning_rate_is_the_energy_sink_estimate(capsule_models, spin):
    """The path check's coning rate is the energy-sink estimate (its relative equilibrium,
    forced response and power) to 1e-9, on the model about 300 rad/s at its own spin and 3 %
    off it; the relative equilibrium is one function (rom.steady_spin) for the runs and the
    analyses, and a steady state of the body-frame equations (residual ≤ 1e-9 of Ω²)."""
    from quadmodes.analysis import reduced_linearisation
    from quadmodes.rom.energy_sink import energy_sink
    from quadmodes.rom.steady_spin import relative_equilibrium
    from quadmodes.runs import spin_check
    from quadmodes.runs.spin_check import coning_rate

    assert spin_check.relative_equilibrium is reduced_linearisation.relative_equilibrium
    model = capsule_models[0]
    sys = rsys.reduced_system(model, "Q")
    e = np.asarray(model.reference_axis, float)
    w0, s_eq, residual = relative_equilibrium(sys, spin, e)
    assert residual <= 1e-9 and np.linalg.norm(w0) == pytest.approx(spin, rel=1e-12)
    want = energy_sink(sys, s_eq, w0, 0.1).growth_rate
    assert want != 0.0
    assert coning_rate(sys, spin, e, 0.1) == pytest.approx(want, rel=1e-9)


def test_a_model_about_the_paths_spin_has_no_coning_rate_error(capsule_models, monkeypatch):
    """sink_error compares the run's model with the model rebuilt about the spin: the model
    about 309 rad/s against itself there is exact (a run that does not depart), the model about
    300 rad/s at 309 rad/s (3 %) is not; at half the departure the error is about half (first
    order in the departure, which the interpolation of spin_limit assumes)."""
    from quadmodes.runs import spin_check

    m300, m309, m304 = capsule_models
    by_spin = {300.0: m300, 309.0: m309, 304.5: m304}
    monkeypatch.setattr(spin_check, "_rebuilt", lambda s, spin: (None, rsys.reduced_system(
        by_spin[round(spin, 6)], "Q")))  # fmt: skip
    e = np.asarray(m300.reference_axis, float)
    own = SimpleNamespace(system=rsys.reduced_system(m309, "Q"))
    assert spin_check.sink_error(own, 309.0 * e, 0.1) == 0.0
    run = SimpleNamespace(system=rsys.reduced_system(m300, "Q"))
    full = spin_check.sink_error(run, 309.0 * e, 0.1)
    half = spin_check.sink_error(run, 304.5 * e, 0.1)
    assert full > 0.0 and math.isfinite(full)
    assert 1.6 <= full / half <= 2.4, (full, half)


def test_a_prolate_path_is_ended_by_its_amplitudes_not_its_tilt(monkeypatch):
    """A prolate body (I_a/I_t = 0.0175, paper-41hz's) coning 6° → 60° about a model at its spin:
    its tilt, tan β = (I_a/I_t) tan θ, turns in the body (ν = 0.98). The whole departure sin β
    passes 2 % at θ = 48.8° (where the check used to end the path); the quasi-static part
    tan²β stays below 9.2e-4, so the path is ended by its modal amplitudes, where they fail
    (the potential's error made 2 % at the amplitude of 55°), located by the bisection."""
    from test_integrators import hand_model

    from quadmodes.runs import path_validity as pv

    ratio, spin = 0.0175, 2 * math.pi * 41.0
    model = hand_model(np.diag([ratio, 1.0, 1.0]), lam=[(2 * math.pi * 4.0) ** 2, (2 * math.pi * 9.0) ** 2])
    sys = dataclasses.replace(rsys.reduced_system(model, "Q"), reference_omega=spin * E1)
    cone = np.radians(np.arange(6.0, 60.01, 0.25))
    tilt, phase = ratio * np.tan(cone), 0.98 * spin * 0.01 * np.arange(len(cone))
    w = spin * np.c_[np.ones(len(cone)), tilt * np.cos(phase), tilt * np.sin(phase)]
    amp = 1e-3 * np.tan(cone)
    y = np.array([rsys.pack_state(sys, omega=wk, s=a * np.array([1.0, 0.5])) for wk, a in zip(w, amp, strict=True)])
    t = 10.0 * np.arange(len(cone))
    sol, setup = SimpleNamespace(t=t, y=y), SimpleNamespace(system=sys)
    diag = SimpleNamespace(spin_rate=np.full(len(t), spin), cone_angle=cone)

    whole = centrifugal_departure(w, spin * E1)
    assert math.degrees(cone[int(np.argmax(whole > CENTRIFUGAL_LIMIT))]) == pytest.approx(48.8, abs=0.3)
    path = path_validity(setup, sol, diag)
    assert path.left_at is None and path.centrifugal_max == pytest.approx((ratio * math.tan(cone[-1])) ** 2)
    assert path.unchecked == ("modal amplitudes",)

    norm = np.linalg.norm([1.0, 0.5])
    fail_at = 1e-3 * math.tan(math.radians(55.0)) * norm

    def error(setup_k, yk, structure):
        a = float(np.linalg.norm(rsys.split_state(setup_k.system, np.asarray(yk))[2]))
        return pv.DEFORMATION_ENERGY_TOLERANCE * a / fail_at, None

    monkeypatch.setattr(pv, "amplitude_error", error)
    monkeypatch.setattr(pv, "is_round_off_state", lambda s, yk: False)
    out = pv.with_amplitude_check(path, setup, sol, diag, structure=object())
    s_norm = amp * norm
    step = (s_norm[-1] - s_norm[0]) / 2**pv.AMPLITUDE_BISECTIONS  # the bisection's resolution
    k = int(np.flatnonzero(t == out.left_at)[0])
    assert fail_at - step <= s_norm[k] and s_norm[k - 1] <= fail_at
    assert "reduced potential" in out.left_reason and not out.valid
    assert all("tilt" not in r and "centrifugal" not in r for _, r in out.failures)
