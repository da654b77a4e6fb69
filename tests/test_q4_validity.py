"""Validity of the Q4 formulation: the truncated quartic potential has a lowest barrier, and a
run that starts with more modal energy than that is reported as outside Q4's validity."""

import numpy as np
import pytest

from quadmodes.case import load_run_case
from quadmodes.rom import dynamics as dyn
from quadmodes.runs import simulate


def _setup(name, formulation="Q4"):
    return simulate.prepare(simulate.apply_overrides(load_run_case(name), formulation=formulation))


@pytest.fixture(scope="module")
def slow_q4():
    return _setup("paper-0.5hz-large")  # 0.5 in of bending


def test_barrier_is_a_maximum_along_its_ray(slow_q4):
    sys = slow_q4.system
    v_b, s_b = dyn.potential_barrier(sys)
    assert 0.0 < v_b < np.inf
    # the effective potential at the reference spin (0.5 Hz: nearly V itself)
    v = lambda s: float(dyn.effective_potential(sys, s))  # noqa: E731
    assert v(s_b) == pytest.approx(v_b, rel=1e-10)
    # first maximum along the ray: below it V rises, beyond it V falls
    assert v(0.98 * s_b) < v_b and v(1.02 * s_b) < v_b
    slope = (v(1.0001 * s_b) - v(0.9999 * s_b)) / 2e-4  # d V(r s_b)/dr at r = 1
    assert slope == pytest.approx(0.0, abs=1e-6 * v_b)
    # Q (quadratic potential) has no barrier
    assert dyn.potential_barrier(_setup("paper-0.5hz", "Q").system)[0] == np.inf


def test_initial_bending_beyond_the_barrier_is_reported(slow_q4):
    # paper-0.5hz-large's 0.5 in of bending lies beyond the maximum of Q4's potential along its own
    # direction (its modal energy is even negative there: the truncated quartic falls)
    val = slow_q4.validity
    assert val.modal_energy < val.barrier_energy and val.past_maximum_on_ray
    assert val.beyond_barrier and not val.valid
    assert "barrier" in val.message() and "use Q" in val.message()
    assert val.as_dict()["valid"] is False


def test_small_bending_is_within_q4_validity():
    run = load_run_case("paper-0.5hz-large")
    small = run.model_copy(update={"initial": run.initial.model_copy(
        update={"bending_amplitude": 0.1 * run.initial.bending_amplitude})})  # fmt: skip
    val = simulate.prepare(simulate.apply_overrides(small, formulation="Q4")).validity
    assert 0.0 < val.modal_energy < val.barrier_energy and not val.past_maximum_on_ray
    assert not val.beyond_barrier


def test_spinning_case_from_rest_is_within_q4_validity():
    val = _setup("paper-41hz-coarse").validity  # coarse: the default mesh costs minutes here
    assert val.modal_energy == 0.0 and val.valid and val.message() == ""
