"""A controlled step between chunks (``integration.step_tolerance``): |H| exact and E + E_d kept
across step changes, the error against a fine fixed-step reference falling with the tolerance,
the step-doubling estimate against the error it estimates, a resume bit for bit, an event
located under a controlled step, and the case's refusal of a controlled non-midpoint run."""

from __future__ import annotations

import numpy as np
import pytest
from test_run import workdir  # noqa: F401  (fixture)

from quadmodes.case import CaseError, RunIntegration
from quadmodes.case.run_loading import run_case_from_toml
from quadmodes.rom import diagnostics as dg
from quadmodes.rom import dynamics as dy
from quadmodes.rom import integrators as it
from quadmodes.rom import step_control as sc
from quadmodes.rom import system as rsys
from quadmodes.rom.reduced import ReducedModel
from quadmodes.runs.events import event_monitor
from quadmodes.runs.step_chunks import integrate_run

SPIN, CONE = 300.0, 8.0  # rad/s, deg: the small capsule spun about its minor axis, coning


@pytest.fixture(scope="module")
def spinner(small_reduced_model):
    sys = rsys.reduced_system(small_reduced_model, "Q")
    w = dy.coning_omega(sys.J0, SPIN, np.radians(CONE))
    y0 = rsys.pack_state(sys, omega=w, s=2e-5 * (-1.0) ** np.arange(sys.n_modes))
    # settle the initial modal transient so that every run starts on the forced response
    sol = it.integrate(sys, y0, (0.0, 0.3), "midpoint", dt=5e-5, save_every=6000)
    return sys, sol.y[-1]


def controlled(tol, dt="1 ms", duration="4 s", until=None):
    return RunIntegration(dt=dt, duration=duration, save_every=4, step_tolerance=tol, until=until)


def test_step_changes_keep_h_to_round_off_and_the_energy_balance(spinner):
    """Chunks at steps 0.1, 0.2, 0.05, 0.3 ms chained: |H| (inertial) to 1e-13, E + E_d to
    1e-9 of E and 1e-3 of the energy dissipated (measured 7e-11 of E: the midpoint's balance is
    exact for the quadratic part at every step; the kinetic terms' O(Δt²) error is bounded)."""
    sys, y = spinner
    hs, ed, t0 = (1e-4, 2e-4, 5e-5, 3e-4), 0.0, 0.0
    h0 = dy.momentum_inertial(sys, y[None, :])[0]
    e0 = dy.energy(sys, y[None, :])[0]
    for h in hs:
        sol = it.integrate(sys, y, (t0, t0 + 0.06), "midpoint", dt=h, save_every=10)
        hh = dy.momentum_inertial(sys, sol.y)
        assert np.abs(hh - h0).max() <= 1e-13 * np.linalg.norm(h0)
        bal = dy.energy(sys, sol.y) + ed + sol.dissipated
        assert np.abs(bal - e0).max() <= 1e-9 * e0
        y, ed, t0 = sol.y[-1], ed + sol.dissipated[-1], t0 + 0.06
        assert np.abs(bal - e0).max() <= 1e-3 * ed  # the balance is not trivially E


@pytest.fixture(scope="module")
def reference(spinner):
    """E_d (J) over 4 s at Δt = 25 µs with its Richardson correction from 50 µs (2e-6 of it)."""
    sys, y = spinner
    fine = it.integrate(sys, y, (0, 4.0), "midpoint", dt=2.5e-5, save_every=10**6)
    half = it.integrate(sys, y, (0, 4.0), "midpoint", dt=5e-5, save_every=10**6)
    return fine.dissipated[-1] + (fine.dissipated[-1] - half.dissipated[-1]) / 3.0


