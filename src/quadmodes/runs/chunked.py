"""Chunked time integration of a reduced system, with progress reporting and early stops.

The run is integrated in chunks of whole steps (a multiple of ``save_every``), so progress can
be reported between chunks; each chunk starts from the last state of the previous one on the
same fixed-step grid (t = i·Δt), so the chunked trajectory is the single-run trajectory up to
the Newton tolerance of the first step of each chunk (its predictor has no previous step to
extrapolate from). The dissipated energy is accumulated across chunks.

An integrator failure (``Solution.status != 0``) or a non-finite state ends the integration
early: what was computed is kept and a one-line reason is returned. Ctrl-C raises
:class:`Interrupted` with what was computed up to the last whole chunk.

Checkpoints: the run's :class:`ChunkProgress` after a whole chunk is everything needed to go
on; a :class:`Checkpointer` saves it (periodically, at the end and on Ctrl-C) and a resumed
run continues from it with the same chunks, which gives the uninterrupted result bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import NoReturn, Protocol

import numpy as np

from quadmodes.rom import integrators
from quadmodes.rom import system as rsys
from quadmodes.rom.solution import Solution

Progress = Callable[[str, float], None]

#: The run is split into at most this many chunks (progress is reported between chunks).
MAX_CHUNKS = 200
#: A chunk has at least this many steps when the chunk count is left to the run (``max_chunks``
#: None). Why: a chunk costs about 0.1 ms of Python around the compiled step loop (the
#: integrator call, its sampling, the merge), the time of about 15 compiled steps of a small
#: model (N = 8: ~150,000 steps/s); 300 steps in 150 chunks of 2 took 15 times the steps' own
#: time (docs/performance.md, "The reduced run of the IKAROS-like sail"). 256 steps keep it
#: to a few per cent, and a chunk of the slowest models (N = 60, or the numpy steppers) still
#: takes well under a second, so progress and Ctrl-C stay prompt.
MIN_CHUNK_STEPS = 256


def _chunk_steps(n_steps: int, save_every: int, max_chunks: int | None = None) -> int:
    """Steps per chunk: the smallest multiple of ``save_every`` giving at most ``max_chunks``
    chunks; ``max_chunks`` None: at most :data:`MAX_CHUNKS` chunks of at least
    :data:`MIN_CHUNK_STEPS` steps (a number given is honoured as it is, e.g. by tests)."""
    floor = 1
    if max_chunks is None:
        max_chunks, floor = MAX_CHUNKS, MIN_CHUNK_STEPS
    per = max(1, math.ceil(n_steps / save_every / max_chunks), math.ceil(floor / save_every))
    return save_every * per


def _first_bad_row(y: np.ndarray) -> int | None:
    """Index of the first row of ``y`` with a non-finite entry (None if all are finite)."""
    bad = ~np.all(np.isfinite(y), axis=1)
    return int(np.argmax(bad)) if bad.any() else None


@dataclass(frozen=True)
class _Stop:
    """How the chunk loop ended: status and message of the merged Solution, and the reason
    of an early stop ("" when the whole duration was integrated)."""

    status: int
    message: str
    reason: str


def _failure(reason: str) -> _Stop:
    return _Stop(1, reason, reason)


@dataclass(frozen=True, eq=False)
class ChunkedRun:
    """Result of :func:`integrate_in_chunks`: the merged :class:`Solution` (all chunks, one
    sample per saved time), ``reason`` ("" when the whole duration was integrated) and the
    integration wall time ``wall_s`` (s)."""

    solution: Solution
    reason: str
    wall_s: float
    event: object = None  # the EventHit of an ``until`` event (quadmodes.runs.events), or None


def _integrate_chunk(system, y: np.ndarray, ta: float, tb: float, integ, h: float):
    """(Solution, None) of one chunk from ``y`` at ``ta`` to ``tb`` (s), or (None, stop) for a
    numerical breakdown inside the integrator (e.g. a non-finite Newton iterate reaching a math
    function)."""
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            sol = integrators.integrate(
                system,
                y,
                (ta, tb),
                integ.method,
                dt=h,
                rtol=integ.rtol,
                save_every=integ.save_every,
            )
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        detail = " ".join(str(exc).split()) or type(exc).__name__
        return None, _failure(
            f"{integ.method}: {type(exc).__name__} ({detail}) between t = {ta:.6g} s and {tb:.6g} s"
        )
    return sol, None


@dataclass(frozen=True, eq=False)
class ChunkProgress:
    """Where a chunked run stands after its last whole chunk (what a checkpoint holds).

    steps: steps done; chunk: steps per chunk; t (s), y, e_d (J): the kept samples so far as
    tuples of pieces (each chunk's first sample repeats the previous chunk's last and is
    dropped); stats: the summed work counters; y_last (7+2N,): the state at step ``steps``;
    e_d_offset (J): the dissipated energy there; stop: why the run must stop (None: go on).

    Every update returns a new object, so that a Ctrl-C arriving at any point leaves the
    caller with a consistent one (a single assignment replaces it)."""

    steps: int
    chunk: int
    t: tuple
    y: tuple
    e_d: tuple
    stats: dict
    y_last: np.ndarray
    e_d_offset: float
    stop: _Stop | None = None
    event: object = None  # where an ``until`` event ended the run (quadmodes.runs.events)
    # a controlled step (quadmodes.runs.step_chunks): the time reached (s), the step proposed
    # for the next chunk (s) and per chunk done (t start s, steps before, step s, estimate, the
    # energy balance's longest next step s)
    t_done: float | None = None
    h_next: float | None = None
    grid: tuple = ()
    # a spin-family run (quadmodes.runs.family_checkpoint): the family so far, for its checkpoint
    family: dict | None = None
    # the completed fraction last reported (progress only: not in a checkpoint; see _report)
    shown: float = 0.0

    def local_step(self, t: float, h: float) -> tuple[float, int]:
        """(the step (s) of the chunk holding the interval that ends at t, the index of the
        step ending at t): ``(h, round(t/h))`` on a fixed grid of step h."""
        if not self.grid:
            return h, int(round(t / h))
        starts = np.array([g[0] for g in self.grid])
        j = max(0, int(np.searchsorted(starts, t, side="left")) - 1)
        t0, k0, hc = self.grid[j][:3]
        return float(hc), int(k0) + int(round((t - t0) / hc))

    @classmethod
    def start(cls, y0: np.ndarray, chunk: int) -> ChunkProgress:
        """Nothing integrated yet: the initial state ``y0``."""
        stats = {"n_steps": 0, "n_rhs": 0, "n_newton": 0, "n_jac": 0}
        return cls(steps=0, chunk=chunk, t=(), y=(), e_d=(), stats=stats, y_last=y0.copy(),
                   e_d_offset=0.0)  # fmt: skip

    def add(self, sol: Solution, k1: int, h: float, adaptive: bool) -> ChunkProgress:
        """This progress with chunk ``sol`` (steps ``self.steps`` to ``k1``) appended, cut at its
        first non-finite state; ``stop`` says why the run must stop (non-finite state,
        integrator failure) or is None."""
        k0 = self.steps
        stats = {key: value + int(sol.stats.get(key, 0)) for key, value in self.stats.items()}
        t_chunk = np.asarray(sol.t, float)
        if not adaptive and len(t_chunk):  # exact global grid times
            t_chunk = (k0 + np.rint((t_chunk - k0 * h) / h)) * h
        y_chunk = np.asarray(sol.y, float)
        ed_chunk = self.e_d_offset + np.asarray(sol.dissipated, float)
        first = 1 if self.t else 0
        bad = _first_bad_row(y_chunk)
        stop = None
        if bad is not None:
            stop = _failure(f"non-finite state at t = {t_chunk[bad]:.6g} s")
            y_chunk, t_chunk, ed_chunk = y_chunk[:bad], t_chunk[:bad], ed_chunk[:bad]
        elif sol.status != 0:
            stop = _Stop(sol.status, sol.message, sol.message)
        pieces = dict(t=(*self.t, t_chunk[first:]), y=(*self.y, y_chunk[first:]),
                      e_d=(*self.e_d, ed_chunk[first:]), stats=stats)  # fmt: skip
        if stop is not None:  # the state stays at the last good chunk boundary
            return ChunkProgress(steps=k0, chunk=self.chunk, y_last=self.y_last,
                                 e_d_offset=self.e_d_offset, stop=stop, **pieces)  # fmt: skip
        return ChunkProgress(steps=k1, chunk=self.chunk, y_last=y_chunk[-1].copy(),
                             e_d_offset=float(ed_chunk[-1]), **pieces)  # fmt: skip

    def stopped(self, stop: _Stop) -> ChunkProgress:
        """This progress ended by ``stop`` (e.g. an integrator breakdown in the next chunk)."""
        return dataclasses.replace(self, stop=stop)

    def merged(self, y0: np.ndarray, n_state: int):
        """(t, y, E_d) of all chunks; the initial state alone if nothing usable was kept."""
        t_all = np.concatenate(self.t) if self.t else np.zeros(0)
        y_all = np.concatenate(self.y) if self.y else np.zeros((0, n_state))
        ed_all = np.concatenate(self.e_d) if self.e_d else np.zeros(0)
        if len(t_all) == 0:  # nothing usable: keep the initial state
            t_all, y_all, ed_all = np.zeros(1), y0[None, :], np.zeros(1)
        return t_all, y_all, ed_all


class Checkpointer(Protocol):
    """Where :func:`integrate_in_chunks` saves its :class:`ChunkProgress`: ``due()`` says
    whether a periodic save is due now (e.g. by wall time); ``save(progress, wall_s)`` writes it
    (atomically) with the integration wall time so far (s)."""

    def due(self) -> bool: ...

    def save(self, progress: ChunkProgress, wall_s: float) -> None: ...


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (or a SIGTERM turned into it) during a chunked run. ``partial``: what was computed
    up to the last whole chunk (a :class:`ChunkedRun`, or the run result built from it by the
    caller); ``saved``: a checkpoint holds it. Being a KeyboardInterrupt, it stops whatever
    does not handle it."""

    def __init__(self, partial, saved: bool, reason: str):
        super().__init__(reason)
        self.partial, self.saved, self.reason = partial, saved, reason


