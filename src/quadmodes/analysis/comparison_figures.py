"""The overlay figures of a comparison, drawn from its dataset (``comparison.nc``, made by
:func:`quadmodes.analysis.compare.to_dataset`): every series on the full order's time grid,
the full order in black, each reduced formulation in its colour; the modal amplitude with its
peak envelope per period of the lowest mode (dashed). The CLI's PNGs and
``qm.open_results("comparison.nc").plot(name)`` come from the same functions, so a figure
redrawn from the file is the one the command wrote."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.io.figures import new_figure, plain_numbers, save_png
from quadmodes.signals import peak_envelope

__all__ = ["COMPARISON_FIGURES", "comparison_figure", "write_comparison_figures"]

_COLOURS = {"rigid": "tab:gray", "L": "tab:orange", "P": "tab:green", "Q": "tab:blue",
            "Q4": "tab:purple"}  # fmt: skip

#: stem of the PNG (``compare_<stem>.png``) -> (variable, axis label, scale; None: relative
#: change from the start).
COMPARISON_FIGURES = {
    "modal_amplitude": ("modal_amplitude", "modal amplitude ‖s‖ (√kg·m)", 1.0),
    "cone_angle": ("cone_angle", "cone angle (deg)", 180.0 / math.pi),
    "spin_rate": ("spin_rate", "spin rate (Hz)", 1.0 / (2 * math.pi)),
    "angular_momentum": ("angular_momentum_norm", "|H| / |H(0)| − 1", None),
    "energy": ("total_energy", "total energy (J)", 1.0),
}


def _models(ds: xr.Dataset) -> list[str]:
    return [str(m) for m in ds["model_label"].values]


def comparison_figure(ds: xr.Dataset, name: str):
    """The overlay figure ``name`` (a key of :data:`COMPARISON_FIGURES`) of the comparison
    dataset ``ds`` as a matplotlib Figure; ValueError for another name."""
    if name not in COMPARISON_FIGURES:
        raise ValueError(f"figure {name!r}: not a comparison figure; use one of "
                         f"{', '.join(COMPARISON_FIGURES)}")  # fmt: skip
    var, ylabel, scale = COMPARISON_FIGURES[name]
    t = ds["time"].values
    f_low = float(ds.attrs.get("lowest_frequency_hz", math.nan))
    fig = new_figure((8.0, 4.2))
    ax = fig.add_subplot(111)
    for k, model in enumerate(_models(ds)):
        y = np.asarray(ds[var].values[k], float)
        y = y / y[0] - 1.0 if scale is None and y[0] else y * (scale or 1.0)
        full = model == "full"
        kw = (dict(color="k", lw=1.6, label="full order") if full
              else dict(color=_COLOURS.get(model), lw=1.0, label=model))  # fmt: skip
        ax.plot(t, y, **kw)
        if name == "modal_amplitude" and math.isfinite(f_low) and f_low > 0:
            ok = np.isfinite(y)
            if y[ok].any():
                te, ee = peak_envelope(t[ok], y[ok], 1.0 / f_low)
                ax.plot(te, ee, ls="--", color=kw["color"], lw=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(ylabel)
    ax.set_title(f"{ds.attrs.get('case', '')}: {ylabel.split(' (')[0]} — reduced vs full order")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return plain_numbers(fig)


def write_comparison_figures(ds: xr.Dataset, directory: str | os.PathLike) -> list[Path]:
    """Every figure of :data:`COMPARISON_FIGURES` as ``compare_<name>.png`` in ``directory``."""
    directory = Path(directory)
    return [save_png(comparison_figure(ds, name), directory / f"compare_{name}.png")
            for name in COMPARISON_FIGURES]  # fmt: skip
