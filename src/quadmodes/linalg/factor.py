"""Sparse LU factorisations (SuperLU, always installed) and rank-one updates of their solves.

Orderings: a matrix with a symmetric pattern whose diagonal pivots are acceptable (the tangent
stiffness of a conservative model, bordered by constraint columns; a shifted ``K − σM``) is
ordered by minimum degree on ``A + Aᵀ`` with diagonal pivoting preferred (SuperLU's
``SymmetricMode``, ``diag_pivot_thresh`` 0.01: an off-diagonal pivot is taken only when the
diagonal one is a hundred times smaller than the largest of its column). On the bordered
inflation tangent of ``paper-membrane`` this keeps 43–45 % less fill than COLAMD (3k and 20k
nodes, docs/performance.md). Other matrices use COLAMD with partial pivoting. Both give the
solution to round-off; only the cost differs.

:func:`factorize` is the one interface the solvers use (factor once, solve many): SuperLU by
default (always installed), or an optional back end chosen by name or by ``$QUADMODES_LINALG``
(``pardiso``: pypardiso, installed separately, about 1.2 GB with MKL); a missing optional back
end is reported in one line and SuperLU is used.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from quadmodes.linalg.ordering import nested_dissection

Solve = Callable[[np.ndarray], np.ndarray]

#: SuperLU options for symmetric-pattern matrices with usable diagonal pivots.
SYMMETRIC_OPTIONS = {"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.01,
                     "options": {"SymmetricMode": True}}  # fmt: skip
#: SuperLU options for general sparse matrices.
GENERAL_OPTIONS = {"permc_spec": "COLAMD"}


class PermutedLU:
    """SuperLU factors of ``A[p][:, p]`` (ordered ahead, ``permc_spec="NATURAL"``) behind the
    solve of ``A``: ``solve(b)`` returns ``A⁻¹ b`` for b ``(n,)`` or ``(n, k)``. dtype: that of
    the factorised matrix (``lu.L`` would build the whole factor as a sparse matrix: 48 ms per
    solve on the 80k-node tangent)."""

    def __init__(self, lu: spla.SuperLU, order: np.ndarray, dtype: np.dtype):
        self.lu, self.order, self.dtype = lu, order, np.dtype(dtype)
        self.shape = lu.shape

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        rhs = np.asarray(rhs)
        out = np.empty(rhs.shape, np.result_type(rhs.dtype, self.dtype))
        out[self.order] = self.lu.solve(rhs[self.order])
        return out


#: Node-graph orderings by stored sparsity pattern: the Newton iterations of one structure
#: factorise matrices of one pattern several times, and SuperLU's own ordering was about half
#: of a factorisation.
_ORDERINGS: dict[tuple, np.ndarray] = {}
_ORDERINGS_KEPT = 16


def _pattern_key(a: sp.csc_matrix) -> tuple:
    """Key of the stored pattern of ``a`` (CSC, sorted indices)."""
    return (a.shape, a.indices.size, hash(a.indptr.tobytes()), hash(a.indices.tobytes()))


def _keep_ordering(key: tuple, order: np.ndarray) -> None:
    if len(_ORDERINGS) >= _ORDERINGS_KEPT:
        _ORDERINGS.pop(next(iter(_ORDERINGS)))
    _ORDERINGS[key] = order


#: How :func:`node_ordering` orders the node graph: "auto" (whichever of the two below makes
#: the node graph's own factorisation cheaper, :func:`elimination_cost`), "dissection" (nested
#: dissection, :mod:`quadmodes.linalg.ordering`) or "minimum degree" (SuperLU's MMD on it).
NODE_ORDERING = "auto"
NODE_METHODS = ("auto", "dissection", "minimum degree")
#: Node elimination orders by node-graph pattern and method: the inflation's bordered tangent
#: and the modes' K − σM of one structure share their node graph, hence their ordering.
_NODE_ORDERS: dict[tuple, np.ndarray] = {}


def node_graph(a: sp.spmatrix, nodes: np.ndarray) -> tuple[np.ndarray, sp.csc_matrix]:
    """``(node_of (l,), graph (k, k))``: for each of the leading ``l`` rows of ``a`` the index of
    its node among the ``k`` distinct ``nodes`` ``(l,)``, and the pattern (ones, diagonal
    included) of the node couplings of the leading block: a function of the stored pattern of
    ``a`` only, not of its values."""
    lead = nodes.size
    _, node_of = np.unique(nodes, return_inverse=True)
    k = int(node_of.max()) + 1 if lead else 0
    lead_block = sp.csc_matrix(a)[:lead, :lead]
    ones = sp.csc_matrix((np.ones(lead_block.nnz), lead_block.indices, lead_block.indptr),
                         shape=lead_block.shape)  # fmt: skip
    agg = sp.csr_matrix((np.ones(lead), (node_of, np.arange(lead))), shape=(k, lead))
    graph = (agg @ ones @ agg.T + sp.identity(k)).tocsc()
    graph.sort_indices()
    graph.data[:] = 1.0
    return node_of, graph


def _dominant(graph: sp.csc_matrix) -> sp.csc_matrix:
    """The node-graph pattern made diagonally dominant (factorised without pivoting)."""
    return sp.csc_matrix(graph + 100.0 * sp.identity(graph.shape[0]))


def elimination_cost(graph: sp.csc_matrix, place: np.ndarray) -> float:
    """Σ_j c_j² over the columns of the Cholesky-like factor of the node graph eliminated in the
    order ``place`` ``(k,)`` (``place[i]``: the step at which node i goes), ``c_j`` a column's
    entries: the operation count of the factorisation up to a constant (its fill alone
    misjudges: on the 80k-node tangent nested dissection has 14 % less fill but 40 % less
    work). The node graph has a ninth of the matrix's entries, so this costs a small part of
    the matrix's factorisation."""
    order = np.empty(place.size, np.int64)
    order[place] = np.arange(place.size)
    permuted = _dominant(graph)[order][:, order].tocsc()
    lower = spla.splu(permuted, permc_spec="NATURAL", diag_pivot_thresh=0.0,
                      options={"SymmetricMode": True}).L  # fmt: skip
    counts = np.diff(lower.indptr).astype(float)
    return float(counts @ counts)


