"""The path's validity, its ``until`` event and its times to given cone angles in ``results.nc``
and the summary (:mod:`quadmodes.runs.results` calls these; the summary is read back from the
dataset alone, as the rest of it).

Variables: ``modal_amplitude`` (time; m for modes of 1 kg modal mass), ``centrifugal_departure``
(time; 1; about a spinning state: the sample's own model's, a spin-family path's member),
``model_reference_spin`` (time; rad/s; a spin-family path: the spin of the member that integrated
each sample, :mod:`quadmodes.runs.family_samples`), ``model_in_range`` (time; 1 until the path
leaves the model's range, then 0), ``time_to_cone`` (cone_mark; s, NaN if not reached) on the coordinate
``cone_mark`` (degree). Attributes: ``path_*`` (:class:`~quadmodes.runs.path_validity.PathValidity`)
(every failing check: ``path_failure_times`` s and ``path_failure_reasons``, one a line) and
``until_*`` (:class:`~quadmodes.runs.events.EventHit`), units in ``*_units`` attributes.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from quadmodes.io import cf
from quadmodes.rom import system as rsys
from quadmodes.runs.centrifugal_load import departure_kind, load_departure, load_departure_about
from quadmodes.runs.events import cone_times
from quadmodes.runs.family_samples import (
    MEMBER_SPIN_LONG_NAME,
    MEMBER_SPIN_VARIABLE,
    is_family,
    sample_member_spins,
)


def path_variables(result) -> tuple[dict, dict]:
    """(data variables, coordinates) of the path's validity and cone times of a run result."""
    t = np.asarray(result.solution.t, float)
    _, w, s, _ = rsys.split_state(result.system, np.asarray(result.solution.y, float))
    amp = np.linalg.norm(s, axis=1) if s.shape[1] else np.zeros(len(t))
    data = {"modal_amplitude": cf.modal_variable(
        ("time",), amp, "m", "kg^0.5 m", "norm of the modal coordinates |s| (modes normalised "
        "to 1 kg)")}  # fmt: skip
    w_ref = np.asarray(result.system.reference_omega, float)
    if np.any(w_ref):
        data["centrifugal_departure"] = cf.variable(
            ("time",), _departure(result, w), "1", "departure of the centrifugal load "
            "from the reduced model's reference, |C(omega) - C(omega_ref)|_2 / Omega_ref^2 "
            f"({departure_kind(result.system)})")  # fmt: skip
    if is_family(result.run):  # which member's chart each sample is in
        data[MEMBER_SPIN_VARIABLE] = cf.variable(
            ("time",), _member_spins(result), "rad/s", MEMBER_SPIN_LONG_NAME)
    path = getattr(result, "path", None)
    if path is not None and path.tension_samples:
        when, least = path.tension_samples
        series = np.full(len(t), np.nan)
        series[np.searchsorted(t, when)] = np.where(np.isfinite(least), least, np.nan)
        data["membrane_least_tension"] = cf.variable(
            ("time",), series, "N/m", "least minor principal stress resultant of the membrane "
            "elements taut at the reference (exact strain of the manifold displacement; NaN: "
            "sample not checked, or its deformation round-off)")  # fmt: skip
    if path is not None:
        inside = t < path.left_at if path.left_at is not None else np.ones(len(t), bool)
        data["model_in_range"] = cf.variable(
            ("time",), inside.astype(np.int8), "1", "1 while the path is inside the reduced "
            "model's range by the checks made (attribute path_checked), then 0")  # fmt: skip
    marks = cone_times(t, result.diagnostics.cone_angle)
    coords = {"cone_mark": cf.coordinate("cone_mark", np.array(list(marks), float), "degree",
                                         "cone angle mark")}  # fmt: skip
    data["time_to_cone"] = cf.variable(("cone_mark",), np.array(list(marks.values()), float), "s",
                                       "first time the cone angle reaches the mark (NaN: not reached)")  # fmt: skip
    return data, coords


def _member_spins(result) -> np.ndarray:
    """(k,) rad/s: the spin of the model that integrated each sample (one model: its own)."""
    return sample_member_spins(result.solution.t, float(result.model.reference_spin),
                               getattr(result, "family", ()))  # fmt: skip


