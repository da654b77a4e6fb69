"""The reduced formulations side by side with the full-order reference on one window.

``compare(run, window)`` integrates the run case with each reduced formulation (``rigid``,
``L``, ``P``, ``Q``: :mod:`quadmodes.rom.dynamics`) and the full-order finite-element transient
(:mod:`quadmodes.fullorder`) from the same initial state over ``[0, window]``, reduces every
model to the same few time series (:class:`Series`) and measures each formulation against the
full order.

Error measures (all relative, dimensionless; the full order is the reference ``F``):

* ``envelope_error``: the modal amplitude ``a(t) = ‖s(t)‖`` (all retained modes, √kg·m;
  for the full order the M-projection of its displacement in the best-fit body frame onto the
  same modes) reduced to its peak envelope (maximum over consecutive windows of one period of
  the lowest retained mode, :func:`quadmodes.runs.results.peak_envelope`);
  ``max |env_R − env_F| / max env_F`` over the full order's envelope times. A model without
  elastic modes (rigid) scores 1.
* ``cone_angle_error``: ``max |θ_R − θ_F| / max θ_F`` (θ the cone angle, theory.md §6).
* ``cone_angle_change_error``: the error of the change over the window,
  ``|Δθ_R(T) − Δθ_F(T)| / max_t |Δθ_F(t)|`` with ``Δθ(t) = θ(t) − θ(0)``: this is what
  dissipation-driven coning growth is about, and it is far more demanding than the angle itself.
* ``spin_rate_error``: ``max |ω_R − ω_F| / ω_F(0)``; ``spin_rate_change_error`` as for θ.
* Long-window scores (:mod:`quadmodes.runs.secular`): straight-line fits over the
  quasi-steady part ``[t_s, T]`` of the window of the cone angle (secular cone-growth rate,
  deg/s), of E_d (mean dissipated power, W) and of the spin rate (rad/s²; its change over the
  interval, rad/s), each with a standard error, and the ratios reduced / full
  (``cone_growth_ratio``, ``dissipated_power_ratio``, ``spin_rate_change_ratio``; null with a
  note when the full order's slope is not distinguishable from 0). ``t_s`` follows a rule fixed
  before fitting (the decay time of the initial-condition transient, ``secular`` docstring) and
  is the same for every model.
* ``wall_s``: integration wall time of the model (s; the reduced model's precomputation is
  paid once and cached, so it is reported apart as ``reduce_wall_s``); ``speedup`` = full-order
  wall time / reduced wall time.

Reduced series are interpolated linearly onto the full order's sample times where two series
are compared point by point; both are sampled at the same interval by default.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.analysis.path_point import reduced_run_from, start_attributes
from quadmodes.io import cf
from quadmodes.io.atomic import atomic_path, write_text
from quadmodes.rom import system as rsys
from quadmodes.runs import secular
from quadmodes.signals import peak_envelope

#: Formulations compared by default, in table order.
FORMULATIONS = ("rigid", "L", "P", "Q", "Q4")
#: Formulations that may be requested (Q4: Q with the quartic manifold potential; QM: the
#: manifold's exact kinetic energy, numpy only, so not run by default).
AVAILABLE = (*FORMULATIONS, "QM")


def default_formulations(run) -> tuple[str, ...]:
    """The formulations compared when none are asked for: :data:`FORMULATIONS` and the run
    case's own ``reduced.formulation`` if it is not among them (QM: a QM run is compared as
    itself, beside the others)."""
    own = run.reduced.formulation
    return FORMULATIONS if own in FORMULATIONS else (*FORMULATIONS, own)

Progress = Callable[[str, float], None]


@dataclass(frozen=True, eq=False)
class Series:
    """The compared time series of one model (k samples, SI units).

    t (k,) s; amplitude (k,) √kg·m = ‖s‖; cone_angle (k,) rad; spin_rate (k,) rad/s;
    H_norm (k,) kg m²/s; E (k,) J total energy; E_d (k,) J dissipated since t = 0;
    wall_s: integration wall time (s); complete / reason: whether the run reached the end."""

    name: str
    t: np.ndarray
    amplitude: np.ndarray
    cone_angle: np.ndarray
    spin_rate: np.ndarray
    H_norm: np.ndarray
    E: np.ndarray
    E_d: np.ndarray
    wall_s: float
    complete: bool = True
    reason: str = ""
    stats: dict = field(default_factory=dict)


def series_from_run(name: str, result) -> Series:
    """:class:`Series` of a reduced :class:`quadmodes.runs.simulate.RunResult`."""
    d, sys = result.diagnostics, result.system
    _, _, s, _ = rsys.split_state(sys, result.solution.y)
    amp = np.linalg.norm(s, axis=1) if s.shape[1] else np.zeros(len(d.t))
    return Series(
        name=name,
        t=np.asarray(d.t, float),
        amplitude=amp,
        cone_angle=np.asarray(d.cone_angle, float),
        spin_rate=np.asarray(d.spin_rate, float),
        H_norm=np.asarray(d.H_norm, float),
        E=np.asarray(d.E, float),
        E_d=np.asarray(d.E_d, float),
        wall_s=float(result.wall_s),
        complete=bool(result.complete),
        reason=result.reason,
        stats={k: v for k, v in result.solution.stats.items() if np.isscalar(v)},
    )


def series_from_full_order(sol) -> Series:
    """:class:`Series` of a :class:`quadmodes.fullorder.FullOrderSolution`."""
    s = np.asarray(sol.modal_coordinates, float)
    return Series(
        name="full",
        t=np.asarray(sol.t, float),
        amplitude=np.linalg.norm(s, axis=1) if s.ndim == 2 and s.shape[1] else np.zeros(len(sol.t)),
        cone_angle=np.asarray(sol.cone_angle, float),
        spin_rate=np.asarray(sol.spin_rate, float),
        H_norm=np.asarray(sol.H_norm, float),
        E=np.asarray(sol.E, float),
        E_d=np.asarray(sol.E_d, float),
        wall_s=float(sol.stats.get("wall_s", float("nan"))),
        complete=sol.status == 0,
        reason="" if sol.status == 0 else sol.message,
        stats={k: v for k, v in sol.stats.items() if np.isscalar(v)},
    )


def envelope(series: Series, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Peak envelope (times (m,) s, values (m,) √kg·m) of the modal amplitude."""
    return peak_envelope(series.t, series.amplitude, period)