def _node_places(graph: sp.csc_matrix, method: str) -> np.ndarray:
    """``place (k,)``: the position of each node in the elimination order of ``graph``."""
    if method not in NODE_METHODS:
        raise ValueError(f"node ordering {method!r}: choose from {', '.join(NODE_METHODS)}")
    if method == "auto":
        candidates = [_node_places(graph, m) for m in ("minimum degree", "dissection")]
        return min(candidates, key=lambda place: elimination_cost(graph, place))
    if method == "minimum degree":
        return spla.splu(_dominant(graph), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                         options={"SymmetricMode": True}).perm_c  # fmt: skip
    order = nested_dissection(graph)
    place = np.empty(order.size, np.int64)
    place[order] = np.arange(order.size)
    return place


def node_ordering(a: sp.csc_matrix, nodes: np.ndarray, method: str | None = None) -> np.ndarray:
    """A fill-reducing ordering ``(m,)`` of ``a`` ``(m, m)`` from its node graph
    (:func:`node_graph`): ``nodes`` ``(l,)`` gives the node of each of the leading ``l`` rows (the
    DOFs of a node couple to the same neighbours); the rows after them (a border) come last.
    method: one of :data:`NODE_METHODS` (default :data:`NODE_ORDERING`, "auto"). The graph
    has about a ninth of the entries of ``a`` for three DOFs per node. On the 80k-node rim
    tangent nested dissection leaves 72 M entries in L + U against 84 M for minimum degree
    and SuperLU factorises it in 40 % less time; on graded meshes (the flange model) minimum
    degree is better, and "auto" takes it (docs/performance.md)."""
    method = method or NODE_ORDERING
    lead = nodes.size
    node_of, graph = node_graph(a, np.asarray(nodes))
    key = (method, _pattern_key(graph))
    if key not in _NODE_ORDERS:
        if len(_NODE_ORDERS) >= _ORDERINGS_KEPT:
            _NODE_ORDERS.pop(next(iter(_NODE_ORDERS)))
        _NODE_ORDERS[key] = _node_places(graph, method)
    place = _NODE_ORDERS[key]
    # rows sorted by the place of their node, then by row
    key_rows = place[node_of].astype(np.int64) * (lead + 1) + np.arange(lead)
    return np.concatenate([np.argsort(key_rows), np.arange(lead, a.shape[0])])


