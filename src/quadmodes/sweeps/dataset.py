"""The sweep's results as one xarray dataset (``sweep.nc``): a dimension per swept parameter
named after the last key of its path, its coordinate in SI with units; every variable with
``units`` and ``long_name``, ``Conventions`` and the CF attributes of :mod:`quadmodes.io.cf`
(the modal amplitude in m for modes normalised to 1 kg, branches numbered from 1).

Per point: the time run's headline scalars, the energy-sink estimate, the stability scalars;
per point and rotating-frame ``branch`` (padded with NaN / "" where a point has fewer): label,
frequency and real parts of the roots. Critical speeds along the dimension ``critical``.
"""

from __future__ import annotations

import json
import math

import numpy as np
import xarray as xr

from quadmodes._version import __version__
from quadmodes.analysis.full_order_markers import marker_attrs, marker_variables
from quadmodes.io import cf
from quadmodes.sweeps.engine import SweepOutcome, SweepPlan

FORMAT = "quadmodes-sweep"
FORMAT_VERSION = 1

#: (key, units, long name) of the scalar variables per point; bool ones are stored as 0/1.
SCALARS = (
    ("cone_growth_rate", "rad/s", "secular cone-growth rate of the time run (least-squares slope "
     "of the cone angle over the quasi-steady part)"),
    ("cone_growth_rate_standard_error", "rad/s", "standard error of the secular cone-growth rate"),
    ("simulated_growth_rate", "1/s", "simulated exponential coning rate: secular cone-growth "
     "rate / mean cone angle over the quasi-steady part"),
    ("cone_growth_significant", "1", "secular cone-growth rate distinguishable from 0 (|slope| "
     ">= 2 standard errors and a growth over the fit >= 1e-10 of the cone angle)"),
    ("dissipated_power", "W", "mean dissipated power of the time run (slope of the dissipated "
     "energy over the quasi-steady part)"),
    ("spin_rate_change", "rad/s", "fitted spin-rate change over the quasi-steady part"),
    ("max_modal_amplitude", "m", "largest modal amplitude |s_k(t)| of the time run (modes "
     "normalised to 1 kg modal mass)"),
    ("cone_angle_end", "rad", "cone angle at the end of the time run"),
    ("complete", "1", "time run complete (1) or stopped early (0)"),
    ("valid", "1", "rotating-frame stiffness positive definite up to the spin (1) or not (0)"),
    ("path_in_range", "1", "the time run's path stays in its reduced model's range (1: no check "
     "made along the path fails) or leaves it (0)"),
    ("path_left_range_at", "s", "time at which the time run's path leaves its reduced model's "
     "range (NaN: it does not)"),
    ("path_valid", "1", "the time run valid along its whole path: every check made and passed (a "
     "sweep does not check the modal amplitudes against the FE model: 0 at every point)"),
    ("energy_sink_power", "W", "energy-sink estimate: mean power dissipated by the steady forced "
     "response to the rigid nutation at the given cone angle"),
    ("energy_sink_cone_rate", "rad/s", "energy-sink estimate of the cone-growth rate at the "
     "given cone angle"),
    ("energy_sink_growth_rate", "1/s", "energy-sink estimate of the exponential coning rate "
     "(cone-growth rate / cone angle)"),
    ("coning_time_constant", "s", "coning time constant of the energy-sink law (1 / growth rate; "
     "negative: the cone decays)"),
    ("nutation_frequency", "rad/s", "body-frame nutation rate of the quasi-rigid spinner "
     "(I_a - I_t)/I_t * spin"),
    ("elastic_momentum_ratio", "1", "elastic angular momentum / rigid transverse angular momentum "
     "of the forced response"),
    ("quasi_rigid", "1", "energy-sink estimate quasi-rigid (elastic momentum ratio <= 0.1)"),
    ("nutation_growth_rate", "1/s", "real part of the nutation root of the damped linearisation "
     "about the relative equilibrium"),
    ("min_rotating_stiffness", "1/s^2", "smallest eigenvalue of the rotating-frame stiffness "
     "Lambda - omega^T J2 omega"),
    ("unstable_undamped", "1", "undamped linearisation has a root with positive real part"),
    ("n_modes", "1", "number of elastic modes of the reduced model"),
    ("wall_s", "s", "wall time of the point on its worker"),
)  # fmt: skip
#: (key, units, long name) of the per-branch variables.
BRANCHES = (
    ("branch_frequency", "rad/s", "rotating-frame frequency |Im lambda| of the undamped "
     "linearisation, per branch"),
    ("branch_growth_undamped", "1/s", "real part of the undamped root, per branch"),
    ("branch_growth", "1/s", "real part of the damped root (stability), per branch"),
)  # fmt: skip


