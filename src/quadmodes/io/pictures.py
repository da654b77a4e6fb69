"""PNG pictures of a surface mesh and its mode shapes: a side view (looking along +y: x to the
right, z up, axes in metres) and a rotated view, shaded facets with visible edges.

The views are orthographic projections drawn on flat axes (facets sorted back to front), so the
aspect is exactly equal, the axes fit the whole body (line cells such as the end-body ties and
their mass points included) and the figure is sized to the body's shape; the PNG is cropped to
its content. Modes are numbered from 1 (as in results.nc, the CLI tables and the mode files).

Inputs are the arrays of :mod:`quadmodes.io.mesh_arrays` (SI units, metres). Figures are drawn
on matplotlib's Agg canvas and saved atomically (:mod:`quadmodes.io.figures`), so they work
headless and leave no partial file behind.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
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
_BASE_COLOR = (0.72, 0.78, 0.88)


@dataclass(frozen=True)
class View:
    """An orthographic view: ``elev``, ``azim`` (degrees, matplotlib's convention: the viewer
    at ``(cos e cos a, cos e sin a, sin e)``), a title, and whether its axes are x and z."""

    title: str
    elev: float
    azim: float
    side: bool = False

    def basis(self) -> np.ndarray:
        """Rows: screen right, screen up, towards the viewer (3, 3), unit vectors."""
        e, a = np.radians(self.elev), np.radians(self.azim)
        right = np.array([-np.sin(a), np.cos(a), 0.0])
        up = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
        toward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        return np.stack([right, up, toward])


#: The side view looks along +y: x to the right, z up.
SIDE_VIEW = View("side view (along y)", 0.0, -90.0, side=True)


def _views(elev: float, azim: float) -> list[View]:
    rotated = View(f"view elev={elev:g}\N{DEGREE SIGN}, azim={azim:g}\N{DEGREE SIGN}", elev, azim)
    return [SIDE_VIEW, rotated]


def _shading(verts: np.ndarray, view: View) -> np.ndarray:
    """Lambert-type brightness in [0.35, 1] per facet; verts (nt, 3, 3). The light comes from
    the viewer, raised 30 degrees and turned 30 degrees left; |n . l| does not depend on the
    facet orientation."""
    normals = np.cross(verts[:, 1] - verts[:, 0], verts[:, 2] - verts[:, 0])
    norm = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = normals / np.where(norm > 0, norm, 1.0)
    light = View("", min(view.elev + 30.0, 90.0), view.azim - 30.0).basis()[2]
    return 0.35 + 0.65 * np.abs(normals @ light)


def _projected_bounds(pts: np.ndarray, view: View) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) corners (2,) m of ``pts`` (n, 3) on the view's screen plane."""
    xy = pts @ view.basis()[:2].T
    return xy.min(axis=0), xy.max(axis=0)


def _facet_colours(verts, view, values, cmap, norm) -> tuple[np.ndarray, np.ndarray]:
    shade = _shading(verts, view)[:, None]
    if values is None:
        rgb = np.asarray(_BASE_COLOR)[None, :] * shade
    else:
        rgb = cmap(norm(values))[:, :3] * (0.55 + 0.45 * shade)
    faces = np.column_stack([np.clip(rgb, 0.0, 1.0), np.ones(len(rgb))])
    edges = np.column_stack([0.35 * faces[:, :3], np.full(len(rgb), 0.6)])
    return faces, edges


def _draw_surface(ax, pts, tri, view: View, values=None, cmap=None, norm=None, edge_width=0.2):
    """Facets of ``tri`` on ``pts`` projected on ``view``, back to front (painter's order)."""
    from matplotlib.collections import PolyCollection

    if len(tri) == 0:
        return
    basis = view.basis()
    verts = pts[tri]
    order = np.argsort((verts @ basis[2]).mean(axis=1))  # far first
    faces, edges = _facet_colours(verts[order], view, None if values is None
                                  else np.asarray(values)[order], cmap, norm)  # fmt: skip
    poly = PolyCollection(verts[order] @ basis[:2].T, facecolors=faces, edgecolors=edges,
                          linewidths=edge_width, zorder=2)  # fmt: skip
    ax.add_collection(poly)


def _draw_wireframe(ax, pts, tri, view: View, color=(0.7, 0.7, 0.7), lw=0.3):
    from matplotlib.collections import LineCollection

    if len(tri) == 0:
        return
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    xy = pts @ view.basis()[:2].T
    ax.add_collection(LineCollection(xy[edges], colors=[color], linewidths=lw, zorder=1))


