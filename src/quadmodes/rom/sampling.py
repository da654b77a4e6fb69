"""Output policy of :func:`quadmodes.rom.integrators.integrate`: which times are saved.

* Fixed step (:func:`fixed_grid`): the step is ``(t1 − t0)/n`` with ``n = ceil((t1 − t0)/dt)``;
  saved are step 0, every ``save_every``-th step and always the last, or, with ``t_eval``, step 0
  and the grid points requested (within 1e-6 Δt of the grid, else ``ValueError``).
* Adaptive (:func:`adaptive_times`): ``t_eval`` if given, else, if ``dt`` is given, an even grid
  with spacing ``span / ceil(span / (dt·save_every))`` (dense output; ``dt`` is only a sampling
  interval), else None (every ``save_every``-th accepted step plus the last).
"""

from __future__ import annotations

import math

import numpy as np


def fixed_grid(t_span, dt, save_every, t_eval) -> tuple[int, float, list[int]]:
    """``(n_steps, step h (s), save_idx)`` of a fixed-step run over ``t_span`` (s); save_idx the
    increasing step indices to sample, starting at 0."""
    t0, t1 = map(float, t_span)
    if dt is None or dt <= 0:
        raise ValueError("fixed-step methods need dt > 0")
    if not t1 > t0:
        raise ValueError(f"t_span must increase, got ({t0}, {t1})")
    n_steps = max(1, math.ceil((t1 - t0) / dt - 1e-9))
    h = (t1 - t0) / n_steps
    if t_eval is None:
        idx = list(range(0, n_steps + 1, max(1, int(save_every))))
        if idx[-1] != n_steps:
            idx.append(n_steps)
    else:
        te = np.asarray(t_eval, float)
        k = np.rint((te - t0) / h).astype(int)
        if np.any(np.abs(t0 + k * h - te) > 1e-6 * h) or k.min() < 0 or k.max() > n_steps:
            raise ValueError("t_eval must lie on the fixed-step grid t0 + i*dt inside t_span")
        idx = sorted(set(k.tolist()) | {0})
    return n_steps, h, idx


def fixed_times(t0: float, h: float, save_idx, n_saved: int, status: int, done: int):
    """Times (s) of the ``n_saved`` samples of a fixed-step run; on failure the last sample is
    the last accepted state, at step ``done``."""
    t = t0 + h * np.asarray(save_idx[:n_saved], float)
    if status:
        t[-1] = t0 + h * done
    return t


def adaptive_times(t_span, dt, save_every, t_eval):
    """Output times (s) of an adaptive run, or None for the solver's own steps."""
    if t_eval is not None or dt is None:
        return t_eval
    t0, t1 = map(float, t_span)
    k = max(1, math.ceil((t1 - t0) / (dt * save_every) - 1e-9))
    return np.linspace(t0, t1, k + 1)
