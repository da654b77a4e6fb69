"""The faster offline build against the straightforward one: GMRES with a kept factorisation
solves to its tolerance, and the inflation by inexact Newton (Krylov steps on a kept
factorisation) gives the same inflated state and frequencies as full Newton (a fresh
factorisation at every iteration) on a small case."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from quadmodes.case import load_case
from quadmodes.linalg import factor
from quadmodes.linalg.factor import lu_factor
from quadmodes.linalg.krylov import gmres
from quadmodes.structure import prestress
from quadmodes.structure.modes import compute_modes
from quadmodes.structure.pipeline import reference_state, structure_for_case, with_gas_law


def _bordered(n: int, seed: int, shift: float = 0.0) -> sp.csc_matrix:
    lap1 = sp.diags([-1.0, 2.0 + shift, -1.0], [-1, 0, 1], shape=(n, n))
    k = sp.kronsum(lap1, lap1)
    c = np.random.default_rng(seed).standard_normal((n * n, 2))
    return sp.bmat([[k, sp.csc_matrix(c)], [sp.csc_matrix(c).T, None]], format="csc")


def test_gmres_with_exact_preconditioner_takes_one_step():
    a = _bordered(12, 1)
    b = np.random.default_rng(2).standard_normal(a.shape[0])
    result = gmres(lambda v: a @ v, lu_factor(a).solve, b, 1e-12, 5)
    assert result.converged and result.iterations == 1
    assert np.linalg.norm(a @ result.x - b) <= 1e-10 * np.linalg.norm(b)


def test_gmres_with_perturbed_preconditioner_reaches_the_true_residual():
    a = _bordered(12, 1)
    old = _bordered(12, 1, shift=0.05)  # the "earlier tangent"
    b = np.random.default_rng(3).standard_normal(a.shape[0])
    result = gmres(lambda v: a @ v, lu_factor(old).solve, b, 1e-10, 30)
    assert result.converged and result.iterations > 1
    assert np.linalg.norm(a @ result.x - b) <= 2e-10 * np.linalg.norm(b)


def test_gmres_gives_up_early_on_a_useless_preconditioner():
    a = _bordered(12, 1)
    b = np.random.default_rng(4).standard_normal(a.shape[0])
    result = gmres(lambda v: a @ v, lambda v: v, b, 1e-12, 40)  # no preconditioning
    assert not result.converged and result.iterations < 40


def _build(case):
    structure = structure_for_case(case)
    x, state = reference_state(case, structure)
    modes = compute_modes(with_gas_law(case, structure, x), x, 6)
    return x, state, modes.frequencies_hz


@pytest.fixture(scope="module")
def coarse_case():
    # the rim-bonded model on 2 in edges (758 nodes): the flange model's graded mesh is 4052
    base = load_case("paper-membrane-rim")
    return base.model_copy(update={"mesh": base.mesh.model_copy(update={"edge_length": 0.0508})})


def test_inexact_newton_inflation_matches_full_newton(coarse_case, monkeypatch):
    x_fast, state_fast, f_fast = _build(coarse_case)
    monkeypatch.setattr(prestress, "KRYLOV_ITERATIONS", 0)  # fresh factorisation every time
    x_full, state_full, f_full = _build(coarse_case)
    extent = np.ptp(x_full, axis=0).max()
    assert np.abs(x_fast - x_full).max() <= 1e-9 * extent
    assert state_fast.residual_norm < 1e-8 and state_full.residual_norm < 1e-8
    np.testing.assert_allclose(f_fast, f_full, rtol=1e-9)


@pytest.mark.parametrize("refactor_after", [None, 0])
def test_refactorisation_rule_leaves_the_inflation_unchanged(coarse_case, monkeypatch,
                                                             refactor_after):  # fmt: skip
    """A fresh float32 factorisation whenever the last GMRES needed more than
    ``REFACTOR_AFTER`` vectors (0: at every iteration; None: never by that rule) changes the
    linear solves only: the same inflated state (1e-9 of the extent) and frequencies (1e-9)."""
    x_ref, _, f_ref = _build(coarse_case)
    monkeypatch.setattr(prestress, "REFACTOR_AFTER", refactor_after)
    x, state, f = _build(coarse_case)
    assert np.abs(x - x_ref).max() <= 1e-9 * np.ptp(x_ref, axis=0).max()
    assert state.residual_norm < 1e-8
    np.testing.assert_allclose(f, f_ref, rtol=1e-9)


def _node_laplacian(n: int = 20) -> sp.csc_matrix:
    """Three DOFs per node of an n × n grid (all coupled), bordered by six dense columns."""
    lap1 = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    block = np.array([[4.0, 1.0, 1.0], [1.0, 4.0, 1.0], [1.0, 1.0, 4.0]])
    k = sp.kron(sp.kronsum(lap1, lap1), block)
    c = np.random.default_rng(5).standard_normal((k.shape[0], 6))
    return sp.bmat([[k, sp.csc_matrix(c)], [sp.csc_matrix(c).T, None]], format="csc")


def test_node_ordering_fills_like_minimum_degree_and_is_reused():
    a = _node_laplacian()
    lead = a.shape[0] - 6
    order = factor.node_ordering(a, np.arange(lead) // 3)
    assert np.array_equal(np.sort(order), np.arange(a.shape[0]))
    assert np.array_equal(order[-6:], np.arange(lead, a.shape[0]))  # the border last
    mmd = lu_factor(a * 1.0)  # SuperLU's own minimum degree on the scalar pattern
    natural = dict(factor.SYMMETRIC_OPTIONS, permc_spec="NATURAL")
    ours = spla.splu(a[order][:, order].tocsc(), **natural)
    fill = lambda lu: lu.L.nnz + lu.U.nnz  # noqa: E731
    assert fill(ours) <= 1.3 * fill(mmd)
    b = np.random.default_rng(6).standard_normal(a.shape[0])
    first = lu_factor(a, border=6, nodes=np.arange(lead) // 3)
    again = lu_factor(2.0 * a, border=6, nodes=np.arange(lead) // 3)  # same pattern: kept order
    assert isinstance(again, factor.PermutedLU)
    np.testing.assert_allclose(again.solve(b), first.solve(b) / 2.0, rtol=1e-9, atol=0)
    x = lu_factor(a, border=6).solve(b)
    assert np.linalg.norm(a @ x - b) <= 1e-10 * np.linalg.norm(b)


def test_permuted_lu_solves_in_the_precision_of_its_factors():
    """A node-ordered factorisation solves in the precision of its factors: float64, and float32
    (the inflation's kept preconditioner)."""
    a = _node_laplacian(8)
    lead = a.shape[0] - 6
    b = np.random.default_rng(7).standard_normal(a.shape[0])
    double = lu_factor(a, border=6, nodes=np.arange(lead) // 3)
    single = lu_factor(a.astype(np.float32), border=6, nodes=np.arange(lead) // 3)
    assert isinstance(double, factor.PermutedLU) and isinstance(single, factor.PermutedLU)
    x = double.solve(b)
    assert x.dtype == np.float64 and np.linalg.norm(a @ x - b) <= 1e-10 * np.linalg.norm(b)
    x32 = single.solve(b.astype(np.float32))
    assert x32.dtype == np.float32
    assert np.linalg.norm(a @ x32 - b) <= 1e-4 * np.linalg.norm(b)