def _departure(result, w: np.ndarray) -> np.ndarray:
    """δ (k,) of the angular velocities ``w`` (k,3): against the sample's own model's reference
    (a spin-family path: each member's spin about the reference axis)."""
    if not is_family(result.run):
        return load_departure(result.system, w)
    w_ref = np.asarray(result.system.reference_omega, float)
    e = w_ref / np.linalg.norm(w_ref)
    spins = _member_spins(result)
    out = np.empty(len(w))
    for spin in np.unique(spins):
        k = spins == spin
        ref = spin * e
        out[k] = load_departure_about(result.system, w[k], ref)
    return out


def _nan(x) -> float:
    return math.nan if x is None else float(x)


def path_attrs(result) -> dict:
    """Global attributes: the path's validity (``path_*``) and the ``until`` event (``until_*``)."""
    attrs: dict = {}
    path = getattr(result, "path", None)
    if path is not None:
        attrs.update(
            path_valid=int(path.valid), path_checked="; ".join(path.checked),
            path_unchecked="; ".join(path.unchecked), path_message=path.message(),
            path_left_at=_nan(path.left_at), path_left_at_units="s",
            path_left_spin_rate=float(path.left_spin), path_left_spin_rate_units="rad/s",
            path_left_cone_angle=float(path.left_cone), path_left_cone_angle_units="rad",
            path_left_reason=path.left_reason,
            centrifugal_departure_max=float(path.centrifugal_max),
            centrifugal_departure_limit=float(path.centrifugal_limit),
            path_spin_range=np.asarray(path.spin_range, float), path_spin_range_units="rad/s",
            path_min_rotating_stiffness=float(path.min_stiffness),
            path_min_rotating_stiffness_units="s^-2",
            path_modal_amplitude_peak=float(path.amplitude_peak),
            path_modal_amplitude_peak_units="m",
            path_modal_amplitude_peak_time=float(path.amplitude_peak_time),
            path_modal_amplitude_error=float(path.amplitude_error),
            path_slack_onset_fraction=float(path.amplitude_slack_fraction),
            path_least_tension=float(path.least_tension), path_least_tension_units="N/m",
            path_slack_area=float(path.slack_area),
            path_reference_slack_area=float(path.reference_slack_area),
            path_slack_where=path.slack_where,
            path_taut=-1 if path.taut is None else int(path.taut),
            centrifugal_measured_spin_rate=float(path.measured_spin),
            centrifugal_measured_spin_rate_units="rad/s",
            centrifugal_measured_frequency_error=float(path.measured_error),
            centrifugal_measured_sink_spin_rate=float(path.measured_sink_spin),
            centrifugal_measured_sink_spin_rate_units="rad/s",
            centrifugal_measured_sink_error=float(path.measured_sink_error),
        )  # fmt: skip
        if path.failures:  # every failing check (the first is path_left_*)
            attrs.update(path_failure_times=np.asarray([when for when, _ in path.failures], float),
                         path_failure_times_units="s",
                         path_failure_reasons="\n".join(reason for _, reason in path.failures))  # fmt: skip
    until = result.run.integration.until if result.run.integration is not None else None
    if until:
        hit = getattr(result, "event", None)
        attrs.update(until=until, until_reached=int(hit is not None))
        if hit is not None:
            attrs.update(until_time=hit.time, until_time_units="s", until_step=int(hit.step),
                         until_cone_angle=hit.cone_angle, until_cone_angle_units="rad",
                         until_spin_rate=hit.spin_rate, until_spin_rate_units="rad/s",
                         until_located=hit.located)  # fmt: skip
    return attrs


def _f(ds: xr.Dataset, key: str) -> float | None:
    x = float(ds.attrs.get(key, math.nan))
    return x if math.isfinite(x) else None


