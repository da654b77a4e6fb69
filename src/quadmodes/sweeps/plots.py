"""Figures of a spin sweep (PNG, headless): the Campbell diagram with the critical speeds
marked, the stability map (coning growth rate against spin, or a colour map against spin and a
second parameter), and the energy-sink estimate against the simulated coning rate.

Each function reads only the dataset (``sweep.nc``, SI) and returns the path written, or the
matplotlib Figure when given no path (``qm.open_results("sweep.nc").plot(name)``: the same
figure); spin rates and frequencies are drawn in the unit chosen (``--units``: Hz by default,
rpm, rad/s).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.analysis.full_order_markers import draw_markers, markers_from_dataset
from quadmodes.io.display_units import HZ, FrequencyUnit, family, family_colours, frequency_unit
from quadmodes.io.figures import new_figure, plain_numbers, save_png

SPIN = "spin_rate"


def _first_line(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` along the spin dimension at the first value of every other dimension."""
    other = {d: 0 for d in ds.dims
             if d not in (SPIN, "branch", "critical") and not str(d).startswith("full_order")}
    return ds.isel(other) if other else ds


def _done(fig, path: Path | None):
    """``fig`` saved to ``path`` (returns the path), or ``fig`` itself if no path (plain
    numbers on its axes)."""
    return plain_numbers(fig) if path is None else save_png(fig, path)


def campbell_figure(ds: xr.Dataset, path: Path | None = None, unit: str | FrequencyUnit = HZ):
    """Rotating-frame frequencies of every branch against spin, in ``unit``, one colour per
    family (never repeated), the legend outside; critical speeds as vertical lines named with
    their spin; the full-order roots (``full_order_*``) as diamonds."""
    unit = frequency_unit(unit)
    line = _first_line(ds)
    spin = unit.from_rad_s(line[SPIN].values)
    freq = unit.from_rad_s(line["branch_frequency"].values)
    labels = line["branch_label"].values
    fig = new_figure((8.5, 4.8))
    ax = fig.add_subplot()
    families = np.vectorize(lambda s: family(str(s)) if str(s) else "")(labels)
    colours = family_colours(families.ravel())
    for name, colour in colours.items():
        mask = families == name
        xs = np.broadcast_to(spin[:, None], freq.shape)[mask]
        ax.plot(xs, freq[mask], "o", ms=3, color=colour, label=name)
    if "full_order_frequency" in ds:
        draw_markers(ax, markers_from_dataset(ds), colours, unit.per_rad_s)
    for k in range(ds.sizes.get("critical", 0)):
        f = unit.from_hz(float(ds["critical_speed_hz"].values[k]))
        what = f"{ds['critical_speed_kind'].values[k]}: {ds['critical_speed_branch'].values[k]}"
        ax.axvline(f, color="k", ls="--", lw=0.8,
                   label="critical speed" if k == 0 else "_nolegend_")  # fmt: skip
        ax.annotate(f"{f:.4g} {unit.name}\n{what}", (f, ax.get_ylim()[1] * 0.9), fontsize=7,
                    rotation=90, ha="right", va="top")  # fmt: skip
    ax.set_xlabel(f"spin rate ({unit.name})")
    ax.set_ylabel(f"rotating-frame frequency ({unit.name})")
    ax.set_title("Campbell diagram of the sweep (undamped, about the relative equilibrium)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    return _done(fig, path)


def stability_figure(ds: xr.Dataset, path: Path | None = None, unit: str | FrequencyUnit = HZ):
    """Coning growth rate (1/s) against spin (in ``unit``): energy-sink estimate, damped nutation
    root and the simulation; with a second swept dimension a colour map of the energy-sink
    rate."""
    unit = frequency_unit(unit)
    other = [d for d in ds["energy_sink_growth_rate"].dims if d != SPIN]
    fig = new_figure((7.5, 4.8))
    ax = fig.add_subplot()
    if len(other) == 1:
        z = ds["energy_sink_growth_rate"].transpose(other[0], SPIN).values
        x = unit.from_rad_s(ds[SPIN].values)
        y = ds[other[0]].values
        lim = float(np.nanmax(np.abs(z))) if np.isfinite(z).any() else 1.0
        mesh = ax.pcolormesh(x, y, z, shading="nearest", cmap="coolwarm", vmin=-lim, vmax=lim)
        fig.colorbar(mesh, ax=ax, label="energy-sink coning rate (1/s)")
        ax.set_ylabel(f"{other[0]} ({ds[other[0]].attrs.get('units', '')})")
    else:
        line = _first_line(ds)
        x = unit.from_rad_s(line[SPIN].values)
        for key, style, name in (("energy_sink_growth_rate", "o-", "energy-sink estimate"),
                                 ("nutation_growth_rate", "s--", "damped nutation root"),
                                 ("simulated_growth_rate", "^:", "time run (secular fit)")):
            if key in line and np.isfinite(line[key].values).any():
                ax.plot(x, line[key].values, style, ms=4, label=name)
        values = np.abs(line["energy_sink_growth_rate"].values)
        values = values[np.isfinite(values) & (values > 0)]
        ax.set_yscale("symlog", linthresh=float(values.min()) if values.size else 1e-6)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel("coning growth rate (1/s; > 0 grows)")
        ax.legend(fontsize=8)
    ax.set_xlabel(f"spin rate ({unit.name})")
    ax.set_title("Stability map")
    return _done(fig, path)


def energy_sink_figure(ds: xr.Dataset, path: Path | None = None, unit=None):
    """Energy-sink estimate against the simulated coning rate (1/s), quasi-rigid points filled."""
    est = ds["energy_sink_growth_rate"].values.ravel()
    simu = ds["simulated_growth_rate"].values.ravel()
    rigid = ds["quasi_rigid"].values.ravel() > 0.5
    fig = new_figure((5.5, 5.0))
    ax = fig.add_subplot()
    ax.plot(simu[rigid], est[rigid], "o", label="quasi-rigid")
    ax.plot(simu[~rigid], est[~rigid], "o", mfc="none", label="not quasi-rigid")
    both = np.concatenate([est[np.isfinite(est)], simu[np.isfinite(simu)]])
    if both.size:
        lo, hi = float(both.min()), float(both.max())
        ax.plot([lo, hi], [lo, hi], "k-", lw=0.6, label="equal")
    ax.set_xlabel("simulated coning rate (1/s)")
    ax.set_ylabel("energy-sink estimate (1/s)")
    ax.legend(fontsize=8)
    return _done(fig, path)


#: The figures of a sweep: PNG stem -> function(ds, path=None, unit).
SWEEP_FIGURES = {"campbell": campbell_figure, "stability": stability_figure,
                 "energy_sink": energy_sink_figure}  # fmt: skip


def figure_names(ds: xr.Dataset) -> list[str]:
    """The figures (keys of :data:`SWEEP_FIGURES`) the dataset supports: none without a swept
    spin rate, the energy-sink comparison only with time runs."""
    if SPIN not in ds.dims:
        return []
    names = ["campbell", "stability"]
    if np.isfinite(ds["simulated_growth_rate"].values).any():
        names.append("energy_sink")
    return names


def sweep_figures(ds: xr.Dataset, directory: Path, unit: str | FrequencyUnit = HZ) -> list[Path]:
    """Every figure that the dataset supports (:func:`figure_names`), spin rates and
    frequencies in ``unit``."""
    directory = Path(directory)
    return [SWEEP_FIGURES[name](ds, directory / f"{name}.png", unit) for name in figure_names(ds)]