def _dims(plan: SweepPlan) -> tuple[list[str], dict, list[int]]:
    """(dimension names, coordinates, shape)."""
    swept = plan.swept
    if not swept:
        return [], {}, []
    def coord(p, dim):
        values = np.asarray(p.values)
        attrs = {"units": cf.spelling(p.path.unit), "long_name": f"{p.path.text} (swept)",
                 "path": p.path.text}  # fmt: skip
        return xr.Variable((dim,), values, attrs)
    if plan.zipped:
        dim = swept[0].name
        return [dim], {p.name: coord(p, dim) for p in swept}, [len(swept[0].values)]
    return ([p.name for p in swept], {p.name: coord(p, p.name) for p in swept},
            [len(p.values) for p in swept])  # fmt: skip


def _position(plan: SweepPlan, where: tuple[int, ...]) -> tuple[int, ...]:
    return where[:1] if plan.zipped else where


def _scalar_array(plan, results, key, shape) -> np.ndarray:
    arr = np.full(shape, np.nan)
    for p, r in zip(plan.points, results, strict=True):
        if r is not None and r.get(key) is not None:
            arr[_position(plan, p.where)] = float(r[key])
    return arr


def _branch_arrays(plan, results, shape):
    count = max((len(r["branch_label"]) for r in results if r is not None), default=0)
    labels = np.full(shape + [count], "", dtype=object)
    arrays = {key: np.full(shape + [count], np.nan) for key, _, _ in BRANCHES}
    for p, r in zip(plan.points, results, strict=True):
        if r is None:
            continue
        pos = _position(plan, p.where)
        n = len(r["branch_label"])
        labels[pos + (slice(0, n),)] = r["branch_label"]
        for key in arrays:
            arrays[key][pos + (slice(0, n),)] = r[key]
    return labels.astype(str), arrays


def _critical_variables(plan: SweepPlan, critical: list[dict]) -> dict:
    dim = ("critical",)
    data = {
        "critical_speed": xr.Variable(dim, [c["spin"] for c in critical], {
            "units": "rad/s", "long_name": "critical speed: spin rate where a rotating-frame "
            "branch passes through zero (divergence) or two branches merge (flutter)"}),
        "critical_speed_hz": xr.Variable(dim, [c["spin"] / (2 * math.pi) for c in critical],
                                         {"units": "Hz", "long_name": "critical speed in Hz"}),
        "critical_speed_kind": xr.Variable(dim, np.array([c["kind"] for c in critical], str), {
            "units": "1", "long_name": "kind of critical speed (divergence, flutter)"}),
        "critical_speed_branch": xr.Variable(dim, np.array([c["branch"] for c in critical], str),
                                             {"units": "1", "long_name": "branch label"}),
        "critical_speed_partner": xr.Variable(dim, np.array([c["partner"] for c in critical],
                                              str), {"units": "1", "long_name":
                                                     "partner branch of a flutter merge"}),
        "critical_speed_bracket_width": xr.Variable(dim, [c["bracket_width"] for c in critical], {
            "units": "rad/s", "long_name": "width of the sweep interval that bracketed it"}),
    }  # fmt: skip
    for p in plan.swept:
        if p.path.keys == ("initial", "spin_rate"):
            continue
        vals = [c["values"].get(p.name, np.nan) for c in critical]
        data[f"{p.name}_at_critical"] = xr.Variable(dim, np.asarray(vals), {
            "units": cf.spelling(p.path.unit), "long_name": f"{p.path.text} of the critical speed"})
    return data


