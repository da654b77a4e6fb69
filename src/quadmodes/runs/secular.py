"""Secular rates fitted over the quasi-steady part: the long-window scores of ``quadmodes
compare``, the answer of ``quadmodes run`` (:func:`run_fits`) and the time runs of a sweep.

Over the quasi-steady interval ``[t_s, T]`` of a compared window (the window ``[0, T]`` after
the start-up transient) three straight lines are fitted by least squares to every model's
series (:class:`quadmodes.analysis.compare.Series`):

* the cone angle θ(t): slope = **secular cone-growth rate** (rad/s, reported in deg/s);
* the dissipated energy E_d(t): slope = **mean dissipated power** (W);
* the spin rate ω(t): slope (rad/s²); the fitted **spin-rate change** over the interval is
  slope · (T − t_s) (rad/s).

Each reduced formulation is scored by the ratio reduced / full order of each slope (the
spin-rate-change ratio is the ratio of the slopes, since the interval is the same).

**Quasi-steady start** (:func:`quasi_steady_interval`; the same ``t_s`` for every model, fixed
before anything is fitted): the initial-condition transient of the retained elastic modes
decays as ``exp(−ζ_i ω_i t)``; its slowest decay time is ``τ = 1 / min_i(ζ_i ω_i)`` (= 1/(ζ ω_min)
for one damping ratio ζ and ω_min = 2π f_min the lowest retained frequency). Then::

    t_s = min(max(T/2, k τ), 3T/4),   k = ln 100 ≈ 4.6

``kτ`` is the time for the transient's amplitude to fall to 1 % of its start; ``T/2`` keeps the
fit away from the start-up even when the damping is strong; the cap ``3T/4`` leaves at least a
quarter of the window to fit (undamped, τ = ∞: t_s = 3T/4). A window whose ``kτ`` exceeds
``3T/4`` is too short for the transient to have died: the cap is reported (``capped``).

**The fit and its standard error** (:func:`fit_line`). The series oscillate (nutation,
vibration) about their trends. A plain least-squares line over an interval of length
``L = T − t_s`` holding many periods is used; a sinusoid ``A sin(ωt + φ)`` left in the data
shifts the fitted slope by ``(12 A / L³) cos φ' (L cos(ωL/2)/ω − 2 sin(ωL/2)/ω²)`` (φ' the phase
at the interval's middle), at most ``12 A/(ω L²) (1 + 2/(ωL))``. Fitting over whole periods
does not remove this term (for ωL = 2πn it is ``∓12 A cos φ'/(ω L²)``), so the fit uses the
whole interval and the error is bounded instead. The reported standard error combines the
textbook residual-based one with that bound for the residual's own rms ``σ`` and dominant
angular frequency ``ω_r`` (peak of its periodogram; A = √2 σ)::

    se² = σ² / ((n − 2)/n · Σ(t − t̄)²) + (12 √2 σ / (ω_r L²) (1 + 2/(ω_r L)))²

so serially correlated residuals are not mistaken for independent samples. A ratio is reported
only where the full order's slope is distinguishable from zero, ``|b_F| ≥ 2 se_F``; otherwise it
is null and a note says why. Everything here is a pure function of arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Decay times of the initial-condition transient waited before the quasi-steady part (ln 100:
#: its amplitude down to 1 %).
K_DECAY = math.log(100.0)
#: A full-order slope counts as non-zero when |slope| ≥ Z_SIGNIFICANT standard errors.
Z_SIGNIFICANT = 2.0
#: A cone growth over the fit below this fraction of the mean cone angle is round-off of the
#: integration, not growth (|H| holds to ~1e-13 over 10⁵ steps; two orders of margin), however
#: small its standard error (an undamped body's cone drifts by ~1e-12 of itself).
ROUND_OFF_GROWTH = 1e-10
#: Fewest samples in the interval for a fit.
MIN_SAMPLES = 8

#: (score, Series attribute, factor SI → reported, reported unit (pint), long name of the slope)
QUANTITIES = (
    ("cone_growth", "cone_angle", 180.0 / math.pi, "degree/s",
     "secular cone-growth rate (least-squares slope of the cone angle over the quasi-steady part)"),
    ("dissipated_power", "E_d", 1.0, "W",
     "mean dissipated power (least-squares slope of the dissipated energy over the quasi-steady "
     "part)"),
    ("spin_rate_slope", "spin_rate", 1.0, "rad/s^2",
     "spin-rate slope (least-squares slope of the spin rate over the quasi-steady part)"),
)  # fmt: skip
#: score → name of its ratio reduced / full order
RATIOS = {
    "cone_growth": "cone_growth_ratio",
    "dissipated_power": "dissipated_power_ratio",
    "spin_rate_slope": "spin_rate_change_ratio",
}
#: score → suffix of its key in the flat table (reported unit)
_KEY_UNIT = {"cone_growth": "deg_per_s", "dissipated_power": "W",
             "spin_rate_slope": "rad_per_s2"}  # fmt: skip


@dataclass(frozen=True)
class QuasiSteady:
    """The fitted interval ``[start_s, end_s]`` (s) and how its start was chosen: ``decay_time_s``
    τ = 1/min(ζ_i ω_i) (inf undamped), ``k`` decay times, ``capped`` when ``kτ`` > 3T/4."""

    start_s: float
    end_s: float
    decay_time_s: float
    k: float
    capped: bool

    @property
    def rule(self) -> str:
        """The rule in words (stored with the outputs)."""
        return (f"t_s = min(max(T/2, k tau), 3T/4), tau = 1/min(zeta_i omega_i) over the retained "
                f"elastic modes, k = ln 100 = {self.k:.3f}")  # fmt: skip


@dataclass(frozen=True)
class LineFit:
    """Least-squares line ``y ≈ intercept + slope (t − t0)`` over ``[t0, t1]`` (SI units of y per
    s); ``se`` its standard error (module docstring), ``residual_rms`` σ, ``residual_hz`` the
    residual's dominant frequency (Hz), ``n`` samples. NaN fields: no fit (too few samples)."""

    slope: float
    intercept: float
    se: float
    residual_rms: float
    residual_hz: float
    n: int
    t0: float
    t1: float


