"""Output of surface meshes and mode shapes: VTU/PVD files for ParaView and PNG pictures.

All inputs are plain numpy arrays in SI units (metres):

* ``points``    (n, 3) float, node positions [m]
* ``triangles`` (nt, 3) int, node indices of the triangular facets
* ``lines``     (m, 2) int, optional extra line cells (ties, beam centre line, ...)
* ``shapes``    (N, n, 3) float, mode shapes at the nodes (any scale)
* ``frequencies_hz`` (N,) float [Hz], ``labels`` list of N strings

Plots use matplotlib's Agg canvas directly (no pyplot global state), so they work headless.
Every writer first writes to a temporary file in the target directory and renames it with
``os.replace`` at the end, so no partial file is left behind on error.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from quadmodes.io.atomic import atomic_path

_MAX_OVERVIEW_MODES = 12

__all__ = [
    "default_scale",
    "plot_mesh_png",
    "plot_mode_png",
    "plot_modes_overview_png",
    "write_mesh_vtu",
    "write_modes_pvd",
    "write_pvd",
]

_PNG_DPI = 120

# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def _as_points(points) -> np.ndarray:
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {pts.shape}")
    return pts


def _as_cells(cells, width: int, n_points: int, name: str) -> np.ndarray:
    arr = np.asarray(cells)
    if arr.size == 0:
        return np.zeros((0, width), dtype=np.int64)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must have shape (m, {width}), got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"{name} must be an integer array, got dtype {arr.dtype}")
    arr = arr.astype(np.int64)
    if arr.min() < 0 or arr.max() >= n_points:
        raise ValueError(f"{name} reference nodes outside 0..{n_points - 1}")
    return arr


def _as_shapes(shapes, n_points: int) -> np.ndarray:
    arr = np.asarray(shapes, dtype=float)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (n_points, 3):
        raise ValueError(f"shapes must have shape (N, {n_points}, 3), got {arr.shape}")
    return arr


def _bbox_diagonal(points: np.ndarray) -> float:
    if len(points) == 0:
        return 0.0
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def default_scale(points, shape, fraction: float = 0.1) -> float:
    """Display scale for a mode shape: ``fraction`` of the bounding-box diagonal of
    ``points`` (n, 3) [m] divided by the largest nodal |shape| ((n, 3) or (N, n, 3)).

    Returns a dimensionless factor (0.0 if the shape is identically zero).
    """
    pts = _as_points(points)
    sh = np.asarray(shape, dtype=float).reshape(-1, 3)
    umax = float(np.max(np.linalg.norm(sh, axis=1))) if sh.size else 0.0
    if umax <= 0.0 or not np.isfinite(umax):
        return 0.0
    return fraction * _bbox_diagonal(pts) / umax


def _numeric_array(name: str, value) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype == bool:
        arr = arr.astype(np.uint8)
    if not (np.issubdtype(arr.dtype, np.number)):
        raise TypeError(f"data {name!r} must be numeric, got dtype {arr.dtype}")
    return arr


def _fill_like(arr: np.ndarray, n: int) -> np.ndarray:
    """Array of ``n`` rows with the trailing shape of ``arr``: NaN for floats, else 0."""
    shape = (n,) + arr.shape[1:]
    if np.issubdtype(arr.dtype, np.floating):
        return np.full(shape, np.nan, dtype=arr.dtype)
    return np.zeros(shape, dtype=arr.dtype)


# --------------------------------------------------------------------------------------------
# VTU / PVD
# --------------------------------------------------------------------------------------------


def write_mesh_vtu(
    path,
    points,
    triangles,
    lines=None,
    point_data: Mapping[str, np.ndarray] | None = None,
    cell_data: Mapping[str, np.ndarray] | None = None,
    field_data: Mapping[str, np.ndarray] | None = None,
) -> Path:
    """Write a surface mesh as a VTK unstructured grid (``.vtu``) via meshio.

    points (n, 3) [m]; triangles (nt, 3) int; lines (m, 2) int or None.
    point_data: name -> (n,) or (n, k) arrays.
    cell_data: name -> (nt,) / (nt, k) per-triangle arrays (line cells get NaN for float
    data, 0 for integer data), or a list ``[tri_values, line_values]`` per cell block.
    field_data: name -> small arrays stored as VTK FieldData.
    Returns the written path.
    """
    import meshio

    path = Path(path)
    pts = _as_points(points)
    tri = _as_cells(triangles, 3, len(pts), "triangles")
    lin = None if lines is None else _as_cells(lines, 2, len(pts), "lines")
    if lin is not None and len(lin) == 0:
        lin = None

    cells = [("triangle", tri)]
    if lin is not None:
        cells.append(("line", lin))

    pdata = {}
    for name, value in (point_data or {}).items():
        arr = _numeric_array(name, value)
        if arr.shape[0] != len(pts):
            raise ValueError(f"point data {name!r} has {arr.shape[0]} rows, expected {len(pts)}")
        pdata[name] = arr

    cdata = {}
    for name, value in (cell_data or {}).items():
        if isinstance(value, list | tuple) and len(value) == len(cells):
            blocks = [_numeric_array(name, v) for v in value]
        else:
            arr = _numeric_array(name, value)
            blocks = [arr]
            if lin is not None:
                blocks.append(_fill_like(arr, len(lin)))
        for block, (ctype, conn) in zip(blocks, cells, strict=True):
            if block.shape[0] != len(conn):
                raise ValueError(
                    f"cell data {name!r} has {block.shape[0]} {ctype} values, expected {len(conn)}"
                )
        cdata[name] = blocks

    fdata = {k: np.atleast_1d(_numeric_array(k, v)) for k, v in (field_data or {}).items()}

    mesh = meshio.Mesh(pts, cells, point_data=pdata, cell_data=cdata)
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")
        if fdata:
            _insert_field_data(tmp, fdata)
    return path


_VTK_TYPES = {
    "f4": "Float32",
    "f8": "Float64",
    "i1": "Int8",
    "i2": "Int16",
    "i4": "Int32",
    "i8": "Int64",
    "u1": "UInt8",
    "u2": "UInt16",
    "u4": "UInt32",
    "u8": "UInt64",
}


def _insert_field_data(path: Path, fdata: Mapping[str, np.ndarray]) -> None:
    """Add a VTK ``<FieldData>`` block (ASCII arrays) to a meshio-written ``.vtu`` file.

    meshio 5.3 reads FieldData from VTU but does not write it.
    """
    parts = ["<FieldData>"]
    for name, arr in fdata.items():
        arr = np.asarray(arr)
        if np.issubdtype(arr.dtype, np.floating):
            arr = arr.astype(np.float64)
            text = " ".join(repr(float(v)) for v in arr.ravel())
        else:
            text = " ".join(str(int(v)) for v in arr.ravel())
        vtk_type = _VTK_TYPES[arr.dtype.str.lstrip("<>=|")]
        ncomp = "" if arr.ndim == 1 else f' NumberOfComponents="{int(np.prod(arr.shape[1:]))}"'
        parts.append(
            f'<DataArray type="{vtk_type}" Name="{escape(name, {chr(34): "&quot;"})}" '
            f'NumberOfTuples="{arr.shape[0]}"{ncomp} format="ascii">{text}</DataArray>'
        )
    parts.append("</FieldData>")
    content = path.read_text(encoding="utf-8")
    tag = "<UnstructuredGrid>"
    i = content.find(tag)
    if i < 0:
        raise RuntimeError(f"unexpected VTU layout in {path}")
    i += len(tag)
    content = content[:i] + "\n" + "\n".join(parts) + content[i:]
    path.write_text(content, encoding="utf-8")


def write_pvd(path, datasets: Sequence[tuple[float, str]]) -> Path:
    """Write a ParaView collection file listing ``(timestep, relative_file)`` pairs."""
    path = Path(path)
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for t, fname in datasets:
        ET.SubElement(coll, "DataSet", timestep=repr(float(t)), group="", part="0", file=fname)
    ET.indent(root)
    tree = ET.ElementTree(root)
    with atomic_path(path) as tmp:
        tree.write(tmp, encoding="utf-8", xml_declaration=True)
    return path


def write_modes_pvd(
    directory,
    points,
    triangles,
    shapes,
    frequencies_hz,
    labels: Sequence[str],
    lines=None,
    frames: int = 12,
    scale: float | None = None,
) -> Path:
    """Write mode shapes for ParaView into ``directory`` (created if needed).

    points (n, 3) [m]; triangles (nt, 3) int; shapes (N, n, 3); frequencies_hz (N,) [Hz];
    labels: N strings; lines (m, 2) int or None.

    Files (k = mode index, j = frame index):

    * ``mode_{k:02d}.vtu``: undeformed mesh with point data ``displacement`` (the mode shape,
      use "Warp By Vector") and ``frequency_hz``; field data ``frequency_hz``, ``mode_index``.
    * ``mode_{k:02d}_frame_{j:03d}.vtu``: surface displaced by
      ``scale * sin(2 pi j / frames) * shape``; ``mode_{k:02d}.pvd`` animates them.
    * ``modes.pvd``: the undeformed per-mode files with timestep = k.
    * ``modes.txt``: index, frequency and label of each mode.

    ``scale`` defaults to 10 % of the bounding-box diagonal divided by max |shape| (per mode).
    Returns the path of ``modes.pvd``.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    pts = _as_points(points)
    shp = _as_shapes(shapes, len(pts))
    freqs = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    labels = list(labels)
    n_modes = shp.shape[0]
    if freqs.shape != (n_modes,) or len(labels) != n_modes:
        raise ValueError(f"got {n_modes} shapes, {freqs.size} frequencies and {len(labels)} labels")
    frames = int(frames)
    if frames < 1:
        raise ValueError("frames must be >= 1")

    top = []
    for k in range(n_modes):
        shape = shp[k]
        f = freqs[k]
        fdata = {"frequency_hz": np.array([f]), "mode_index": np.array([k], dtype=np.int64)}
        base = f"mode_{k:02d}"
        write_mesh_vtu(
            directory / f"{base}.vtu",
            pts,
            triangles,
            lines=lines,
            point_data={"displacement": shape, "frequency_hz": np.full(len(pts), f)},
            field_data=fdata,
        )
        top.append((float(k), f"{base}.vtu"))

        s = default_scale(pts, shape) if scale is None else float(scale)
        anim = []
        for j in range(frames):
            amp = s * math.sin(2.0 * math.pi * j / frames)
            disp = amp * shape
            fname = f"{base}_frame_{j:03d}.vtu"
            write_mesh_vtu(
                directory / fname,
                pts + disp,
                triangles,
                lines=lines,
                point_data={"displacement": disp, "frequency_hz": np.full(len(pts), f)},
                field_data=fdata,
            )
            anim.append((float(j), fname))
        write_pvd(directory / f"{base}.pvd", anim)

    with atomic_path(directory / "modes.txt") as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write("# mode\tfrequency_hz\tlabel\n")
            for k in range(n_modes):
                fh.write(f"{k}\t{freqs[k]:.9g}\t{labels[k]}\n")
    return write_pvd(directory / "modes.pvd", top)


