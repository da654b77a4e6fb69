"""Long-window scores of ``quadmodes compare`` (runs.secular) on synthetic series.

The slope tolerance is derived here, not taken from the code: a least-squares line over an
interval of length L centred at t_m has slope b = (12/L³) ∫ τ y(t_m + τ) dτ (continuous limit,
τ ∈ [−L/2, L/2]). For y = A sin(ω(t_m + τ) + φ) only the odd part A cos(ωt_m + φ) sin(ωτ)
contributes, and ∫ τ sin(ωτ) dτ = −L cos(ωL/2)/ω + 2 sin(ωL/2)/ω², so the slope is off by at most
12 A/(ω L²) (1 + 2/(ωL)). The sampled sum differs from the integral by O(Δt²) relative, which
the test covers with a 1 % margin.
"""

from __future__ import annotations

import math
import types

import numpy as np
import pytest

from quadmodes.case.units import ureg
from quadmodes.runs import secular as sc


def _bound(A: float, omega: float, L: float) -> float:
    """12 A/(ω L²)(1 + 2/(ωL)): derived in the module docstring."""
    return 12 * A / (omega * L**2) * (1 + 2 / (omega * L))


def _series(t, cone, e_d, spin):
    return types.SimpleNamespace(t=t, cone_angle=cone, E_d=e_d, spin_rate=spin)


T_END, DT = 4.0, 2.5e-4
T = np.arange(0.0, T_END + DT / 2, DT)
INTERVAL = sc.QuasiSteady(2.0, 4.0, 0.25, sc.K_DECAY, False)


@pytest.mark.parametrize("f_hz", [40.3, 31.0, 3.7])
@pytest.mark.parametrize("phi", np.linspace(0.0, 2 * np.pi, 7, endpoint=False))
def test_trend_plus_sinusoid_recovers_the_slope(f_hz, phi):
    slope, A, omega = 3.0e-4, 2.0e-3, 2 * np.pi * f_hz  # A ≫ slope·L: the oscillation dominates
    y = 0.1 + slope * T + A * np.sin(omega * T + phi)
    fit = sc.fit_line(T, y, 2.0, 4.0)
    err = abs(fit.slope - slope)
    assert err <= 1.01 * _bound(A, omega, 2.0)
    assert fit.se >= err  # the reported standard error covers the oscillation's bias
    assert fit.residual_hz == pytest.approx(f_hz, abs=0.5)  # periodogram resolution 1/L


def test_exact_line_and_noise():
    fit = sc.fit_line(T, 1.5 - 0.7 * T, 2.0, 4.0)
    assert fit.slope == pytest.approx(-0.7, rel=1e-12) and fit.se < 1e-12
    # white noise of rms σ: the least-squares slope has standard deviation σ √(12/n) / L
    rng = np.random.default_rng(3)
    sigma = 1e-3
    errs = [sc.fit_line(T, 2e-3 * T + sigma * rng.standard_normal(len(T)), 2.0, 4.0).slope - 2e-3
            for _ in range(40)]  # fmt: skip
    sd = sigma * math.sqrt(12 / 8001) / 2.0
    assert np.std(errs) == pytest.approx(sd, rel=0.35)  # 40 draws: ±~11 % (1σ) on a std


def test_ratio_of_slopes():
    a, b = 2.2e-4, 1.0e-4  # rad/s
    osc = 1e-5 * np.sin(2 * np.pi * 40.0 * T)

    def model(k):
        return _series(T, 0.1 + k * T + osc, 0.05 * k / b * T + osc, 257.0 - 3 * k / b * T)

    s = sc.score(model(b), {"R": model(a)}, INTERVAL)
    r = s.ratios["R"]
    # the same oscillation in both: each slope off by at most the bound, ratio to first order
    db = _bound(1e-5, 2 * np.pi * 40.0, 2.0)
    assert r["cone_growth_ratio"] == pytest.approx(a / b, abs=1.01 * (1 + a / b) * db / b)
    assert r["dissipated_power_ratio"] == pytest.approx(a / b, rel=1e-3)
    assert r["spin_rate_change_ratio"] == pytest.approx(a / b, rel=1e-9)  # exact lines
    row = s.row("R")
    assert row["cone_growth_deg_per_s"] == pytest.approx(math.degrees(a), rel=0.05)
    assert row["spin_rate_change_rad_per_s"] == pytest.approx(-3 * a / b * 2.0, rel=1e-9)
    assert s.notes == ()