NO_FIT = LineFit(*(math.nan,) * 5, 0, math.nan, math.nan)


def decay_time(frequencies_hz, damping_ratio) -> float:
    """Slowest decay time τ = 1/min_i(ζ_i ω_i) (s) of the retained elastic modes (inf if none
    or undamped). frequencies_hz (N,) Hz, damping_ratio scalar or (N,)."""
    f = np.asarray(frequencies_hz, float).ravel()
    z = np.broadcast_to(np.asarray(damping_ratio, float), f.shape)
    rate = 2 * math.pi * f * z
    rate = rate[(f > 0) & np.isfinite(rate)]
    return float(1.0 / rate.min()) if len(rate) and rate.min() > 0 else math.inf


def quasi_steady_interval(window_s: float, tau_s: float, k: float = K_DECAY,
                          t0: float = 0.0) -> QuasiSteady:  # fmt: skip
    """``[t_s, T]`` for the window ``[t0, t0 + window_s]`` (s): ``t_s − t0 = min(max(T/2, kτ),
    3T/4)`` with τ = ``tau_s`` (s; :func:`decay_time`)."""
    if not window_s > 0:
        raise ValueError("window: must be a positive duration")
    wait = k * tau_s
    start = min(max(0.5 * window_s, wait), 0.75 * window_s)
    return QuasiSteady(t0 + start, t0 + window_s, float(tau_s), float(k), bool(wait > 0.75 * window_s))


