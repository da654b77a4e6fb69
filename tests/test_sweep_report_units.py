"""The sweep report's per-point table shows angular rates in the unit the user chose
(``sweep --units``), other quantities in the files' units; the files stay SI."""

import math

import numpy as np
import xarray as xr

from quadmodes.io.display_units import frequency_unit
from quadmodes.sweeps.report import _point_table


def _dataset() -> xr.Dataset:
    swept = {"units": "rad/s", "long_name": "initial.spin_rate (swept)"}
    dim = "initial_spin_rate"
    return xr.Dataset(
        {"spin_rate_change": (dim, [2 * math.pi, -math.pi], {"units": "rad/s", "long_name": "spin change"}),
         "coning_power": (dim, [1.5, 2.5], {"units": "W", "long_name": "power"}),
         "cone_growth_rate": (dim, [math.pi / 180, 0.0], {"units": "rad/s", "long_name": "cone growth"})},
        coords={dim: (dim, 2 * math.pi * np.array([20.0, 41.0]), swept)},
    )  # fmt: skip


def test_rates_follow_the_chosen_unit_and_power_keeps_its_own():
    hz = _point_table(_dataset(), frequency_unit("Hz"))
    # 2π·20 rad/s = 20 Hz; a spin change of 2π rad/s = 1 Hz; the power is not a rate
    assert "initial.spin_rate (swept) [Hz]" in hz and "spin change [Hz]" in hz and "power [W]" in hz
    # a cone angle's rate is no frequency: deg/s whatever the unit (π/180 rad/s = 1 deg/s)
    assert "cone growth [deg/s]" in hz
    assert '<td class="num">20</td><td class="num">1</td><td class="num">1.5</td><td class="num">1</td>' in hz
    rpm = _point_table(_dataset(), frequency_unit("rpm"))  # 1 Hz = 60 rpm
    assert '<td class="num">2460</td><td class="num">-30</td><td class="num">2.5</td><td class="num">0</td>' in rpm
