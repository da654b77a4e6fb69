"""Signal metrics of a run: the peak envelope of an oscillating amplitude and its log decrement.

Log decrement (:func:`log_decrement`): for the first bending pair (s_b1, s_b2) the amplitude
``a(t) = √(s_b1² + s_b2²)``; its peak envelope (:func:`peak_envelope`) is the maximum of ``a`` in
consecutive windows of one period ``T = 1/f`` of the pair (f the mean of the pair's natural
frequencies), each maximum refined by a parabola through the neighbouring samples.
``ln(envelope)`` is fitted by a straight line in time, using the windows whose envelope exceeds
10× the late-time level (the median of ``a`` over the last 10 % of the run) so that a forced
floor does not bias a decay; if fewer than three windows qualify, all windows are used.
``δ = −slope·T`` per period: 2πζ for a free decay with modal damping ratio ζ, negative for
growth. ``free_decay`` says whether the signal is one: it starts displaced (``a(0) > 0``) and at
least three windows exceed 10× the late-time level. A forced steady response (a spinning body
started undeformed) is not, and its fitted "decrement" means nothing: the run summary reports
the log decrement only for a free decay.

Pure functions on arrays (time in s, any amplitude unit); no file or plotting code. A leaf of
the package (imports nothing of quadmodes), so the run results, the plots (:mod:`quadmodes.io`)
and the comparison all use it.
"""

from __future__ import annotations

import math

import numpy as np


def _parabola_peak(t: np.ndarray, a: np.ndarray, i: int) -> tuple[float, float]:
    """(time, value) of the vertex of the parabola through samples i-1, i, i+1 of ``a(t)``,
    or sample i itself at the ends, for a non-concave triple or a vertex beyond the neighbours."""
    ti, ai = t[i], a[i]
    if 0 < i < len(a) - 1:
        y0, y1, y2 = a[i - 1], a[i], a[i + 1]
        den = y0 - 2 * y1 + y2
        if den < 0:
            p = 0.5 * (y0 - y2) / den
            if abs(p) <= 1:
                ai = y1 - 0.25 * (y0 - y2) * p
                ti = ti + p * 0.5 * (t[i + 1] - t[i - 1])
    return ti, ai


def peak_envelope(t: np.ndarray, a: np.ndarray, period: float):
    """(times, values) of the maximum of ``a`` in consecutive windows of length ``period``,
    each refined by a parabola through the maximum sample and its neighbours.

    t (n,) s, a (n,), period s; returns two (n_windows,) arrays (empty if n < 3 or period ≤ 0)."""
    t = np.asarray(t, float)
    a = np.asarray(a, float)
    if len(t) < 3 or not period > 0:
        return np.zeros(0), np.zeros(0)
    n_win = int(math.floor((t[-1] - t[0]) / period + 1e-9))
    et, ea = [], []
    edges = np.searchsorted(t, t[0] + period * np.arange(n_win + 1))
    for k in range(n_win):
        lo, hi = edges[k], max(edges[k + 1], edges[k] + 1)
        ti, ai = _parabola_peak(t, a, lo + int(np.argmax(a[lo:hi])))
        et.append(ti)
        ea.append(ai)
    return np.asarray(et), np.asarray(ea)


def log_decrement(t: np.ndarray, a: np.ndarray, frequency_hz: float) -> dict:
    """Log decrement per period of ``a(t)`` (see the module docstring).

    Returns ``{"log_decrement", "fit_start_s", "fit_end_s", "fit_peaks", "period_s"}``;
    ``log_decrement`` is None when the samples cannot resolve the period or there are fewer
    than three windows."""
    out = {
        "log_decrement": None,
        "fit_start_s": None,
        "fit_end_s": None,
        "fit_peaks": 0,
        "period_s": None,
        "free_decay": False,
    }
    t = np.asarray(t, float)
    a = np.asarray(a, float)
    if not (frequency_hz and frequency_hz > 0) or len(t) < 8:
        return out
    period = 1.0 / frequency_hz
    out["period_s"] = period
    if np.median(np.diff(t)) > period / 4:  # too coarse to see the oscillation
        return out
    et, ea = peak_envelope(t, a, period)
    ok = ea > 0
    et, ea = et[ok], ea[ok]
    if len(ea) < 3:
        return out
    floor = float(np.median(a[int(0.9 * len(a)) :]))
    use = ea > 10.0 * floor
    out["free_decay"] = bool(a[0] > 0 and use.sum() >= 3)
    if use.sum() < 3:
        use = np.ones_like(ea, bool)
    slope = np.polyfit(et[use], np.log(ea[use]), 1)[0]
    out.update(
        log_decrement=float(-slope * period),
        fit_start_s=float(et[use][0]),
        fit_end_s=float(et[use][-1]),
        fit_peaks=int(use.sum()),
    )
    return out
