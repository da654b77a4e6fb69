"""The progress of a run that ends on an event (``--until``): the larger of t/T and the distance
to the event (quadmodes.runs.events.progress_fraction), not t/T alone (a run whose duration is
3 h and whose event came at 297 s showed 0 % for all of its 51 minutes).

Closed forms: the fraction of a value half-way to its level is 0.5 (cone, spin falling or
rising, time), it never falls when the value oscillates, it stays below 1 until the event is
reached; along the torque-free triaxial body's Jacobi path the fraction reported after each
chunk is the running maximum of (θ(t) − θ₀)/(θ_event − θ₀) of the exact cone angle (and of
(ω₁(0) − ω₁(t))/(ω₁(0) − ω_event) for a spin event); a run through the chunk loops of the fixed
and the controlled step, a spin family through its switches, and ``quadmodes run --until``
report fractions above 0 before the end, counted toward the event, and 1 at the event.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from test_run import run_toml, workdir  # noqa: F401  (fixture)
from test_run_events import W0, Keep, cone_exact, integ, omega1_exact, rigid_system
from test_step_control import spinner  # noqa: F401  (fixture)

from quadmodes.case import RunIntegration, load_run_case
from quadmodes.rom import integrators as it
from quadmodes.rom import system as rsys
from quadmodes.runs import simulate as sim
from quadmodes.runs.chunked import ChunkProgress, integrate_in_chunks
from quadmodes.runs.events import FRACTION_CEILING, event_monitor, progress_fraction
from quadmodes.runs.step_chunks import integrate_run

AXIS = np.array([1.0, 0.0, 0.0])


def test_half_way_to_the_level_is_one_half():
    deg = math.radians
    # a cone event from 6 deg to 10 deg, at 8 deg after 1 s of a 3 h duration
    assert progress_fraction(1.0, 10800.0, [deg(8.0)], deg(6.0), deg(10.0)) == pytest.approx(0.5)
    # the spin falling 41 -> 37 Hz, at 39 Hz; and rising 20 -> 30 Hz, at 25 Hz
    assert progress_fraction(1.0, 1e4, [39.0], 41.0, 37.0) == pytest.approx(0.5)
    assert progress_fraction(1.0, 1e4, [25.0], 20.0, 30.0) == pytest.approx(0.5)
    # a time event at 400 s of a 3 h run, at t = 100 s: the value is the time itself
    assert progress_fraction(100.0, 10800.0, [100.0], 0.0, 400.0) == pytest.approx(0.25)
    # a chunk's samples: its largest distance counts
    assert progress_fraction(1.0, 1e4, [7.0, 9.0, 8.0], 6.0, 10.0) == pytest.approx(0.75)


def test_the_duration_counts_when_it_comes_first_and_without_an_event():
    assert progress_fraction(60.0, 100.0, [6.5], 6.0, 10.0) == pytest.approx(0.6)
    assert progress_fraction(60.0, 100.0) == pytest.approx(0.6)
    assert progress_fraction(100.0, 100.0) == 1.0


def test_clamped_below_one_until_the_event_and_never_below_zero():
    assert progress_fraction(0.0, 100.0, [12.0], 6.0, 10.0) == FRACTION_CEILING < 1.0
    assert progress_fraction(0.0, 100.0, [5.0], 6.0, 10.0) == 0.0  # moving away from the level
    assert progress_fraction(0.0, 100.0, [42.0], 41.0, 37.0) == 0.0


def test_monotone_while_the_value_oscillates():
    """A cone angle growing slowly under a nutation ten times its growth per period: the
    fraction, folded over the samples, never falls and is the running maximum of the exact
    distance."""
    t = np.linspace(0.0, 10.0, 2001)
    theta = 6.0 + 0.3 * t + 1.0 * np.sin(2 * np.pi * 3.0 * t)
    exact = np.maximum.accumulate(np.clip((theta - 6.0) / 4.0, 0.0, FRACTION_CEILING))
    shown, got = 0.0, []
    for k in range(0, len(t), 7):  # chunks of 7 samples
        shown = progress_fraction(t[k], 1e6, theta[k : k + 7], 6.0, 10.0, shown)
        got.append(shown)
    assert np.all(np.diff(got) >= 0.0)
    ends = np.minimum(np.arange(0, len(t), 7) + 6, len(t) - 1)
    np.testing.assert_allclose(got, exact[ends], rtol=0, atol=1e-12)


def test_flat_spin_counts_the_cone_angle_toward_90_deg_less_its_angle():
    """"flat spin 5 deg" from near the minor axis e1 of the rigid triaxial body: the fraction of
    a chunk of its exact path is the largest (θ − θ₀)/(85° − θ₀) of the cone angle about e1
    (the angle to the major axis itself is ill-defined while two moments are near equal)."""
    sys = rigid_system()
    y0 = rsys.pack_state(sys, omega=W0)
    mon = event_monitor(sys, y0, "flat spin 5 deg", AXIS)
    theta0 = float(cone_exact(0.0))
    assert mon.start == pytest.approx(theta0, abs=1e-12)
    assert mon.target == pytest.approx(math.radians(85.0), abs=1e-12)
    sol = it.integrate(sys, y0, (0.0, 0.5), "midpoint", dt=1e-4, save_every=50)
    state = dataclasses.replace(ChunkProgress.start(y0, 1), t=(sol.t,), y=(sol.y,))
    want = np.max((cone_exact(sol.t) - theta0) / (math.radians(85.0) - theta0))
    assert want > 0.02  # the chunk has moved toward the level
    assert mon.fraction(state, 0.5, 1e6) == pytest.approx(want, abs=1e-6)


def _recorder():
    calls: list[tuple[str, float]] = []
    return calls, lambda stage, f: calls.append((stage, f))


@pytest.mark.parametrize("kind", ["cone", "spin"])
def test_the_fixed_step_loop_reports_the_distance_along_the_jacobi_path(kind):
    """The rigid triaxial body from near its minor axis (tests/test_run_events.py), a 30 s
    duration and the event within the first second: after each chunk of 0.1 s the fraction is
    the running maximum, over the saved samples so far, of the exact path's distance to the
    level (t/T would be below 0.05)."""
    sys = rigid_system()
    y0 = rsys.pack_state(sys, omega=W0)
    if kind == "cone":
        text, start, level = "cone 40 deg", float(cone_exact(0.0)), math.radians(40.0)
        exact = cone_exact
    else:
        text, start, level = "spin 1.9 rad/s", float(omega1_exact(0.0)), 1.9
        exact = omega1_exact
    settings = integ(text, duration="30 s")
    calls, progress = _recorder()
    out = integrate_in_chunks(sys, y0, settings, progress, "body", max_chunks=300,
                              event=event_monitor(sys, y0, text, AXIS))  # fmt: skip
    assert out.event is not None
    stages = {s for s, _ in calls}
    assert stages == {f"body (to {text} or 30 s)"}
    got = np.array([f for _, f in calls])
    assert got[0] == 0.0 and got[-1] == 1.0 and np.all(np.diff(got) >= 0.0)
    ts = np.arange(0.0, out.event.time + 0.1, 0.01)  # the saved samples, every 10 ms
    dist = np.maximum.accumulate(np.clip((exact(ts) - start) / (level - start), 0.0, None))
    chunk_ends = 0.1 * np.arange(1, len(got) - 1)
    want = dist[np.rint(chunk_ends / 0.01).astype(int)]
    np.testing.assert_allclose(got[1:-1], want, rtol=0, atol=1e-4)
    assert got[-2] > 0.5  # the last chunk before the event: well on the way


def test_the_controlled_step_loop_counts_toward_the_event(spinner):  # noqa: F811
    """The small capsule coning (tests/test_step_control.py), a controlled step (chunks of 8
    probe times, about 2 s), ``until = "time 10 s"`` of 100 s: after each chunk the fraction
    is t/10 s (t/T would be below 0.1 all run), at the event 1."""
    sys, y0 = spinner
    settings = RunIntegration(dt="1 ms", duration="100 s", save_every=4, step_tolerance=1e-3,
                              until="time 10 s")  # fmt: skip
    calls, progress = _recorder()
    keep = Keep()  # saved after every chunk, before its report: the chunk ends
    out = integrate_run(sys, y0, settings, progress, "capsule", checkpoint=keep,
                        event=event_monitor(sys, y0, "time 10 s", AXIS))  # fmt: skip
    assert out.event is not None and out.event.time == 10.0
    assert {s for s, _ in calls} == {"capsule (to time 10 s or 100 s)"}
    got = np.array([f for _, f in calls])
    assert got[0] == 0.0 and got[-1] == 1.0 and np.all(np.diff(got) >= 0.0)
    ends = np.array([p.t_done for p in keep.saved])
    assert len(ends) >= 3
    np.testing.assert_allclose(got[1 : 1 + len(ends)], ends / 10.0, rtol=1e-12)


def test_a_spin_family_counts_from_the_paths_start_through_its_switches(workdir):  # noqa: F811
    """A family switching every chunk or two (tests/test_spin_family.py), ``until = "time
    0.03 s"`` of 1 s: the fractions are t/0.03 s at the 10 ms chunk ends (not t/1 s), never
    fall at a switch (a new segment starts where the last one stood), and end at 1."""
    text = run_toml(spin='"300 rad/s"', cone='"10 deg"', amplitude='"0 in"', duration='"1 s"',
                    dt='"0.2 ms"', save_every="50")  # fmt: skip
    text = text.replace('formulation = "Q"', 'formulation = "Q"\nreference = "spinning"\n'
                        'path_model = "spin-family"\npath_switch = 1e-6')  # fmt: skip
    text = text.replace("[integration]", '[integration]\nuntil = "time 0.03 s"')
    (workdir / "fam.toml").write_text(text, encoding="utf-8")
    run = load_run_case(workdir / "fam.toml")
    calls = []
    result = sim.simulate(run, progress=lambda s, f: calls.append((s, f)), max_chunks=100)
    assert result.complete and result.event is not None and len(result.family) >= 1
    got = np.array([f for s, f in calls if s == "small-run (to time 0.03 s or 1 s)"])
    assert got[-1] == 1.0 and np.all(np.diff(got) >= 0.0)
    before = got[(got > 0) & (got < 1)]
    assert len(before) >= 2
    np.testing.assert_allclose(before * 0.03 / 0.01, np.rint(before * 3.0), rtol=0, atol=1e-9)


def test_quadmodes_run_until_shows_progress_toward_the_event(workdir):  # noqa: F811
    """``quadmodes run --until "time 0.3 s" --duration "10 s"``: its progress lines (stderr not
    a terminal: a line per 10 %) name the event and pass 0 % before the end (t/T: below 3 %)."""
    from typer.testing import CliRunner

    from quadmodes.cli.app import app

    got = CliRunner().invoke(app, ["run", str(workdir / "small-run.toml"), "-o",
                                   str(workdir / "out"), "--until", "time 0.3 s",
                                   "--duration", "10 s", "--no-plots", "--json"])  # fmt: skip
    assert got.exit_code == 0, got.output
    lines = [s for s in got.stderr.splitlines() if "small-run (to time 0.3 s or 10 s)" in s]
    pct = [int(m[1]) for s in lines if (m := re.search(r": (\d+) %$", s))]
    assert pct[-1] == 100 and any(0 < p < 100 for p in pct)
