"""``report.html`` of a sweep: the counts, the swept parameters, the critical speeds, a table
of the headline variables at every point (one-parameter sweeps) and the figures, embedded
(:mod:`quadmodes.io.report`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.io import report as rep
from quadmodes.io.display_units import frequency_unit

#: Headline variables shown per point when present (name fragments of sweep.nc variables).
_HEADLINE = ("cone", "power", "spin_rate_change", "energy_sink", "time_constant")
_FIGURES = (("campbell.png", "Campbell diagram with the critical speeds"),
            ("stability.png", "stability map"),
            ("energy_sink.png", "energy-sink estimate against the simulated coning rate"))


def _label(da: xr.DataArray) -> str:
    return f"{da.attrs.get('long_name', da.name)} [{da.attrs.get('units', '1')}]"


def _point_table(ds: xr.Dataset) -> str:
    """The headline variables against the single swept dimension ("" for maps)."""
    dims = [d for d in ds.dims if d in ds.coords and ds[d].attrs.get("long_name", "")
            .endswith("(swept)")]  # fmt: skip
    if len(dims) != 1:
        return ""
    dim = dims[0]
    names = [n for n, v in ds.data_vars.items() if v.dims == (dim,)
             and any(h in n for h in _HEADLINE)]  # fmt: skip
    header = [_label(ds[dim])] + [_label(ds[n]) for n in names]
    rows = [[float(x)] + [float(ds[n].values[i]) for n in names]
            for i, x in enumerate(np.asarray(ds[dim].values))]  # fmt: skip
    return rep.table(header, rows)


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
        rep.Section("Sweep", rep.key_values(counts) + rep.key_values(swept, "swept parameters")),
        rep.Section("Critical speeds", crit_body),
    ]
    table = _point_table(ds)
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