def lu_factor(a: sp.spmatrix, symmetric: bool = True, border: int = 0,
              nodes: np.ndarray | None = None) -> spla.SuperLU | PermutedLU:  # fmt: skip
    """SuperLU factorisation of the square sparse matrix ``a`` (real or complex).

    symmetric: ``a`` has a symmetric sparsity pattern and acceptable diagonal pivots (use
    :data:`SYMMETRIC_OPTIONS`); if that factorisation finds an exactly singular pivot it is
    redone with :data:`GENERAL_OPTIONS` (full partial pivoting) before giving up. border: the
    number of trailing constraint rows and columns (a bordered matrix). nodes: ``(m − border,)``
    node of each leading row: the ordering is then computed on the node graph
    (:func:`node_ordering`, much faster than SuperLU's own on ``a``), once per stored sparsity
    pattern (a pure function of it, so the factors do not depend on what was factorised
    before), and the permuted matrix is factorised with ``NATURAL``."""
    a = sp.csc_matrix(a)
    if not symmetric:
        return spla.splu(a, **GENERAL_OPTIONS)
    try:
        if nodes is None:
            return spla.splu(a, **SYMMETRIC_OPTIONS)
        order = kept_node_ordering(a, nodes)
        return permuted_lu(a[order][:, order].tocsc(), order)
    except RuntimeError:  # "Factor is exactly singular": let partial pivoting decide
        return spla.splu(a, **GENERAL_OPTIONS)


def kept_node_ordering(a: sp.csc_matrix, nodes: np.ndarray) -> np.ndarray:
    """The node-graph ordering ``(m,)`` of ``a`` (CSC; its indices sorted in place) that
    :func:`lu_factor` uses, computed once per stored sparsity pattern (:func:`node_ordering`)."""
    a.sort_indices()
    key = (NODE_ORDERING, *_pattern_key(a))
    if key not in _ORDERINGS:
        _keep_ordering(key, node_ordering(a, np.asarray(nodes)))
    return _ORDERINGS[key]


def permuted_lu(permuted: sp.csc_matrix, order: np.ndarray) -> PermutedLU:
    """The factorisation of ``A`` given ``permuted = A[order][:, order]`` (CSC), as
    :func:`lu_factor` makes it with ``nodes`` (``NATURAL`` on the permuted matrix; raises
    RuntimeError for an exactly singular pivot). For callers that assemble the permuted matrix
    themselves, once per pattern (:mod:`quadmodes.fullorder.preconditioner`)."""
    natural = dict(SYMMETRIC_OPTIONS, permc_spec="NATURAL")
    return PermutedLU(spla.splu(permuted, **natural), order, permuted.dtype)


class Factorization(Protocol):
    """A factorised square sparse matrix A: ``solve(b)`` returns ``A⁻¹ b`` for b ``(n,)`` or
    ``(n, k)``; ``backend`` names what factorised it."""

    backend: str

    def solve(self, rhs: np.ndarray) -> np.ndarray: ...


#: Names accepted by :func:`factorize` (and by the environment variable ``QUADMODES_LINALG``).
BACKENDS = ("superlu", "pardiso")

_REPORTED: set[str] = set()


class _SuperLU:
    """:func:`lu_factor` behind the :class:`Factorization` interface."""

    backend = "superlu"

    def __init__(self, a: sp.spmatrix, symmetric: bool, border: int = 0, nodes=None):
        self.lu = lu_factor(a, symmetric, border, nodes)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return self.lu.solve(rhs)


class _Pardiso:
    """PARDISO (``pypardiso``, MKL) on a real square matrix, general (unsymmetric) mode. Its
    symmetric modes (``mtype`` 2, −2) were measured: they factorise faster still but put the
    shift-invert frequencies of the 20k-node model off by 1e-4 relative (general mode 3e-6,
    SuperLU 1e-8; docs/performance.md), so the back end is not used for accuracy-bound work."""

    backend = "pardiso"

    def __init__(self, a: sp.spmatrix, symmetric: bool):
        import pypardiso  # optional: pip install pypardiso

        self.a = sp.csr_matrix(a)
        self.solver = pypardiso.PyPardisoSolver(mtype=11)
        self.solver.factorize(self.a)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return self.solver.solve(self.a, np.asarray(rhs, float))


