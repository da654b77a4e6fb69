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


def save_png(fig, path: str | os.PathLike, tight: bool = True) -> Path:
    """Write ``fig`` to ``path`` as PNG at :data:`DPI`, atomically; ``tight`` (default): cropped
    to the drawn content (0.05 in margin), so no label is clipped and no white border is left
    (False: the figure's own size). Returns the path."""
    path = Path(path)
    crop = {"bbox_inches": "tight", "pad_inches": 0.05} if tight else {}
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=DPI, **crop)
    return path