def test_error_falls_with_the_tolerance(spinner, reference):
    """The dissipated energy of controlled runs against the fine reference: the error falls
    with the tolerance (diffrax-style), about the tolerance (measured 0.7–1.0 × it), the
    steps ∝ tol^(-1/2) (second order); |H| to round-off throughout."""
    sys, y = spinner
    errs, steps = [], []
    for tol in (1e-3, 1e-4, 1e-5):
        run = integrate_run(sys, y, controlled(tol), max_chunks=4)
        assert run.reason == "" and run.solution.dt is None
        errs.append(abs(run.solution.dissipated[-1] / reference - 1))
        steps.append(run.solution.stats["n_steps"])
        assert errs[-1] <= 1.5 * tol  # measured 0.73–0.996 × tol
        d = dg.diagnostics(sys, run.solution)
        assert np.abs(d.H_norm / d.H_norm[0] - 1).max() <= 1e-12
    assert errs[0] > 5 * errs[1] > 25 * errs[2]
    assert steps[0] < steps[1] < steps[2]


def test_the_probe_estimates_the_error_of_the_run(spinner, reference):
    """The step-doubling estimate at h is within a factor 2 of the run's actual error of the
    dissipated energy at that fixed step."""
    sys, y = spinner
    for h in (1e-3, 2e-4):
        est = sc.probe(sys, y, h, int(round(4.0 / h)))
        assert est.measure == "dissipated power"
        sol = it.integrate(sys, y, (0, 4.0), "midpoint", dt=h, save_every=10**6)
        actual = abs(sol.dissipated[-1] / reference - 1)
        assert 0.5 * actual <= est.err <= 2.0 * actual


class Keep:
    def __init__(self):
        self.saved = []

    def due(self):
        return True

    def save(self, progress, wall_s):
        self.saved.append(progress)


def test_a_resumed_controlled_run_is_the_uninterrupted_one_bit_for_bit(spinner):
    sys, y = spinner
    settings = controlled(1e-4, duration="8 s")
    keep = Keep()
    first = integrate_run(sys, y, settings, max_chunks=8, checkpoint=keep)
    steps = {g[2] for g in keep.saved[-1].grid}
    assert len(keep.saved) >= 3 and len(steps) >= 2  # the step changed on the way
    again = integrate_run(sys, y, settings, max_chunks=8, resume=(keep.saved[1], 0.0))
    assert np.array_equal(again.solution.t, first.solution.t)
    assert np.array_equal(again.solution.y, first.solution.y)
    assert np.array_equal(again.solution.dissipated, first.solution.dissipated)


def rigid_triaxial():
    """A torque-free rigid body J0 = diag(1, 2, 3) kg m² spun near its minor axis: its cone
    angle about that axis oscillates from 36.9° past 40° (tests/test_run_events.py has its
    Jacobi solution)."""
    z = np.zeros
    model = ReducedModel(
        mass=1.0, free=True, frequencies_hz=z(0), damping_ratio=z(0), labels=(),
        J0=np.diag([1.0, 2.0, 3.0]), J1=z((0, 3, 3)), J2u=z((0, 0, 3, 3)), J2g=z((0, 0, 3, 3)),
        c=z((0, 3)), Cuu=z((0, 0, 3)), Cxg=z((0, 0, 3)), S1=z((0, 3)), S2=z((0, 0, 3)),
        mu=z((0, 0)), Lam=z((0, 0)), C=z((0, 0)), X=z((1, 3)), translational=np.ones(1, bool),
        weights=np.ones(1), Phi=z((0, 1, 3)), G=z((0, 0, 1, 3)),
    )  # fmt: skip
    sys = rsys.reduced_system(model, "rigid")
    return sys, rsys.pack_state(sys, omega=np.array([2.0, 0.0, 0.5]))


