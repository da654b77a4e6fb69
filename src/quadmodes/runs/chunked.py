"""Chunked time integration of a reduced system, with progress reporting and early stops.

The run is integrated in chunks of whole steps (a multiple of ``save_every``), so progress can
be reported between chunks; each chunk starts from the last state of the previous one on the
same fixed-step grid (t = i·Δt), so the chunked trajectory is the single-run trajectory up to
the Newton tolerance of the first step of each chunk (its predictor has no previous step to
extrapolate from). The dissipated energy is accumulated across chunks.

An integrator failure (``Solution.status != 0``), a non-finite state or an interrupt (Ctrl-C)
ends the integration early: what was computed is kept and a one-line reason is returned.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from quadmodes.rom import integrators
from quadmodes.rom import system as rsys
from quadmodes.rom.solution import Solution

Progress = Callable[[str, float], None]

#: The run is split into at most this many chunks (progress is reported between chunks).
MAX_CHUNKS = 200


def _chunk_steps(n_steps: int, save_every: int, max_chunks: int = MAX_CHUNKS) -> int:
    """Steps per chunk: the smallest multiple of ``save_every`` giving at most ``max_chunks``."""
    per = max(1, math.ceil(n_steps / save_every / max_chunks))
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


class _Samples:
    """Samples kept so far (each chunk's first sample repeats the previous chunk's last and is
    dropped), the summed work counters, and the last state and dissipated energy."""

    def __init__(self, y0: np.ndarray, h: float, adaptive: bool):
        self.ts: list[np.ndarray] = []
        self.ys: list[np.ndarray] = []
        self.eds: list[np.ndarray] = []
        self.stats = {"n_steps": 0, "n_rhs": 0, "n_newton": 0, "n_jac": 0}
        self.y = y0.copy()
        self.ed_offset = 0.0
        self.h, self.adaptive = h, adaptive

    def add(self, sol: Solution, k0: int) -> _Stop | None:
        """Append chunk ``sol`` (started at step ``k0``), cut at its first non-finite state;
        returns why the run must stop (non-finite state, integrator failure) or None."""
        for key in self.stats:
            self.stats[key] += int(sol.stats.get(key, 0))
        t_chunk = np.asarray(sol.t, float)
        if not self.adaptive and len(t_chunk):  # exact global grid times
            t_chunk = (k0 + np.rint((t_chunk - k0 * self.h) / self.h)) * self.h
        y_chunk = np.asarray(sol.y, float)
        ed_chunk = self.ed_offset + np.asarray(sol.dissipated, float)
        first = 1 if self.ts else 0
        bad = _first_bad_row(y_chunk)
        stop = None
        if bad is not None:
            stop = _failure(f"non-finite state at t = {t_chunk[bad]:.6g} s")
            y_chunk, t_chunk, ed_chunk = y_chunk[:bad], t_chunk[:bad], ed_chunk[:bad]
        self.ts.append(t_chunk[first:])
        self.ys.append(y_chunk[first:])
        self.eds.append(ed_chunk[first:])
        if stop is not None:
            return stop
        if sol.status != 0:
            return _Stop(sol.status, sol.message, sol.message)
        self.y = y_chunk[-1].copy()
        self.ed_offset = float(ed_chunk[-1])
        return None

    def merged(self, y0: np.ndarray, n_state: int):
        """(t, y, E_d) of all chunks; the initial state alone if nothing usable was kept."""
        t_all = np.concatenate(self.ts) if self.ts else np.zeros(0)
        y_all = np.concatenate(self.ys) if self.ys else np.zeros((0, n_state))
        ed_all = np.concatenate(self.eds) if self.eds else np.zeros(0)
        if len(t_all) == 0:  # nothing usable: keep the initial state
            t_all, y_all, ed_all = np.zeros(1), y0[None, :], np.zeros(1)
        return t_all, y_all, ed_all


def integrate_in_chunks(
    system: rsys.ReducedSystem,
    y0: np.ndarray,
    integ,
    progress: Progress | None = None,
    name: str = "",
    max_chunks: int = MAX_CHUNKS,
) -> ChunkedRun:
    """Integrate ``system`` from ``y0`` (7+2N,) over ``integ.duration`` (s) with the settings of
    ``integ`` (the run case's ``[integration]``: method, dt, rtol, save_every) in at most
    ``max_chunks`` chunks; ``progress(name, fraction)`` is called before and between chunks.
    An integrator failure, a non-finite state or Ctrl-C ends the run early (not raised)."""
    n_total = integ.n_steps
    h = integ.duration / n_total
    chunk = _chunk_steps(n_total, integ.save_every, max_chunks)
    adaptive = integ.method == "adaptive"
    samples = _Samples(y0, h, adaptive)
    stop = None
    k0 = 0
    start = time.perf_counter()
    if progress:
        progress(name, 0.0)
    try:
        while k0 < n_total:
            k1 = min(k0 + chunk, n_total)
            sol, stop = _integrate_chunk(system, samples.y, k0 * h, k1 * h, integ, h)
            if stop is None:
                stop = samples.add(sol, k0)
            if stop is not None:
                break
            k0 = k1
            if progress:
                progress(name, k1 / n_total)
    except KeyboardInterrupt:
        stop = _failure(f"interrupted at t = {k0 * h:.6g} s")
    wall = time.perf_counter() - start
    stats = samples.stats
    stats["wall_s"] = wall
    t_all, y_all, ed_all = samples.merged(y0, system.n_state)
    stop = _Stop(0, "ok", "") if stop is None else stop
    merged = Solution(
        t_all,
        y_all,
        integ.method,
        stats,
        stop.status,
        stop.message,
        ed_all,
        None if adaptive else h,
    )
    return ChunkedRun(merged, stop.reason, wall)
