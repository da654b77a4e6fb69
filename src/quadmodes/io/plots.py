"""The figures of a run, from its results dataset (``results.nc``): one function per figure
returning a matplotlib Figure (:data:`RUN_FIGURES`, :func:`run_figure`), so the CLI's PNGs and
``qm.open_results(...).plot(name)`` draw the same thing.

* ``angular_momentum.png`` — |H| and its relative change
* ``bending_mode.png`` — first bending coefficient s_b1(t); a run of many bending periods is
  drawn as its envelope (max and min per time bin) instead of a line that fills a band
* ``bending_mode_early.png`` — the same at early times
* ``energy.png`` — total energy, and total + dissipated
* ``spin_rate.png`` — spin rate
* ``cone_angle.png`` — cone angle
* ``summary.png`` — all of the above plus the bending-pair envelope and its log-decrement fit

and, for a hub-driven spin-up, ``tip_deflection.png`` (:func:`plot_tip_deflection`).

Figures are drawn on matplotlib's Agg canvas (:mod:`quadmodes.io.figures`), so plotting works
headless; no axis uses offset notation (:func:`~quadmodes.io.figures.plain_numbers`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.io import cf
from quadmodes.io.figures import new_figure, plain_numbers, save_png
from quadmodes.signals import log_decrement, peak_envelope


def _title(ds: xr.Dataset, what: str) -> str:
    case = ds.attrs.get("case", "")
    flag = "" if int(ds.attrs.get("complete", 1)) else " (INCOMPLETE)"
    return f"{case}: {what}{flag}"


def _first_bending(ds: xr.Dataset):
    """(values, label) of the first bending coefficient, or of mode 1 if none is bending."""
    s = ds["modal_coordinates"]
    if s.sizes.get("mode", 0) == 0:
        return None, ""
    pair = [int(k) for k in np.atleast_1d(ds.attrs.get("bending_modes", []))]
    mode = pair[0] if pair else 1
    label = str(ds["mode_label"].sel(mode=mode).values)
    freq = float(ds["mode_frequency_hz"].sel(mode=mode).values)
    return s.sel(mode=mode).values, f"mode {mode} ({label}, {freq:.2f} Hz)"


def _displacement_axis(ax, ds: xr.Dataset) -> None:
    scale = ds.attrs.get("bending_displacement_per_unit")
    if scale is None or not float(scale) > 0:
        return
    k = 1e3 * float(scale)  # kg^0.5 m -> mm at the node that moves most
    sec = ax.secondary_yaxis("right", functions=(lambda v: v * k, lambda v: v / k))
    sec.set_ylabel("largest nodal displacement (mm)")


def _plot_h(ax, ds, relative: bool) -> None:
    t = ds["time"].values
    hn = ds["angular_momentum_norm"].values
    if relative:
        ax.plot(t, (hn - hn[0]) / hn[0], lw=0.8)
        ax.set_ylabel("(|H| − |H₀|) / |H₀|")
    else:
        ax.plot(t, hn, lw=1.0)
        ax.set_ylabel("|H| (kg m²/s)")
        ax.ticklabel_format(axis="y", useOffset=False)
        lo, hi = hn.min(), hn.max()
        pad = max(0.05 * abs(hn[0]), hi - lo)
        ax.set_ylim(lo - pad, hi + pad)


#: A coefficient oscillating more than this many periods across a figure is drawn as its
#: envelope: a line would fill the axes as a solid band (a 120 s run at 9 Hz: 1100 periods).
ENVELOPE_PERIODS = 150
#: Time bins of an envelope (each bin's max and min): about one per pixel column or two.
ENVELOPE_BINS = 400


def min_max_envelope(t: np.ndarray, s: np.ndarray, bins: int = ENVELOPE_BINS):
    """(bin centres (b,) s, max (b,), min (b,)) of ``s`` over ``bins`` equal time bins of ``t``
    (empty bins dropped)."""
    edges = np.linspace(t[0], t[-1], bins + 1)
    k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, bins - 1)
    hi = np.full(bins, -np.inf)
    lo = np.full(bins, np.inf)
    np.maximum.at(hi, k, s)
    np.minimum.at(lo, k, s)
    keep = np.isfinite(hi)
    centres = 0.5 * (edges[:-1] + edges[1:])
    return centres[keep], hi[keep], lo[keep]


def _plot_bending(ax, ds, t_max: float | None = None) -> bool:
    s, label = _first_bending(ds)
    if s is None:
        ax.text(0.5, 0.5, "no elastic modes", ha="center", va="center", transform=ax.transAxes)
        return False
    t = ds["time"].values
    if t_max is not None:
        keep = t <= t_max
        t, s = t[keep], s[keep]
    pair = [int(k) for k in np.atleast_1d(ds.attrs.get("bending_modes", []))] or [1]
    f = float(ds["mode_frequency_hz"].sel(mode=pair[0]).values)
    periods = f * float(t[-1] - t[0]) if len(t) > 1 else 0.0
    if periods > ENVELOPE_PERIODS and len(t) > 2 * ENVELOPE_BINS:
        tc, hi, lo = min_max_envelope(t, s)
        ax.fill_between(tc, lo, hi, color="C0", alpha=0.25, lw=0)
        ax.plot(tc, hi, lw=0.8, color="C0", label=f"max and min over {(t[-1] - t[0]) / ENVELOPE_BINS:.3g} s")
        ax.plot(tc, lo, lw=0.8, color="C0")
        ax.legend(fontsize=7, loc="best")
    else:
        ax.plot(t, s, lw=0.5)
    ax.set_ylabel("s (kg^0.5 m)")
    ax.set_title(label, fontsize=8)
    return True


def _plot_energy(ax, ds) -> None:
    t = ds["time"].values
    e = ds["total_energy"].values
    ax.plot(t, e, lw=1.0, label="total energy E = T + V")
    ax.plot(t, ds["energy_balance"].values, lw=1.0, ls="--", label="E + dissipated")
    ax.set_ylabel("energy (J)")
    ax.ticklabel_format(axis="y", useOffset=False)
    ax.legend(fontsize=7, loc="best")


def _plot_series(ax, ds, name: str, ylabel: str | None = None) -> None:
    """``ds[name]`` against time; the axis label is its ``long_name (units)`` unless given."""
    ax.plot(ds["time"].values, ds[name].values, lw=1.0)
    ax.set_ylabel(ylabel or cf.axis_label(ds[name]))


def _plot_envelope(ax, ds) -> None:
    if "bending_amplitude" not in ds:
        ax.text(0.5, 0.5, "no bending pair", ha="center", va="center", transform=ax.transAxes)
        return
    t = ds["time"].values
    a = ds["bending_amplitude"].values
    pair = [int(k) for k in np.atleast_1d(ds.attrs.get("bending_modes", []))]
    f = float(np.mean(ds["mode_frequency_hz"].sel(mode=pair).values))
    ax.semilogy(t, np.maximum(a, 1e-300), lw=0.4, color="0.6", label="a(t)")
    et, ea = peak_envelope(t, a, 1.0 / f)
    if len(et):
        ax.semilogy(et, np.maximum(ea, 1e-300), ".", ms=2, label="peak per period")
    ld = log_decrement(t, a, f)
    if ld["log_decrement"] is not None and ld["free_decay"]:  # a forced response has none
        use = (et >= ld["fit_start_s"]) & (et <= ld["fit_end_s"])
        coef = np.polyfit(et[use], np.log(ea[use]), 1)
        tt = np.array([ld["fit_start_s"], ld["fit_end_s"]])
        ax.semilogy(
            tt,
            np.exp(np.polyval(coef, tt)),
            "r-",
            lw=1.2,
            label=f"fit: δ = {ld['log_decrement']:.4g}",
        )
    positive = a[a > 0]
    if len(positive):
        ax.set_ylim(max(positive.min(), positive.max() * 1e-8) * 0.5, positive.max() * 2)
    ax.set_ylabel("√(s_b1² + s_b2²)")
    ax.legend(fontsize=7, loc="best")


def early_window(span: float) -> float:
    """The length (s) of the early-times figure of a run lasting ``span`` s: 0.5 s or 1 % of
    the run, whichever is longer, and at most the run (then it is the whole run)."""
    return min(span, max(0.5, 0.01 * span))


def _early_time(ds: xr.Dataset) -> float:
    t = ds["time"].values
    span = float(t[-1] - t[0]) if len(t) else 0.0
    return early_window(span) + (float(t[0]) if len(t) else 0.0)


def _single(ds: xr.Dataset, what: str, draw):
    """One-panel figure of ``ds`` against time: ``draw(ax)`` plots, ``what`` titles."""
    fig = new_figure((7.0, 4.0))
    ax = fig.add_subplot(1, 1, 1)
    draw(ax)
    ax.set_xlabel("time (s)")
    ax.grid(True, lw=0.3)
    fig.suptitle(_title(ds, what), fontsize=10)
    fig.subplots_adjust(left=0.14, right=0.86, bottom=0.13, top=0.84)
    return fig


def angular_momentum_figure(ds: xr.Dataset):
    """|H| (top) and its relative change (bottom)."""
    fig = new_figure((7.0, 5.0))
    ax1 = fig.add_subplot(2, 1, 1)
    _plot_h(ax1, ds, relative=False)
    ax1.grid(True, lw=0.3)
    ax2 = fig.add_subplot(2, 1, 2, sharex=ax1)
    _plot_h(ax2, ds, relative=True)
    ax2.set_xlabel("time (s)")
    ax2.grid(True, lw=0.3)
    fig.suptitle(_title(ds, "magnitude of the angular momentum"), fontsize=10)
    fig.subplots_adjust(left=0.14, right=0.95, bottom=0.1, top=0.9, hspace=0.3)
    return fig


def _bending(ds: xr.Dataset, t_max=None):
    def draw(ax):
        if _plot_bending(ax, ds, t_max):
            _displacement_axis(ax, ds)

    return draw


def _summary_panels(ds: xr.Dataset) -> list[tuple[str, object]]:
    """(title, draw(ax)) of the six panels of ``summary.png``."""
    return [
        ("|H| relative change", lambda ax: _plot_h(ax, ds, relative=True)),
        ("first bending coefficient", lambda ax: _plot_bending(ax, ds)),
        ("bending pair amplitude and log decrement", lambda ax: _plot_envelope(ax, ds)),
        ("energy", lambda ax: _plot_energy(ax, ds)),
        (
            "spin rate",
            lambda ax: _plot_series(ax, ds, "spin_rate_hz"),
        ),
        (
            "cone angle",
            lambda ax: _plot_series(ax, ds, "cone_angle_deg"),
        ),
    ]


def summary_figure(ds: xr.Dataset):
    """All panels on one page (2 × 3), titled with formulation, method and step."""
    fig = new_figure((13.0, 7.5))
    for k, (what, draw) in enumerate(_summary_panels(ds)):
        ax = fig.add_subplot(2, 3, k + 1)
        draw(ax)
        if not ax.get_title():
            ax.set_title(what, fontsize=9)
        else:
            ax.set_title(f"{what}: {ax.get_title()}", fontsize=8)
        ax.set_xlabel("time (s)")
        ax.grid(True, lw=0.3)
    method = ds.attrs.get("method", "")
    dt = float(ds.attrs.get("dt", math.nan))
    fig.suptitle(
        _title(
            ds,
            f"formulation {ds.attrs.get('formulation', '')}, {method}, dt = {1e3 * dt:.3g} ms",
        ),
        fontsize=11,
    )
    fig.subplots_adjust(left=0.075, right=0.985, bottom=0.07, top=0.9, wspace=0.4, hspace=0.32)
    return fig


#: The figures of a free-body run: file stem -> function(ds) -> Figure; the answer first.
RUN_FIGURES = {
    "cone_angle": lambda ds: _single(ds, "cone angle",
                                     lambda ax: _plot_series(ax, ds, "cone_angle_deg")),
    "spin_rate": lambda ds: _single(ds, "spin rate",
                                    lambda ax: _plot_series(ax, ds, "spin_rate_hz")),
    "energy": lambda ds: _single(ds, "total energy", lambda ax: _plot_energy(ax, ds)),
    "angular_momentum": angular_momentum_figure,
    "bending_mode": lambda ds: _single(ds, "first bending coefficient", _bending(ds)),
    "bending_mode_early": lambda ds: _single(
        ds, "first bending coefficient, early times", _bending(ds, _early_time(ds))),
    "summary": summary_figure,
}  # fmt: skip


def run_figure(ds: xr.Dataset, name: str):
    """The figure ``name`` (a key of :data:`RUN_FIGURES`, the PNG's stem) of the run dataset
    ``ds``, as a matplotlib Figure without offset notation; ValueError for another name."""
    if name not in RUN_FIGURES:
        raise ValueError(f"figure {name!r}: not a run figure; use one of {', '.join(RUN_FIGURES)}")
    return plain_numbers(RUN_FIGURES[name](ds))


def write_plots(ds: xr.Dataset, directory: str | os.PathLike) -> list[Path]:
    """Write the PNG figures of ``ds`` (:data:`RUN_FIGURES`) into ``directory``; returns their
    paths."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    return [save_png(run_figure(ds, name), directory / f"{name}.png") for name in RUN_FIGURES]


def tip_deflection_figure(ds: xr.Dataset):
    """The in-plane (and axial) tip deflection and the hub rate of a spin-up (its dataset)."""
    t = ds["time"].values
    fig = new_figure((7.0, 5.5))
    ax, ax2 = fig.subplots(2, 1, sharex=True)
    ax.plot(t, ds["tip_inplane"].values, label="in-plane v (hub y)")
    ax.plot(t, ds["tip_axial"].values, "--", label="axial (hub x)")
    ax.plot([ds.attrs["peak_time"]], [ds.attrs["peak_tip_deflection"]], "o", color="C3")
    ax.set_ylabel("tip displacement (m)")
    ax.set_title(
        f"{ds.attrs['case']}: formulation {ds.attrs['formulation']}, "
        f"Ωs = {ds.attrs['omega_s']:.3g} rad/s ({ds.attrs['status']})"
    )
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    ax2.plot(t, ds["hub_rate"].values, color="k")
    ax2.set_ylabel("hub rate (rad/s)")
    ax2.set_xlabel("time (s)")
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    return plain_numbers(fig)


def plot_tip_deflection(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """PNG of :func:`tip_deflection_figure` at ``path``."""
    return save_png(tip_deflection_figure(ds), path)