def test_a_controlled_checkpoint_file_resumes_bit_for_bit(spinner, tmp_path):
    """The controlled step's state (time reached, next step, the chunks' grid) goes through
    the checkpoint file (.npz) exactly."""
    from types import SimpleNamespace

    from quadmodes.runs.run_checkpoint import RunCheckpoint

    sys, y = spinner
    settings = controlled(1e-4, duration="8 s")
    run = SimpleNamespace(to_toml=lambda: "x = 1\n", integration=settings)
    setup = SimpleNamespace(run=run, model=SimpleNamespace(provenance={}),
                            initial=SimpleNamespace(y0=y))  # fmt: skip
    keep = Keep()
    first = integrate_run(sys, y, settings, max_chunks=8, checkpoint=keep)
    ckpt = RunCheckpoint(tmp_path / "c.npz", setup)
    ckpt.save(keep.saved[1], 1.0)
    loaded, wall = ckpt.load()
    assert wall == 1.0 and loaded.grid == keep.saved[1].grid
    assert (loaded.t_done, loaded.h_next) == (keep.saved[1].t_done, keep.saved[1].h_next)
    again = integrate_run(sys, y, settings, max_chunks=8, resume=(loaded, 0.0))
    assert np.array_equal(again.solution.y, first.solution.y)
    assert again.solution.stats["n_probe_steps"] == first.solution.stats["n_probe_steps"]


def test_an_event_under_a_controlled_step_is_located_to_the_step():
    """An undamped body (the probe measures the body state): the time the cone angle reaches
    40°, controlled at 1e-6 from dt = 1 ms, against the fixed 0.1 ms step: within 1e-5 s;
    located to the step (of its chunk), with fewer steps."""
    sys, y = rigid_triaxial()
    axis = np.array([1.0, 0.0, 0.0])
    hits = {}
    for name, settings in (
        ("fixed", RunIntegration(dt="0.1 ms", duration="3 s", save_every=10, until="cone 40 deg")),
        ("controlled", RunIntegration(dt="1 ms", duration="3 s", save_every=10,
                                      step_tolerance=1e-6, until="cone 40 deg")),
    ):  # fmt: skip
        mon = event_monitor(sys, y, "cone 40 deg", axis)
        run = integrate_run(sys, y, settings, max_chunks=20, event=mon)
        assert run.event is not None and run.event.located == "step"
        hits[name] = run.event
    assert hits["controlled"].time == pytest.approx(hits["fixed"].time, abs=1e-5)
    assert hits["controlled"].step < hits["fixed"].step


@pytest.mark.parametrize("method, tol", [("backward-euler", "1e-3"), ("midpoint", "2.0")])
def test_a_controlled_step_needs_the_midpoint_and_a_tolerance_below_1(method, tol):
    text = (f'name = "x"\nkind = "run"\nmodel = "paper-membrane-coarse"\n[initial]\n'
            f'spin_rate = "41 Hz"\n[integration]\nmethod = "{method}"\ndt = "1 ms"\n'
            f'duration = "1 s"\nstep_tolerance = {tol}\n')  # fmt: skip
    with pytest.raises(CaseError, match="step_tolerance") as exc:
        run_case_from_toml(text)
    assert "\n" not in str(exc.value)


def test_quadmodes_run_with_a_controlled_step(workdir):  # noqa: F811
    """A run case with ``step_tolerance``: complete, |H| to round-off, the steps taken and the
    probes' work in the summary and results.nc."""
    import json

    from test_run import run_toml
    from typer.testing import CliRunner

    from quadmodes.cli.app import app
    from quadmodes.runs import results as res

    text = run_toml(duration='"0.5 s"') + "step_tolerance = 1e-3\n"
    (workdir / "c.toml").write_text(text, encoding="utf-8")
    got = CliRunner().invoke(app, ["run", str(workdir / "c.toml"), "-o", str(workdir / "out"),
                                   "--json", "--no-plots"])  # fmt: skip
    assert got.exit_code == 0, got.output
    summary = json.loads(got.stdout)["small-run"]
    assert summary["complete"] and summary["step_tolerance"] == 1e-3
    assert 0 < summary["dt_min_s"] <= summary["dt_max_s"] and summary["probe_steps"] > 0
    assert summary["H_norm_relative_drift"] < 1e-12
    ds = res.load_results(workdir / "out" / "small-run" / "results.nc")
    assert ds.attrs["dt_max_units"] == "s" and ds.attrs["n_probe_steps"] > 0
    page = (workdir / "out" / "small-run" / "report.html").read_text(encoding="utf-8")
    assert "step tolerance" in page and "step taken (ms)" in page
