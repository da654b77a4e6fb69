"""Node orderings by nested dissection: a permutation, separators that separate, fill no worse
than minimum degree where it is chosen, and a function of the pattern alone."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse import csgraph

from quadmodes.linalg import factor, ordering


def _grid(n: int, m: int) -> sp.csr_matrix:
    """Node graph of an n × m triangulated grid (each square cut by one diagonal)."""
    idx = np.arange(n * m).reshape(n, m)
    pairs = [(idx[:, :-1], idx[:, 1:]), (idx[:-1], idx[1:]), (idx[:-1, :-1], idx[1:, 1:])]
    rows = np.concatenate([a.ravel() for a, _ in pairs])
    cols = np.concatenate([b.ravel() for _, b in pairs])
    g = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n * m, n * m))
    return (g + g.T + sp.identity(n * m)).tocsr()


def test_levels_and_the_separators_they_give():
    g = _grid(30, 30)
    levels = ordering.peripheral_levels(g)
    rows, cols = g.nonzero()
    assert np.abs(levels[rows] - levels[cols]).max() == 1  # a level touches only its neighbours
    assert levels.max() >= 29  # from a corner (a pseudo-peripheral node), across the grid
    order = ordering.nested_dissection(g)
    assert np.array_equal(np.sort(order), np.arange(900))
    # the last nodes eliminated separate the rest: removing the top separator disconnects it
    top = order[-ordering.peripheral_levels(g).tolist().count(0) - 40:]
    rest = np.setdiff1d(np.arange(900), top)
    count, _ = csgraph.connected_components(g[rest][:, rest], directed=False)
    assert count >= 2


def test_dense_nodes_go_last():
    """A hub tied to a whole patch (a rigid end body) is eliminated after everything else."""
    g = _grid(20, 20).tolil()
    hub = 400
    g.resize((401, 401))
    g[hub, :100] = 1.0
    g[:100, hub] = 1.0
    g[hub, hub] = 1.0
    order = ordering.nested_dissection(g.tocsr())
    assert order[-1] == hub and np.array_equal(np.sort(order), np.arange(401))


def _stiffness(n: int) -> sp.csc_matrix:
    """An SPD matrix with three DOFs per node on the n × n grid: (graph Laplacian + I) ⊗ B."""
    g = _grid(n, n)
    lap = sp.diags(np.asarray(g.sum(axis=1)).ravel()) - g + 2.0 * sp.identity(g.shape[0])
    k = sp.kron(lap, np.ones((3, 3)) + 3.0 * np.eye(3), format="csc")
    k.sort_indices()
    return k


def _fill(a: sp.csc_matrix, order: np.ndarray) -> int:
    lu = spla.splu(a[order][:, order].tocsc(), **dict(factor.SYMMETRIC_OPTIONS,
                                                       permc_spec="NATURAL"))  # fmt: skip
    return lu.L.nnz + lu.U.nnz


@pytest.mark.parametrize("n", [12, 40])
def test_auto_takes_the_cheaper_of_the_two(n):
    """On a triangulated grid with three DOFs per node, "auto" gives the ordering of smaller
    elimination cost, never more fill than 1.05 × the better of the two methods."""
    k = _stiffness(n)
    nodes = np.arange(k.shape[0]) // 3
    fills = {m: _fill(k, factor.node_ordering(k, nodes, m)) for m in factor.NODE_METHODS}
    assert fills["auto"] <= 1.05 * min(fills["dissection"], fills["minimum degree"])
    with pytest.raises(ValueError, match="choose from"):
        factor.node_ordering(k, nodes, "nonsense")


def test_ordering_depends_on_the_pattern_not_the_values():
    k = _stiffness(15)
    nodes = np.arange(k.shape[0]) // 3
    other = k.copy()
    other.data = np.random.default_rng(9).uniform(0.0, 2.0, other.data.size)
    other.data[::7] = 0.0  # stored zeros stay in the pattern
    for method in factor.NODE_METHODS:
        factor._NODE_ORDERS.clear()
        first = factor.node_ordering(k, nodes, method)
        factor._NODE_ORDERS.clear()
        assert np.array_equal(factor.node_ordering(other, nodes, method), first)
