"""Energy-sink consistency along a run's path (issue 29 item 5): does the energy-sink law,
applied to the power the run itself dissipates, predict the cone growth the run itself shows?

The law (:mod:`quadmodes.rom.energy_sink`, docs/sweeps.md): a torque-free body keeps its
angular momentum H while its kinetic energy T = H²/2 (cos²θ/I_a + sin²θ/I_t) falls by the
dissipated power P, so

    θ̇_law = P / (H² sin θ cos θ (1/I_a − 1/I_t))

(the same as ``P I_t cos θ / (I_a Ω² sin θ (I_t − I_a))`` with H = I_a Ω / cos θ). Here every
piece is the run's own: over windows along the path, P is the slope of the dissipated energy
E_d, θ̇_sim the slope of the cone angle (straight lines, :func:`quadmodes.runs.secular.fit_line`,
with standard errors), θ, |H|, I_a, I_t the window means of the diagnostics. The ratio
θ̇_sim / θ̇_law is 1 where the dissipated energy all comes out of the rigid-body kinetic energy
at constant H; it departs from 1 by what the law leaves out: the energy going into (or out
of) the elastic response (whose amplitude grows with θ), the change of I_a, I_t with the
spin (the centrifugal stretch relaxing as the spin falls) and a fit's noise.

Windows: :data:`SINK_WINDOWS` equal windows over ``[t_0, T]``, t_0 = min(k τ, T/2) with τ the
slowest decay time of the retained modes and k = ln 100 (the start-up transient down to 1 %,
the rule of :mod:`quadmodes.runs.secular`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from quadmodes.runs.secular import K_DECAY, decay_time, fit_line

#: Number of windows along the path.
SINK_WINDOWS = 10

RULE = ("windows: 10 equal windows over [min(k tau, T/2), T], tau = 1/min(zeta_i omega_i) of "
        "the retained modes, k = ln 100; per window P = slope of the dissipated energy, "
        "theta_dot = slope of the cone angle (least squares), law: theta_dot_law = P / (H^2 "
        "sin(theta) cos(theta) (1/I_a - 1/I_t)) at the window means of theta, |H|, I_a, I_t; "
        "ratio = theta_dot / theta_dot_law")  # fmt: skip


def law_cone_rate(power, h_norm, axial, transverse, cone):
    """θ̇ (rad/s) the energy-sink law gives for ``power`` P (W) at angular momentum |H|
    ``h_norm`` (kg m²/s), moments I_a ``axial``, I_t ``transverse`` (kg m²) and cone angle
    ``cone`` θ (rad): ``P / (H² sin θ cos θ (1/I_a − 1/I_t))`` (module docstring); arrays
    broadcast; NaN where θ = 0 or I_a = I_t."""
    p, h = np.asarray(power, float), np.asarray(h_norm, float)
    th = np.asarray(cone, float)
    den = h**2 * np.sin(th) * np.cos(th) * (1.0 / np.asarray(axial, float)
                                             - 1.0 / np.asarray(transverse, float))  # fmt: skip
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den != 0.0, p / np.where(den != 0.0, den, 1.0), np.nan)


@dataclass(frozen=True)
class SinkConsistency:
    """The energy-sink law against the run, per window (each (w,), SI): start, end s; cone
    rad (mean); power W (slope of E_d) and its standard error; cone_rate rad/s (slope of θ)
    and its standard error; law_rate rad/s (θ̇_law of the window's P); ratio = cone_rate /
    law_rate and its standard error (both slopes' errors combined)."""

    start: np.ndarray
    end: np.ndarray
    cone: np.ndarray
    power: np.ndarray
    power_se: np.ndarray
    cone_rate: np.ndarray
    cone_rate_se: np.ndarray
    law_rate: np.ndarray
    ratio: np.ndarray
    ratio_se: np.ndarray

    def as_json(self) -> dict:
        """Summary keys: the ratios (null where undefined), their range over the windows whose
        cone growth the run resolves (slope ≥ 2 standard errors: elsewhere the ratio is noise,
        e.g. ±160 for a cone that does not move), how many those are, and the rule."""
        resolved = np.isfinite(self.ratio) & (np.abs(self.cone_rate) >= 2.0 * self.cone_rate_se)
        r = self.ratio[resolved]

        def clean(a):
            return [float(x) if math.isfinite(x) else None for x in a]

        return {"windows": len(self.start), "window_start_s": clean(self.start),
                "window_end_s": clean(self.end), "ratio": clean(self.ratio),
                "ratio_se": clean(self.ratio_se),
                "windows_resolved": int(resolved.sum()),
                "ratio_min": float(r.min()) if len(r) else None,
                "ratio_max": float(r.max()) if len(r) else None, "rule": RULE}  # fmt: skip


def window_edges(t_end: float, tau: float, n: int = SINK_WINDOWS) -> np.ndarray:
    """The n + 1 edges (s) of the windows over ``[min(k τ, T/2), T]`` (module docstring)."""
    t0 = min(K_DECAY * tau, 0.5 * t_end) if math.isfinite(tau) else 0.5 * t_end
    return np.linspace(t0, t_end, n + 1)


def sink_consistency(t, cone, dissipated, h_norm, axial, transverse, frequencies_hz,
                     damping_ratio, n: int = SINK_WINDOWS) -> SinkConsistency:  # fmt: skip
    """:class:`SinkConsistency` of a run's series (each (k,), SI: t s, cone rad, dissipated
    J, |H| kg m²/s, I_a, I_t kg m²) over ``n`` windows; the retained modes' frequencies (Hz)
    and damping ratio set where the windows start (module docstring)."""
    t = np.asarray(t, float)
    edges = window_edges(float(t[-1]), decay_time(frequencies_hz, damping_ratio), n)
    rows = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        sel = (t >= a) & (t <= b)
        fc, fp = fit_line(t, cone, a, b), fit_line(t, dissipated, a, b)
        th = float(np.mean(np.asarray(cone)[sel])) if sel.any() else math.nan
        law = float(law_cone_rate(fp.slope, np.mean(np.asarray(h_norm)[sel]),
                                  np.mean(np.asarray(axial)[sel]),
                                  np.mean(np.asarray(transverse)[sel]), th)) if sel.any() else math.nan  # fmt: skip
        ratio = fc.slope / law if law else math.nan
        rel = math.hypot(fc.se / fc.slope, fp.se / fp.slope) if fc.slope and fp.slope else math.nan
        rows.append((a, b, th, fp.slope, fp.se, fc.slope, fc.se, law, ratio, abs(ratio) * rel))
    cols = np.array(rows, float).T if rows else np.zeros((10, 0))
    return SinkConsistency(*cols)


# ---------------------------------------------------------------------------------------------
# results.nc and the summary
# ---------------------------------------------------------------------------------------------

_VARIABLES = (  # (name, field, units, long_name)
    ("sink_window_start", "start", "s", "start of the energy-sink consistency window"),
    ("sink_window_end", "end", "s", "end of the energy-sink consistency window"),
    ("sink_cone_angle", "cone", "rad", "mean cone angle over the window"),
    ("sink_dissipated_power", "power", "W", "dissipated power over the window: least-squares "
     "slope of the dissipated energy"),
    ("sink_dissipated_power_standard_error", "power_se", "W", "standard error of the window's "
     "dissipated power"),
    ("sink_cone_growth_rate", "cone_rate", "rad/s", "simulated cone-growth rate over the "
     "window: least-squares slope of the cone angle"),
    ("sink_cone_growth_rate_standard_error", "cone_rate_se", "rad/s", "standard error of the "
     "window's simulated cone-growth rate"),
    ("sink_law_cone_growth_rate", "law_rate", "rad/s", "cone-growth rate the energy-sink law "
     "gives for the window's dissipated power, P / (H^2 sin(theta) cos(theta) (1/I_a - 1/I_t))"),
    ("sink_consistency_ratio", "ratio", "1", "simulated cone-growth rate / energy-sink law's "
     "cone-growth rate for the simulated dissipated power (1: consistent)"),
    ("sink_consistency_ratio_standard_error", "ratio_se", "1", "standard error of the "
     "consistency ratio (both slopes' standard errors combined)"),
)  # fmt: skip


def sink_variables(result) -> tuple[dict, dict, dict]:
    """(data variables, coordinates, attributes) of the energy-sink consistency of a
    :class:`~quadmodes.runs.simulate.RunResult` on the dimension ``sink_window`` (its
    coordinate: the window's centre, s); empty for a run without elastic modes or too short."""
    from quadmodes.io import cf

    d, model = result.diagnostics, result.model
    n = result.system.n_modes
    if n == 0 or len(d.t) < 4:
        return {}, {}, {}
    c = sink_consistency(d.t, d.cone_angle, d.E_d, d.H_norm, d.I_a, d.I_t,
                         model.frequencies_hz[:n], model.damping_ratio)  # fmt: skip
    dims = ("sink_window",)
    data = {name: cf.variable(dims, getattr(c, field), units, long)
            for name, field, units, long in _VARIABLES}  # fmt: skip
    coords = {"sink_window": cf.coordinate(dims, 0.5 * (c.start + c.end), "s",
                                           "centre of the energy-sink consistency window")}  # fmt: skip
    return data, coords, {"sink_consistency_rule": RULE}


def sink_summary(ds) -> dict:
    """``{"energy_sink_consistency": {...}}`` (:meth:`SinkConsistency.as_json`) read back from
    a results dataset; {} if it has none."""
    if "sink_consistency_ratio" not in ds:
        return {}
    fields = {field: np.asarray(ds[name].values, float) for name, field, _, _ in _VARIABLES}
    out = SinkConsistency(**fields).as_json()
    out["rule"] = str(ds.attrs.get("sink_consistency_rule", RULE))
    return {"energy_sink_consistency": out}