def time_fraction(t: float, duration: float) -> float:
    """t/duration in [0, 1] (1 from duration·(1 − 1e-12) on: k·(T/n) need not round to T): the
    completed fraction of a run without an ``until`` event."""
    if not duration > 0:
        return 0.0
    return 1.0 if t >= duration * (1.0 - 1e-12) else max(0.0, t / duration)


def _report(progress, name: str, state: ChunkProgress, event, t: float,
            duration: float) -> ChunkProgress:  # fmt: skip
    """``progress(name, fraction)`` of a run at time t (s) of ``duration`` (s), and ``state``
    with that fraction as ``shown``: 1 where its ``until`` event ended it, else
    ``event.fraction`` (t/duration or the distance to the event, whichever is larger:
    :func:`quadmodes.runs.events.progress_fraction`), t/duration without an event."""
    if not progress:
        return state
    if state.event is not None:
        frac = 1.0
    elif event is not None:
        frac = event.fraction(state, t, duration)
    else:
        frac = time_fraction(t, duration)
    progress(name, frac)
    return dataclasses.replace(state, shown=frac)


def stage(name: str, event, duration: float) -> str:
    """The progress stage of run ``name``: with an ``until`` event, what it counts toward."""
    return name if event is None else event.stage(name, duration)


def _loop(system, integ, progress, name, state: ChunkProgress, h, adaptive, checkpoint, wall,
          event=None):  # fmt: skip
    """Integrate chunk after chunk from ``state`` to ``integ.n_steps``, saving a checkpoint
    whenever ``checkpoint.due()`` and at the end; ``event`` (an ``after_chunk(state, integ,
    h)``, :class:`quadmodes.runs.events.EventMonitor`) may stop it after a chunk. Returns (the
    last progress, True if Ctrl-C stopped it); the progress is always a consistent one (see
    :class:`ChunkProgress`)."""
    n_total = integ.n_steps
    try:
        while state.steps < n_total and state.stop is None:
            k0 = state.steps
            k1 = min(k0 + state.chunk, n_total)
            sol, stop = _integrate_chunk(system, state.y_last, k0 * h, k1 * h, integ, h)
            if stop is not None:
                state = state.stopped(stop)
                break
            state = state.add(sol, k1, h, adaptive)
            if event is not None and state.stop is None:
                state = event.after_chunk(state, integ, h)
            if checkpoint is not None and state.stop is None:
                if state.steps == n_total or checkpoint.due():
                    checkpoint.save(state, wall())
            if state.stop is None or state.event is not None:
                state = _report(progress, name, state, event, state.steps * h, integ.duration)
    except KeyboardInterrupt:
        return state, True
    return state, False


