"""Read and write triangulated surfaces through meshio (format chosen by file extension)."""

from __future__ import annotations

import contextlib
import io
import stat
import warnings
from pathlib import Path

import meshio
import numpy as np

from quadmodes.limits import MESH_FILE_BYTES, MESH_NODES, LimitError, check_count
from quadmodes.mesh.surface import TriangleSurface

__all__ = ["check_mesh_file", "merge_coincident", "read_surface", "write_surface"]


def read_surface(path: str | Path, scale: float = 1.0) -> TriangleSurface:
    """Read the triangle cells of a mesh file (any meshio format) as a surface in metres.

    Only ``triangle`` cell blocks are used; other cells are ignored and nodes not used by any
    triangle are dropped (indices renumbered in order). 2-D points get z = 0. Coordinates are
    multiplied by ``scale`` (metres per file unit: ``geometry.file_unit``). Nodes at exactly the
    same position are merged (exporters that write each triangle's own corners, as STL does,
    would otherwise leave a surface open along every edge).

    Before reading: the path must be a regular file (not a folder, FIFO or device) no larger
    than :data:`quadmodes.limits.MESH_FILE_BYTES`; a binary STL's triangle count (its header)
    estimates the nodes against :data:`~quadmodes.limits.MESH_NODES`, and every format's node
    count is checked once read, before any model is built.

    Raises ``ValueError`` (one line naming ``geometry.file`` and the fix) if the file cannot be
    read, is too large or holds no triangles.
    """
    path = Path(path)
    size = check_mesh_file(path)
    _check_nodes(path, _stl_node_estimate(path, size), "estimated from its header")
    try:  # meshio prints its own messages and may call sys.exit: keep them to ourselves
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            with warnings.catch_warnings():  # meshio's STL sniffing overflows on ASCII files
                warnings.simplefilter("ignore", RuntimeWarning)
                mesh = meshio.read(path)
    except (Exception, SystemExit) as exc:  # ReadError, KeyError, OSError, SystemExit, ...
        reason = " ".join(str(exc).split()) if not isinstance(exc, SystemExit) else "unreadable"
        raise ValueError(
            f"mesh: cannot read surface file '{path}' (geometry.file) as a triangle mesh "
            f"({reason or type(exc).__name__}); give a non-empty surface mesh file (.vtu, .stl, "
            ".obj, .ply, .msh)"
        ) from None
    blocks = [np.asarray(c.data, dtype=np.int64) for c in mesh.cells if c.type == "triangle"]
    if not blocks or sum(len(b) for b in blocks) == 0:
        types = sorted({c.type for c in mesh.cells}) or ["none"]
        raise ValueError(
            f"mesh: file '{path}' (geometry.file) has no triangle cells (found: "
            f"{', '.join(types)}); export the surface as triangles"
        )
    triangles = np.concatenate(blocks)
    points = np.asarray(mesh.points, dtype=float)
    if points.shape[1] < 3:
        points = np.hstack([points, np.zeros((len(points), 3 - points.shape[1]))])
    used, inverse = np.unique(triangles, return_inverse=True)
    points, triangles = merge_coincident(points[used, :3], inverse.reshape(triangles.shape))
    _check_nodes(path, len(points), "in the file")
    return TriangleSurface(points * float(scale), triangles)


