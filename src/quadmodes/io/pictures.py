"""PNG pictures of a surface mesh and its mode shapes: a side view (looking along y) and a
rotated view, shaded facets with visible edges, equal aspect.

Inputs are the arrays of :mod:`quadmodes.io.mesh_arrays` (SI units, metres). Figures are drawn
on matplotlib's Agg canvas and saved atomically (:mod:`quadmodes.io.figures`), so they work
headless and leave no partial file behind.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from quadmodes.io.figures import new_figure, save_png
from quadmodes.io.mesh_arrays import (
    as_cells,
    as_lines,
    as_mode_set,
    as_points,
    as_shapes,
    default_scale,
)

__all__ = ["plot_mesh_png", "plot_mode_png", "plot_modes_overview_png"]

_MAX_OVERVIEW_MODES = 12


def _view_direction(elev: float, azim: float) -> np.ndarray:
    e, a = np.radians(elev), np.radians(azim)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def _shading(verts: np.ndarray, elev: float, azim: float) -> np.ndarray:
    """Lambert-type brightness in [0.35, 1] per facet; verts (nt, 3, 3).

    The light comes from the viewer, raised 30 degrees and turned 30 degrees left, and
    |n . l| is used so that the result does not depend on facet orientation.
    """
    normals = np.cross(verts[:, 1] - verts[:, 0], verts[:, 2] - verts[:, 0])
    norm = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = normals / np.where(norm > 0, norm, 1.0)
    light = _view_direction(min(elev + 30.0, 90.0), azim - 30.0)
    return 0.35 + 0.65 * np.abs(normals @ light)


def _set_equal_aspect(ax, coords: np.ndarray, zoom: float = 1.0) -> None:
    lo = coords.min(axis=0)
    hi = coords.max(axis=0)
    span = hi - lo
    pad = 1e-3 * max(float(span.max()), 1e-12)
    span = np.maximum(span, pad)
    mid = 0.5 * (lo + hi)
    ax.set_xlim(mid[0] - span[0] / 2, mid[0] + span[0] / 2)
    ax.set_ylim(mid[1] - span[1] / 2, mid[1] + span[1] / 2)
    ax.set_zlim(mid[2] - span[2] / 2, mid[2] + span[2] / 2)
    ax.set_box_aspect(tuple(span), zoom=zoom)


def _style_axes(ax, small: bool = False, side: bool = False) -> None:
    """Axis labels in metres; no ticks for small panels, no y ticks for the side view."""
    fs = 6 if small else 8
    if small:
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_zticks([])
        return
    ax.set_xlabel("x [m]", fontsize=fs)
    ax.set_zlabel("z [m]", fontsize=fs)
    ax.tick_params(labelsize=fs - 1)
    if side:
        ax.set_yticks([])
    else:
        ax.set_ylabel("y [m]", fontsize=fs)


def _two_view_axes(fig, with_colorbar: bool):
    """Two 3-D axes side by side filling the figure, plus a colour-bar axes or None."""
    right = 0.86 if with_colorbar else 1.0
    width = right / 2
    axes = [fig.add_axes((i * width, 0.0, width, 0.9), projection="3d") for i in range(2)]
    cax = fig.add_axes((0.915, 0.2, 0.012, 0.55)) if with_colorbar else None
    return axes, cax


def _draw_surface(
    ax,
    pts: np.ndarray,
    tri: np.ndarray,
    elev: float,
    azim: float,
    values: np.ndarray | None = None,
    cmap=None,
    norm=None,
    base_color=(0.72, 0.78, 0.88),
    edge_width: float = 0.2,
):
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    verts = pts[tri]
    shade = _shading(verts, elev, azim)[:, None]
    if values is None:
        rgb = np.asarray(base_color)[None, :] * shade
    else:
        rgb = cmap(norm(values))[:, :3] * (0.55 + 0.45 * shade)
    colors = np.column_stack([np.clip(rgb, 0.0, 1.0), np.ones(len(rgb))])
    edge = np.column_stack([0.35 * colors[:, :3], np.full(len(rgb), 0.6)])
    coll = Poly3DCollection(verts, facecolors=colors, edgecolors=edge, linewidths=edge_width)
    coll.set_zorder(2)
    ax.add_collection3d(coll)
    return coll


def _draw_lines(ax, pts: np.ndarray, lines: np.ndarray | None, color="crimson", lw=1.2):
    if lines is None or len(lines) == 0:
        return
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    coll = Line3DCollection(pts[lines], colors=color, linewidths=lw, zorder=3)
    ax.add_collection3d(coll)


def _draw_wireframe(ax, pts: np.ndarray, tri: np.ndarray, color=(0.7, 0.7, 0.7), lw=0.3):
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    coll = Line3DCollection(pts[edges], colors=[color], linewidths=lw, zorder=1)
    ax.add_collection3d(coll)


# (title, elev, azim) of the two standard views; the side view looks along +y.
_SIDE_VIEW = ("side view (along y)", 0.0, -90.0)


def _views(elev: float, azim: float):
    return [
        _SIDE_VIEW,
        (f"view elev={elev:g}\N{DEGREE SIGN}, azim={azim:g}\N{DEGREE SIGN}", elev, azim),
    ]


def plot_mesh_png(
    path,
    points,
    triangles,
    title: str | None = None,
    lines=None,
    elev: float = 10,
    azim: float = -60,
    cell_values=None,
    cell_label: str | None = None,
) -> Path:
    """Render a triangulated surface to PNG: side view (elev=0, looking along y) and a
    rotated view (``elev``, ``azim`` in degrees), equal aspect, shaded facets, visible edges.

    points (n, 3) [m]; triangles (nt, 3) int; lines (m, 2) int or None (drawn in red);
    cell_values (nt,) optional per-facet values shown with a colour map and a colour bar
    labelled ``cell_label``. Returns the path.
    """
    import matplotlib
    from matplotlib import cm, colors

    pts = as_points(points)
    tri = as_cells(triangles, 3, len(pts), "triangles")
    lin = as_lines(lines, len(pts))
    vals = None
    cmap = norm = None
    if cell_values is not None:
        vals = np.asarray(cell_values, dtype=float).reshape(-1)
        if vals.shape != (len(tri),):
            raise ValueError(f"cell_values must have shape ({len(tri)},), got {vals.shape}")
        finite = vals[np.isfinite(vals)]
        vmin, vmax = (finite.min(), finite.max()) if finite.size else (0.0, 1.0)
        if vmax <= vmin:
            vmin, vmax = vmin - 0.5, vmax + 0.5
        cmap = matplotlib.colormaps["viridis"].with_extremes(bad=(0.8, 0.8, 0.8))
        norm = colors.Normalize(vmin=vmin, vmax=vmax)

    fig = new_figure((12, 5))
    axes, cax = _two_view_axes(fig, vals is not None)
    for i, (ax, (vtitle, e, a)) in enumerate(zip(axes, _views(elev, azim), strict=True)):
        ax.view_init(elev=e, azim=a)
        ax.computed_zorder = False  # wireframe < surface < lines, whatever the depth
        _draw_surface(ax, pts, tri, e, a, values=vals, cmap=cmap, norm=norm)
        _draw_lines(ax, pts, lin)
        _set_equal_aspect(ax, pts, zoom=1.15)
        _style_axes(ax, side=i == 0)
        ax.set_title(vtitle, fontsize=9)
    if title:
        fig.suptitle(title, fontsize=12)
    if vals is not None:
        sm = cm.ScalarMappable(norm=norm, cmap=cmap)
        cb = fig.colorbar(sm, cax=cax)
        if cell_label:
            cb.set_label(cell_label)
    return save_png(fig, path)


def _relative_magnitude(shape: np.ndarray) -> np.ndarray:
    """|shape| per node (n,) divided by its largest value (zeros for a zero shape)."""
    mag = np.linalg.norm(shape, axis=1)
    umax = float(mag.max()) if mag.size else 0.0
    return mag / umax if umax > 0 else np.zeros_like(mag)


def _mode_title(frequency_hz: float, label: str, index: int | None) -> str:
    head = f"{frequency_hz:.1f} Hz"
    if index is not None:
        head = f"Mode {index}: {head}"
    return f"{head} \N{EM DASH} {label}" if label else head


def plot_mode_png(
    path,
    points,
    triangles,
    shape,
    frequency_hz: float,
    label: str,
    lines=None,
    scale: float | None = None,
    index: int | None = None,
    elev: float = 10,
    azim: float = -60,
) -> Path:
    """Render one mode shape to PNG: undeformed mesh as a light grey wireframe and the surface
    displaced by ``scale * shape`` coloured by |shape|, in a side and a rotated view.

    points (n, 3) [m]; triangles (nt, 3) int; shape (n, 3) any scale; frequency_hz [Hz];
    label: free text; lines (m, 2) int or None. Title: "Mode {index}: {f:.1f} Hz — {label}"
    (without "Mode {index}: " if ``index`` is None). ``scale`` defaults to 10 % of the
    bounding-box diagonal / max |shape|. Returns the path.
    """
    import matplotlib
    from matplotlib import cm, colors

    pts = as_points(points)
    tri = as_cells(triangles, 3, len(pts), "triangles")
    lin = as_lines(lines, len(pts))
    shp = as_shapes(shape, len(pts))[0]
    s = default_scale(pts, shp) if scale is None else float(scale)
    deformed = pts + s * shp

    facet_vals = _relative_magnitude(shp)[tri].mean(axis=1)
    cmap = matplotlib.colormaps["plasma"]
    norm = colors.Normalize(0.0, 1.0)

    fig = new_figure((12, 5))
    axes, cax = _two_view_axes(fig, True)
    allpts = np.vstack([pts, deformed])
    for i, (ax, (vtitle, e, a)) in enumerate(zip(axes, _views(elev, azim), strict=True)):
        ax.view_init(elev=e, azim=a)
        ax.computed_zorder = False  # wireframe < surface < lines, whatever the depth
        _draw_wireframe(ax, pts, tri)
        _draw_surface(
            ax, deformed, tri, e, a, values=facet_vals, cmap=cmap, norm=norm, edge_width=0.1
        )
        if lin is not None:
            _draw_lines(ax, pts, lin, color=(0.6, 0.6, 0.6), lw=0.8)
            _draw_lines(ax, deformed, lin)
        _set_equal_aspect(ax, allpts, zoom=1.15)
        _style_axes(ax, side=i == 0)
        ax.set_title(vtitle, fontsize=9)
    fig.suptitle(_mode_title(frequency_hz, label, index), fontsize=12)
    sm = cm.ScalarMappable(norm=norm, cmap=cmap)
    cb = fig.colorbar(sm, cax=cax)
    cb.set_label(f"|displacement| / max (display scale {s:.3g})")
    return save_png(fig, path)


def plot_modes_overview_png(
    path,
    points,
    triangles,
    shapes,
    frequencies_hz,
    labels: Sequence[str],
    lines=None,
    scale: float | None = None,
) -> Path:
    """Grid of small side views (elev=0, looking along y), one per mode (first 12 modes),
    each showing the displaced surface coloured by |shape| over the undeformed wireframe and
    titled with index, frequency and label.

    points (n, 3) [m]; triangles (nt, 3) int; shapes (N, n, 3); frequencies_hz (N,) [Hz];
    labels: N strings; lines (m, 2) int or None. Returns the path.
    """
    import matplotlib
    from matplotlib import colors

    pts = as_points(points)
    tri = as_cells(triangles, 3, len(pts), "triangles")
    lin = as_lines(lines, len(pts))
    shp, freqs, labels = as_mode_set(pts, shapes, frequencies_hz, labels)
    n = min(shp.shape[0], _MAX_OVERVIEW_MODES)
    if n == 0:
        raise ValueError("no modes to plot")
    ncols = min(4, n)
    nrows = math.ceil(n / ncols)
    cmap = matplotlib.colormaps["plasma"]
    norm = colors.Normalize(0.0, 1.0)
    _, e, a = _SIDE_VIEW

    fig = new_figure((3.2 * ncols, 2.9 * nrows + 0.3))
    for k in range(n):
        ax = fig.add_subplot(nrows, ncols, k + 1, projection="3d")
        ax.view_init(elev=e, azim=a)
        ax.computed_zorder = False  # wireframe < surface < lines, whatever the depth
        s = default_scale(pts, shp[k]) if scale is None else float(scale)
        deformed = pts + s * shp[k]
        rel = _relative_magnitude(shp[k])
        _draw_wireframe(ax, pts, tri, lw=0.2)
        _draw_surface(
            ax,
            deformed,
            tri,
            e,
            a,
            values=rel[tri].mean(axis=1),
            cmap=cmap,
            norm=norm,
            edge_width=0.05,
        )
        if lin is not None:
            _draw_lines(ax, deformed, lin, lw=0.8)
        _set_equal_aspect(ax, np.vstack([pts, deformed]), zoom=1.2)
        _style_axes(ax, small=True)
        ax.set_title(f"{k + 1}: {freqs[k]:.1f} Hz\n{labels[k]}", fontsize=8)
    fig.subplots_adjust(left=0.02, right=0.98, bottom=0.02, top=0.92, wspace=0.05, hspace=0.2)
    return save_png(fig, path)
