"""Scatter of element arrays into global vectors and sparse matrices.

Conventions used by every element kernel in :mod:`quadmodes.fe`:

* The global state is an array ``x`` of shape ``(n, 3)``: one 3-vector per *vector degree of
  freedom* (a node position, or for cable elements also a slope vector). Scalar DOF ``3*i+k`` is
  component ``k`` of vector DOF ``i``.
* An element set has a connectivity ``conn`` of shape ``(ne, k)`` (vector DOFs per element).
* Element kernels take gathered arrays ``x[conn]`` of shape ``(ne, k, 3)`` and return forces of shape
  ``(ne, k, 3)`` and stiffness blocks of shape ``(ne, 3k, 3k)`` ordered like ``x[conn].reshape(ne, 3k)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


def element_dofs(conn: np.ndarray) -> np.ndarray:
    """Scalar DOF indices ``(ne, 3k)`` of an element connectivity ``(ne, k)``."""
    conn = np.asarray(conn)
    return (3 * conn[:, :, None] + np.arange(3)).reshape(conn.shape[0], -1)


def assemble_vector(conn: np.ndarray, element_values: np.ndarray, n: int) -> np.ndarray:
    """Sum element vectors ``(ne, k, 3)`` into a global ``(n, 3)`` array."""
    out = np.empty((n, 3))
    idx = np.asarray(conn).ravel()
    vals = element_values.reshape(-1, 3)
    for c in range(3):  # three bincounts are much faster than np.add.at
        out[:, c] = np.bincount(idx, weights=vals[:, c], minlength=n)
    return out


def assemble_matrix(conn: np.ndarray, element_matrices: np.ndarray, n: int) -> sp.csr_matrix:
    """Sum element matrices ``(ne, 3k, 3k)`` into a global sparse ``(3n, 3n)`` CSR matrix."""
    dofs = element_dofs(conn)
    m = dofs.shape[1]
    rows = np.repeat(dofs, m, axis=1).ravel()
    cols = np.tile(dofs, (1, m)).ravel()
    mat = sp.coo_matrix((element_matrices.ravel(), (rows, cols)), shape=(3 * n, 3 * n))
    return mat.tocsr()


@dataclass(frozen=True, eq=False)
class CsrPattern:
    """CSR sparsity pattern ``(3n, 3n)`` of a sum of element-matrix sets, and where every entry
    of every element matrix lands in the CSR data array (computed once per structure, so each
    assembly is one ``bincount``: no COO → CSR conversion per call).

    indptr ``(3n + 1,)``, indices ``(nnz,)``: the pattern, rows sorted, columns sorted in a row.
    slots ``(Σ ne·m²,)``: data position of each entry of the element matrices of all sets,
    concatenated in set order, each set's ``(ne, m, m)`` raveled."""

    size: int
    indptr: np.ndarray
    indices: np.ndarray
    slots: np.ndarray