def dominant_angular_frequency(t: np.ndarray, r: np.ndarray) -> float:
    """Angular frequency (rad/s) of the largest periodogram peak of ``r(t)`` above zero (the
    samples taken as evenly spaced at their mean interval); the lowest resolvable 2π/L if flat."""
    n = len(t)
    span = float(t[-1] - t[0]) * n / max(n - 1, 1)
    if n < 4 or not span > 0:
        return math.nan
    power = np.abs(np.fft.rfft(r - r.mean()))[1:]
    k = int(np.argmax(power)) + 1 if power.any() else 1
    return 2 * math.pi * k / span


def oscillation_bound(amplitude: float, omega: float, length: float) -> float:
    """Largest slope shift (units of y per s) a sinusoid of ``amplitude`` and angular frequency
    ``omega`` (rad/s) can give a least-squares line over an interval of ``length`` s:
    ``12 A/(ω L²)(1 + 2/(ωL))``."""
    if not (omega > 0 and length > 0):
        return math.inf if amplitude > 0 else 0.0
    return 12.0 * amplitude / (omega * length**2) * (1.0 + 2.0 / (omega * length))


def fit_line(t: np.ndarray, y: np.ndarray, t0: float, t1: float) -> LineFit:
    """Least-squares line through the samples of ``y(t)`` with ``t0 ≤ t ≤ t1`` (s); t, y (n,).

    The standard error combines the residual-based one with :func:`oscillation_bound` for the
    residual's rms and dominant frequency (module docstring)."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    eps = 1e-9 * max(abs(t1), 1.0)
    sel = (t >= t0 - eps) & (t <= t1 + eps) & np.isfinite(y)
    n = int(sel.sum())
    if n < MIN_SAMPLES:
        return NO_FIT
    ts, ys = t[sel], y[sel]
    x = ts - t0
    xm = x.mean()
    sxx = float(np.sum((x - xm) ** 2))
    slope = float(np.sum((x - xm) * (ys - ys.mean())) / sxx)
    intercept = float(ys.mean() - slope * xm)
    r = ys - (intercept + slope * x)
    sigma = float(np.sqrt(np.mean(r**2)))
    omega_r = dominant_angular_frequency(ts, r)
    length = float(ts[-1] - ts[0])
    se_white = math.sqrt(float(np.sum(r**2)) / (n - 2) / sxx)
    se_osc = oscillation_bound(math.sqrt(2.0) * sigma, omega_r, length) if sigma > 0 else 0.0
    return LineFit(slope, intercept, math.hypot(se_white, se_osc), sigma,
                   omega_r / (2 * math.pi), n, float(t0), float(t1))  # fmt: skip


@dataclass(frozen=True)
class RunFits:
    """The secular fits of one run over its quasi-steady ``interval``: ``cone`` (rad/s),
    ``power`` (W, the slope of the dissipated energy), ``spin`` (rad/s²) :class:`LineFit`;
    ``mean_cone`` (rad) the mean cone angle over the interval; ``growth_rate`` (1/s) the
    exponential coning rate σ = slope/mean cone and ``time_constant`` (s) 1/σ (inf for a zero
    slope, negative: the cone decays); ``significant``: |slope| ≥ Z_SIGNIFICANT se and the
    growth over the fit at least :data:`ROUND_OFF_GROWTH` of the mean cone angle."""

    interval: QuasiSteady
    cone: LineFit
    power: LineFit
    spin: LineFit
    mean_cone: float

    @property
    def growth_rate(self) -> float:
        return self.cone.slope / self.mean_cone if self.mean_cone > 0 else math.nan

    @property
    def time_constant(self) -> float:
        sigma = self.growth_rate
        return 1.0 / sigma if sigma != 0.0 else math.inf

    @property
    def significant(self) -> bool:
        growth = abs(self.cone.slope) * (self.interval.end_s - self.interval.start_s)
        return bool(abs(self.cone.slope) >= Z_SIGNIFICANT * self.cone.se
                    and growth >= ROUND_OFF_GROWTH * abs(self.mean_cone))  # fmt: skip


def run_fits(t, cone_angle, dissipated_energy, spin_rate, frequencies_hz,
             damping_ratio) -> RunFits:  # fmt: skip
    """:class:`RunFits` of a run's diagnostics (t (n,) s, cone angle rad, dissipated energy J,
    spin rate rad/s) over the quasi-steady part of its whole window, the start decided by the
    retained modes (``frequencies_hz`` (N,) Hz, ``damping_ratio`` scalar or (N,);
    :func:`quasi_steady_interval`)."""
    t = np.asarray(t, float)
    cone = np.asarray(cone_angle, float)
    tau = decay_time(frequencies_hz, damping_ratio)
    q = quasi_steady_interval(float(t[-1] - t[0]), tau, t0=float(t[0]))
    fits = [fit_line(t, y, q.start_s, q.end_s) for y in (cone, dissipated_energy, spin_rate)]
    sel = (t >= q.start_s) & (t <= q.end_s)
    mean_cone = float(np.mean(cone[sel])) if sel.any() else math.nan
    return RunFits(q, *fits, mean_cone)


def covers(series, interval: QuasiSteady) -> bool:
    """Whether ``series.t`` spans the interval (to within one sample interval)."""
    t = np.asarray(series.t, float)
    if len(t) < 2:
        return False
    step = float(np.median(np.diff(t)))
    return t[0] <= interval.start_s + step and t[-1] >= interval.end_s - step


def secular_fits(series, interval: QuasiSteady) -> dict[str, LineFit]:
    """The three :class:`LineFit` of ``series`` (a compare.Series: t, cone_angle, E_d,
    spin_rate) over ``interval``, keyed by score name (SI slopes); NO_FIT where the series does
    not cover the interval."""
    if not covers(series, interval):
        return {name: NO_FIT for name, *_ in QUANTITIES}
    return {name: fit_line(series.t, getattr(series, attr), interval.start_s, interval.end_s)
            for name, attr, *_ in QUANTITIES}  # fmt: skip


def slope_ratio(rom: LineFit, ref: LineFit, z: float = Z_SIGNIFICANT, factor: float = 1.0,
                unit: str = "SI") -> tuple[float, str]:  # fmt: skip
    """``rom.slope / ref.slope`` and ``""``, or NaN and the reason when the reference slope is
    not distinguishable from zero (``|b_F| < z se_F``) or either fit is missing (the reason
    quotes the slope × ``factor`` in ``unit``)."""
    if not (math.isfinite(rom.slope) and math.isfinite(ref.slope)):
        return math.nan, "no fit (series does not cover the quasi-steady interval)"
    if not abs(ref.slope) >= z * ref.se or ref.slope == 0.0:
        return math.nan, (f"full-order slope {ref.slope * factor:.3g} ± {ref.se * factor:.3g} "
                          f"{unit} not "
                          f"distinguishable from 0 (|slope| < {z:g} se)")  # fmt: skip
    return rom.slope / ref.slope, ""


def _entries(fits: dict[str, LineFit], length_s: float) -> dict[str, float]:
    """Flat table entries (reported units) of one model's fits."""
    out: dict[str, float] = {}
    for name, _, factor, _, _ in QUANTITIES:
        f = fits[name]
        out[f"{name}_{_KEY_UNIT[name]}"] = f.slope * factor
        out[f"{name}_se_{_KEY_UNIT[name]}"] = f.se * factor
    out["spin_rate_change_rad_per_s"] = fits["spin_rate_slope"].slope * length_s
    return out