def _draw_lines(ax, pts, lines, view: View, color="crimson", lw=1.0, zorder=3):
    """Line cells (end-body ties, beam centre line) and their end points, on top."""
    from matplotlib.collections import LineCollection

    if lines is None or len(lines) == 0:
        return
    xy = pts @ view.basis()[:2].T
    ax.add_collection(LineCollection(xy[lines], colors=color, linewidths=lw, zorder=zorder))
    nodes = np.unique(lines)
    ax.plot(*xy[nodes].T, ".", color=color, ms=2.5, zorder=zorder)


def _drawn(pts: np.ndarray, tri: np.ndarray, lines: np.ndarray | None) -> np.ndarray:
    """The points that the facets and line cells use (all points if none): what the axes fit."""
    used = [tri.ravel()] + ([lines.ravel()] if lines is not None else [])
    used = np.unique(np.concatenate(used)) if sum(u.size for u in used) else slice(None)
    return pts[used]


def _fit_axes(ax, lo: np.ndarray, hi: np.ndarray, view: View, small: bool) -> None:
    """Equal aspect, limits = the bounds with a 3 % margin; axis labels on the side view."""
    span = np.maximum(hi - lo, 1e-9)
    pad = 0.03 * float(span.max())
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")
    if small or not view.side:
        ax.set_xticks([])
        ax.set_yticks([])
        for spine in ax.spines.values():
            spine.set_visible(False)
        return
    ax.set_xlabel("x [m]", fontsize=8)
    ax.set_ylabel("z [m]", fontsize=8)
    ax.tick_params(labelsize=7)


def _panel_size(lo, hi, max_width: float, max_height: float, min_width: float = 1.5):
    """(width, height) inches of a panel showing the bounds ``lo``..``hi`` (2,) at equal
    aspect, as large as fits ``max_width`` × ``max_height`` (at least ``min_width`` × 1.2)."""
    span = np.maximum(np.asarray(hi) - np.asarray(lo), 1e-9)
    scale = min(max_width / float(span[0]), max_height / float(span[1]))
    return max(min_width, float(span[0]) * scale), max(1.2, float(span[1]) * scale)


def _two_view_figure(allpts: np.ndarray, views: list[View], with_colorbar: bool,
                     max_height: float = 5.2, max_width: float = 6.5):  # fmt: skip
    """A figure with one axes per view, each sized to its view of ``allpts`` (equal aspect,
    within ``max_width`` × ``max_height`` inches), and a colour-bar axes (or None)."""
    bounds = [_projected_bounds(allpts, v) for v in views]
    sizes = [_panel_size(lo, hi, max_width, max_height) for lo, hi in bounds]
    gap, left, bar, bottom, top = 0.5, 0.7, (1.1 if with_colorbar else 0.1), 0.45, 0.5
    total_w = left + sum(w for w, _ in sizes) + gap * (len(sizes) - 1) + bar
    height = max(h for _, h in sizes)
    total_h = bottom + height + top
    fig = new_figure((total_w, total_h))
    axes, x = [], left
    for w, h in sizes:
        axes.append(fig.add_axes((x / total_w, bottom / total_h, w / total_w, h / total_h)))
        x += w + gap
    cax = None
    if with_colorbar:
        bar_h = max(0.6 * height, 1.0)
        cax = fig.add_axes(((x - gap + 0.25) / total_w, bottom / total_h, 0.12 / total_w,
                            min(bar_h, height) / total_h))  # fmt: skip
    return fig, axes, cax, bounds


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
    """Render a triangulated surface to PNG: side view (looking along y) and a rotated view
    (``elev``, ``azim`` in degrees), equal aspect, shaded facets, visible edges, the whole body.

    points (n, 3) [m]; triangles (nt, 3) int; lines (m, 2) int or None (drawn in red with their
    end points: end-body ties and mass points); cell_values (nt,) optional per-facet values
    shown with a colour map and a colour bar labelled ``cell_label``. Returns the path.
    """
    import matplotlib
    from matplotlib import cm, colors

    pts = as_points(points)
    tri = as_cells(triangles, 3, len(pts), "triangles")
    lin = as_lines(lines, len(pts))
    vals = cmap = norm = None
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
    views = _views(elev, azim)
    fig, axes, cax, bounds = _two_view_figure(_drawn(pts, tri, lin), views, vals is not None)
    for ax, view, (lo, hi) in zip(axes, views, bounds, strict=True):
        _draw_surface(ax, pts, tri, view, values=vals, cmap=cmap, norm=norm)
        _draw_lines(ax, pts, lin, view)
        _fit_axes(ax, lo, hi, view, small=False)
        ax.set_title(view.title, fontsize=9)
    if title:
        fig.suptitle(title, fontsize=12)
    if vals is not None:
        cb = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), cax=cax)
        if cell_label:
            cb.set_label(cell_label)
    return save_png(fig, path, tight=True)