def backend_choice(backend: str | None = None) -> str:
    """The back end to use: ``backend``, else ``$QUADMODES_LINALG``, else "superlu"; an
    optional back end that does not import is reported in one line (once) and replaced by
    "superlu". Raises ValueError for an unknown name."""
    name = (backend or os.environ.get("QUADMODES_LINALG") or "superlu").strip().lower()
    if name not in BACKENDS:
        raise ValueError(f"linalg back end {name!r}: choose from {', '.join(BACKENDS)}")
    if name == "pardiso" and importlib.util.find_spec("pypardiso") is None:
        if name not in _REPORTED:
            _REPORTED.add(name)
            print("note: pypardiso is not installed (pip install pypardiso); using "
                  "SuperLU", file=sys.stderr)  # fmt: skip
        return "superlu"
    return name


class _Single:
    """A float32 SuperLU factorisation of a real matrix behind float64 solves (``lu``: an
    existing float32 factorisation instead of ``a``)."""

    backend = "superlu (float32)"

    def __init__(self, a: sp.spmatrix | None, symmetric: bool = True, border: int = 0,
                 nodes=None, lu=None):  # fmt: skip
        if lu is None:
            lu = lu_factor(sp.csc_matrix(a).astype(np.float32), symmetric, border, nodes)
        self.lu = lu

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return self.lu.solve(np.asarray(rhs, np.float32)).astype(np.float64)


def factorize(a: sp.spmatrix, symmetric: bool = True, backend: str | None = None,
              single: bool = False, border: int = 0,
              nodes: np.ndarray | None = None) -> Factorization:  # fmt: skip
    """Factorise the real or complex square sparse matrix ``a`` once, for many solves.

    symmetric: ``a`` has a symmetric pattern and usable diagonal pivots (the SuperLU ordering
    of :func:`lu_factor`). backend: see :func:`backend_choice` (complex matrices always use
    SuperLU). Every back end solves to round-off; only the cost differs. single: factorise a
    real matrix in single precision (SuperLU, float32; solves take and return float64, to
    about 1e-7 × cond(a) relative): an approximate inverse for an iteration whose residual is
    computed in double (modified Newton), half the memory and faster solves. border, nodes: see
    :func:`lu_factor` (SuperLU only)."""
    if single and not np.iscomplexobj(a.data if sp.issparse(a) else a):
        return _Single(a, symmetric, border, nodes)
    name = backend_choice(backend)
    if name == "pardiso" and not np.iscomplexobj(a.data if sp.issparse(a) else a):
        return _Pardiso(a, symmetric)
    return _SuperLU(a, symmetric, border, nodes)


def single_permuted(permuted: sp.csc_matrix, order: np.ndarray) -> Factorization:
    """What ``factorize(a, single=True, nodes=...)`` returns, from the float32 permuted matrix
    ``permuted = A[order][:, order]`` (:func:`permuted_lu`; RuntimeError if exactly singular)."""
    return _Single(None, lu=permuted_lu(permuted, order))


def with_rank_one_terms(solve: Solve, low_rank: Sequence[tuple[float, np.ndarray]]) -> Solve:
    """Solve with ``A + Σ c v vᵀ`` given the solve with ``A`` (Sherman–Morrison, one term after
    the other). low_rank: ``(c, v)`` pairs, ``v`` of the solve's length; empty: ``solve`` itself."""
    if not low_rank:
        return solve
    terms = []
    for coef, vec in low_rank:
        terms.append((coef, vec, _updated(solve, terms)(vec)))

    return _updated(solve, terms)


def _updated(solve: Solve, terms: list) -> Solve:
    def updated(rhs: np.ndarray) -> np.ndarray:
        y = solve(rhs)
        for coef, vec, kv in terms:
            y = y - kv * (coef * (vec @ y) / (1.0 + coef * (vec @ kv)))
        return y

    return updated