@dataclass(frozen=True, eq=False)
class SecularScores:
    """The long-window scores of a comparison: the interval, every model's fits (``fits["full"]``
    and one per reduced formulation, score name → :class:`LineFit`), the ratios reduced / full
    by formulation (NaN = null) and the notes explaining the nulls."""

    interval: QuasiSteady
    fits: dict[str, dict[str, LineFit]]
    ratios: dict[str, dict[str, float]]
    notes: tuple[str, ...] = ()

    def row(self, model: str) -> dict[str, float]:
        """Flat entries of ``model`` for the table: the ratios (formulations only) then the
        fitted values in reported units (``..._deg_per_s``, ``..._W``, ``..._rad_per_s2``) and
        the fitted spin-rate change (rad/s)."""
        length = self.interval.end_s - self.interval.start_s
        return {**self.ratios.get(model, {}), **_entries(self.fits[model], length)}

    def as_json(self) -> dict:
        """The interval and the full order's fits (for comparison.json)."""
        q = self.interval
        return {"start_s": q.start_s, "end_s": q.end_s, "decay_time_s": q.decay_time_s,
                "k": q.k, "capped": q.capped, "rule": q.rule,
                "significance_z": Z_SIGNIFICANT, "full_order": self.row("full")}  # fmt: skip