def sweep_dataset(plan: SweepPlan, outcome: SweepOutcome, command: str = "") -> xr.Dataset:
    """The dataset of a finished (or partly failed) sweep (module docstring)."""
    dims, coords, shape = _dims(plan)
    results = outcome.results
    data = {}
    for key, units, long in SCALARS:
        data[key] = xr.Variable(dims, _scalar_array(plan, results, key, shape),
                                {"units": units, "long_name": long})
    data["max_modal_amplitude"].attrs["mass_normalised_units"] = "kg^0.5 m"  # io.cf
    failed = np.zeros(shape, np.int8)
    for p, r in zip(plan.points, results, strict=True):
        failed[_position(plan, p.where)] = r is None
    data["failed"] = xr.Variable(dims, failed, {"units": "1", "long_name": "point failed (1)"})
    labels, arrays = _branch_arrays(plan, results, shape)
    data["branch_label"] = xr.Variable(dims + ["branch"], labels,
                                       {"units": "1", "long_name": "rotating-frame branch label"})
    for key, units, long in BRANCHES:
        data[key] = xr.Variable(dims + ["branch"], arrays[key], {"units": units, "long_name": long})
    data.update(_critical_variables(plan, outcome.critical))
    attrs = {**cf.provenance(f"quadmodes sweep of {plan.run.name}"),
             "modal_normalisation": cf.MODAL_NORMALISATION,
             "format": FORMAT, "format_version": FORMAT_VERSION, "quadmodes_version": __version__,
             "run_case_toml": plan.run.to_toml(), "model_case_toml": plan.model_case.to_toml(),
             "parameters": json.dumps([{"path": p.path.text, "name": p.name,
                                        "values": list(p.values), "units": p.path.unit}
                                       for p in plan.params]),
             "zipped": int(plan.zipped), "time_run": int(plan.time_run), "command": command,
             "failures": json.dumps(outcome.failures), "points": len(plan.points),
             "points_resumed": outcome.resumed}  # fmt: skip
    if outcome.full_order is not None:
        data.update(marker_variables(outcome.full_order))
        attrs.update(marker_attrs(outcome.full_order))
    if outcome.full_order_failures:
        attrs["full_order_failures"] = json.dumps(outcome.full_order_failures)
    coords["branch"] = cf.coordinate("branch", np.arange(1, labels.shape[-1] + 1), "1",
                                     "branch number (from 1, as campbell.nc)")
    return cf.complete(xr.Dataset(data, coords=coords, attrs=attrs))


def _finite_or_none(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _full_order_summary(ds: xr.Dataset) -> list[dict]:
    """Per full-order spin (Hz) its roots (Hz) with the branch each matched."""
    if "full_order_frequency" not in ds:
        return []
    out = []
    for i, spin in enumerate(ds["full_order_spin"].values):
        f = ds["full_order_frequency"].values[i]
        roots = [{"branch": str(ds["full_order_branch_label"].values[i, j]),
                  "matched": bool(ds["full_order_matched"].values[i, j]),
                  "frequency_hz": float(f[j]) / (2 * math.pi),
                  "relative_error": (_finite_or_none(ds["full_order_relative_error"].values[i, j])
                                     if ds["full_order_matched"].values[i, j] else None)}
                 for j in range(f.size) if np.isfinite(f[j])]  # fmt: skip
        out.append({"spin_hz": float(spin) / (2 * math.pi), "roots": roots})
    return out


def summary(ds: xr.Dataset, outcome: SweepOutcome) -> dict:
    """JSON-ready summary: point counts, failures, critical speeds (Hz) with branches."""
    crit = [{"spin_hz": c["spin"] / (2 * math.pi), "kind": c["kind"], "branch": c["branch"],
             "partner": c["partner"], "entering": c["entering"], **c.get("values", {})}
            for c in outcome.critical]  # fmt: skip
    return {"points": int(ds.attrs["points"]), "resumed": outcome.resumed,
            "failed": len(outcome.failures), "failures": outcome.failures,
            "critical_speeds": crit, "wall_s": outcome.wall_s,
            "full_order": _full_order_summary(ds),
            "full_order_failures": outcome.full_order_failures,
            "lost_workers": list(getattr(outcome, "lost_workers", [])),
            "dimensions": {k: int(v) for k, v in ds.sizes.items()}}  # fmt: skip
