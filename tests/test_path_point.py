"""The full order from a point of a reduced path (issue 29 item 4, ``compare --at``).

The reconstructed full-order state at a path point must carry the reduced state's angular
momentum and energy (to the model's tolerance) and its modal coordinates, and at t = 0 be the
map that starts every comparison. Coarse paper model at 41 Hz, a path point 0.1 s in (fast)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from quadmodes.analysis import path_point as pp
from quadmodes.analysis.comparison_run import prepare_comparison
from quadmodes.case import CaseError, load_run_case
from quadmodes.fe.model import strain_energy
from quadmodes.fullorder import kinematics as kin
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import system as rsys


@pytest.fixture(scope="module")
def start():
    """(run cut to 0.1 s, its full-order setup at t = 0, the path point at 0.1 s)."""
    run, setup0 = prepare_comparison(load_run_case("paper-41hz-coarse"), 0.1)
    return run, setup0, pp.path_point(run, "time 0.1 s", model=setup0.model)


def _full(setup, x, v):
    """(H inertial (3,), T + Π (J), modal coordinates (N,), T (J)) of a full-order state."""
    m = setup.model
    body = kin.make_body(setup.structure.mass_scalar, setup.structure.translational, m.X, m, False)
    smp = kin.sample(body, x, v, None, None)
    return smp.H, smp.T + strain_energy(setup.structure, x), smp.s, smp.T


def test_point_is_on_the_step_grid_and_on_the_path(start):
    run, setup0, point = start
    assert point.step == 200 and point.time == pytest.approx(0.1, abs=1e-12)
    # the same state as the reduced run saved at t = 0.1 s (same steps, same Newton tolerance)
    from quadmodes.runs import simulate

    res = simulate.simulate(run, model=setup0.model)
    k = int(np.argmin(np.abs(res.solution.t - 0.1)))
    assert np.max(np.abs(res.solution.y[k] - point.y)) <= 1e-9 * np.max(np.abs(point.y))
    assert point.dissipated == pytest.approx(res.diagnostics.E_d[k], rel=1e-6)


def test_full_state_carries_momentum_energy_and_modal_coordinates(start):
    _, setup0, point = start
    setup = pp.full_order_setup_at(setup0, point)
    sys = rsys.reduced_system(setup.model, "Q")
    n = setup.model.n_modes
    h_f, e_f, s_f, _ = _full(setup, setup.x0, setup.v0)
    h_r = dyn.momentum_inertial(sys, point.y[None])[0]
    # |H|: the reduced model's to the stretch outside the retained modes (5e-5 at t = 0 too)
    assert np.linalg.norm(h_f - h_r) <= 1e-4 * np.linalg.norm(h_r)
    # the modal coordinates of the full state (M-projection, quadratic modes) are the point's
    assert np.max(np.abs(s_f - point.y[7 : 7 + n])) <= 1e-6 * np.max(np.abs(point.y[7 : 7 + n]))
    # energy: the change from t = 0 is the reduced path's (−E_d) to 1e-6 of the kinetic energy
    # (the reduced potential against the FE energy of the relaxed state: 2 % of the change)
    _, e0, _, t0 = _full(setup0, setup0.x0, setup0.v0)
    e_r = dyn.energy(sys, point.y[None])[0] - dyn.energy(sys, _y0(setup0)[None])[0]
    assert e_r == pytest.approx(-point.dissipated, rel=1e-6)
    assert abs((e_f - e0) - e_r) <= min(1e-6 * t0, 0.05 * abs(e_r))


def _y0(setup0):
    from quadmodes.runs import simulate

    return simulate.prepare(setup0.run, setup0.model).initial.y0


def test_at_t0_the_map_is_the_initial_mapping(start):
    _, setup0, point = start
    y0 = _y0(setup0)
    at0 = pp.PathPoint("t = 0", "time", 0.0, 0, y0, 0.0, 0.0, 0.0, "test")
    setup = pp.full_order_setup_at(setup0, at0)
    assert np.array_equal(setup.x0, setup0.x0) and np.array_equal(setup.v0, setup0.v0)


def test_unreached_point_and_adaptive_method_are_refused(start):
    run, setup0, _ = start
    sys = rsys.reduced_system(setup0.model, "Q")
    y = np.vstack([_y0(setup0)] * 2)
    with pytest.raises(ValueError, match="does not reach 'cone 30 deg'"):
        pp.point_on_samples(sys, run.integration, "cone 30 deg", np.array([0.0, 0.05]), y,
                            np.zeros(2), np.array([0.0, 0.0, 1.0]), "test")  # fmt: skip
    adaptive = run.integration.model_copy(update={"method": "adaptive"})
    with pytest.raises(CaseError, match="--at: a path point needs a fixed-step method"):
        pp.path_point(run.model_copy(update={"integration": adaptive}), "time 0.01 s",
                      model=setup0.model)  # fmt: skip


def test_point_read_from_results_is_the_integrated_one(start, tmp_path):
    """A results.nc of the run (samples every 7 steps) gives the same state at the same step
    as the run integrated to the point (the sample before, stepped forward)."""
    from quadmodes.runs import results, simulate

    run, setup0, point = start
    every = run.integration.model_copy(update={"save_every": 7, "duration": 0.2})
    res = simulate.simulate(run.model_copy(update={"integration": every}), model=setup0.model)
    path = results.write_dataset(results.to_dataset(res), tmp_path / "results.nc")
    read = pp.path_point(run, "time 0.1 s", model=setup0.model, results=path)
    assert read.step == point.step and read.source == str(path)
    assert np.max(np.abs(read.y - point.y)) <= 1e-9 * np.max(np.abs(point.y))
    assert read.dissipated == pytest.approx(point.dissipated, rel=1e-6)
    other = run.integration.model_copy(update={"dt": 2.5e-4})
    with pytest.raises(CaseError, match="--results: .* another time step"):
        pp.path_point(run.model_copy(update={"integration": other}), "time 0.1 s",
                      model=setup0.model, results=path)  # fmt: skip


@pytest.mark.parametrize(
    "args, field",
    [
        (["--at", "cone"], "--at"),
        (["--at", "bend 3 deg"], "--at"),
        (["--results", "results.nc"], "--results"),
        (["--at", "cone 10 deg", "--results", "nowhere.nc"], "--results"),
    ],
)
def test_compare_at_bad_input_is_one_line(tmp_path, args, field):
    from typer.testing import CliRunner

    from quadmodes.cli.app import app

    out = tmp_path / "cmp"
    result = CliRunner().invoke(app, ["compare", "paper-41hz-coarse", *args, "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert field in result.output and len(result.output.strip().splitlines()) == 1
    assert not out.exists()


def test_api_compare_at_starts_both_sides_at_the_point():
    """qm.compare(..., at=...): the reduced and full-order series start at the point (4 steps
    of full order)."""
    import quadmodes as qm

    c = qm.compare("paper-41hz-coarse", "2 ms", formulations=["Q"], at="time 0.05 s")
    assert c.start["step"] == 100 and c.start["at"] == "time 0.05 s"
    assert c.notes[0].startswith("started from the reduced path at time 0.05 s")
    q, full = c.reduced["Q"], c.full
    assert q.t[0] == 0.0 and q.E_d[0] == 0.0 and full.E_d[0] == 0.0
    # the same modal amplitude at the start (the full order's projection of its mapped state)
    assert full.amplitude[0] == pytest.approx(q.amplitude[0], rel=1e-6)
    assert math.degrees(q.cone_angle[0]) == pytest.approx(c.start["cone_angle_deg"], rel=1e-9)
    assert full.cone_angle[0] == pytest.approx(q.cone_angle[0], rel=2e-3)