def score(full, reduced: dict, interval: QuasiSteady) -> SecularScores:
    """Fits of the full-order series ``full`` and of each reduced series (name → Series) over
    ``interval``, and the ratios reduced / full."""
    fits = {"full": secular_fits(full, interval)}
    ratios: dict[str, dict[str, float]] = {}
    notes: list[str] = []
    shared_notes: list[str] = []
    for name, ser in reduced.items():
        fits[name] = secular_fits(ser, interval)
        ratios[name] = {}
    for q, _, factor, unit, _ in QUANTITIES:
        key, ref = RATIOS[q], fits["full"][q]
        shared = ""
        for name in reduced:
            value, why = slope_ratio(fits[name][q], ref, factor=factor, unit=unit)
            ratios[name][key] = value
            if why and (why.startswith("full") or not math.isfinite(ref.slope)):
                shared = why if math.isfinite(ref.slope) else "full order " + why
            elif why:
                notes.append(f"{key} of {name}: null, {why}")
        if shared:
            shared_notes.append(f"{key}: null for every formulation, {shared}")
    return SecularScores(interval, fits, ratios, tuple(shared_notes + notes))


def dataset_variables(scores: SecularScores, models: list[str], formulations: list[str]) -> dict:
    """xarray variables of the scores: fitted slopes and standard errors by ``model`` (full
    first), ratios by ``formulation`` (NaN = null), the interval as scalars. Units pint-parsable."""
    import xarray as xr

    data = {}
    for name, _, factor, unit, long in QUANTITIES:
        vals = [scores.fits[m][name].slope * factor for m in models]
        ses = [scores.fits[m][name].se * factor for m in models]
        data[name] = xr.Variable(("model",), vals, {"units": unit, "long_name": long})
        data[f"{name}_standard_error"] = xr.Variable(
            ("model",), ses, {"units": unit, "long_name": f"standard error of the {long}"})
        key = RATIOS[name]
        what = "spin-rate change" if name == "spin_rate_slope" else long.split(" (")[0]
        data[key] = xr.Variable(
            ("formulation",), [scores.ratios[f][key] for f in formulations],
            {"units": "1",
             "long_name": f"{what}, reduced / full order (NaN: full order not distinguishable "
                          f"from 0)"})  # fmt: skip
    length = scores.interval.end_s - scores.interval.start_s
    data["spin_rate_change"] = xr.Variable(
        ("model",), [scores.fits[m]["spin_rate_slope"].slope * length for m in models],
        {"units": "rad/s", "long_name": "fitted spin-rate change over the quasi-steady part"})
    for key, value, long in (
        ("quasi_steady_start", scores.interval.start_s, "start t_s of the quasi-steady part"),
        ("quasi_steady_end", scores.interval.end_s, "end T of the quasi-steady part"),
        ("transient_decay_time", scores.interval.decay_time_s,
         "slowest decay time 1/min(zeta_i omega_i) of the retained modes"),
    ):  # fmt: skip
        data[key] = xr.Variable((), value, {"units": "s", "long_name": long})
    return data