def path_summary(ds: xr.Dataset) -> dict:
    """JSON-ready keys: ``valid`` (at the start and along the path), ``valid_at_start``,
    ``path_validity`` {…}, ``until`` {…} and ``time_to_cone_s`` {mark deg: s or None}."""
    out: dict = {}
    if "time_to_cone" in ds:
        out["time_to_cone_s"] = {f"{m:g}": _f_value(v) for m, v in
                                 zip(ds["cone_mark"].values, ds["time_to_cone"].values, strict=True)}  # fmt: skip
    if "path_valid" in ds.attrs:
        start = bool(int(ds.attrs.get("valid", 1)))
        path_ok = bool(int(ds.attrs["path_valid"]))
        left = _f(ds, "path_left_at")
        rng = np.atleast_1d(ds.attrs.get("path_spin_range", [math.nan, math.nan]))
        out.update(valid=start and path_ok, valid_at_start=start, path_validity={
            "valid": path_ok, "checked": _split(ds.attrs.get("path_checked", "")),
            "unchecked": _split(ds.attrs.get("path_unchecked", "")),
            "left_range_at_s": left,
            "left_range_spin_hz": None if left is None else _hz(_f(ds, "path_left_spin_rate")),
            "left_range_cone_deg": None if left is None else _deg(_f(ds, "path_left_cone_angle")),
            "left_range_reason": str(ds.attrs.get("path_left_reason", "")),
            "centrifugal_departure_max": _f(ds, "centrifugal_departure_max"),
            "centrifugal_departure_limit": _f(ds, "centrifugal_departure_limit"),
            "spin_range_hz": [_hz(_f_value(r)) for r in rng],
            "min_rotating_stiffness_s-2": _f(ds, "path_min_rotating_stiffness"),
            "modal_amplitude_peak_m": _f(ds, "path_modal_amplitude_peak"),
            "modal_amplitude_error": _f(ds, "path_modal_amplitude_error"),
            "slack_onset_fraction_of_peak": _f(ds, "path_slack_onset_fraction"),
            "least_tension_n_per_m": _f(ds, "path_least_tension"),
            "slack_area_fraction": _f(ds, "path_slack_area"),
            "reference_slack_area_fraction": _f(ds, "path_reference_slack_area"),
            "slack_where": str(ds.attrs.get("path_slack_where", "")),
            "taut": {1: True, 0: False}.get(int(ds.attrs.get("path_taut", -1))),
            "centrifugal_measured_at_spin_hz": _hz(_f(ds, "centrifugal_measured_spin_rate")),
            "centrifugal_measured_frequency_error": _f(ds, "centrifugal_measured_frequency_error"),
            "centrifugal_measured_sink_at_spin_hz": _hz(_f(ds, "centrifugal_measured_sink_spin_rate")),
            "centrifugal_measured_sink_error": _f(ds, "centrifugal_measured_sink_error"),
            "failures": _failures(ds),
            "message": str(ds.attrs.get("path_message", "")),
        })  # fmt: skip
    if "until" in ds.attrs:
        reached = bool(int(ds.attrs.get("until_reached", 0)))
        out["until"] = {"event": str(ds.attrs["until"]), "reached": reached}
        if reached:
            out["until"].update(time_s=_f(ds, "until_time"), step=int(ds.attrs["until_step"]),
                                cone_angle_deg=_deg(_f(ds, "until_cone_angle")),
                                spin_rate_hz=_hz(_f(ds, "until_spin_rate")),
                                located=str(ds.attrs.get("until_located", "")))  # fmt: skip
    return out


def _failures(ds: xr.Dataset) -> list[dict]:
    """Every failing check of the path: [{"time_s": its first failing sample, "reason"}]."""
    times = np.atleast_1d(ds.attrs.get("path_failure_times", []))
    reasons = [r for r in str(ds.attrs.get("path_failure_reasons", "")).split("\n") if r]
    return [{"time_s": float(when), "reason": reason}
            for when, reason in zip(times, reasons, strict=False)]  # fmt: skip


def _f_value(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def _split(text: str) -> list[str]:
    return [p for p in str(text).split("; ") if p]


def _hz(v: float | None) -> float | None:
    return None if v is None else v / (2 * math.pi)


def _deg(v: float | None) -> float | None:
    return None if v is None else math.degrees(v)
