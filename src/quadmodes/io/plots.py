"""PNG figures of a run, after the seed's Figures 6–16, from a results dataset.

* ``angular_momentum.png`` — |H| and its relative change (seed Figs. 6, 11)
* ``bending_mode.png`` — first bending coefficient s_b1(t) (Figs. 7, 12)
* ``bending_mode_early.png`` — the same at early times (Fig. 13)
* ``energy.png`` — total energy, and total + dissipated (Figs. 8, 14)
* ``spin_rate.png`` — spin rate (Figs. 9, 15)
* ``cone_angle.png`` — cone angle (Figs. 10, 16)
* ``summary.png`` — all of the above plus the bending-pair envelope and its log-decrement fit

and, for a hub-driven spin-up, ``tip_deflection.png`` (:func:`plot_tip_deflection`).

Figures are drawn on matplotlib's Agg canvas (:mod:`quadmodes.io.figures`), so plotting works
headless.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.io import cf
from quadmodes.io.atomic import atomic_path
from quadmodes.io.figures import new_figure, save_png
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


def _plot_bending(ax, ds, t_max: float | None = None) -> bool:
    s, label = _first_bending(ds)
    if s is None:
        ax.text(0.5, 0.5, "no elastic modes", ha="center", va="center", transform=ax.transAxes)
        return False
    t = ds["time"].values
    if t_max is not None:
        keep = t <= t_max
        t, s = t[keep], s[keep]
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


def _early_time(ds: xr.Dataset) -> float:
    t = ds["time"].values
    span = float(t[-1] - t[0]) if len(t) else 0.0
    return min(span, max(0.5, 0.01 * span)) + (float(t[0]) if len(t) else 0.0)


def _write_single(ds: xr.Dataset, path: Path, what: str, draw) -> Path:
    """One-panel figure of ``ds`` against time: ``draw(ax)`` plots, ``what`` titles."""
    fig = new_figure((7.0, 4.0))
    ax = fig.add_subplot(1, 1, 1)
    draw(ax)
    ax.set_xlabel("time (s)")
    ax.grid(True, lw=0.3)
    fig.suptitle(_title(ds, what), fontsize=10)
    fig.subplots_adjust(left=0.14, right=0.86, bottom=0.13, top=0.84)
    return save_png(fig, path, tight=True)


def _write_angular_momentum(ds: xr.Dataset, path: Path) -> Path:
    """|H| (top) and its relative change (bottom), seed Figs. 6, 11."""
    fig = new_figure((7.0, 5.0))
    ax1 = fig.add_subplot(2, 1, 1)
    _plot_h(ax1, ds, relative=False)
    ax1.grid(True, lw=0.3)
    ax2 = fig.add_subplot(2, 1, 2, sharex=ax1)
    _plot_h(ax2, ds, relative=True)
    ax2.set_xlabel("time (s)")
    ax2.grid(True, lw=0.3)
    fig.suptitle(
        _title(ds, "magnitude of the angular momentum (cf. seed Figs. 6, 11)"), fontsize=10
    )
    fig.subplots_adjust(left=0.14, right=0.95, bottom=0.1, top=0.9, hspace=0.3)
    return save_png(fig, path, tight=True)


def _single_figures(ds: xr.Dataset) -> list[tuple[str, str, object]]:
    """(file name, title, draw(ax)) of the one-panel figures (seed Figs. 7–10, 12–16)."""

    def bending(ax, t_max=None):
        if _plot_bending(ax, ds, t_max):
            _displacement_axis(ax, ds)

    return [
        ("bending_mode.png", "first bending coefficient (cf. seed Figs. 7, 12)", bending),
        (
            "bending_mode_early.png",
            "first bending coefficient, early times (cf. seed Fig. 13)",
            lambda ax: bending(ax, _early_time(ds)),
        ),
        ("energy.png", "total energy (cf. seed Figs. 8, 14)", lambda ax: _plot_energy(ax, ds)),
        (
            "spin_rate.png",
            "spin rate (cf. seed Figs. 9, 15)",
            lambda ax: _plot_series(ax, ds, "spin_rate_hz"),
        ),
        (
            "cone_angle.png",
            "cone angle (cf. seed Figs. 10, 16)",
            lambda ax: _plot_series(ax, ds, "cone_angle_deg"),
        ),
    ]


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


def _write_summary(ds: xr.Dataset, path: Path) -> Path:
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
    return save_png(fig, path, tight=True)


def write_plots(ds: xr.Dataset, directory: str | os.PathLike) -> list[Path]:
    """Write the PNG figures of ``ds`` into ``directory``; returns their paths."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = [_write_angular_momentum(ds, directory / "angular_momentum.png")]
    for name, what, draw in _single_figures(ds):
        paths.append(_write_single(ds, directory / name, what, draw))
    paths.append(_write_summary(ds, directory / "summary.png"))
    return paths


def plot_tip_deflection(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """PNG of the in-plane (and axial) tip deflection and the hub rate of a spin-up."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    t = ds["time"].values
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
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
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png", dpi=110)
    finally:
        plt.close(fig)
    return path
