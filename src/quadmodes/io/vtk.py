"""Surface meshes and mode shapes for ParaView: VTK unstructured grids (``.vtu``, via meshio)
and collection files (``.pvd``).

Inputs are the arrays of :mod:`quadmodes.io.mesh_arrays` (SI units, metres). Every file is
written through :mod:`quadmodes.io.atomic`, so no partial file is left behind on error.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from quadmodes.io.atomic import atomic_path, write_text
from quadmodes.io.mesh_arrays import as_cells, as_lines, as_mode_set, as_points, default_scale

__all__ = ["write_mesh_vtu", "write_modes_pvd", "write_pvd"]

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


def _point_data(point_data: Mapping[str, np.ndarray] | None, n_points: int) -> dict:
    """name -> numeric (n_points,) / (n_points, k) arrays; ValueError for another row count."""
    pdata = {}
    for name, value in (point_data or {}).items():
        arr = _numeric_array(name, value)
        if arr.shape[0] != n_points:
            raise ValueError(f"point data {name!r} has {arr.shape[0]} rows, expected {n_points}")
        pdata[name] = arr
    return pdata


def _cell_data(cell_data: Mapping[str, np.ndarray] | None, cells: list, has_lines: bool) -> dict:
    """name -> one array per cell block of ``cells`` [("triangle", tri), ("line", lin)?]: a
    per-triangle array gets a NaN (float) or 0 (integer) block for the line cells."""
    cdata = {}
    for name, value in (cell_data or {}).items():
        if isinstance(value, list | tuple) and len(value) == len(cells):
            blocks = [_numeric_array(name, v) for v in value]
        else:
            arr = _numeric_array(name, value)
            blocks = [arr]
            if has_lines:
                blocks.append(_fill_like(arr, len(cells[1][1])))
        for block, (ctype, conn) in zip(blocks, cells, strict=True):
            if block.shape[0] != len(conn):
                raise ValueError(
                    f"cell data {name!r} has {block.shape[0]} {ctype} values, expected {len(conn)}"
                )
        cdata[name] = blocks
    return cdata


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
    pts = as_points(points)
    tri = as_cells(triangles, 3, len(pts), "triangles")
    lin = as_lines(lines, len(pts))
    if lin is not None and len(lin) == 0:
        lin = None

    cells = [("triangle", tri)] if len(tri) or lin is None else []  # a beam: lines only
    if lin is not None:
        cells.append(("line", lin))
    pdata = _point_data(point_data, len(pts))
    cdata = _cell_data(cell_data, cells, lin is not None and len(cells) == 2)
    fdata = {k: np.atleast_1d(_numeric_array(k, v)) for k, v in (field_data or {}).items()}

    mesh = meshio.Mesh(pts, cells, point_data=pdata, cell_data=cdata)
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")
        if fdata:
            text = _with_field_data(tmp.read_text(encoding="utf-8"), fdata, tmp)
            write_text(tmp, text)
    return path


def _field_data_block(fdata: Mapping[str, np.ndarray]) -> str:
    """VTK ``<FieldData>`` XML block with one ASCII ``DataArray`` per entry of ``fdata``."""
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
    return "\n".join(parts)


def _with_field_data(content: str, fdata: Mapping[str, np.ndarray], path: Path) -> str:
    """The text ``content`` of a meshio-written ``.vtu`` file (from ``path``) with a VTK
    ``<FieldData>`` block inserted after ``<UnstructuredGrid>``.

    meshio 5.3 reads FieldData from VTU but does not write it.
    """
    tag = "<UnstructuredGrid>"
    i = content.find(tag)
    if i < 0:
        raise RuntimeError(f"unexpected VTU layout in {path}")
    i += len(tag)
    return content[:i] + "\n" + _field_data_block(fdata) + content[i:]


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


def _write_mode_files(
    directory: Path, k: int, pts, triangles, lines, shape, f, frames, scale
) -> str:
    """Files of mode number ``k`` (from 1; shape (n, 3), frequency ``f`` Hz):
    ``mode_{k:02d}.vtu`` and its ``frames`` frames, all on the undeformed mesh with the frame's
    displacement as point data, and their ``.pvd``; returns the name of the mode's file."""
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
    s = default_scale(pts, shape) if scale is None else float(scale)
    anim = []
    for j in range(frames):
        amp = s * math.sin(2.0 * math.pi * j / frames)
        fname = f"{base}_frame_{j:03d}.vtu"
        write_mesh_vtu(
            directory / fname,
            pts,  # undeformed: Warp By Vector (scale 1) applies the displacement once
            triangles,
            lines=lines,
            point_data={"displacement": amp * shape, "frequency_hz": np.full(len(pts), f)},
            field_data=fdata,
        )
        anim.append((float(j), fname))
    write_pvd(directory / f"{base}.pvd", anim)
    return f"{base}.vtu"


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

    Files (k = mode number, from 1 as in results.nc, the CLI tables and the PNG pictures;
    j = frame index from 0). Every file holds the undeformed mesh and the displacement as point
    data, so ParaView's "Warp By Vector" (scale factor 1, or any other) shows it once:

    * ``mode_{k:02d}.vtu``: point data ``displacement`` (the mode shape as computed) and
      ``frequency_hz``; field data ``frequency_hz``, ``mode_index`` (= k).
    * ``mode_{k:02d}_frame_{j:03d}.vtu``: point data ``displacement`` =
      ``scale * sin(2 pi j / frames) * shape``; ``mode_{k:02d}.pvd`` animates them.
    * ``modes.pvd``: the per-mode files with timestep = k.
    * ``modes.txt``: number, frequency and label of each mode.

    ``scale`` defaults to 10 % of the bounding-box diagonal divided by max |shape| (per mode).
    Returns the path of ``modes.pvd``.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    pts = as_points(points)
    shp, freqs, labels = as_mode_set(pts, shapes, frequencies_hz, labels)
    frames = int(frames)
    if frames < 1:
        raise ValueError("frames must be >= 1")
    top = []
    for k in range(shp.shape[0]):
        name = _write_mode_files(
            directory, k + 1, pts, triangles, lines, shp[k], freqs[k], frames, scale
        )
        top.append((float(k + 1), name))
    table = "# mode\tfrequency_hz\tlabel\n" + "".join(
        f"{k + 1}\t{freqs[k]:.9g}\t{labels[k]}\n" for k in range(shp.shape[0])
    )
    write_text(directory / "modes.txt", table)
    return write_pvd(directory / "modes.pvd", top)
