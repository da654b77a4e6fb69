"""The Krylov path's kept preconditioner assembled straight into its permuted factorisation
data (:mod:`quadmodes.fullorder.preconditioner`) against the straightforward path: the same
matrix entry by entry and the same float32 solves bit for bit, compiled or numpy, over several
renewals (the map must survive the factorisations), on the small capsule of conftest.py with a
gas-law pressure (rank-one terms)."""

import math
from dataclasses import replace

import numpy as np
import pytest

import quadmodes.fullorder.preconditioner as pre
from quadmodes.fe.model import centre_of_mass
from quadmodes.fe.pressure import PressureSet
from quadmodes.fullorder import kinematics as kin
from quadmodes.fullorder.kernels import StepOperators, jit_module
from quadmodes.fullorder.newton import NewtonMatrix, _kept
from quadmodes.fullorder.setup import setup_problem

H = 2.5e-4


@pytest.fixture(scope="module")
def capsule(small_modal_model):
    """(problem, ops, pairs): the capsule with a gas law and three step pairs 0.1 mm and 2°
    apart."""
    m = small_modal_model
    sets = tuple(
        replace(e, gas_law_exponent=1.4, reference_volume=e.volume(m.x))
        if isinstance(e, PressureSet) else e
        for e in m.structure.elements
    )  # fmt: skip
    gas = replace(m.structure, elements=sets)
    problem = setup_problem(gas, m.x, (0.0, H), H, model=None, damping=False, hub=None,
                            newton_tol=1e-11, energy_momentum=True, rotation_map=True)  # fmt: skip
    ops = StepOperators.build(gas, problem.m_full, problem.free, True)
    rng = np.random.default_rng(5)
    pairs = []
    for k in range(3):
        x0 = m.x + 1e-4 * rng.standard_normal(m.x.shape)
        rot = kin.axis_rotation(np.array([0.3, 0.2, 1.0]), math.radians(2.0 * (k + 1)))
        c = centre_of_mass(gas, x0)
        pairs.append((x0, (x0 - c) @ rot.T + c + 1e-4 * rng.standard_normal(m.x.shape)))
    return problem, ops, pairs


@pytest.mark.parametrize("jit", [False] + ([True] if jit_module() is not None else []))
def test_permuted_assembly_is_the_straightforward_preconditioner_bit_for_bit(capsule, jit,
                                                                            monkeypatch):  # fmt: skip
    problem, ops, pairs = capsule
    if not jit:
        monkeypatch.setattr(pre, "jit_module", lambda: None)
    w = 0.5 * H * H
    permuted = pre.PermutedNewtonAssembly.of(ops, problem.free)
    b = np.random.default_rng(9).standard_normal(len(problem.free))
    for x0, x1 in pairs:  # several renewals with one map
        a = ops.newton_matrix(x0, x1, w)
        a.sort_indices()
        ref = a[permuted.order][:, permuted.order].tocsc()
        ref.sort_indices()
        assert np.array_equal(ref.indptr, permuted.indptr)
        assert np.array_equal(ref.indices, permuted.indices)
        assert np.array_equal(ref.data, permuted.data(ops, x0, x1, w))
        slow = NewtonMatrix.at(problem, x0, x1, ops, single=True, node_order=True)
        fast = _kept(problem, ops, permuted, x0, x1)
        assert fast.low and np.array_equal(fast.solve(b), slow.solve(b))


@pytest.mark.skipif(jit_module() is None, reason="numba cannot be imported here")
def test_compiled_bar_force_is_the_numpy_one_bit_for_bit(capsule):
    # the ties' step force compiled (jit.bar_force) adds bar by bar in index order: the sums of
    # the sparse products of the numpy form, so every run is unchanged by it
    from quadmodes.fe.bar import BarKernel, BarSet

    problem, _, pairs = capsule
    bars = [e for e in problem.structure.elements if isinstance(e, BarSet)]
    assert bars
    for x0, x1 in pairs:
        for e in bars:
            plain, compiled = BarKernel(e, problem.n), BarKernel(e, problem.n, jit_module())
            start = plain.start(x0)
            assert np.array_equal(compiled.force(start, x1), plain.force(start, x1))


@pytest.mark.skipif(jit_module() is None, reason="numba cannot be imported here")
def test_fused_membrane_blocks_are_the_numpy_ones_to_round_off(capsule):
    # the renewal thread's preconditioner (issue 27 item 4): the SVK membranes' Jacobian blocks
    # computed and added in one compiled pass (jit.membrane_block_scatter) instead of formed
    # by numpy and scattered; the same sums in the same order, the blocks to round-off
    problem, ops, pairs = capsule
    w = 0.5 * H * H
    permuted = pre.PermutedNewtonAssembly.of(ops, problem.free)
    assert any(type(k) is pre.MembraneKernel for k in ops.kernels)
    for x0, x1 in pairs:
        ref = permuted.data(ops, x0, x1, w)
        got = permuted.data(ops, x0, x1, w, fused=True)
        stiff = np.abs(ref - permuted.mass).max()  # the weight·J part
        assert np.abs(got - ref).max() <= 1e-13 * stiff
