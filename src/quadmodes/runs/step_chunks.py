"""Chunked integration with a controlled step (``integration.step_tolerance``): the chunk loop of
:mod:`quadmodes.runs.chunked` with the step chosen before each chunk by
:func:`quadmodes.rom.step_control.choose_step` (a step-doubling probe from the chunk's first
state), each chunk one compiled fixed-step call at its own step.

Chunks: about ``duration / max_chunks`` (s) each, and at least :data:`PROBES_PER_CHUNK` probe
times (at most the duration), a whole number of ``save_every`` steps (the
samples are every ``save_every`` steps, so their spacing follows the step); the last chunk ends
on the duration exactly (its step shortened to fit, never lengthened). A chunk whose Newton
fails is integrated again at half the step (twice at most) before the run stops.

After each chunk the next step is also bounded by the chunk's energy balance
(:func:`quadmodes.rom.step_control.balance_step`: the drift of E + E_d over the chunk, from a
straight line through its samples, against the chunk's share of the budget plus half of what
the run has not spent); the first chunk's step is at most the case's ``dt``.

Resume-safe: the step proposed for the next chunk (``h_next``), the time reached (``t_done``)
and the chunks' grid (t start, steps before, step, estimate, the energy balance's longest next
step) are in the
:class:`~quadmodes.runs.chunked.ChunkProgress` a checkpoint holds; the probe depends on nothing
else (the state and the proposal), so a resumed run takes the same steps, bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from quadmodes.rom import dynamics as dyn
from quadmodes.rom import step_control as sc
from quadmodes.runs.chunked import (
    MAX_CHUNKS,
    ChunkProgress,
    _finish,
    _integrate_chunk,
    _interrupted,
    _report,
    _Stop,
    integrate_in_chunks,
    stage,
)

#: Times a failing chunk is integrated again at half its step before the run stops.
RETRIES = 2
#: A chunk is at least this many probe times long (the probes cost ≲ 1.5/this of the run).
PROBES_PER_CHUNK = 8.0
#: The work counters of a controlled run: the integrator's and the probes' steps.
STATS = ("n_steps", "n_rhs", "n_newton", "n_jac", "n_probe_steps")


def start(y0: np.ndarray, dt: float) -> ChunkProgress:
    """Nothing integrated yet: the state y0 and the first proposal, the case's ``dt`` (s)."""
    base = ChunkProgress.start(y0, 0)
    return dataclasses.replace(base, stats={k: 0 for k in STATS}, t_done=0.0, h_next=float(dt))


def plan(t_done: float, duration: float, h: float, save_every: int,
         chunk_time: float) -> tuple[int, float, float]:  # fmt: skip
    """(steps n, step h_c (s), end time t_b (s)) of the next chunk from ``t_done`` at the step
    h: ~``chunk_time`` long, n a multiple of ``save_every``; when less than a quarter chunk
    would be left, the chunk runs to ``duration`` with its step shortened to fit."""
    remaining = duration - t_done
    per = save_every * h
    n = save_every * max(1, math.ceil(min(chunk_time, remaining) / per - 1e-9))
    if remaining - n * h < 0.25 * chunk_time:
        n = save_every * max(1, math.ceil(remaining / per - 1e-9))
        return n, remaining / n, duration
    return n, h, t_done + n * h


def _chunk(system, state: ChunkProgress, integ, h: float, chunk_time: float):
    """(Solution or None, stop or None, steps, step, end time) of the next chunk at step h,
    halved on a Newton failure (:data:`RETRIES` times)."""
    for attempt in range(RETRIES + 1):
        n, hc, tb = plan(state.t_done, integ.duration, h, integ.save_every, chunk_time)
        sol, stop = _integrate_chunk(system, state.y_last, state.t_done, tb, integ, hc)
        if stop is None and sol.status == 0:
            return sol, None, n, hc, tb
        if attempt < RETRIES:
            h = 0.5 * h
    return sol, stop, n, hc, tb


def _balance_step(system, before: ChunkProgress, after: ChunkProgress, h: float, e0: float,
                  duration: float) -> float:
    """:func:`quadmodes.rom.step_control.balance_step` of the chunk from ``before`` to
    ``after`` (its step h, s): the drift of E + E_d over it against :data:`~quadmodes.rom.
    step_control.BALANCE` × max(energy dissipated, E₀ × its time / ``duration``) plus half the
    run's budget so far (BALANCE × (E_d + E₀ t / duration)) not yet spent."""
    t, y, e_d = after.t[-1], after.y[-1], after.e_d[-1]
    if len(t) < 3:
        return math.inf
    balance = dyn.energy(system, y) + e_d
    span = float(t[-1] - before.t_done)
    # the drift over the chunk from a straight line through all its samples: the bounded
    # oscillation of the energy error (as large as the drift over one chunk) averages out
    defect = float(np.polyfit(t - t[0], balance - balance[0], 1)[0]) * span
    dissipated = after.e_d_offset - before.e_d_offset
    allowed = sc.BALANCE * max(dissipated, abs(e0) * span / duration)
    # half the budget the run has not used so far may be spent too (a chunk whose line is tilted
    # by a slow oscillation of the energy error, not a drift, does not cut the step at once)
    spent = abs(float(dyn.energy(system, before.y_last[None, :])[0]) + before.e_d_offset - e0)
    budget = sc.BALANCE * (before.e_d_offset + abs(e0) * before.t_done / duration)
    allowed += 0.5 * max(0.0, budget - spent)
    return sc.balance_step(h, defect, allowed) if allowed > 0 else math.inf