def element_entries(conn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns ``(ne·m²,)`` of the entries of element matrices ``(ne, m, m)`` (m = 3k)
    raveled, for a connectivity ``conn`` ``(ne, k)``."""
    dofs = element_dofs(conn)
    m = dofs.shape[1]
    return np.repeat(dofs, m, axis=1).ravel(), np.tile(dofs, (1, m)).ravel()


def csr_pattern(
    conns: Sequence[np.ndarray], n: int, extra: Sequence[tuple[np.ndarray, np.ndarray]] = ()
) -> CsrPattern:
    """The :class:`CsrPattern` of element sets with connectivities ``conns`` (each ``(ne, k)``)
    over ``n`` vector DOFs. ``extra``: further entries as ``(rows, cols)`` scalar-DOF index
    arrays (e.g. the COO entries of a mass matrix); their slots follow the sets' in order.

    Every element couples all three components of its vector DOFs, so the pattern is a node
    pattern times 3×3 blocks: the node pairs are sorted once (k² keys per element instead of
    9k²) and expanded (an extra entry brings its whole 3×3 block, the rest stored zeros)."""
    conns = [np.asarray(c, np.int64) for c in conns]
    extra = [(np.asarray(r, np.int64), np.asarray(c, np.int64)) for r, c in extra]
    keys = [(np.repeat(c, c.shape[1], axis=1) * n + np.tile(c, (1, c.shape[1]))).ravel()
            for c in conns]  # fmt: skip
    keys += [(r // 3) * n + c // 3 for r, c in extra]
    pairs, pair_of = np.unique(np.concatenate(keys), return_inverse=True)
    node_rows, node_cols = pairs // n, pairs % n
    nptr = np.concatenate([[0], np.cumsum(np.bincount(node_rows, minlength=n))])
    rank = np.arange(pairs.size) - nptr[node_rows]  # place of the column node in its row
    row_len = 3 * np.repeat(np.diff(nptr), 3)  # scalar row 3I+i: 3 deg(I) entries
    indptr = np.concatenate([[0], np.cumsum(row_len)])
    base = indptr[3 * node_rows[:, None] + np.arange(3)] + 3 * rank[:, None]  # (pairs, 3 rows)
    indices = np.empty(9 * pairs.size, np.int64)
    for j in range(3):
        indices[base + j] = (3 * node_cols + j)[:, None]
    slots, offset = [], 0
    for c in conns:
        ne, k = c.shape
        pair = pair_of[offset : offset + ne * k * k].reshape(ne, k, k)
        offset += ne * k * k
        b = base[pair].transpose(0, 1, 3, 2)  # (ne, a, i, b): rows 3a+i, columns 3b+j
        slots.append((b[..., None] + np.arange(3)).ravel())
    for r, c in extra:
        pair = pair_of[offset : offset + r.size]
        offset += r.size
        slots.append(base[pair, r % 3] + c % 3)
    index_type = np.int32 if indices.size < 2**31 else np.int64
    slot_all = np.concatenate(slots) if slots else np.zeros(0, np.int64)
    return CsrPattern(3 * n, indptr.astype(index_type), indices.astype(index_type),
                      slot_all.astype(index_type))  # fmt: skip


@dataclass(frozen=True, eq=False)
class SubmatrixMap:
    """CSC pattern of the submatrix ``A[keep][:, keep]`` of a :class:`CsrPattern` and, for each
    of its entries, the position in the pattern's CSR data: ``data_sub = data[positions]``.

    size: ``len(keep)``; indptr ``(size + 1,)``, indices ``(nnz_sub,)``, positions ``(nnz_sub,)``."""

    size: int
    indptr: np.ndarray
    indices: np.ndarray
    positions: np.ndarray

    def csc(self, data: np.ndarray) -> sp.csc_matrix:
        """The submatrix (CSC) of the full matrix with CSR data ``data`` ``(nnz,)``."""
        shape = (self.size, self.size)
        return sp.csc_matrix((data[self.positions], self.indices, self.indptr), shape=shape)


def submatrix_map(pattern: CsrPattern, keep: np.ndarray) -> SubmatrixMap:
    """The :class:`SubmatrixMap` of ``pattern`` on the scalar DOFs ``keep`` (sorted indices)."""
    nnz = pattern.indices.size
    shape = (pattern.size, pattern.size)
    # data = 1 + position, so that no entry is an explicit zero that scipy could drop
    marks = sp.csr_matrix((np.arange(1, nnz + 1, dtype=np.int64), pattern.indices,
                           pattern.indptr), shape=shape)  # fmt: skip
    sub = marks[keep][:, keep].tocsc()
    sub.sort_indices()
    return SubmatrixMap(len(keep), sub.indptr, sub.indices, sub.data - 1)


def assemble_csr(pattern: CsrPattern, element_matrices: Sequence[np.ndarray]) -> sp.csr_matrix:
    """Sum element matrices (one ``(ne, 3k, 3k)`` array per set, in the pattern's set order)
    into the sparse ``(3n, 3n)`` CSR matrix of ``pattern``."""
    values = np.concatenate([np.ravel(k) for k in element_matrices])
    data = np.bincount(pattern.slots, weights=values, minlength=pattern.indices.size)
    shape = (pattern.size, pattern.size)
    return sp.csr_matrix((data, pattern.indices, pattern.indptr), shape=shape)


def assemble_scalar_matrix(conn: np.ndarray, element_matrices: np.ndarray, n: int) -> sp.csr_matrix:
    """Sum scalar element matrices ``(ne, k, k)`` (e.g. mass ``M_s``) into a sparse ``(n, n)`` matrix."""
    conn = np.asarray(conn)
    k = conn.shape[1]
    rows = np.repeat(conn, k, axis=1).ravel()
    cols = np.tile(conn, (1, k)).ravel()
    mat = sp.coo_matrix((element_matrices.ravel(), (rows, cols)), shape=(n, n))
    return mat.tocsr()


def expand_scalar_matrix(ms: sp.spmatrix) -> sp.csr_matrix:
    """Isotropic 3-D matrix ``M = M_s ⊗ I_3`` from a scalar ``(n, n)`` matrix."""
    return sp.kron(ms, sp.identity(3), format="csr")


