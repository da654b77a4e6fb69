"""Runs that end on an event (``integration.until``, ``quadmodes run --until``), and the path's
times to given cone angles.

The event is a level crossing of a scalar of the state, g(t, y) = value − level
(:mod:`quadmodes.case.run_events`): the cone angle, the spin rate about the spin axis, the time,
or for "flat spin" the angle between H and the major principal axis. It is reached at the first
saved sample where g has left the sign it had at t = 0 (or is zero). It is then located to the
step: the sample interval that holds it is integrated again step by step from the sample before
(fixed-step methods: the same steps, up to the Newton tolerance of the first one), the first step
past the level is found and the time is interpolated linearly in g within that step. The run
keeps its samples up to the first saved sample past the event (the save grid stays regular).

The event is checked after every chunk of :func:`quadmodes.runs.chunked.integrate_in_chunks`
on that chunk's samples only, and after a resume on every sample of the checkpoint; it depends
on nothing but the saved states, so a run interrupted and resumed ends on the same step as the
uninterrupted one.

The spin axis of the event is memoryless: at every state the eigenvector of the deformed inertia
J̃(s) nearest the nominal spin axis (sign along it), the axis the diagnostics track by continuity
(:mod:`quadmodes.rom.diagnostics`; the same unless two principal moments cross).

Progress (:func:`progress_fraction`): a run that ends on an event reports the larger of t/T (T
its duration, the longest it may go) and its distance to the event, (v − v₀)/(v_event − v₀) of
the event's value v (v₀ at t = 0): the cone angle, the spin, the time, or for "flat spin" the
cone angle toward 90° − the flat-spin angle (the angle to the major axis itself is ill-defined
while two principal moments are near equal, as for an axisymmetric body); the largest over each
chunk's samples and over the run so far (a cone angle oscillates with the nutation), below 1
until the event is reached.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from quadmodes.case import CaseError
from quadmodes.case.run_events import parse_until
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import integrators
from quadmodes.rom import system as rsys
from quadmodes.rom.diagnostics import cone_angle
from quadmodes.runs.chunked import _Stop, time_fraction

#: The distance to an event is shown below this until the event is reached.
FRACTION_CEILING = 0.999

#: Cone angles (deg) whose first times the run reports (those above the initial cone angle).
CONE_MARKS_DEG = (10.0, 20.0, 30.0, 45.0, 60.0, 75.0)


@dataclass(frozen=True)
class EventHit:
    """Where a run reached its ``until`` event.

    text: the event as written; kind: "cone", "spin", "time" or "flat spin"; level (rad, rad/s,
    s or rad); time (s): interpolated within the step; step: the first step at or past the level
    (its end time step·Δt, s); cone_angle (rad) and spin_rate (rad/s) at the event
    (interpolated like the time); located: "step" (located to the step) or "sample"
    (interpolated between saved samples: the adaptive method)."""

    text: str
    kind: str
    level: float
    time: float
    step: int
    cone_angle: float
    spin_rate: float
    located: str = "step"

    def as_dict(self) -> dict:
        return {"until": self.text, "kind": self.kind, "reached": True,
                "time_s": self.time, "step": self.step,
                "cone_angle_deg": math.degrees(self.cone_angle),
                "spin_rate_hz": self.spin_rate / (2 * math.pi), "located": self.located}  # fmt: skip


def spin_axes(system: rsys.ReducedSystem, s: np.ndarray, axis0: np.ndarray):
    """(v_a (k,3), v_major (k,3)): for s (k,N) the eigenvector of J̃(s) nearest ``axis0`` (3,)
    (sign along it) and the eigenvector of the largest principal moment."""
    jt = dyn.inertia_tensor(system, s, "rot")
    _, vec = np.linalg.eigh(0.5 * (jt + np.swapaxes(jt, -1, -2)))
    d = np.einsum("a,kab->kb", axis0, vec)
    j = np.argmax(np.abs(d), axis=1)
    idx = np.arange(len(s))
    va = vec[idx, :, j] * np.sign(d[idx, j])[:, None]
    return va, vec[:, :, 2]


def progress_fraction(t: float, duration: float, values=(), start: float = math.nan,
                      target: float = math.nan, shown: float = 0.0) -> float:
    """The completed fraction of a run at time t (s) of its ``duration`` T (s) on its way to an
    event whose value goes from ``start`` (at t = 0) to ``target``: max(``shown`` (the fraction
    shown so far), t/T, the largest (v − start)/(target − start) over ``values`` (the latest
    samples' values v)), the event's part clamped to [0, :data:`FRACTION_CEILING`]; no event
    (no values, or start = target): max(shown, t/T). Units: any, the same for all three."""
    frac = time_fraction(t, duration)
    v = np.asarray(values, float).ravel()
    span = target - start
    if len(v) and math.isfinite(span) and span != 0.0:
        toward = float(np.max((v - start) / span))
        frac = max(frac, min(max(toward, 0.0), FRACTION_CEILING))
    return max(float(shown), frac)


def state_measures(system: rsys.ReducedSystem, y: np.ndarray, axis0: np.ndarray) -> dict:
    """For states y (k, 7+2N): cone angle (rad), spin rate ω·v_a (rad/s) and the angle between
    H and the major principal axis (rad, folded to [0, π/2]), each (k,)."""
    _, w, s, _ = rsys.split_state(system, y)
    h = dyn.body_momentum(system, y)
    va, vmaj = spin_axes(system, s, axis0)
    return {"cone": cone_angle(h, va), "spin": np.einsum("ka,ka->k", w, va),
            "flat spin": cone_angle(h, vmaj)}  # fmt: skip


@dataclass(frozen=True, eq=False)
class EventMonitor:
    """The ``until`` event of a run: its system, text, kind, level (SI), nominal spin axis
    ``axis0`` (3,) and ``side0``, the sign of g at the initial state (±1)."""

    system: rsys.ReducedSystem
    text: str
    kind: str
    level: float
    axis0: np.ndarray
    side0: float
    start: float = math.nan  # the progress measure at the run's start (rad, rad/s or s)

    def measure(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The value whose distance to :attr:`target` is the run's progress (k,): the time (s),
        the spin (rad/s) or the cone angle (rad; also for "flat spin") at t (k,), y (k, 7+2N)."""
        if self.kind == "time":
            return np.asarray(t, float)
        kind = "spin" if self.kind == "spin" else "cone"
        return state_measures(self.system, np.atleast_2d(y), self.axis0)[kind]

    @property
    def target(self) -> float:
        """The value of :meth:`measure` at the event: the level, or for "flat spin" the cone
        angle 90° − the flat-spin angle (rad)."""
        return 0.5 * math.pi - self.level if self.kind == "flat spin" else self.level

    def fraction(self, state, t: float, duration: float) -> float:
        """:func:`progress_fraction` of a run at time t (s) of ``duration`` (s) whose ``state``
        (a :class:`~quadmodes.runs.chunked.ChunkProgress`) holds the latest chunk's samples
        (none: its last state) and the fraction shown so far."""
        if state.t and len(state.t[-1]):
            ts, ys = state.t[-1], state.y[-1]
        else:
            ts, ys = np.array([t]), state.y_last[None, :]
        return progress_fraction(t, duration, self.measure(ts, ys), self.start, self.target,
                                 state.shown)  # fmt: skip

    def stage(self, name: str, duration: float) -> str:
        """The progress stage of run ``name``: what its fraction counts toward."""
        return f"{name} (to {self.text} or {duration:g} s)"

    def g(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        """g = value − level (k,) at times t (k,) s and states y (k, 7+2N)."""
        if self.kind == "time":
            return np.asarray(t, float) - self.level
        return state_measures(self.system, np.atleast_2d(y), self.axis0)[self.kind] - self.level

    def reached(self, g: np.ndarray) -> np.ndarray:
        """True where g has left its initial side (or is zero)."""
        return np.sign(g) != self.side0

    def after_chunk(self, state, integ, h: float):
        """``state`` (a :class:`~quadmodes.runs.chunked.ChunkProgress` whose last piece is new)
        cut at the first saved sample past the event, with ``event`` and a stop set; unchanged
        when the new samples do not reach it."""
        if not state.t or not len(state.t[-1]):
            return state
        t_new, y_new, ed_new = state.t[-1], state.y[-1], state.e_d[-1]
        before = [p for p in state.t[:-1] if len(p)]
        t_prev = before[-1][-1] if before else None
        g = self.g(t_new, y_new)
        hits = np.flatnonzero(self.reached(g))
        if not len(hits):
            return state
        j = int(hits[0])
        if j == 0 and t_prev is None:  # the first sample is the initial state: never reached
            return state
        if j == 0:
            y_prev = [p for p in state.y[:-1] if len(p)][-1][-1]
            ta, ya, ga = float(t_prev), y_prev, float(self.g(np.array([t_prev]), y_prev)[0])
        else:
            ta, ya, ga = float(t_new[j - 1]), y_new[j - 1], float(g[j - 1])
        h_loc, k_b = state.local_step(float(t_new[j]), h)  # a controlled step: that chunk's
        k_a = k_b - int(round((float(t_new[j]) - ta) / h_loc))
        hit = self.locate(ta, ya, ga, float(t_new[j]), y_new[j], float(g[j]), integ, h_loc, k_a)
        pieces = dict(t=(*state.t[:-1], t_new[: j + 1]), y=(*state.y[:-1], y_new[: j + 1]),
                      e_d=(*state.e_d[:-1], ed_new[: j + 1]))  # fmt: skip
        stop = _Stop(0, f"reached {self.text} at t = {hit.time:.6g} s", "")
        return dataclasses.replace(state, steps=k_b, y_last=y_new[j].copy(),
                                   e_d_offset=float(ed_new[j]), stop=stop, event=hit,
                                   stats=_steps_to(state, hit), **pieces)  # fmt: skip

    def after_resume(self, state, integ, h: float):
        """:meth:`after_chunk` on every sample of a resumed ``state`` (its pieces merged)."""
        pieces = [k for k, p in enumerate(state.t) if len(p)]
        if not pieces:
            return state
        merged = {name: (np.concatenate([getattr(state, name)[k] for k in pieces]),)
                  for name in ("t", "y", "e_d")}  # fmt: skip
        return self.after_chunk(dataclasses.replace(state, **merged), integ, h)

    def locate(self, ta, ya, ga, tb, yb, gb, integ, h, k_a=None) -> EventHit:
        """The :class:`EventHit` between the saved samples (ta, ya) and (tb, yb) (g = ga, gb):
        the steps (of h, s) between them integrated again (fixed-step methods), the first step
        past the level and the time interpolated linearly in g within it; ``k_a``: the index
        of the step ending at ta (default ta/h, the fixed grid)."""
        if integ.method == "adaptive":  # no steps of its own to locate it to: the samples
            ts, ys, gs = np.array([ta, tb]), np.array([ya, yb]), np.array([ga, gb])
            k0, located = None, "sample"
        else:
            sol = integrators.integrate(self.system, ya, (ta, tb), integ.method, dt=h,
                                        rtol=integ.rtol, save_every=1)  # fmt: skip
            ts, ys = np.asarray(sol.t, float), np.asarray(sol.y, float)
            ts = ta + h * np.arange(len(ts))  # the global grid (t = i·Δt)
            gs = self.g(ts, ys)
            gs[0] = ga
            k0, located = (int(round(ta / h)) if k_a is None else int(k_a)), "step"
        past = np.flatnonzero(self.reached(gs))
        k = int(past[0]) if len(past) and past[0] > 0 else len(ts) - 1
        frac = gs[k - 1] / (gs[k - 1] - gs[k]) if gs[k - 1] != gs[k] else 1.0
        frac = float(min(max(frac, 0.0), 1.0))
        m = state_measures(self.system, ys[k - 1 : k + 1], self.axis0)

        def at(v):
            return float(v[0] + frac * (v[1] - v[0]))

        time = self.level if self.kind == "time" else at(ts[k - 1 : k + 1])
        step = (k0 + k) if k0 is not None else int(round(ts[k] / h))
        return EventHit(self.text, self.kind, self.level, time, step, at(m["cone"]),
                        at(m["spin"]), located)  # fmt: skip


def _steps_to(state, hit: EventHit) -> dict:
    """``state.stats`` with ``n_steps`` (the run's steps, as reported) ending on the event's
    step, not on the end of the chunk that passed it (``state.steps``, in the same count);
    unchanged for an event located between samples (adaptive: no step of its own). The work
    counters (right-hand sides, Newton iterations) keep the work done."""
    stats = dict(state.stats)
    if hit.located == "step" and "n_steps" in stats:
        stats["n_steps"] = max(0, int(stats["n_steps"]) - max(0, int(state.steps) - int(hit.step)))
    return stats


def event_monitor(system: rsys.ReducedSystem, y0: np.ndarray, until: str | None,
                  spin_axis) -> EventMonitor | None:  # fmt: skip
    """The :class:`EventMonitor` of ``until`` (an ``integration.until`` text, None: no event)
    for a run of ``system`` from ``y0`` about the nominal body axis ``spin_axis`` (3,); raises
    ValueError when the run starts on the event's level."""
    if not until:
        return None
    kind, level = parse_until(until)
    axis0 = np.asarray(spin_axis, float)
    axis0 = axis0 / np.linalg.norm(axis0)
    mon = EventMonitor(system, until, kind, level, axis0, 1.0)
    g0 = float(mon.g(np.zeros(1), y0[None, :])[0])
    if abs(g0) <= 1e-9 * max(1.0, abs(level)):  # on the level to round-off: ill-posed
        raise ValueError(f"integration.until = {until!r}: the run starts on that level")
    start = float(mon.measure(np.zeros(1), y0[None, :])[0])
    return dataclasses.replace(mon, side0=float(np.sign(g0)), start=start)


def run_event(system: rsys.ReducedSystem, init, run) -> EventMonitor | None:
    """The :class:`EventMonitor` of a run case's ``integration.until`` from its initial state
    ``init`` (:class:`~quadmodes.runs.initial.InitialState`; None without an event); raises
    :class:`~quadmodes.case.CaseError` naming the field when the run starts on its level."""
    try:
        return event_monitor(system, init.y0, run.integration.until, init.spin_axis)
    except ValueError as exc:
        raise CaseError(str(exc), field="integration.until") from None


def cone_times(t: np.ndarray, cone: np.ndarray, marks_deg=CONE_MARKS_DEG) -> dict[float, float]:
    """{mark (deg): first time (s) the sampled cone angle ``cone`` (k,) rad reaches it,
    interpolated linearly between the samples (NaN if not reached)} for the marks above the
    initial cone angle."""
    out = {}
    deg = np.degrees(np.asarray(cone, float))
    for mark in marks_deg:
        if len(deg) == 0 or deg[0] >= mark:
            continue
        past = np.flatnonzero(deg >= mark)
        if not len(past):
            out[mark] = math.nan
            continue
        k = int(past[0])
        f = (mark - deg[k - 1]) / (deg[k] - deg[k - 1])
        out[mark] = float(t[k - 1] + f * (t[k] - t[k - 1]))
    return out