def test_quasi_steady_start_follows_the_rule():
    Tw = 4.0
    k = math.log(100.0)
    tau = sc.decay_time([31.0, 38.0], 0.02)
    assert tau == pytest.approx(1 / (0.02 * 2 * np.pi * 31.0), rel=1e-12)
    # slowest decay, not lowest frequency: a lightly damped higher mode sets τ
    assert sc.decay_time([31.0, 38.0], [0.02, 0.001]) == pytest.approx(1 / (0.001 * 2 * np.pi * 38))
    assert sc.decay_time([31.0], 0.0) == math.inf
    strong = sc.quasi_steady_interval(Tw, 0.1)  # kτ = 0.46 s < T/2
    assert (strong.start_s, strong.end_s, strong.capped) == (2.0, 4.0, False)
    middle = sc.quasi_steady_interval(Tw, 2.5 / k)  # kτ = 2.5 s between T/2 and 3T/4
    assert middle.start_s == pytest.approx(2.5) and not middle.capped
    weak = sc.quasi_steady_interval(Tw, 1.0)  # kτ = 4.6 s > 3T/4: at least T/4 remains
    assert weak.start_s == pytest.approx(3.0) and weak.capped
    assert sc.quasi_steady_interval(Tw, math.inf).start_s == pytest.approx(3.0)
    assert sc.quasi_steady_interval(Tw, tau).start_s == 2.0  # the seed's 2 % on 31 Hz


def test_flat_reference_gives_a_null_ratio_with_a_note():
    rng = np.random.default_rng(5)
    flat = _series(T, 0.1 + 1e-4 * np.sin(2 * np.pi * 40 * T) + 1e-6 * rng.standard_normal(len(T)),
                   0.02 * T, np.full_like(T, 257.0))  # fmt: skip
    rom = _series(T, 0.1 + 1e-4 * T, 0.03 * T, 257.0 - 0.1 * T)
    s = sc.score(flat, {"Q": rom}, INTERVAL)
    assert math.isnan(s.ratios["Q"]["cone_growth_ratio"])
    assert math.isnan(s.ratios["Q"]["spin_rate_change_ratio"])  # exactly flat: slope 0
    assert s.ratios["Q"]["dissipated_power_ratio"] == pytest.approx(1.5, rel=1e-9)
    notes = " ".join(s.notes)
    assert "cone_growth_ratio" in notes and "not distinguishable from 0" in notes
    assert "spin_rate_change_ratio" in notes and "dissipated_power_ratio" not in notes


def test_a_series_that_stops_early_has_no_fit():
    short = _series(T[T < 2.5], *(np.ones((3, int(np.sum(T < 2.5))))))
    full = _series(T, 0.1 + 1e-4 * T, 0.02 * T, 257.0 - 0.1 * T)
    s = sc.score(full, {"Q": short}, INTERVAL)
    assert all(math.isnan(v) for v in s.ratios["Q"].values())
    assert any("Q" in n and "no fit" in n for n in s.notes)


def test_dataset_variables_carry_units_and_long_names():
    full = _series(T, 0.1 + 1e-4 * T, 0.02 * T, 257.0 - 0.1 * T)
    s = sc.score(full, {"Q": full}, INTERVAL)
    data = sc.dataset_variables(s, ["full", "Q"], ["Q"])
    assert {"cone_growth", "dissipated_power", "spin_rate_slope", "spin_rate_change",
            "cone_growth_ratio", "dissipated_power_ratio", "spin_rate_change_ratio",
            "quasi_steady_start", "quasi_steady_end"} <= set(data)  # fmt: skip
    for name, var in data.items():
        ureg.Unit(var.attrs["units"])  # raises if pint cannot parse it
        assert var.attrs["long_name"], name
    q = ureg.Quantity(float(data["cone_growth"].values[0]), data["cone_growth"].attrs["units"])
    assert q.to("rad/s").magnitude == pytest.approx(1e-4, rel=1e-9)
    assert float(data["dissipated_power"].values[1]) == pytest.approx(0.02, rel=1e-9)
