"""Results of a run: a self-describing NetCDF file (``results.nc``) and a JSON summary.

``results.nc`` (xarray, written with h5netcdf) follows the CF conventions as far as they fit
(:mod:`quadmodes.io.cf`): a ``time`` coordinate (s), ``long_name`` and ``units`` (parsed by pint)
on every variable and coordinate, ``Conventions = "CF-1.10"``, the modal coordinates in m for
modes normalised to a modal mass of 1 kg (``mass_normalised_units = "kg^0.5 m"``: the same numbers,
:mod:`quadmodes.io.cf`), axis labels as auxiliary coordinates; global attributes carry the
provenance (the run case TOML ``case_toml``, which embeds a model built in Python, the model
case TOML, ``model_hash``, ``source`` and the package version), the method, step, formulation,
status and work counters and ``complete`` (1/0, with ``incomplete_reason`` when 0). The summary (:func:`summary`) is computed
from the dataset alone, so it can be recomputed from a saved file.

The log decrement of the summary is :func:`quadmodes.signals.log_decrement`, reported for a
free decay only. The run's answer (secular cone-growth rate, dissipated power, energy-sink time
constant, stability) is :mod:`quadmodes.runs.answer`.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.io import cf
from quadmodes.io.atomic import write_text
from quadmodes.io.outputs import write_netcdf
from quadmodes.runs.answer import answer_summary, answer_variables
from quadmodes.runs.path_results import path_attrs, path_summary, path_variables
from quadmodes.runs.sink_consistency import sink_summary, sink_variables
from quadmodes.runs.validity_results import validity_attrs, validity_summary
from quadmodes.signals import log_decrement

FORMAT = "quadmodes-run-results"
FORMAT_VERSION = 1
XYZ = ["x", "y", "z"]
QUAT = ["w", "x", "y", "z"]


_var = cf.variable


def _run_variables(d, q, w, s, sd, pair: tuple[int, ...]) -> dict[str, xr.Variable]:
    """Data variables of ``results.nc``: diagnostics ``d`` (:class:`quadmodes.rom.diagnostics.
    Diagnostics`), the state split into q (nt, 4), ω (nt, 3) rad/s, s and ṡ (nt, N), and the
    amplitude of the bending pair ``pair`` (0-based mode indices; none if empty)."""
    t = ("time",)
    tx = ("time", "xyz")
    data = {
        "angular_momentum": _var(
            tx, d.H, "kg m^2/s", "angular momentum about the centre of mass, inertial frame"
        ),
        "angular_momentum_norm": _var(t, d.H_norm, "kg m^2/s", "magnitude |H|"),
        "kinetic_energy": _var(t, d.T, "J", "kinetic energy of rotation and vibration"),
        "potential_energy": _var(t, d.V, "J", "elastic potential energy 1/2 s^T Lambda s"),
        "total_energy": _var(t, d.E, "J", "total mechanical energy E = T + V"),
        "dissipated_energy": _var(
            t, d.E_d, "J", "energy dissipated by modal damping since t = 0 (integrator's own)"
        ),
        "energy_balance": _var(t, d.E_balance, "J", "E + dissipated energy (constant for Q)"),
        "spin_rate": _var(
            t, d.spin_rate, "rad/s", "spin rate omega . v_a about the tracked minor axis"
        ),
        "spin_rate_hz": _var(t, d.spin_rate / (2 * math.pi), "Hz", "spin rate"),
        "cone_angle": _var(
            t, d.cone_angle, "rad", "angle between H and the instantaneous minor principal axis"
        ),
        "cone_angle_deg": _var(t, np.degrees(d.cone_angle), "degree", "cone angle"),
        "principal_axis": _var(
            tx, d.axis_inertial, "1", "tracked minor principal axis of J~(s), inertial frame"
        ),
        "axial_inertia": _var(t, d.I_a, "kg m^2", "moment of inertia about the tracked axis"),
        "transverse_inertia": _var(
            t, d.I_t, "kg m^2", "mean of the other two principal moments of inertia"
        ),
        **_modal_variables(s, sd),
        "omega_body": _var(tx, w, "rad/s", "angular velocity, body frame"),
        "quaternion": _var(
            ("time", "quat"), q, "1", "attitude quaternion (scalar first), body to inertial"
        ),
    }
    if pair:
        amp = np.sqrt(np.sum(s[:, list(pair)] ** 2, axis=1))
        data["bending_amplitude"] = cf.modal_variable(
            t, amp, "m", "kg^0.5 m", "first bending pair amplitude sqrt(s_b1^2 + s_b2^2) (modes "
            "normalised to 1 kg)"
        )
    return data


def _modal_variables(s, sd) -> dict[str, xr.Variable]:
    """Modal coordinates s and velocities ṡ (nt, N), stated for modes normalised to a modal mass
    of 1 kg (m, m/s; the same numbers as kg^0.5 m, kg^0.5 m/s: :mod:`quadmodes.io.cf`)."""
    tm = ("time", "mode")
    return {
        "modal_coordinates": cf.modal_variable(
            tm, s, "m", "kg^0.5 m", "modal coordinates s (modes normalised to 1 kg modal mass)"),
        "modal_velocities": cf.modal_variable(
            tm, sd, "m/s", "kg^0.5 m/s", "modal velocities ds/dt (modes normalised to 1 kg)"),
    }  # fmt: skip


def _mode_coords(time: np.ndarray, labels: list[str], freqs: np.ndarray) -> dict:
    """Coordinates: time (s), the labels of the xyz and quat dimensions (``xyz_label``,
    ``quat_label``), and the retained modes (number from 1, label, frequency Hz)."""
    n = len(freqs)
    c = cf.coordinate
    return {
        "time": c("time", np.asarray(time, float), "s", "time"),
        **cf.label_coordinate("xyz", XYZ, "Cartesian axis"),
        **cf.label_coordinate("quat", QUAT, "quaternion component"),
        "mode": c("mode", np.arange(1, n + 1), "1", "retained mode number"),
        "mode_label": c("mode", np.array(labels, dtype=object), "1", "mode label"),
        "mode_frequency_hz": c("mode", freqs, "Hz", "natural frequency (not spinning)"),
    }


def _run_attrs(result, n: int) -> dict:
    """Global attributes of ``results.nc`` for a run result with ``n`` retained modes."""
    from quadmodes.runs.initial import largest_nodal_displacement

    sol, run, model = result.solution, result.run, result.model
    pair = result.initial.bending_modes
    stats = sol.stats
    key = str(model.provenance.get("content_key", ""))
    attrs = {
        **cf.provenance(f"quadmodes run {run.name}", key),
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "case": run.name,
        "case_toml": run.to_toml(),
        "model_case": result.model_case.name,
        "model_case_toml": result.model_case.to_toml(),
        "reduced_model_key": key,
        "method": run.integration.method,
        "dt": float(sol.dt) if sol.dt is not None else float(run.integration.dt),
        "dt_units": "s",
        "duration": float(run.integration.duration),
        "save_every": int(run.integration.save_every),
        "rtol": float(run.integration.rtol),
        "formulation": run.reduced.formulation,
        "reference": "spinning" if getattr(model, "reference_spin", 0.0) else "rest",
        "reference_spin": float(getattr(model, "reference_spin", 0.0)),
        "reference_spin_units": "rad/s",
        "n_modes": int(n),
        "damping_ratio": float(model.damping_ratio[0]) if len(model.damping_ratio) else 0.0,
        "status": "complete" if result.complete else "incomplete",
        "integrator_status": int(sol.status),
        "integrator_message": str(sol.message),
        "complete": int(bool(result.complete)),
        "n_steps": int(stats.get("n_steps", 0)),
        "n_rhs": int(stats.get("n_rhs", 0)),
        "n_newton": int(stats.get("n_newton", 0)),
        "n_jac": int(stats.get("n_jac", 0)),
        "wall_s": float(result.wall_s),
        "spin_axis_body": np.asarray(result.initial.spin_axis, float),
        "bending_modes": np.asarray([k + 1 for k in pair], np.int64),
        "comment": "SI units; modal coordinates s in m for modes normalised to a modal mass of "
        "1 kg (kg^0.5 m for quadmodes' phi^T M phi = 1: the same numbers); time in s",
        "modal_normalisation": cf.MODAL_NORMALISATION,
    }
    if pair:
        attrs["bending_displacement_per_unit"] = largest_nodal_displacement(model, pair[0])
        attrs["bending_displacement_per_unit_units"] = "1"  # m per m of modal coordinate
    attrs.update(validity_attrs(getattr(result, "validity", None)))
    attrs.update(mode_choice_attrs(getattr(result, "mode_choice", None)))
    if getattr(run.integration, "step_tolerance", None) is not None:  # runs.step_chunks
        attrs.update(step_tolerance=float(run.integration.step_tolerance),
                     dt_min=float(stats.get("dt_min_s", math.nan)), dt_min_units="s",
                     dt_max=float(stats.get("dt_max_s", math.nan)), dt_max_units="s",
                     n_probe_steps=int(stats.get("n_probe_steps", 0)))  # fmt: skip
    if not result.complete:
        attrs["incomplete_reason"] = result.reason
    if result.notes:
        attrs["notes"] = "; ".join(result.notes)
    return attrs


def to_dataset(result) -> xr.Dataset:
    """The :class:`quadmodes.runs.simulate.RunResult` as an xarray Dataset (SI units)."""
    from quadmodes.rom import system as rsys

    sol, sys, model = result.solution, result.system, result.model
    q, w, s, sd = rsys.split_state(sys, sol.y)
    n = sys.n_modes
    labels = list(model.labels[:n]) if n else []
    freqs = np.asarray(model.frequencies_hz[:n], float)
    data = _run_variables(result.diagnostics, q, w, s, sd, result.initial.bending_modes)
    answer, answer_attrs = answer_variables(result)
    path_data, path_coords = path_variables(result)
    sink_data, sink_coords, sink_attrs = sink_variables(result)  # energy-sink consistency
    ds = xr.Dataset({**data, **answer, **path_data, **sink_data},
                    coords={**_mode_coords(sol.t, labels, freqs), **path_coords, **sink_coords})  # fmt: skip
    ds.attrs.update(_run_attrs(result, n), **answer_attrs)
    ds.attrs.update(path_attrs(result), **sink_attrs)
    return ds


def mode_choice_attrs(choice) -> dict:
    """results.nc attributes of a :class:`quadmodes.runs.mode_choice.ModeChoice` (empty if
    None): ``modes_requested`` ("auto" or N), ``mode_rule`` (one line) and, with "auto",
    ``mode_margin`` (1) and ``mode_cutoff_hz`` (Hz)."""
    if choice is None:
        return {}
    attrs = {"modes_requested": str(choice.requested), "mode_rule": choice.rule}
    if choice.cutoff_hz is not None:
        attrs.update(mode_margin=float(choice.margin), mode_cutoff_hz=float(choice.cutoff_hz))
    return attrs


def write_dataset(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``ds`` to ``path`` (NetCDF4 via h5netcdf) atomically, with the CF attributes
    completed (:func:`quadmodes.io.cf.complete`)."""
    path = Path(path)
    cf.complete(ds)
    return write_netcdf(ds, path, invalid_netcdf=False,
                        encoding=cf.encoding(ds, compress=True))  # ENOSPC: clean


