"""Fill-reducing orderings of a node graph by nested dissection on breadth-first level sets.

A finite-element matrix with three DOFs per node has the sparsity of its node graph times 3×3
blocks, so an ordering of the nodes orders the matrix (:func:`quadmodes.linalg.factor.node_ordering`).
Nested dissection (George 1973, with the level-structure separators of George and Liu's
automatic version) splits the graph by a vertex separator, orders both parts first (each split
the same way) and the separator last; on the surface meshes of an inflated membrane it leaves
about 10 % less fill than multiple minimum degree at 80k nodes and factorises about a third
faster (docs/performance.md). The separator is the breadth-first level that holds the median
node, counted from a pseudo-peripheral node: breadth-first levels only touch their neighbours,
so a level is a vertex separator. Nodes of very high degree (a rigid body tied to a patch) are
ordered last, outside the dissection. Everything is a function of the graph alone (no
coordinates, no randomness).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

#: Parts with at most this many nodes are not split further (kept in their given order).
LEAF_NODES = 16
#: Parts of at most this many leaves are cut in one go (:func:`one_way_dissection`).
ONE_WAY_NODES = 4
#: Nodes with more than this many times the median degree are ordered last (:func:`dense_nodes`).
DENSE_FACTOR = 8.0


def bfs_levels(graph: sp.csr_matrix, start: int) -> np.ndarray:
    """Breadth-first level ``(n,)`` of every node of the connected ``graph`` ``(n, n)`` from node
    ``start`` (0 there, the number of edges of a shortest path elsewhere)."""
    dist = csgraph.shortest_path(graph, method="D", unweighted=True, indices=start)
    return dist.astype(np.int64)


def peripheral_levels(graph: sp.csr_matrix, sweeps: int = 4) -> np.ndarray:
    """Breadth-first levels ``(n,)`` of the connected ``graph`` from a pseudo-peripheral node: start
    at a node of least degree, move to a farthest node of least degree while the eccentricity
    grows (at most ``sweeps`` searches)."""
    degree = np.diff(graph.indptr)
    start = int(np.argmin(degree))
    levels = bfs_levels(graph, start)
    for _ in range(sweeps - 1):
        far = np.flatnonzero(levels == levels.max())
        candidate = int(far[np.argmin(degree[far])])
        trial = bfs_levels(graph, candidate)
        if trial.max() <= levels.max():
            break
        levels = trial
    return levels


def _dissect(g: sp.csr_matrix, ids: np.ndarray, out: list, leaf: int) -> None:
    """Append the nested-dissection order of the nodes ``ids`` ``(k,)`` to ``out`` (as pieces);
    ``g`` ``(k, k)`` is the graph among them (children are sliced from it, not from the whole
    graph: scipy's column slicing costs the width of the matrix sliced)."""
    if ids.size <= leaf:
        out.append(ids)
        return
    count, label = csgraph.connected_components(g, directed=False)
    if count > 1:
        for c in range(count):
            part = np.flatnonzero(label == c)
            _dissect(g[part][:, part], ids[part], out, leaf)
        return
    levels = peripheral_levels(g)
    if ids.size <= ONE_WAY_NODES * leaf:
        out.extend(one_way_dissection(ids, levels, leaf))
        return
    middle = int(np.searchsorted(np.cumsum(np.bincount(levels)), 0.5 * ids.size))
    if middle == 0 or middle >= levels.max():  # no level splits it (a clique, a star)
        out.append(ids)
        return
    for part in (np.flatnonzero(levels < middle), np.flatnonzero(levels > middle)):
        _dissect(g[part][:, part], ids[part], out, leaf)
    out.append(ids[levels == middle])


def one_way_dissection(ids: np.ndarray, levels: np.ndarray, leaf: int) -> list[np.ndarray]:
    """A small part ``ids`` ``(k,)`` cut at once into slabs of about ``leaf`` nodes by every
    level of its breadth-first ``levels`` ``(k,)`` that closes a slab: the slabs first, each in
    its given order, then the separating levels (one search instead of a recursion of them)."""
    counts = np.bincount(levels)
    cuts, filled = [], 0
    for lev, c in enumerate(counts[:-1]):
        filled += c
        if filled >= leaf:
            cuts.append(lev + 1)  # level lev + 1 separates the slab below it
            filled = -counts[lev + 1]  # the separating level is not part of the next slab
    separator = np.isin(levels, cuts)
    slab = np.searchsorted(np.asarray(cuts), levels)
    pieces = [ids[(slab == k) & ~separator] for k in range(len(cuts) + 1)]
    return [p for p in pieces if p.size] + [ids[separator]]


def nested_dissection(graph: sp.spmatrix, leaf: int = LEAF_NODES) -> np.ndarray:
    """Elimination order ``(n,)`` of the nodes of the symmetric ``graph`` ``(n, n)`` (its stored
    pattern; the diagonal is ignored): ``order[k]`` is the node eliminated k-th. Parts of at
    most ``leaf`` nodes keep their given order."""
    g = sp.csr_matrix(graph, copy=True)
    g.setdiag(0)
    g.eliminate_zeros()
    g.data[:] = 1.0
    dense = dense_nodes(g)
    keep = np.flatnonzero(~dense)
    pieces: list[np.ndarray] = []
    _dissect(g[keep][:, keep], keep, pieces, leaf)
    pieces.append(np.flatnonzero(dense))  # eliminated last, like a border
    return np.concatenate(pieces)


def dense_nodes(graph: sp.csr_matrix, factor: float = DENSE_FACTOR) -> np.ndarray:
    """``(n,)`` bool: nodes with more than ``factor`` times the median degree (and more than
    ``factor``) neighbours, e.g. the node of a rigid end body tied to a whole patch. They join
    every level of a breadth-first search and would make the level separators useless, so they
    are taken out and eliminated last."""
    degree = np.diff(graph.indptr)
    if degree.size == 0:
        return np.zeros(0, bool)
    return degree > factor * max(float(np.median(degree)), 1.0)
