"""The spinning spacecraft with booms (built-in hub-booms): the reduced model's rotating-frame
frequencies against the full order's linearisation, and the energy-sink stability rule (a damped
minor-axis spinner cones up, a major-axis spinner does not) in the linearised reduced model."""

from __future__ import annotations

import numpy as np
import pytest

import quadmodes as qm
from quadmodes.analysis.campbell import campbell
from quadmodes.analysis.rotating_comparison import rotating_frequency_comparison
from quadmodes.case import load_case


@pytest.fixture(scope="module")
def model():
    return qm.reduced_model("hub-booms", 8)


def test_hub_booms_principal_axes_are_minor_x_and_major_z(model):
    j = np.diag(model.J0)
    assert j[0] < j[1] < j[2]


@pytest.mark.parametrize("axis", ["minor", "major"])
def test_reduced_rotating_frequencies_match_the_full_order_linearisation(axis):
    table = rotating_frequency_comparison(load_case("hub-booms"), (0.5, 1.0), 8, ("Q",),
                                          axis=axis)  # fmt: skip
    assert len(table.rows) >= 2 * 8
    assert table.max_error("Q", elastic_only=True) < 0.01


def test_damped_minor_axis_spinner_cones_up_and_major_axis_spinner_does_not(model):
    spins = 2 * np.pi * np.array([0.5, 1.0])
    minor = campbell(model, spins, axis=[1.0, 0.0, 0.0], damped=True)
    major = campbell(model, spins, axis=[0.0, 0.0, 1.0], damped=True)
    nut_minor = minor.growth[:, minor.branch("nutation")]
    nut_major = major.growth[:, major.branch("nutation")]
    assert np.all(nut_minor > 0.0)
    assert np.all(nut_major < 0.0)
    # every elastic branch is damped in both
    for c in (minor, major):
        others = [i for i, lab in enumerate(c.labels) if lab != "nutation"]
        assert np.all(c.growth[:, others] < 0.0)
