"""The kept preconditioner of the Krylov path (:mod:`~quadmodes.fullorder.krylov`) assembled
straight into the data of its factorisation: the Newton matrix's element blocks are summed
into the float64 CSC data of the free-DOF matrix *already permuted* to the node ordering its
float32 SuperLU factorisation uses, through one map computed once per run.

Why: on the flange-bonded ``paper-41hz`` (6,085 nodes, 18,255 free DOFs, 461k entries) a
renewal of the preconditioner cost about as much in assembly and reordering as in SuperLU's
``gstrf`` (CPU: element blocks 26 ms, the ``bincount`` of their 2.1M entries into the whole
pattern 30–55 ms, the free-DOF submatrix, the pattern key and the permutation ``A[p][:, p]``
≈ 10 ms, against ``gstrf`` ≈ 100 ms). Here the blocks are added in one pass (compiled, or a
``bincount`` over the free entries only) into the permuted data; nothing else is per renewal.

The arithmetic is the one of ``NewtonMatrix.at(..., single=True, node_order=True)``: every
entry is the same sum in the same order (``bincount`` adds in input order), so the float32
matrix, its factors and every solve are bit for bit those of the straightforward path (the
tests compare the two; ``newton_policy="fixed"`` therefore still reproduces the version
before issue 27 exactly).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.membrane_kernels import MembraneKernel
from quadmodes.fe.model import tangent_low_rank
from quadmodes.fullorder.kernels import StepOperators, jit_module
from quadmodes.linalg.factor import Factorization, kept_node_ordering, single_permuted


@dataclass(frozen=True, eq=False)
class PermutedNewtonAssembly:
    """Where the Newton matrix ``M + (Δt²/2) J`` of a run lands in its permuted free-DOF CSC.

    order (m,): the node ordering of the m free DOFs
    (:func:`~quadmodes.linalg.factor.kept_node_ordering`); indptr (m+1,), indices (nnz,): the
    CSC pattern of ``A[order][:, order]``; positions: per kernel of ``ops`` (its blocks
    ``(ne, k, k)`` raveled) the data position of every block entry, −1 for entries on a fixed
    DOF; mass (nnz,): M in that data (kg)."""

    order: np.ndarray
    indptr: np.ndarray
    indices: np.ndarray
    positions: tuple
    mass: np.ndarray

    @classmethod
    def of(cls, ops: StepOperators, free: np.ndarray) -> PermutedNewtonAssembly:
        """The map of the run's operators ``ops`` on the free scalar DOFs ``free`` (sorted)."""
        fm = ops.free_map
        nnz_free = fm.positions.size
        # data = 1 + position in the free CSC (no explicit zero scipy could drop), permuted by
        # the very scipy calls lu_factor makes, so pattern and entry order are its own
        template = sp.csc_matrix((np.arange(1, nnz_free + 1, dtype=np.float64), fm.indices,
                                  fm.indptr), shape=(fm.size, fm.size))  # fmt: skip
        order = kept_node_ordering(template, np.asarray(free) // 3)
        permuted = template[order][:, order].tocsc()
        permuted.sort_indices()  # as splu sorts its input (the data follow): SuperLU's view
        source = fm.positions[permuted.data.astype(np.int64) - 1]  # slot in the whole pattern
        where = np.full(ops.pattern.indices.size, -1, np.int64)
        where[source] = np.arange(source.size)
        positions, start = [], 0
        for kern in ops.kernels:
            size = kern.conn.shape[0] * (3 * kern.conn.shape[1]) ** 2
            positions.append(where[ops.pattern.slots[start : start + size]])
            start += size
        return cls(order, permuted.indptr, permuted.indices, tuple(positions),
                   ops.mass_data[source])  # fmt: skip

    def data(self, ops: StepOperators, x0: np.ndarray, x1: np.ndarray,
             weight: float, fused: bool = False) -> np.ndarray:  # fmt: skip
        """The permuted CSC data ``(nnz,)`` of ``M + weight·J(x₀, x₁)`` (weight: Δt²/2, s²)
        without the global rank-one terms; equal entry by entry to
        ``ops.newton_matrix(x0, x1, weight)[order][:, order]``. fused: the St Venant–Kirchhoff
        membranes' blocks computed and added in one compiled pass
        (``jit.membrane_block_scatter``; the same sums in the same order, the blocks to
        round-off, not bit for bit; the renewal thread's, :mod:`~quadmodes.fullorder.renewal`)."""
        acc = np.zeros(self.mass.size)
        jit = jit_module()
        if jit is not None:
            for pos, kern in zip(self.positions, ops.kernels, strict=True):
                if fused and type(kern) is MembraneKernel:
                    jit.membrane_block_scatter(kern.conn, kern.g0, kern.g1, kern.vol, kern.d,
                                               x0, x1, pos, 1.0, acc)  # fmt: skip
                else:
                    jit.scatter_add(pos, kern.block(x0, x1).ravel(), acc)
        else:  # bincount adds in input order: the same sums
            blocks = [kern.block(x0, x1).ravel() for kern in ops.kernels]
            keep = [pos >= 0 for pos in self.positions]
            pos = np.concatenate([p[k] for p, k in zip(self.positions, keep, strict=True)])
            values = np.concatenate([b[k] for b, k in zip(blocks, keep, strict=True)])
            acc = np.bincount(pos, weights=values, minlength=self.mass.size)
        return self.mass + weight * acc

    def factorize(self, ops: StepOperators, x0: np.ndarray, x1: np.ndarray,
                  weight: float, fused: bool = False) -> Factorization:  # fmt: skip
        """float32 factorisation of the free-DOF Newton matrix at (x0, x1) (n,3), as
        ``factorize(a, single=True, nodes=free // 3)`` makes it (RuntimeError: exactly
        singular); fused: see :meth:`data`."""
        size = self.order.size
        # copies of the pattern: the factorisation may reorder its input's arrays in place
        a = sp.csc_matrix((self.data(ops, x0, x1, weight, fused).astype(np.float32),
                           self.indices.copy(), self.indptr.copy()), shape=(size, size))  # fmt: skip
        return single_permuted(a, self.order)


def low_rank_terms(structure, z0: np.ndarray, z1: np.ndarray) -> list:
    """The gas law's rank-one terms ``[(c, v)]`` of ``∂f_step/∂x₁`` at the pair (z0, z1), as
    :meth:`~quadmodes.fullorder.newton.NewtonMatrix.at` takes them."""
    return [(0.5 * c, v) for c, v in tangent_low_rank(structure, 0.5 * (z0 + z1))]