# --------------------------------------------------------------------------------------------
# PNG plots
# --------------------------------------------------------------------------------------------


def _new_figure(figsize):
    # Figure + FigureCanvasAgg directly: headless, no pyplot state, no global backend switch.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=_PNG_DPI)
    FigureCanvasAgg(fig)
    return fig


def _save_png(fig, path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=_PNG_DPI)
    return path


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

    pts = _as_points(points)
    tri = _as_cells(triangles, 3, len(pts), "triangles")
    lin = None if lines is None else _as_cells(lines, 2, len(pts), "lines")
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

    fig = _new_figure((12, 5))
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
    return _save_png(fig, path)


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

    pts = _as_points(points)
    tri = _as_cells(triangles, 3, len(pts), "triangles")
    lin = None if lines is None else _as_cells(lines, 2, len(pts), "lines")
    shp = _as_shapes(shape, len(pts))[0]
    s = default_scale(pts, shp) if scale is None else float(scale)
    deformed = pts + s * shp

    mag = np.linalg.norm(shp, axis=1)
    umax = float(mag.max()) if mag.size else 0.0
    rel = mag / umax if umax > 0 else np.zeros_like(mag)
    facet_vals = rel[tri].mean(axis=1)
    cmap = matplotlib.colormaps["plasma"]
    norm = colors.Normalize(0.0, 1.0)

    fig = _new_figure((12, 5))
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
    return _save_png(fig, path)


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

    pts = _as_points(points)
    tri = _as_cells(triangles, 3, len(pts), "triangles")
    lin = None if lines is None else _as_cells(lines, 2, len(pts), "lines")
    shp = _as_shapes(shapes, len(pts))
    freqs = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    labels = list(labels)
    if freqs.shape != (shp.shape[0],) or len(labels) != shp.shape[0]:
        raise ValueError(
            f"got {shp.shape[0]} shapes, {freqs.size} frequencies and {len(labels)} labels"
        )
    n = min(shp.shape[0], _MAX_OVERVIEW_MODES)
    if n == 0:
        raise ValueError("no modes to plot")
    ncols = min(4, n)
    nrows = math.ceil(n / ncols)
    cmap = matplotlib.colormaps["plasma"]
    norm = colors.Normalize(0.0, 1.0)
    _, e, a = _SIDE_VIEW

    fig = _new_figure((3.2 * ncols, 2.9 * nrows + 0.3))
    for k in range(n):
        ax = fig.add_subplot(nrows, ncols, k + 1, projection="3d")
        ax.view_init(elev=e, azim=a)
        ax.computed_zorder = False  # wireframe < surface < lines, whatever the depth
        s = default_scale(pts, shp[k]) if scale is None else float(scale)
        deformed = pts + s * shp[k]
        mag = np.linalg.norm(shp[k], axis=1)
        umax = float(mag.max()) if mag.size else 0.0
        rel = mag / umax if umax > 0 else np.zeros_like(mag)
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
    return _save_png(fig, path)
