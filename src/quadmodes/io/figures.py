"""Headless matplotlib figures written as PNG: a :class:`~matplotlib.figure.Figure` on an Agg
canvas (no pyplot global state, no backend switch) and an atomic PNG save."""

from __future__ import annotations

import os
from pathlib import Path

from quadmodes.io.atomic import atomic_path

#: Resolution of every PNG figure (dots per inch).
DPI = 120


def new_figure(figsize=(7.0, 4.0)):
    """A matplotlib Figure of ``figsize`` (inches) at :data:`DPI` on its own Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def plain_numbers(fig):
    """``fig`` with every linear axis (secondary axes included) labelled in plain numbers: no
    offset notation (an axis of 41.0000 to 41.0003 Hz reads 41, 41.0001 …, never "+4.1e1"
    and increments). Returns ``fig``."""
    from matplotlib.ticker import ScalarFormatter

    def axes_of(ax):
        yield ax
        for child in getattr(ax, "child_axes", ()):
            yield from axes_of(child)

    for top in fig.axes:
        for ax in axes_of(top):
            for axis in (ax.xaxis, ax.yaxis):
                formatter = axis.get_major_formatter()
                if isinstance(formatter, ScalarFormatter):
                    formatter.set_useOffset(False)
    return fig


def save_png(fig, path: str | os.PathLike, tight: bool = True) -> Path:
    """Write ``fig`` to ``path`` as PNG at :data:`DPI`, atomically; ``tight`` (default): cropped
    to the drawn content (0.05 in margin), so no label is clipped and no white border is left
    (False: the figure's own size); no axis in offset notation (:func:`plain_numbers`). Returns
    the path."""
    path = Path(path)
    plain_numbers(fig)
    crop = {"bbox_inches": "tight", "pad_inches": 0.05} if tight else {}
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=DPI, **crop)
    return path
