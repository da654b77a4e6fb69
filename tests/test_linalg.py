"""Sparse factorisations: both SuperLU orderings solve to round-off, the fallback for a zero
pivot, and the Sherman–Morrison rank-one updates against a dense solve."""

import numpy as np
import pytest
import scipy.sparse as sp

from quadmodes.linalg.factor import lu_factor, with_rank_one_terms


def _bordered_laplacian(n: int = 30, seed: int = 1) -> sp.csc_matrix:
    """A 2-D Laplacian (n² unknowns, the pattern of a membrane tangent) bordered by two dense
    constraint columns: symmetric and indefinite, with a zero diagonal block."""
    lap1 = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    k = sp.kronsum(lap1, lap1)
    c = np.random.default_rng(seed).standard_normal((n * n, 2))
    return sp.bmat([[k, sp.csc_matrix(c)], [sp.csc_matrix(c).T, None]], format="csc")


@pytest.mark.parametrize("symmetric", [True, False])
def test_both_orderings_solve_the_bordered_system(symmetric):
    a = _bordered_laplacian()
    b = np.random.default_rng(2).standard_normal(a.shape[0])
    x = lu_factor(a, symmetric=symmetric).solve(b)
    assert np.linalg.norm(a @ x - b) <= 1e-12 * np.linalg.norm(b) * np.linalg.norm(x)
    x_dense = np.linalg.solve(a.toarray(), b)
    assert np.allclose(x, x_dense, rtol=0, atol=1e-10 * np.abs(x_dense).max())


def test_zero_diagonal_needs_off_diagonal_pivots():
    # [[0, 1], [1, 0]] ⊕ [[0, 2], [2, 0]]: every diagonal pivot is zero
    a = sp.csc_matrix(np.array([[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 2], [0, 0, 2, 0]], float))
    b = np.array([1.0, 2.0, 3.0, 4.0])
    assert np.allclose(lu_factor(a).solve(b), [2.0, 1.0, 2.0, 1.5], rtol=0, atol=1e-15)


def test_rank_one_terms_match_a_dense_solve():
    rng = np.random.default_rng(3)
    a = _bordered_laplacian(12)
    m = a.shape[0]
    terms = [(0.7, rng.standard_normal(m)), (-0.2, rng.standard_normal(m))]
    solve = with_rank_one_terms(lu_factor(a).solve, terms)
    dense = a.toarray() + sum(c * np.outer(v, v) for c, v in terms)
    b = rng.standard_normal(m)
    expected = np.linalg.solve(dense, b)
    assert np.allclose(solve(b), expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    assert with_rank_one_terms(np.negative, []) is np.negative


def test_factorize_interface_and_missing_optional_back_end(monkeypatch, capsys):
    import importlib.util

    from quadmodes.linalg import factor

    a = _bordered_laplacian(12)
    b = np.random.default_rng(4).standard_normal(a.shape[0])
    f = factor.factorize(a)
    assert f.backend == "superlu"
    assert np.linalg.norm(a @ f.solve(b) - b) <= 1e-10 * np.linalg.norm(b)
    many = f.solve(np.stack([b, 2 * b], 1))  # several right-hand sides at once
    assert np.allclose(many[:, 1], 2 * many[:, 0], rtol=0, atol=1e-12 * np.abs(many).max())
    with pytest.raises(ValueError, match="choose from"):
        factor.factorize(a, backend="nonsense")
    # a missing optional back end: one line, then the default
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "pypardiso" else real(name, *a))  # fmt: skip
    monkeypatch.setattr(factor, "_REPORTED", set())
    monkeypatch.setenv("QUADMODES_LINALG", "pardiso")
    assert factor.factorize(a).backend == "superlu"
    assert factor.factorize(a).backend == "superlu"
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pypardiso" in err


def test_single_precision_factorisation_is_an_approximate_inverse():
    from quadmodes.linalg.factor import factorize

    lap1 = sp.diags([-1.0, 4.0, -1.0], [-1, 0, 1], shape=(40, 40))
    a = sp.kronsum(lap1, lap1, format="csc")  # SPD, condition ~3
    b = np.random.default_rng(6).standard_normal(a.shape[0])
    x = factorize(a, single=True).solve(b)
    assert x.dtype == np.float64
    exact = factorize(a).solve(b)
    err = np.abs(x - exact).max() / np.abs(exact).max()
    assert 0.0 < err <= 1e-5  # single-precision round-off, not double


@pytest.mark.parametrize("symmetric", [True, False])
def test_pardiso_solves_as_superlu(symmetric):
    """The optional PARDISO back end on the bordered Laplacian: the same solution as SuperLU to
    round-off (skipped without pypardiso)."""
    pytest.importorskip("pypardiso")
    from quadmodes.linalg.factor import factorize

    a = _bordered_laplacian()
    b = np.random.default_rng(8).standard_normal((a.shape[0], 2))
    f = factorize(a, symmetric=symmetric, backend="pardiso")
    assert f.backend == "pardiso"
    x, ref = f.solve(b), factorize(a, symmetric=symmetric).solve(b)
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-10 * np.abs(ref).max())