def integrate_in_chunks(
    system: rsys.ReducedSystem,
    y0: np.ndarray,
    integ,
    progress: Progress | None = None,
    name: str = "",
    max_chunks: int | None = None,
    *,
    checkpoint: Checkpointer | None = None,
    resume: tuple[ChunkProgress, float] | None = None,
    event=None,
) -> ChunkedRun:
    """Integrate ``system`` from ``y0`` (7+2N,) over ``integ.duration`` (s) with the settings of
    ``integ`` (the run case's ``[integration]``: method, dt, rtol, save_every) in at most
    ``max_chunks`` chunks (None: at most :data:`MAX_CHUNKS` of at least
    :data:`MIN_CHUNK_STEPS` steps); ``progress(stage, fraction)`` is called before and between
    chunks (stage: ``name``, with an ``until`` event what it counts toward, :func:`stage`).
    An integrator failure or a non-finite state ends the run early (not raised).

    ``checkpoint``: saves the progress when due, at the end and on Ctrl-C; ``resume``:
    (progress, wall time before, s) of a checkpoint of this same run: the integration continues
    from its last whole chunk with the same chunks, so the result is the uninterrupted one bit
    for bit (every chunk starts from the saved state exactly as it did in the uninterrupted
    run). Ctrl-C raises :class:`Interrupted` carrying the run up to its last whole chunk (saved
    to ``checkpoint`` first, if any). ``event``: an ``until`` event
    (:class:`quadmodes.runs.events.EventMonitor`) checked after every chunk (and on the samples
    of a resumed checkpoint), which ends the run complete where it is reached."""
    n_total = integ.n_steps
    h = integ.duration / n_total
    adaptive = integ.method == "adaptive"
    if resume is None:
        chunk = _chunk_steps(n_total, integ.save_every, max_chunks)
        state, wall_before = ChunkProgress.start(y0, chunk), 0.0
    else:
        state, wall_before = resume
        if not 0 <= state.steps <= n_total:
            raise ValueError(f"resume: {state.steps} steps done, the run has {n_total}")
        if event is not None:  # an event already in the saved samples ends it there again
            state = event.after_resume(state, integ, h)
    start = time.perf_counter()

    def wall() -> float:
        return wall_before + time.perf_counter() - start

    name = stage(name, event, integ.duration)
    state = _report(progress, name, state, event, state.steps * h, integ.duration)
    state, interrupted = _loop(system, integ, progress, name, state, h, adaptive, checkpoint, wall,
                               event)  # fmt: skip
    if interrupted:
        _interrupted(system, y0, integ, state, h, checkpoint, wall)
    return _finish(system, y0, integ, state, h, wall(), state.stop or _Stop(0, "ok", ""))


def _finish(system, y0, integ, state: ChunkProgress, h, wall_s, stop: _Stop) -> ChunkedRun:
    """The :class:`ChunkedRun` of ``state`` ended by ``stop``."""
    fixed = integ.method != "adaptive" and not state.grid
    stats = dict(state.stats, wall_s=wall_s)
    t_all, y_all, ed_all = state.merged(y0, system.n_state)
    merged = Solution(t_all, y_all, integ.method, stats, stop.status, stop.message, ed_all,
                      h if fixed else None)  # fmt: skip
    return ChunkedRun(merged, stop.reason, wall_s, state.event)


def _interrupted(system, y0, integ, state, h, checkpoint, wall) -> NoReturn:
    """Save ``state`` (if anything was integrated) and raise :class:`Interrupted`."""
    t = state.steps * h if state.t_done is None else state.t_done
    reason = f"interrupted at t = {t:.6g} s"
    saved = False
    if checkpoint is not None and state.steps > 0:
        checkpoint.save(state, wall())
        saved = True
    partial = _finish(system, y0, integ, state, h, wall(), _failure(reason))
    raise Interrupted(partial, saved, reason)