def _relative_magnitude(shape: np.ndarray, tri: np.ndarray | None = None) -> np.ndarray:
    """|shape| per node (n,) divided by its largest value on the nodes of the facets ``tri``
    (all nodes if there are none), so that the surface colours span the map even when an end
    body moves most; zeros for a zero shape."""
    mag = np.linalg.norm(shape, axis=1)
    on = mag[np.unique(tri)] if tri is not None and len(tri) else mag
    umax = float(on.max()) if on.size else 0.0
    return np.minimum(mag / umax, 1.0) if umax > 0 else np.zeros_like(mag)


def _mode_title(frequency_hz: float, label: str, index: int | None) -> str:
    head = f"{frequency_hz:.1f} Hz"
    if index is not None:
        head = f"Mode {index}: {head}"
    return f"{head} \N{EM DASH} {label}" if label else head


def _draw_mode(ax, pts, deformed, tri, lin, rel, view, cmap, norm, small: bool) -> None:
    """Undeformed wireframe (grey), displaced surface coloured by |shape|, ties on top."""
    _draw_wireframe(ax, pts, tri, view, lw=0.2 if small else 0.3)
    _draw_surface(ax, deformed, tri, view, values=rel[tri].mean(axis=1) if len(tri) else None,
                  cmap=cmap, norm=norm, edge_width=0.05 if small else 0.1)  # fmt: skip
    if lin is not None:
        if not small:
            _draw_lines(ax, pts, lin, view, color=(0.6, 0.6, 0.6), lw=0.7, zorder=2.5)
        _draw_lines(ax, deformed, lin, view, lw=0.7 if small else 1.0)


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
    (without "Mode {index}: " if ``index`` is None; modes are numbered from 1). ``scale``
    defaults to 10 % of the bounding-box diagonal / max |shape|. Returns the path.
    """
    import matplotlib
    from matplotlib import cm, colors

    pts = as_points(points)
    tri = as_cells(triangles, 3, len(pts), "triangles")
    lin = as_lines(lines, len(pts))
    shp = as_shapes(shape, len(pts))[0]
    s = default_scale(pts, shp) if scale is None else float(scale)
    deformed = pts + s * shp
    cmap, norm = matplotlib.colormaps["plasma"], colors.Normalize(0.0, 1.0)
    rel = _relative_magnitude(shp, tri)
    views = _views(elev, azim)
    drawn = np.vstack([_drawn(pts, tri, lin), _drawn(deformed, tri, lin)])
    fig, axes, cax, bounds = _two_view_figure(drawn, views, len(tri) > 0)
    for ax, view, (lo, hi) in zip(axes, views, bounds, strict=True):
        _draw_mode(ax, pts, deformed, tri, lin, rel, view, cmap, norm, small=False)
        _fit_axes(ax, lo, hi, view, small=False)
        ax.set_title(view.title, fontsize=9)
    fig.suptitle(f"{_mode_title(frequency_hz, label, index)}  (shape × {s:.3g})", fontsize=12)
    if cax is not None:
        cb = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), cax=cax)
        cb.set_label("|displacement| / max on the surface", fontsize=9)
    return save_png(fig, path, tight=True)


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
    """Grid of small side views (looking along y), one per mode (first 12 modes), each showing
    the displaced surface coloured by |shape| over the undeformed wireframe and titled with its
    number (from 1), frequency and label.

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
    cmap, norm = matplotlib.colormaps["plasma"], colors.Normalize(0.0, 1.0)
    scales = [default_scale(pts, shp[k]) if scale is None else float(scale) for k in range(n)]
    deformed = [pts + scales[k] * shp[k] for k in range(n)]
    drawn = np.vstack([_drawn(x, tri, lin) for x in (pts, *deformed)])
    lo, hi = _projected_bounds(drawn, SIDE_VIEW)  # one frame for all
    width, height = _panel_size(lo, hi, 5.0, 3.0, 1.7)
    nrows = math.ceil(n / max(1, min(n, int(16.0 // (width + 0.15)))))
    ncols = math.ceil(n / nrows)  # rows as full as possible
    fig = new_figure((ncols * (width + 0.15), nrows * (height + 0.6)))
    for k in range(n):
        ax = fig.add_subplot(nrows, ncols, k + 1)
        _draw_mode(ax, pts, deformed[k], tri, lin, _relative_magnitude(shp[k], tri), SIDE_VIEW,
                   cmap, norm, small=True)  # fmt: skip
        _fit_axes(ax, lo, hi, SIDE_VIEW, small=True)
        ax.set_title(f"{k + 1}: {freqs[k]:.1f} Hz\n{labels[k]}", fontsize=8)
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.01, top=0.93, wspace=0.08, hspace=0.25)
    return save_png(fig, path, tight=True)