def load_results(path: str | os.PathLike) -> xr.Dataset:
    """Read a ``results.nc`` file into memory."""
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.load()


# ---------------------------------------------------------------------------------------------
# summary
# ---------------------------------------------------------------------------------------------


def _float(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def summary(ds: xr.Dataset) -> dict:
    """JSON-ready summary of a results dataset (see docs/paper-cases.md for the keys)."""
    h = np.asarray(ds["angular_momentum"].values, float)
    hn = np.asarray(ds["angular_momentum_norm"].values, float)
    h0 = float(hn[0]) if len(hn) else float("nan")
    e = np.asarray(ds["total_energy"].values, float)
    ed = np.asarray(ds["dissipated_energy"].values, float)
    t = np.asarray(ds["time"].values, float)
    out: dict = {
        "case": str(ds.attrs.get("case", "")),
        "status": str(ds.attrs.get("status", "")),
        "complete": bool(int(ds.attrs.get("complete", 0))),
        "method": str(ds.attrs.get("method", "")),
        "formulation": str(ds.attrs.get("formulation", "")),
        "dt_s": _float(ds.attrs.get("dt", float("nan"))),
        "t_end_s": _float(t[-1]) if len(t) else None,
        "steps": int(ds.attrs.get("n_steps", 0)),
        **({"step_tolerance": _float(ds.attrs["step_tolerance"]),
            "dt_min_s": _float(ds.attrs.get("dt_min", float("nan"))),
            "dt_max_s": _float(ds.attrs.get("dt_max", float("nan"))),
            "probe_steps": int(ds.attrs.get("n_probe_steps", 0))}
           if "step_tolerance" in ds.attrs else {}),
        "wall_s": _float(ds.attrs.get("wall_s", float("nan"))),
        "H0_kg_m2_s": _float(h0),
        "H_relative_drift": _float(np.max(np.linalg.norm(h - h[0], axis=1)) / h0),
        "H_norm_relative_drift": _float(np.max(np.abs(hn - h0)) / h0),
        "energy_start_J": _float(e[0]),
        "energy_end_J": _float(e[-1]),
        "dissipated_energy_J": _float(ed[-1]),
        "energy_balance_relative_error": _float(
            np.max(np.abs(e + ed - e[0])) / max(abs(e[0]), 1e-300)
        ),
        "spin_rate_start_hz": _float(ds["spin_rate_hz"].values[0]),
        "spin_rate_end_hz": _float(ds["spin_rate_hz"].values[-1]),
        "cone_angle_start_deg": _float(ds["cone_angle_deg"].values[0]),
        "cone_angle_end_deg": _float(ds["cone_angle_deg"].values[-1]),
        "cone_angle_max_deg": _float(np.max(ds["cone_angle_deg"].values)),
    }
    if "bending_amplitude" in ds:
        a = np.asarray(ds["bending_amplitude"].values, float)
        pair = [int(k) for k in np.atleast_1d(ds.attrs.get("bending_modes", []))]
        freqs = ds["mode_frequency_hz"].sel(mode=pair).values
        ld = log_decrement(t, a, float(np.mean(freqs)))
        out.update(
            bending_modes=pair,
            bending_frequency_hz=_float(np.mean(freqs)),
            bending_amplitude_start=_float(a[0]),
            bending_amplitude_max=_float(a.max()),
            bending_amplitude_end=_float(a[-1]),
            # a fit to a forced steady response means nothing: only for a free decay
            log_decrement=ld["log_decrement"] if ld["free_decay"] else None,
            log_decrement_fit_start_s=ld["fit_start_s"],
            log_decrement_fit_end_s=ld["fit_end_s"],
            log_decrement_fit_peaks=ld["fit_peaks"],
        )
        zeta = float(ds.attrs.get("damping_ratio", 0.0))
        out["log_decrement_of_damping"] = _float(2 * math.pi * zeta)
        if not ld["free_decay"]:
            out["log_decrement_note"] = ("not a free decay (the bending pair does not start "
                                         "displaced and decay): no log decrement")  # fmt: skip
    else:
        out.update(log_decrement=None, bending_modes=[])
    out.update(answer_summary(ds))
    out.update(validity_summary(ds))
    out.update(path_summary(ds))  # valid: at the start and along the path
    out.update(sink_summary(ds))  # the energy-sink law against the run, along the path
    out["n_modes"] = int(ds.attrs.get("n_modes", ds.sizes.get("mode", 0)))
    if "reference" in ds.attrs:  # the state the reduced model is expanded about
        out["reference"] = str(ds.attrs["reference"])
        out["reference_spin_hz"] = _float(float(ds.attrs["reference_spin"]) / (2 * math.pi))
    for key in ("modes_requested", "mode_rule", "mode_margin", "mode_cutoff_hz"):
        if key in ds.attrs:
            value = ds.attrs[key]
            out[key] = str(value) if key in ("modes_requested", "mode_rule") else _float(value)
    if not out["complete"]:
        out["incomplete_reason"] = str(ds.attrs.get("incomplete_reason", ""))
    return out


def write_run_data(
    result, directory: str | os.PathLike, extra: dict | None = None
) -> tuple[xr.Dataset, dict]:
    """Write ``results.nc`` and ``summary.json`` of ``result`` into ``directory`` (each
    atomically); returns the dataset and the summary (with ``extra`` keys merged in, e.g.
    ``dt_convergence``, ``mode_convergence``)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    ds = to_dataset(result)
    write_dataset(ds, directory / "results.nc")
    info = summary(ds)
    info.update(extra or {})
    write_text(directory / "summary.json", json.dumps(info, indent=2) + "\n")
    return ds, info


def write_outputs(
    result, directory: str | os.PathLike, plots: bool = True, extra: dict | None = None
) -> dict:
    """Write ``results.nc``, ``summary.json`` (:func:`write_run_data`) and then, if ``plots``,
    the PNG figures of ``result`` into ``directory``; returns the summary."""
    ds, info = write_run_data(result, directory, extra)
    if plots:
        from quadmodes.io.plots import write_plots

        write_plots(ds, directory)
    return info


# ---------------------------------------------------------------------------------------------
# hub-driven spin-up (clamped beam)
# ---------------------------------------------------------------------------------------------

SPINUP_FORMAT = "quadmodes-spinup-results"


def spinup_dataset(run) -> xr.Dataset:
    """The :class:`quadmodes.runs.simulate.SpinupRun` as an xarray Dataset (SI units): hub rate, tip
    displacement (hub frame: axial x, in-plane y, out-of-plane z), modal coordinates."""
    r = run.result
    model = r.model
    n = r.s.shape[1]
    t = ("time",)
    data = {
        "hub_rate": _var(t, r.rate, "rad/s", "prescribed hub rate Omega(t) about z"),
        "tip_displacement": _var(
            ("time", "xyz"), r.tip, "m", "tip displacement U_tip, hub frame (x axial)"
        ),
        "tip_axial": _var(t, r.tip[:, 0], "m", "axial tip displacement (hub x; foreshortening)"),
        "tip_inplane": _var(
            t, r.tip[:, 1], "m", "in-plane tip deflection v (hub y; negative = lag)"
        ),
        "tip_outofplane": _var(t, r.tip[:, 2], "m", "out-of-plane tip deflection (hub z)"),
        **_modal_variables(r.s, r.sdot),
    }
    coords = _mode_coords(r.time, list(model.labels[:n]), np.asarray(model.frequencies_hz[:n]))
    del coords["quat_label"]
    ds = xr.Dataset(data, coords=coords)
    sp = run.run.spinup
    attrs = {
        **cf.provenance(f"quadmodes spin-up {run.run.name}"),
        "format": SPINUP_FORMAT,
        "format_version": FORMAT_VERSION,
        "case": run.run.name,
        "case_toml": run.run.to_toml(),
        "model_case": run.model_case.name,
        "model_case_toml": run.model_case.to_toml(),
        "method": "DOP853",
        "rtol": float(sp.rtol),
        "formulation": r.formulation,
        "n_modes": int(n),
        "omega_s": float(r.omega_s),
        "omega_s_units": "rad/s",
        "ramp_time": float(r.t_ramp),
        "duration": float(sp.duration),
        "peak_tip_deflection": float(r.peak_deflection),
        "peak_time": float(r.peak_time),
        "max_abs_after_spinup": float(r.after_ramp_max),
        "status": r.status,
        "message": r.message,
        "complete": int(run.complete),
        "n_steps": int(r.n_steps),
        "wall_s": float(run.wall_s),
        "comment": "SI units; hub frame, beam along +x, rotation about +z",
        "modal_normalisation": cf.MODAL_NORMALISATION,
    }
    attrs.update(validity_attrs(run.validity))
    if r.omega_0 > 0.0:  # a spin change of a free body on a hub (runs.spin_change)
        attrs.update(omega_0=float(r.omega_0), omega_0_units="rad/s",
                     settling_time=float(r.settling_time), settling_time_units="s",
                     comment="SI units; tip relative to the hub, hub frame: radial x, in-plane "
                     "y (negative = lag), out-of-plane z; hub_rate is the hub's own spin rate",
                     **path_attrs(run))  # fmt: skip
    if not run.complete:
        attrs["incomplete_reason"] = run.reason
    ds.attrs.update(attrs)
    return ds


def spinup_summary(ds: xr.Dataset) -> dict:
    """JSON-ready summary of a spin-up results dataset."""
    t = np.asarray(ds["time"].values, float)
    out = {
        "case": str(ds.attrs.get("case", "")),
        "kind": "spinup",
        "status": str(ds.attrs.get("status", "")),
        "complete": bool(int(ds.attrs.get("complete", 0))),
        "formulation": str(ds.attrs.get("formulation", "")),
        "method": str(ds.attrs.get("method", "")),
        "omega_s_rad_s": _float(ds.attrs.get("omega_s", float("nan"))),
        "ramp_time_s": _float(ds.attrs.get("ramp_time", float("nan"))),
        "t_end_s": _float(t[-1]) if len(t) else None,
        "peak_tip_deflection_m": _float(ds.attrs.get("peak_tip_deflection", float("nan"))),
        "peak_time_s": _float(ds.attrs.get("peak_time", float("nan"))),
        "max_abs_after_spinup_m": _float(ds.attrs.get("max_abs_after_spinup", float("nan"))),
        "steps": int(ds.attrs.get("n_steps", 0)),
        "wall_s": _float(ds.attrs.get("wall_s", float("nan"))),
        "message": str(ds.attrs.get("message", "")),
    }
    out.update(validity_summary(ds))
    if "omega_0" in ds.attrs:  # a spin change: its start, settling and path
        out.update(omega_0_rad_s=_float(ds.attrs["omega_0"]),
                   settling_time_s=_float(ds.attrs.get("settling_time", float("nan"))))
        out.update(path_summary(ds))
    if not out["complete"]:
        out["incomplete_reason"] = str(ds.attrs.get("incomplete_reason", ""))
    return out


def write_spinup_outputs(run, directory: str | os.PathLike, plots: bool = True) -> dict:
    """Write ``results.nc``, ``summary.json`` and (if ``plots``) ``tip_deflection.png`` of a
    :class:`quadmodes.runs.simulate.SpinupRun` into ``directory``; returns the summary."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    ds = spinup_dataset(run)
    write_dataset(ds, directory / "results.nc")
    info = spinup_summary(ds)
    write_text(directory / "summary.json", json.dumps(info, indent=2) + "\n")
    if plots:
        from quadmodes.io.plots import plot_tip_deflection

        plot_tip_deflection(ds, directory / "tip_deflection.png")
    return info
