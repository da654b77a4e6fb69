"""``report.html`` of a sweep: the answer in a box at the top (critical speeds, the coning
verdict over the points), the critical speeds, the counts, the swept parameters, a table of
the headline variables at every point (one-parameter sweeps) and the figures, embedded
(:mod:`quadmodes.io.report`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.io import report as rep
from quadmodes.io.display_units import frequency_unit

#: Headline variables shown per point when present (name fragments of sweep.nc variables).
_HEADLINE = ("cone", "power", "spin_rate_change", "energy_sink", "time_constant")
_FIGURES = (("campbell.png", "Campbell diagram of the sweep: the rotating-frame frequency of "
                             "every branch against the spin rate, about the spinning relative "
                             "equilibrium; dashed lines: the critical speeds"),
            ("stability.png", "Stability map: the coning growth rate (1/s, > 0: the cone grows) "
                              "against the spin rate, by the energy-sink law, the damped "
                              "nutation root and the time runs"),
            ("energy_sink.png", "The energy-sink estimate of the coning rate against the rate "
                                "fitted to each point's time run (1/s); on the line they agree"))


def _label(da: xr.DataArray) -> str:
    return f"{da.attrs.get('long_name', da.name)} [{da.attrs.get('units', '1')}]"


def _column(da: xr.DataArray, u) -> tuple[str, np.ndarray]:
    """A table column's header and values: a spin rate (rad/s in the files) in ``u``, a cone
    angle's rate in deg/s (as ``run`` prints it), anything else in the files' unit."""
    values = np.asarray(da.values, dtype=float)
    name = f"{da.attrs.get('long_name', da.name)}"
    if da.attrs.get("units") == "rad/s" and "spin" in str(da.name):
        return f"{name} [{u.name}]", u.from_rad_s(values)
    if da.attrs.get("units") == "rad/s" and "cone" in str(da.name):
        return f"{name} [deg/s]", np.degrees(values)
    return _label(da), values


def _point_table(ds: xr.Dataset, u) -> str:
    """The headline variables against the single swept dimension ("" for maps); angular rates
    in ``u`` (a FrequencyUnit), the rest in the files' units."""
    dims = [d for d in ds.dims if d in ds.coords and ds[d].attrs.get("long_name", "")
            .endswith("(swept)")]  # fmt: skip
    if len(dims) != 1:
        return ""
    dim = dims[0]
    names = [n for n, v in ds.data_vars.items() if v.dims == (dim,)
             and any(h in n for h in _HEADLINE)]  # fmt: skip
    columns = [_column(ds[dim], u)] + [_column(ds[n], u) for n in names]
    rows = [[float(c[1][i]) for c in columns] for i in range(ds[dim].size)]
    return rep.table([c[0] for c in columns], rows)


def _coning_row(ds: xr.Dataset) -> tuple[str, str, bool | None] | None:
    """The coning verdict over the points: how many grow (energy-sink rate > 0) and the range
    of the coning time constant."""
    if "energy_sink_growth_rate" not in ds:
        return None
    rate = np.asarray(ds["energy_sink_growth_rate"].values, float).ravel()
    rate = rate[np.isfinite(rate)]
    if not rate.size:
        return ("coning (energy sink)", "no estimate at any point", None)
    grows = int(np.sum(rate > 0))
    text = f"the cone grows at {grows} of {rate.size} points, decays at {int(np.sum(rate < 0))}"
    if grows:
        tau = 1.0 / rate[rate > 0]
        text += f"; e-folding time {tau.min():.4g} – {tau.max():.4g} s where it grows"
    return ("coning (energy sink)", text, grows == 0)


def _path_row(ds: xr.Dataset) -> tuple[str, str, bool | None] | None:
    """The time runs' validity along their paths: at how many points the path stays in the
    reduced model's range, and the earliest time one leaves it."""
    if "path_in_range" not in ds:
        return None
    inside = np.asarray(ds["path_in_range"].values, float).ravel()
    known = np.isfinite(inside)
    if not known.any():
        return None
    left = np.asarray(ds["path_left_range_at"].values, float).ravel()
    n_out = int(np.sum(inside[known] == 0))
    text = f"in the model's range at {int(np.sum(inside[known] == 1))} of {int(known.sum())} points"
    if n_out:
        text += f"; leaves it at {n_out} (earliest at t = {np.nanmin(left):.4g} s)"
    text += " (modal amplitudes not checked against the FE model in a sweep)"
    return ("time runs along their path", text, n_out == 0)


def _answer(ds: xr.Dataset, info: dict, u) -> rep.Section:
    """The box at the top: critical speeds, the coning verdict over the points, failures."""
    from quadmodes.io.verdict import verdict_box

    crit = info["critical_speeds"]
    headline = (f"{len(crit)} critical speed(s) in the swept range: " + ", ".join(
        f"{u.from_hz(c['spin_hz']):.4g} {u.name} ({c['kind']}, {c['branch']})" for c in crit)
        if crit else "no critical speed in the swept range")  # fmt: skip
    rows = [r for r in (_coning_row(ds), _path_row(ds)) if r is not None]
    rows.append(("points", f"{info['points']} ({info['failed']} failed)", info["failed"] == 0))
    kind = "stable" if rows[0][2] else "unstable" if rows[0][2] is False else ""
    return rep.Section("The answer", verdict_box(headline, rows, kind))


def write_sweep_report(directory: Path, ds: xr.Dataset, info: dict, command: str,
                       unit="Hz") -> Path:  # fmt: skip
    """Write ``directory/report.html`` for the sweep dataset ``ds`` and its summary ``info``
    (:func:`quadmodes.sweeps.dataset.summary`), spin rates and frequencies of its tables in
    ``unit`` ("Hz", "rpm" or "rad/s"); returns its path."""
    u = frequency_unit(unit)
    swept = [(d, f"{ds[d].size} values, {_label(ds[d])}") for d in ds.dims if d in ds.coords]
    counts = [("points", info["points"]), ("resumed from earlier files", info["resumed"]),
              ("failed", info["failed"]), ("wall time (s)", info["wall_s"]),
              ("command", command)]  # fmt: skip
    crit = info["critical_speeds"]
    crit_body = (rep.table([f"spin ({u.name})", "kind", "branch", "partner"],
                           [[u.from_hz(c["spin_hz"]), c["kind"], c["branch"], c["partner"] or "—"]
                            for c in crit])  # fmt: skip
                 if crit else rep.paragraph("none in the swept range"))
    failures = info.get("failures") or {}
    sections = [
        _answer(ds, info, u),
        rep.Section("Critical speeds", crit_body),
        rep.Section("Sweep", rep.key_values(counts) + rep.key_values(swept, "swept parameters")),
    ]
    table = _point_table(ds, u)
    if table:
        sections.append(rep.Section("Headline numbers per point", table))
    full = [[u.from_hz(spin["spin_hz"]), r["branch"], u.from_hz(r["frequency_hz"]),
             "—" if r["relative_error"] is None else f"{100 * r['relative_error']:+.3f} %"]
            for spin in info.get("full_order", []) for r in spin["roots"]]  # fmt: skip
    if full:
        sections.append(rep.Section("Full-order linearisation", rep.table(
            [f"spin ({u.name})", "matched branch", f"full order ({u.name})", "reduced vs full"],
            full)))
    if failures:
        sections.append(rep.Section("Failed points", rep.key_values(sorted(failures.items()))))
    sections.append(rep.Section("Figures", rep.figures(directory, _FIGURES)))
    return rep.write_report(directory, "quadmodes sweep", sections, subtitle=command)