def merge_coincident(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(points, triangles)`` with nodes at exactly equal coordinates merged into the first of
    them (order of first occurrence kept; unchanged when there are none). points (n, 3) m,
    triangles (nt, 3) int."""
    _, first, inverse = np.unique(points, axis=0, return_index=True, return_inverse=True)
    if len(first) == len(points):
        return points, triangles
    order = np.argsort(first)  # unique rows by first occurrence
    renumber = np.empty(len(first), dtype=np.int64)
    renumber[order] = np.arange(len(first))
    return points[first[order]], renumber[inverse.ravel()][triangles]


def check_mesh_file(path: Path) -> int:
    """The size (bytes) of the mesh file ``path``; ``ValueError`` unless it is an existing,
    non-empty regular file within :data:`~quadmodes.limits.MESH_FILE_BYTES`."""
    where = f"surface file '{path}' (geometry.file)"
    try:
        info = path.stat()  # follows symlinks: a link to /dev/zero is a device
    except FileNotFoundError:
        raise ValueError(
            f"mesh: {where} not found; check the path (a relative path is relative to the case "
            "file)"
        ) from None
    except OSError as exc:
        raise ValueError(f"mesh: {where} cannot be read ({exc.strerror}); check the path") from None
    if not stat.S_ISREG(info.st_mode):
        kind = "a folder" if stat.S_ISDIR(info.st_mode) else "not a regular file (a pipe, " \
            "device or socket)"
        raise ValueError(f"mesh: {where} is {kind}; give a surface mesh file (.vtu, .stl, ...)")
    if info.st_size == 0:
        raise ValueError(f"mesh: {where} is empty (0 bytes); export the surface mesh again")
    try:
        bound = MESH_FILE_BYTES.value()
    except LimitError as exc:
        raise ValueError(str(exc)) from None
    if info.st_size > bound:
        raise ValueError(
            f"mesh: {where} has {info.st_size / 1e6:,.0f} MB, more than the limit of "
            f"{bound / 1e6:,.0f} MB; give a coarser surface, or raise the limit with "
            f"{MESH_FILE_BYTES.env}={info.st_size}"
        )
    return int(info.st_size)


def _stl_node_estimate(path: Path, size: int) -> int:
    """Nodes of a binary STL from its header (a closed surface has about half as many nodes as
    triangles); 0 for any other file."""
    if path.suffix.lower() != ".stl" or size < 84:
        return 0
    with open(path, "rb") as f:
        head = f.read(84)
    if head[:5].lower() == b"solid" and b"\0" not in head[:80]:
        return 0  # an ASCII STL: the size bound covers it
    n_triangles = int.from_bytes(head[80:84], "little")
    return n_triangles // 2 + 2 if size == 84 + 50 * n_triangles else 0


def _check_nodes(path: Path, nodes: int, how: str) -> None:
    """``ValueError`` when ``nodes`` exceed :data:`~quadmodes.limits.MESH_NODES`."""
    try:
        check_count(MESH_NODES, nodes, f"mesh: surface file '{path}' (geometry.file)",
                    f"give a coarser surface (node count {how})")  # fmt: skip
    except LimitError as exc:
        raise ValueError(str(exc)) from None


def _per_item_data(
    kind: str, data: dict | None, count_name: str, count: int
) -> dict[str, np.ndarray]:
    """``data`` as arrays, each checked to have first dimension ``count`` (``ValueError`` naming
    ``kind`` and ``count_name`` otherwise)."""
    out = {}
    for name, value in (data or {}).items():
        arr = np.asarray(value)
        if arr.shape[:1] != (count,):
            raise ValueError(
                f"mesh: {kind} '{name}' has shape {arr.shape}; "
                f"its first dimension must be {count_name} = {count}"
            )
        out[name] = arr
    return out


def write_surface(
    path: str | Path,
    surface: TriangleSurface,
    point_data: dict | None = None,
    cell_data: dict | None = None,
) -> None:
    """Write a surface with meshio; the format follows the extension (``.vtu`` -> VTU).

    Parameters
    ----------
    path : output file name.
    surface : the surface (points in metres).
    point_data : name -> array with first dimension n_points (e.g. (n,) or (n, 3)).
    cell_data : name -> array with first dimension n_triangles.
    """
    path = Path(path)
    pdata = _per_item_data("point_data", point_data, "n_points", surface.n_points)
    cdata = _per_item_data("cell_data", cell_data, "n_triangles", surface.n_triangles)
    cdata = {name: [arr] for name, arr in cdata.items()}  # meshio wants one array per cell block
    mesh = meshio.Mesh(
        surface.points, [("triangle", surface.triangles)], point_data=pdata, cell_data=cdata
    )
    try:
        meshio.write(path, mesh)
    except Exception as exc:  # unknown extension, unwritable directory, ...
        raise ValueError(f"mesh: cannot write surface file '{path}': {exc}") from exc
