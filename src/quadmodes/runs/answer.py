"""The answer of a free-body run in ``results.nc`` and its summary: does the spin cone, how fast,
and is it stable.

Two sources, stored side by side as scalar variables (SI, ``units`` pint reads, ``long_name``):

* **the run itself** (:func:`quadmodes.runs.secular.run_fits`): straight lines fitted over the
  quasi-steady part ``[t_s, T]`` of the run, ``t_s = min(max(T/2, kτ), 3T/4)`` with
  ``τ = 1/min(ζ_i ω_i)`` of the retained modes and ``k = ln 100`` (the start-up transient down to
  1 %; the rule is stored as ``quasi_steady_rule``): the **secular cone-growth rate** (slope of
  the cone angle) with its standard error (residual-based, combined with the bound on the slope
  shift an oscillation left in the data can give), the **dissipated power** (slope of the
  dissipated energy) and the simulated coning time constant θ̄/θ̇ (θ̄ the mean cone angle over
  the fit; reported only where the slope is at least 2 standard errors);
* **the linearisation at the spin** (:class:`quadmodes.analysis.run_answer.LinearAnswer`,
  attached to the result by the caller): the **energy-sink estimate** (mean power of the steady
  forced response to the rigid nutation, coning rate σ and **time constant** τ = 1/σ) at the
  initial spin and cone angle (what ``quadmodes sweep … --no-time-run`` computes) and at the
  mean spin and cone angle of the quasi-steady part (``…_at_fit_state``: the state the run's
  fitted rate belongs to; ``time_constant_ratio`` compares the run with it), the damped
  nutation root, and the **stability verdict** with its rule (``stability_rule``).

Pure functions of the run's arrays; the summary reads the dataset alone, so it can be recomputed
from a saved file.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from quadmodes.io import cf
from quadmodes.runs import secular

#: The values of ``spin_stability`` (CF flag_values / flag_meanings).
STABILITY_FLAGS = ("unstable", "stable", "neutral", "unknown")

_FIT_VARIABLES = (
    ("cone_growth_rate", "rad/s", "secular cone-growth rate: least-squares slope of the cone angle "
     "over the quasi-steady part [quasi_steady_start, quasi_steady_end]"),
    ("cone_growth_rate_standard_error", "rad/s", "standard error of the secular cone-growth rate "
     "(residuals and the bound on an oscillation left in the data)"),
    ("simulated_growth_rate", "1/s", "simulated exponential coning rate: secular cone-growth rate "
     "/ mean cone angle over the quasi-steady part"),
    ("simulated_coning_time_constant", "s", "simulated coning time constant: mean cone angle / "
     "secular cone-growth rate over the quasi-steady part (e-folding time; negative: decay)"),
    ("dissipated_power", "W", "mean dissipated power: least-squares slope of the dissipated "
     "energy over the quasi-steady part"),
    ("dissipated_power_standard_error", "W", "standard error of the mean dissipated power"),
    ("spin_rate_slope", "rad/s^2", "spin-rate slope: least-squares slope of the spin rate over "
     "the quasi-steady part"),
    ("quasi_steady_start", "s", "start t_s of the quasi-steady part (rule: quasi_steady_rule)"),
    ("quasi_steady_end", "s", "end T of the quasi-steady part"),
    ("transient_decay_time", "s", "slowest decay time 1/min(zeta_i omega_i) of the retained modes"),
)  # fmt: skip
_LINEAR_VARIABLES = (
    ("energy_sink_power", "W", "energy-sink estimate: mean power dissipated by the steady forced "
     "response to the rigid nutation at the initial cone angle"),
    ("energy_sink_growth_rate", "1/s", "energy-sink estimate of the exponential coning rate "
     "(cone-growth rate / cone angle)"),
    ("coning_time_constant", "s", "coning time constant of the energy-sink law (1 / growth rate; "
     "negative: the cone decays), as quadmodes sweep computes it"),
    ("energy_sink_cone_rate", "rad/s", "energy-sink estimate of the cone-growth rate at the initial "
     "cone angle"),
    ("nutation_frequency", "rad/s", "body-frame nutation rate of the quasi-rigid spinner "
     "(I_a - I_t)/I_t * spin"),
    ("elastic_momentum_ratio", "1", "elastic angular momentum / rigid transverse angular momentum "
     "of the forced response (quasi-rigid: <= 0.1)"),
    ("nutation_growth_rate", "1/s", "real part of the nutation root of the damped linearisation "
     "about the relative equilibrium"),
    ("coning_rate", "1/s", "coning rate sigma the stability verdict used (stability_rule)"),
)  # fmt: skip
_FIT_STATE_VARIABLES = (
    ("coning_time_constant_at_fit_state", "s", "coning time constant of the energy-sink law at the "
     "mean spin rate and cone angle of the quasi-steady part (the state the run's fit sees)"),
    ("energy_sink_power_at_fit_state", "W", "energy-sink estimate of the mean dissipated power at "
     "the mean spin rate and cone angle of the quasi-steady part"),
    ("fit_spin_rate", "rad/s", "mean spin rate over the quasi-steady part"),
    ("fit_cone_angle", "rad", "mean cone angle over the quasi-steady part"),
)  # fmt: skip


def answer_variables(result) -> tuple[dict[str, xr.Variable], dict]:
    """The scalar variables and global attributes of the run's answer (module docstring) for a
    :class:`quadmodes.runs.simulate.RunResult` (its ``linear`` answer, if attached)."""
    d, model = result.diagnostics, result.model
    if len(d.t) < 2:
        return {}, {}
    fits = secular.run_fits(d.t, d.cone_angle, d.E_d, d.spin_rate, model.frequencies_hz,
                            model.damping_ratio)  # fmt: skip
    q = fits.interval
    tau = fits.time_constant if fits.significant else math.nan
    significant = cf.variable((), np.int8(fits.significant), "1", "secular cone growth "
                              "distinguishable from 0 (|slope| >= 2 standard errors, growth over "
                              "the fit >= 1e-10 of the cone angle) (1) or not (0)")  # fmt: skip
    values = (fits.cone.slope, fits.cone.se, fits.growth_rate, tau, fits.power.slope,
              fits.power.se, fits.spin.slope, q.start_s, q.end_s, q.decay_time_s)  # fmt: skip
    data = {k: cf.variable((), v, u, n) for (k, u, n), v in zip(_FIT_VARIABLES, values, strict=True)}
    data["cone_growth_significant"] = significant
    attrs = {"quasi_steady_rule": q.rule}
    lin = getattr(result, "linear", None)
    if lin is not None:
        s = lin.sink
        values = (s.power, s.growth_rate, s.time_constant, s.cone_rate, s.nutation_frequency,
                  s.elastic_momentum_ratio, lin.nutation_growth_rate, lin.coning_rate)  # fmt: skip
        data.update({k: cf.variable((), v, u, n)
                     for (k, u, n), v in zip(_LINEAR_VARIABLES, values, strict=True)})  # fmt: skip
        if lin.fit_sink is not None:
            values = (lin.fit_sink.time_constant, lin.fit_sink.power, lin.fit_spin, lin.fit_cone)
            data.update({k: cf.variable((), v, u, n)
                         for (k, u, n), v in zip(_FIT_STATE_VARIABLES, values, strict=True)})  # fmt: skip
        data["quasi_rigid"] = cf.variable((), np.int8(s.quasi_rigid), "1",
                                          "energy-sink estimate quasi-rigid (1) or not (0)")  # fmt: skip
        flag = cf.variable((), np.int8(STABILITY_FLAGS.index(lin.stability)), "1",
                           "stability of the spin (flag_meanings; rule: stability_rule)")  # fmt: skip
        flag.attrs.update(flag_values=np.arange(len(STABILITY_FLAGS), dtype=np.int8),
                          flag_meanings=" ".join(STABILITY_FLAGS))  # fmt: skip
        data["spin_stability"] = flag
        attrs["stability_rule"] = lin.rule
    return data, attrs


def _get(ds: xr.Dataset, key: str, factor: float = 1.0) -> float | None:
    if key not in ds:
        return None
    x = float(ds[key].values) * factor
    return x if math.isfinite(x) else None


def answer_summary(ds: xr.Dataset) -> dict:
    """JSON-ready answer keys read back from a results dataset (units in the key names); {} if
    it has none. ``time_constant_ratio``: simulated / energy-sink time constant (null where
    either is missing)."""
    if "cone_growth_rate" not in ds:
        return {}
    deg = 180.0 / math.pi
    out = {
        "cone_growth_rate_deg_per_s": _get(ds, "cone_growth_rate", deg),
        "cone_growth_rate_se_deg_per_s": _get(ds, "cone_growth_rate_standard_error", deg),
        "cone_growth_significant": bool(int(ds["cone_growth_significant"])),
        "cone_growth_fit_start_s": _get(ds, "quasi_steady_start"),
        "cone_growth_fit_end_s": _get(ds, "quasi_steady_end"),
        "quasi_steady_rule": str(ds.attrs.get("quasi_steady_rule", "")),
        "simulated_coning_time_constant_s": _get(ds, "simulated_coning_time_constant"),
        "dissipated_power_W": _get(ds, "dissipated_power"),
        "dissipated_power_se_W": _get(ds, "dissipated_power_standard_error"),
    }  # fmt: skip
    if "spin_stability" in ds:
        tau_start = _get(ds, "coning_time_constant")
        tau_fit = _get(ds, "coning_time_constant_at_fit_state")
        tau_run = out["simulated_coning_time_constant_s"]
        out.update({
            "energy_sink_power_W": _get(ds, "energy_sink_power"),
            "energy_sink_power_at_fit_state_W": _get(ds, "energy_sink_power_at_fit_state"),
            "energy_sink_growth_rate_per_s": _get(ds, "energy_sink_growth_rate"),
            "coning_time_constant_s": tau_start,
            "coning_time_constant_at_fit_state_s": tau_fit,
            # the run against the estimate at the state its fit sees, and at the start (sweep's)
            "time_constant_ratio": tau_run / tau_fit if tau_run and tau_fit else None,
            "time_constant_ratio_to_start": tau_run / tau_start if tau_run and tau_start else None,
            "energy_sink_quasi_rigid": bool(int(ds["quasi_rigid"])),
            "elastic_momentum_ratio": _get(ds, "elastic_momentum_ratio"),
            "nutation_growth_rate_per_s": _get(ds, "nutation_growth_rate"),
            "spin_stability": STABILITY_FLAGS[int(ds["spin_stability"])],
            "stability_rule": str(ds.attrs.get("stability_rule", "")),
        })  # fmt: skip
        out["spin_verdict"] = verdict_text(out)
    return out


def _duration(seconds: float) -> str:
    """``seconds`` in s, with years when over a day."""
    s = abs(seconds)
    return f"{s:.4g} s" + (f" ≈ {s / 3.15576e7:.3g} years" if s > 86400.0 else "")


def verdict_text(answer: dict) -> str:
    """One line: the spin's stability, its coning time constant and whether the run saw it."""
    stability, tau = answer["spin_stability"], answer["coning_time_constant_s"]
    if stability == "neutral":
        return "neutral: no dissipation, the cone keeps its angle (energy sink)"
    if stability not in ("stable", "unstable") or tau is None:
        return stability
    what = "grows" if stability == "unstable" else "decays"
    text = f"{stability}: the cone {what}, e-folding time {_duration(tau)} (energy sink)"
    if answer["cone_growth_significant"] and answer["simulated_coning_time_constant_s"]:
        return text + f"; this run: {_duration(answer['simulated_coning_time_constant_s'])}"
    return text + "; too slow for this run to see (its slope is within 2 standard errors of 0)"