def _on(t_ref: np.ndarray, t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``y`` sampled at ``t`` interpolated onto ``t_ref`` (NaN outside the sampled span)."""
    out = np.interp(t_ref, t, y)
    out[(t_ref < t[0] - 1e-12) | (t_ref > t[-1] + 1e-12)] = np.nan
    return out


def _max_rel(diff: np.ndarray, scale: float) -> float:
    if not np.isfinite(diff).any() or not scale > 0:
        return float("nan")
    return float(np.nanmax(np.abs(diff)) / scale)


def errors(rom: Series, ref: Series, period: float) -> dict[str, float]:
    """Error measures of ``rom`` against ``ref`` (see the module docstring)."""
    out: dict[str, float] = {}
    te, ef = envelope(ref, period)
    if rom.amplitude.any():
        tr, er = envelope(rom, period)
        er_on = _on(te, tr, er) if len(tr) >= 2 else np.full_like(ef, np.nan)
        out["envelope_error"] = _max_rel(er_on - ef, float(np.max(ef)) if len(ef) else 0.0)
    else:
        out["envelope_error"] = 1.0 if len(ef) and np.max(ef) > 0 else 0.0
    t = ref.t
    for key, scale_of in (("cone_angle", np.max), ("spin_rate", lambda y: abs(y[0]))):
        r = _on(t, rom.t, getattr(rom, key))
        f = getattr(ref, key)
        out[f"{key}_error"] = _max_rel(r - f, float(scale_of(f)))
        df = f - f[0]
        dr = r - r[0]
        last = np.flatnonzero(np.isfinite(dr))
        if len(last) == 0:
            out[f"{key}_change_error"] = float("nan")
            continue
        i = last[-1]
        out[f"{key}_change_error"] = _max_rel(np.array([dr[i] - df[i]]), float(np.max(np.abs(df))))
    return out


# ---------------------------------------------------------------------------------------------
# running the comparison
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Comparison:
    """A finished comparison: the run case (with the window as its duration), the full-order
    series, the reduced series by formulation, the error table, the lowest retained frequency
    (Hz, sets the envelope window), timing of the shared precomputation (s) and the long-window
    scores (:class:`quadmodes.runs.secular.SecularScores`)."""

    run: object
    full: Series
    reduced: dict[str, Series]
    table: dict[str, dict[str, float]]
    lowest_frequency_hz: float
    reduce_wall_s: float
    full_order_dt: float
    notes: tuple[str, ...] = ()
    secular: secular.SecularScores | None = None
    start: dict | None = None  # the reduced path point both sides start from (path_point)

    def as_json(self) -> dict:
        """The table as the JSON payload of ``quadmodes compare --json`` (undefined numbers,
        e.g. an envelope error on a window shorter than two periods, are null)."""
        return _json_safe({
            "case": self.run.name,
            "window_s": float(self.run.integration.duration),
            "full_order": {
                "wall_s": self.full.wall_s,
                "dt_s": self.full_order_dt,
                "complete": self.full.complete,
                "reason": self.full.reason,
                "steps": int(self.full.stats.get("n_steps", 0)),
                "newton_iterations": int(self.full.stats.get("n_newton", 0)),
                "factorisations": int(self.full.stats.get("n_factor", 0)),
                "cone_angle_start_deg": math.degrees(self.full.cone_angle[0]),
                "cone_angle_end_deg": math.degrees(self.full.cone_angle[-1]),
                "spin_rate_start_hz": self.full.spin_rate[0] / (2 * math.pi),
                "spin_rate_end_hz": self.full.spin_rate[-1] / (2 * math.pi),
                "H_relative_drift": _drift(self.full.H_norm),
                "damped_modes": int(self.full.stats.get("damped_modes", 0)),
                "damping_cutoff_hz": float(self.full.stats.get("damping_cutoff_hz", math.nan)),
            },
            "reduce_wall_s": self.reduce_wall_s,
            "reduced_model": {  # what the reduced runs used ("auto" resolved to N)
                "modes": self.run.reduced.modes,
                "reference": self.run.reduced.reference,
                "spin_rate_hz": float(self.run.initial.spin_rate) / (2 * math.pi),
            },
            "quasi_steady": self.secular.as_json() if self.secular else None,
            "start": self.start,  # null: the run's initial state
            "formulations": {k: dict(v) for k, v in self.table.items()},
            "notes": list(self.notes),
        })


def _json_safe(obj):
    """``obj`` with non-finite floats replaced by None (strict JSON has no NaN)."""
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer | np.bool_):
        return obj.item()
    return obj


def _drift(h: np.ndarray) -> float:
    return float(np.max(np.abs(h - h[0])) / h[0]) if len(h) and h[0] > 0 else float("nan")


def window_run(run, window: float, formulation: str | None = None):
    """``run`` with ``integration.duration = window`` (s) and, if given, the formulation."""
    integ = run.integration.model_copy(update={"duration": float(window)})
    update = {"integration": integ}
    if formulation is not None:
        update["reduced"] = run.reduced.model_copy(update={"formulation": formulation})
    return run.model_copy(update=update)


def run_reduced(run, formulations=FORMULATIONS, progress: Progress | None = None,
                y_start: np.ndarray | None = None):  # fmt: skip
    """Reduced runs of ``run`` (its modes resolved: a whole ``reduced.modes``, as
    :func:`compare` gives it) per formulation: ``({name: RunResult}, reduce_wall_s)``, from the
    run's initial state or from the reduced state ``y_start`` (7+2N,) (a point of a reduced
    path; the rigid formulation takes its attitude and angular velocity).

    The reduced model is built (or loaded from the cache) once; its time is returned apart."""
    from quadmodes.models.build import reduced_model_for
    from quadmodes.rom import integrators
    from quadmodes.runs import simulate

    kernel = integrators.numba_kernel()
    if kernel is not None:  # load the compiled kernel before any timing
        kernel.warm_up()
    start = time.perf_counter()
    model = reduced_model_for(
        run.model_case(), run.reduced.modes, progress, spin=run.reference_spin,
        axis=run.reference_axis,
    )
    reduce_wall = time.perf_counter() - start
    results = {}
    for name in formulations:
        sub = window_run(run, run.integration.duration, name)
        results[name] = (simulate.simulate(sub, model=model) if y_start is None
                         else reduced_run_from(sub, model, y_start))  # fmt: skip
        if progress:
            progress(f"reduced {name}", 1.0)
    return results, reduce_wall


def compare(
    run,
    window: float,
    *,
    formulations=FORMULATIONS,
    full_order_dt: float | None = None,
    full_order: Callable | None = None,
    progress: Progress | None = None,
    start=None,
) -> Comparison:
    """Compare ``formulations`` of run case ``run`` with the full order over ``[0, window]`` s.

    ``full_order(run, dt) -> FullOrderSolution`` runs the reference (default:
    :func:`quadmodes.analysis.full_order_runs.full_order_for_run` with the run's initial state);
    ``full_order_dt`` its step (default: the run's step). ``start``: a reduced path's
    :class:`~quadmodes.analysis.path_point.PathPoint` (``full_order`` starts there too)."""
    unknown = [f for f in formulations if f not in AVAILABLE]
    if unknown:
        raise ValueError(
            f"--formulations: unknown {', '.join(unknown)}; choose from {', '.join(AVAILABLE)}"
        )
    if not window > 0:
        raise ValueError("--window: must be a positive duration, e.g. \"1 s\"")
    from quadmodes.runs.mode_choice import resolve_modes

    # "auto" → N modes, once for the reduced runs and the full order (a resolved run, e.g. from
    # quadmodes.analysis.comparison_run.prepare_comparison, is kept as it is)
    run, _ = resolve_modes(window_run(run, window), progress=progress)
    dt_full = float(full_order_dt or run.integration.dt)
    roms, reduce_wall = run_reduced(run, formulations, progress,
                                    None if start is None else start.y)  # fmt: skip
    if full_order is None:
        from quadmodes.analysis.full_order_runs import full_order_for_run

        def full_order(r, dt):
            return full_order_for_run(r, dt=dt, progress=progress)

    full_sol = full_order(run, dt_full)
    full = series_from_full_order(full_sol)
    model = roms[formulations[-1]].model
    freqs = model.frequencies_hz[: run.reduced.modes]
    f_low = float(np.min(freqs)) if len(freqs) else 1.0
    tau = secular.decay_time(freqs, model.damping_ratio[: run.reduced.modes])
    reduced = {name: series_from_run(name, r) for name, r in roms.items()}
    table = {}
    for name, ser in reduced.items():
        row = errors(ser, full, 1.0 / f_low)
        row["wall_s"] = ser.wall_s
        row["speedup"] = full.wall_s / ser.wall_s if ser.wall_s > 0 else float("nan")
        row["complete"] = ser.complete
        row["steps_per_s"] = ser.stats.get("n_steps", 0) / ser.wall_s if ser.wall_s > 0 else None
        table[name] = row
    scores = secular.score(full, reduced, secular.quasi_steady_interval(window, tau))
    for name in table:
        table[name].update(scores.row(name))
    notes = [full_sol.damping] if getattr(full_sol, "damping", "") else []
    if not full.complete:
        notes.append(f"full order stopped early: {full.reason}")
    notes.extend(scores.notes)
    if start is not None:
        notes.insert(0, start.describe())
    return Comparison(run, full, reduced, table, f_low, reduce_wall, dt_full, tuple(notes),
                      scores, None if start is None else start.as_json())  # fmt: skip


# ---------------------------------------------------------------------------------------------
# outputs
# ---------------------------------------------------------------------------------------------

_SERIES_VARS = {
    "modal_amplitude": ("amplitude", "m", "modal amplitude ‖s‖ over the retained modes (modes "
                        "normalised to 1 kg modal mass)"),
    "cone_angle": ("cone_angle", "rad", "angle between H and the tracked minor principal axis"),
    "spin_rate": ("spin_rate", "rad/s", "angular velocity about the tracked principal axis"),
    "angular_momentum_norm": ("H_norm", "kg m^2/s", "|H| about the centre of mass"),
    "total_energy": ("E", "J", "kinetic + potential energy"),
    "dissipated_energy": ("E_d", "J", "energy dissipated by damping since t = 0"),
}


def to_dataset(cmp: Comparison) -> xr.Dataset:
    """All series on the full order's time grid (reduced ones interpolated), dims
    (model, time), with units; the error table as (formulation, metric) variable."""
    t = cmp.full.t
    models = ["full", *cmp.reduced]
    series = [cmp.full, *cmp.reduced.values()]
    data = {}
    for var, (attr, unit, desc) in _SERIES_VARS.items():
        rows = [getattr(cmp.full, attr)] + [
            _on(t, s.t, getattr(s, attr)) for s in series[1:]
        ]
        data[var] = xr.Variable(("model", "time"), np.vstack(rows), {"units": unit, "long_name": desc})
    data["modal_amplitude"].attrs["mass_normalised_units"] = "kg^0.5 m"  # io.cf: the same numbers
    metrics = ["envelope_error", "cone_angle_error", "cone_angle_change_error", "spin_rate_error",
               "spin_rate_change_error"]  # fmt: skip
    names = list(cmp.reduced)
    table = np.array([[float(cmp.table[f].get(m, np.nan)) for m in metrics] for f in names])
    data["error_table"] = xr.Variable(
        ("formulation", "metric"), table,
        {"units": "1", "long_name": "errors against full order (relative, dimensionless)"},
    )  # fmt: skip
    data["wall_time"] = xr.Variable(
        ("formulation",), [cmp.table[f]["wall_s"] for f in names],
        {"units": "s", "long_name": "integration wall time of the reduced run"},
    )  # fmt: skip
    data["speedup"] = xr.Variable(
        ("formulation",), [cmp.table[f]["speedup"] for f in names],
        {"units": "1", "long_name": "full-order wall time / reduced wall time"},
    )  # fmt: skip
    data["full_order_wall_time"] = xr.Variable((), cmp.full.wall_s, {"units": "s",
                                               "long_name": "full-order wall time"})  # fmt: skip
    if cmp.secular is not None:
        data.update(secular.dataset_variables(cmp.secular, models, names))
    ds = xr.Dataset(
        data,
        coords={
            "time": xr.Variable(("time",), t, {"units": "s", "long_name": "time"}),
            **cf.label_coordinate("model", models, "model: full order or reduced formulation"),
            **cf.label_coordinate("formulation", list(cmp.reduced), "reduced formulation"),
            **cf.label_coordinate("metric", metrics, "error metric"),
        },
        attrs={
            **cf.provenance(f"quadmodes comparison {cmp.run.name}"),
            "format": "quadmodes-comparison",
            "case": cmp.run.name,
            "run_case_toml": cmp.run.to_toml(),
            "window_s": float(cmp.run.integration.duration),
            "lowest_frequency_hz": float(cmp.lowest_frequency_hz),
            "full_order_dt_s": cmp.full_order_dt,
            "reduced_dt_s": float(cmp.run.integration.dt),
            "full_order_complete": int(cmp.full.complete),
            "quasi_steady_rule": cmp.secular.interval.rule if cmp.secular else "",
            "full_order_damped_modes": int(cmp.full.stats.get("damped_modes", 0)),
            "full_order_damping_cutoff_hz": float(cmp.full.stats.get("damping_cutoff_hz", math.nan)),
            "notes": "\n".join(cmp.notes),
            "modal_normalisation": cf.MODAL_NORMALISATION,
            **start_attributes(cmp.start),
        },
    )
    return cf.complete(ds)


def plot_comparison(cmp: Comparison, directory: str | os.PathLike) -> list[Path]:
    """The overlay figures of :mod:`~quadmodes.analysis.comparison_figures` (modal amplitude
    with envelopes, cone angle, spin rate, |H|, energy), drawn from :func:`to_dataset` (what
    ``comparison.nc`` holds, so a figure redrawn from the file is the same), as PNGs in
    ``directory``."""
    from quadmodes.analysis.comparison_figures import write_comparison_figures

    return write_comparison_figures(to_dataset(cmp), directory)


def table_rows(cmp: Comparison) -> list[dict]:
    """One flat dict per formulation (for CSV/Markdown)."""
    rows = []
    for name, row in cmp.table.items():
        rows.append({"formulation": name, **{k: row[k] for k in row}})
    return rows


def write_comparison(cmp: Comparison, directory: str | os.PathLike, plots: bool = True) -> dict:
    """Write ``comparison.nc``, ``comparison.json``, ``comparison.csv`` and the plots into
    ``directory``; returns the JSON payload."""
    import csv
    import json

    from quadmodes.runs.results import write_dataset

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    write_dataset(to_dataset(cmp), directory / "comparison.nc")
    payload = cmp.as_json()
    write_text(directory / "comparison.json", json.dumps(payload, indent=2) + "\n")
    rows = table_rows(cmp)
    with atomic_path(directory / "comparison.csv") as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    if plots:
        plot_comparison(cmp, directory)
    return payload