def _advance(system, state: ChunkProgress, integ, chunk_time: float, e0: float) -> ChunkProgress:
    """``state`` with the next chunk: probe, integrate, append (or stopped)."""
    tol = float(integ.step_tolerance)
    # the last chunk's energy balance; the first chunk no longer than the case's step
    cap = state.grid[-1][4] if state.grid else float(integ.dt)
    h, est, h_next, pstats = sc.choose_step(system, state.y_last, state.h_next, integ.dt, tol,
                                            chunk_time, h_cap=cap)  # fmt: skip
    state = dataclasses.replace(
        state, stats=dict(state.stats, n_probe_steps=state.stats["n_probe_steps"]
                          + pstats["n_steps"]))  # fmt: skip
    sol, stop, n, hc, tb = _chunk(system, state, integ, h, chunk_time)
    if sol is None:
        return state.stopped(stop)
    ta, k0 = state.t_done, state.steps
    new = state.add(sol, k0 + int(sol.stats.get("n_steps", 0)), hc, True)
    if hc < h:  # a retried chunk: propose from the step that worked
        h_next = min(h_next, 2.0 * hc)
    cap = math.inf
    if new.stop is None:  # the energy balance over the chunk bounds the next steps
        cap = _balance_step(system, state, new, hc, e0, integ.duration)
        h_next = min(h_next, cap)
    return dataclasses.replace(new, t_done=float(tb) if new.stop is None else ta,
                               h_next=float(h_next),
                               grid=(*state.grid, (ta, k0, hc, float(est.err), cap)))  # fmt: skip


def _loop(system, integ, progress, name, state, checkpoint, wall, event, chunk_time, e0):
    """Chunk after chunk to the duration (the controlled form of ``chunked._loop``); returns
    (the last progress, True if Ctrl-C stopped it)."""
    end = integ.duration * (1.0 - 1e-12)
    try:
        while state.t_done < end and state.stop is None:
            state = _advance(system, state, integ, chunk_time, e0)
            if event is not None and state.stop is None:
                state = event.after_chunk(state, integ, state.grid[-1][2])
            if checkpoint is not None and state.stop is None:
                if state.t_done >= end or checkpoint.due():
                    checkpoint.save(state, wall())
            if state.stop is None or state.event is not None:
                state = _report(progress, name, state, event, state.t_done, integ.duration)
    except KeyboardInterrupt:
        return state, True
    return state, False


def integrate_controlled(system, y0, integ, progress=None, name="", max_chunks=None, *,
                         checkpoint=None, resume=None, event=None):  # fmt: skip
    """:func:`quadmodes.runs.chunked.integrate_in_chunks` with a controlled step (module
    docstring): same arguments, same :class:`~quadmodes.runs.chunked.ChunkedRun`; the merged
    Solution has ``dt`` None; its stats count the probes' steps (``n_probe_steps``) and give
    the shortest and longest step (``dt_min_s``, ``dt_max_s``, s) and ``n_chunks``."""
    max_chunks = MAX_CHUNKS if max_chunks is None else max_chunks
    chunk_time = min(integ.duration, max(integ.duration / max(1, int(max_chunks)),
                     PROBES_PER_CHUNK * sc.probe_time(system, np.asarray(y0, float))))  # fmt: skip
    if resume is None:
        state, wall_before = start(y0, integ.dt), 0.0
    else:
        state, wall_before = resume
        if state.t_done is None or state.h_next is None:
            raise ValueError("resume: the checkpoint is not of a run with a controlled step")
        if event is not None:
            state = event.after_resume(state, integ, integ.dt)
    begin = time.perf_counter()

    def wall() -> float:
        return wall_before + time.perf_counter() - begin

    name = stage(name, event, integ.duration)
    state = _report(progress, name, state, event, state.t_done, integ.duration)
    e0 = float(dyn.energy(system, np.asarray(y0, float)[None, :])[0])  # the balance's scale
    state, interrupted = _loop(system, integ, progress, name, state, checkpoint, wall, event,
                               chunk_time, e0)  # fmt: skip
    h = state.grid[-1][2] if state.grid else integ.dt
    if interrupted:
        _interrupted(system, y0, integ, state, h, checkpoint, wall)
    out = _finish(system, y0, integ, state, h, wall(), state.stop or _Stop(0, "ok", ""))
    steps = [g[2] for g in state.grid] or [float(integ.dt)]
    out.solution.stats.update(dt_min_s=min(steps), dt_max_s=max(steps), n_chunks=len(state.grid))
    return out


def integrate_run(system, y0, integ, progress=None, name="", max_chunks=None, *, checkpoint=None,
                  resume=None, event=None):  # fmt: skip
    """A run's chunked integration: :func:`integrate_controlled` when ``integ.step_tolerance``
    is set, else :func:`quadmodes.runs.chunked.integrate_in_chunks` (the fixed step)."""
    integrate = (integrate_in_chunks if getattr(integ, "step_tolerance", None) is None
                 else integrate_controlled)  # fmt: skip
    return integrate(system, y0, integ, progress, name, max_chunks, checkpoint=checkpoint,
                     resume=resume, event=event)  # fmt: skip
