"""Runs that end on an event (``integration.until``): the event time of a torque-free triaxial
rigid body against its Jacobi elliptic solution, the location to the step against a step-by-step
integration, and the same event after a resume; the parsing of the event text."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipj

from quadmodes.case import RunIntegration
from quadmodes.case.run_events import parse_until
from quadmodes.rom import integrators as it
from quadmodes.rom import system as rsys
from quadmodes.rom.reduced import ReducedModel
from quadmodes.runs.chunked import ChunkProgress, integrate_in_chunks
from quadmodes.runs.events import cone_times, event_monitor

I1, I2, I3 = 1.0, 2.0, 3.0
W0 = np.array([2.0, 0.0, 0.5])  # near the minor axis e1 (H² < 2E I2: it circles e1)


def rigid_system():
    z = np.zeros
    model = ReducedModel(
        mass=1.0, free=True, frequencies_hz=z(0), damping_ratio=z(0), labels=(),
        J0=np.diag([I1, I2, I3]), J1=z((0, 3, 3)), J2u=z((0, 0, 3, 3)), J2g=z((0, 0, 3, 3)),
        c=z((0, 3)), Cuu=z((0, 0, 3)), Cxg=z((0, 0, 3)), S1=z((0, 3)), S2=z((0, 0, 3)),
        mu=z((0, 0)), Lam=z((0, 0)), C=z((0, 0)), X=z((1, 3)), translational=np.ones(1, bool),
        weights=np.ones(1), Phi=z((0, 1, 3)), G=z((0, 0, 1, 3)),
    )  # fmt: skip
    return rsys.reduced_system(model, "rigid")


def omega1_exact(t):
    """ω1(t) of the torque-free body from W0 (ω2(0) = 0; H² < 2E I2, so the polhode circles the
    minor axis): ω1 = a dn(τ, m) (Landau & Lifshitz §37 with axes 1 and 3 exchanged)."""
    e2 = I1 * W0[0] ** 2 + I3 * W0[2] ** 2  # 2E
    h2 = (I1 * W0[0]) ** 2 + (I3 * W0[2]) ** 2
    assert h2 < e2 * I2
    rate = math.sqrt((I2 - I1) * (e2 * I3 - h2) / (I1 * I2 * I3))
    m = (I3 - I2) * (h2 - e2 * I1) / ((I2 - I1) * (e2 * I3 - h2))
    _, _, dn, _ = ellipj(rate * np.asarray(t, float), m)
    return math.sqrt((e2 * I3 - h2) / (I1 * (I3 - I1))) * dn


def cone_exact(t):
    """Angle between H and the minor axis: cos θ = I1 ω1 / |H|."""
    h = math.hypot(I1 * W0[0], I3 * W0[2])
    return np.arccos(np.clip(I1 * omega1_exact(t) / h, -1, 1))


def integ(until=None, dt="1 ms", duration="3 s", save_every=10):
    return RunIntegration(dt=dt, duration=duration, save_every=save_every, until=until)


def run(sys, y0, settings, **kw):
    mon = event_monitor(sys, y0, settings.until, np.array([1.0, 0.0, 0.0]))
    return integrate_in_chunks(sys, y0, settings, max_chunks=20, event=mon, **kw)


@pytest.fixture(scope="module")
def body():
    sys = rigid_system()
    return sys, rsys.pack_state(sys, omega=W0)


def test_the_exact_cone_path_oscillates_between_its_bounds():
    t = np.linspace(0, 5, 2001)
    theta = np.degrees(cone_exact(t))
    assert theta[0] == pytest.approx(np.degrees(np.arctan2(I3 * W0[2], I1 * W0[0])), abs=1e-9)
    assert theta.max() > 40.0  # the level below is crossed


@pytest.mark.parametrize("kind", ["cone", "spin"])
def test_event_time_matches_the_jacobi_solution(body, kind):
    """The first time the cone angle reaches 40 deg (the spin ω1 falls to 1.9 rad/s) against
    the elliptic-function solution: to O(Δt²) of the midpoint rule, far below a step."""
    sys, y0 = body
    if kind == "cone":
        level, text = math.radians(40.0), "cone 40 deg"
        t_exact = brentq(lambda t: cone_exact(t) - level, 0.0, 1.4)
    else:
        level, text = 1.9, "spin 1.9 rad/s"
        t_exact = brentq(lambda t: omega1_exact(t) - level, 0.0, 1.4)
    out = run(sys, y0, integ(text))
    hit = out.event
    assert out.reason == "" and hit is not None and hit.located == "step"
    assert abs(hit.time - t_exact) < 2e-6  # Δt = 1 ms: the step is 500 times larger
    assert hit.step == math.ceil(hit.time / 1e-3)  # the first step at or past the level
    value = hit.cone_angle if kind == "cone" else hit.spin_rate
    assert value == pytest.approx(level, abs=1e-9)  # interpolated in the same step
    # the run keeps its samples up to the first saved sample past the event
    t = out.solution.t
    assert t[-2] < hit.time <= t[-1] and t[-1] - t[-2] == pytest.approx(1e-2)


def test_location_is_the_step_interpolation(body):
    """The event against an independent step-by-step integration: the first step whose cone
    angle exceeds the level, the time interpolated linearly in the angle within it."""
    sys, y0 = body
    level = math.radians(40.0)
    sol = it.integrate(sys, y0, (0.0, 1.0), "midpoint", dt=1e-3)
    h = np.einsum("ab,kb->ka", sys.J0, sol.y[:, 4:7])
    theta = np.arctan2(np.hypot(h[:, 1], h[:, 2]), np.abs(h[:, 0]))
    k = int(np.argmax(theta >= level))
    t_step = sol.t[k - 1] + (level - theta[k - 1]) / (theta[k] - theta[k - 1]) * 1e-3
    hit = run(sys, y0, integ("cone 40 deg")).event
    assert hit.step == k
    assert hit.time == pytest.approx(t_step, abs=1e-10)


class Keep:
    """A checkpointer that keeps every saved progress in memory."""

    def __init__(self):
        self.saved: list[ChunkProgress] = []

    def due(self) -> bool:
        return True

    def save(self, progress, wall_s):
        self.saved.append(progress)


def test_the_event_survives_a_resume(body):
    """Resumed from a checkpoint before the event, or from one of a run past it (the event
    then in the saved samples), the run ends on the same step at the same time, bit for bit."""
    sys, y0 = body
    settings = integ("cone 40 deg")
    keep = Keep()
    first = run(sys, y0, settings, checkpoint=keep)
    assert keep.saved and all(p.steps < first.event.step for p in keep.saved)
    again = run(sys, y0, settings, resume=(keep.saved[len(keep.saved) // 2], 0.0))
    assert again.event == first.event
    assert np.array_equal(again.solution.y, first.solution.y)
    past = Keep()
    run(sys, y0, integ(None), checkpoint=past)  # no event: saved to the end
    late = run(sys, y0, settings, resume=(past.saved[-1], 0.0))
    assert late.event == first.event and np.array_equal(late.solution.t, first.solution.t)


def test_a_time_event_is_exact_and_flat_spin_is_not_reached_by_a_rigid_body(body):
    sys, y0 = body
    hit = run(sys, y0, integ("time 0.1234 s")).event
    assert hit.time == 0.1234 and hit.step == 124


def test_the_steps_reported_end_on_the_event_step(body):
    """The steps of a run that ended on an event count to the event's step (its time / Δt for a
    time on the grid), not to the end of the chunk that passed it (150 steps a chunk here);
    also resumed from a checkpoint of a run past the event."""
    sys, y0 = body
    timed = run(sys, y0, integ("time 0.25 s"))
    assert timed.solution.stats["n_steps"] == round(0.25 / 1e-3) == timed.event.step
    coned = run(sys, y0, integ("cone 40 deg"))
    assert coned.solution.stats["n_steps"] == coned.event.step
    assert coned.event.step * 1e-3 == pytest.approx(coned.event.time, abs=1e-3)
    past = Keep()
    run(sys, y0, integ(None), checkpoint=past)  # 3000 steps saved
    late = run(sys, y0, integ("time 0.25 s"), resume=(past.saved[-1], 0.0))
    assert late.solution.stats["n_steps"] == 250
    # torque-free and rigid: the angle to the major axis never falls (no dissipation)
    out = run(sys, y0, integ("flat spin", duration="0.5 s"))
    assert out.event is None and out.solution.t[-1] == pytest.approx(0.5)


def test_cone_times_interpolate_between_samples():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    cone = np.radians([5.0, 15.0, 25.0, 35.0])
    got = cone_times(t, cone, (10.0, 20.0, 30.0, 45.0))
    assert got[10.0] == pytest.approx(0.5) and got[30.0] == pytest.approx(2.5)
    assert math.isnan(got[45.0])
    assert 10.0 not in cone_times(t, np.radians([12.0, 13, 14, 15]), (10.0,))


@pytest.mark.parametrize(
    ("text", "kind", "level"),
    [("cone 60 deg", "cone", math.radians(60)), ("Spin rate 30 Hz", "spin", 60 * math.pi),
     ("t 2 s", "time", 2.0), ("flat spin", "flat spin", math.radians(1.0)),
     ("flat spin 0.5 deg", "flat spin", math.radians(0.5))],
)  # fmt: skip
def test_until_texts(text, kind, level):
    assert parse_until(text) == (kind, pytest.approx(level))


@pytest.mark.parametrize("text", ["cone", "cone 90 deg", "spin -3 Hz", "banana 3 s", "cone 3 m"])
def test_bad_until_texts(text):
    with pytest.raises(ValueError):
        parse_until(text)


def test_a_run_that_starts_on_its_level_is_refused(body):
    sys, y0 = body
    theta0 = math.degrees(math.atan2(I3 * W0[2], I1 * W0[0]))
    with pytest.raises(ValueError, match="starts on that level"):
        event_monitor(sys, y0, f"cone {theta0!r} deg", np.array([1.0, 0.0, 0.0]))


def test_flat_spin_time_matches_the_jacobi_solution():
    """A torque-free body circling its major axis e3 (ω0 = (0.3, 0, 2) rad/s), started a
    quarter period on, where H is farthest from e3: "flat spin X" (the angle between H and the
    major axis below X) is reached when the Jacobi solution's angle, arccos(I3 ω3 / |H|), falls
    to X."""
    from scipy.special import ellipk
    from test_integrators import jacobi_solution

    sys = rigid_system()
    w0 = np.array([0.3, 0.0, 2.0])
    e2, h2 = I1 * w0[0] ** 2 + I3 * w0[2] ** 2, (I1 * w0[0]) ** 2 + (I3 * w0[2]) ** 2
    rate = math.sqrt((I3 - I2) * (h2 - e2 * I1) / (I1 * I2 * I3))
    m = (I2 - I1) * (e2 * I3 - h2) / ((I3 - I2) * (h2 - e2 * I1))
    t_q = ellipk(m) / rate

    def angle(t):
        return np.arccos(I3 * jacobi_solution(I1, I2, I3, w0, np.atleast_1d(t_q + t))[:, 2]
                         / math.sqrt(h2))  # fmt: skip

    lo, hi = float(angle(t_q)[0]), float(angle(0.0)[0])
    assert hi - lo > math.radians(1.0)
    level = 0.5 * (lo + hi)
    t_exact = brentq(lambda t: float(angle(t)[0]) - level, 0.0, t_q)
    y0 = rsys.pack_state(sys, omega=jacobi_solution(I1, I2, I3, w0, np.array([t_q]))[0])
    text = f"flat spin {math.degrees(level)!r} deg"
    hit = run(sys, y0, integ(text, duration="4 s")).event
    assert hit is not None and abs(hit.time - t_exact) < 1e-5
