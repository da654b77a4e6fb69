"""Tension-field (wrinkling) membrane law: SVK where taut, no compression, C¹, exact step work."""

import numpy as np
import pytest
import scipy.sparse as sp

from quadmodes.fe import wrinkling as wr
from quadmodes.fe.membrane import membrane_set, plane_stress_matrix
from quadmodes.fe.model import Structure
from quadmodes.fullorder.step import step_force, step_strains

E_MOD, NU = 344.7e6, 0.3
D = plane_stress_matrix(E_MOD, NU)
LAW = (D, E_MOD, NU)


def strains_from(e1, e2, theta):
    """Strain tensors ``(n,2,2)`` with principal values e1, e2 and major direction angle θ."""
    c, s = np.cos(theta), np.sin(theta)
    r = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    lam = np.zeros((len(e1), 2, 2))
    lam[:, 0, 0], lam[:, 1, 1] = e1, e2
    return np.einsum("eij,ejk,elk->eil", r, lam, r)


def random_strains(rng, n, scale=1e-2):
    a = rng.normal(scale=scale, size=(n, 2, 2))
    return 0.5 * (a + np.swapaxes(a, 1, 2))


def svk_stress(strain):
    ev = np.stack([strain[:, 0, 0], strain[:, 1, 1], 2 * strain[:, 0, 1]], -1) @ D.T
    return np.stack([np.stack([ev[:, 0], ev[:, 2]], -1), np.stack([ev[:, 2], ev[:, 1]], -1)], -2)


def test_taut_states_are_st_venant_kirchhoff():
    rng = np.random.default_rng(0)
    e1 = rng.uniform(1e-4, 1e-2, 200)
    e2 = e1 * rng.uniform(-0.29, 1.0, 200)  # ε₂ > −ν ε₁: both principal stresses positive
    e = strains_from(e1, e2, rng.uniform(0, np.pi, 200))
    assert not np.any(wr.states(*wr.principal_strains(e)[:2], NU))
    s = svk_stress(e)
    np.testing.assert_allclose(wr.stress(*LAW, e), s, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(wr.energy_density(*LAW, e), 0.5 * np.einsum("eij,eij->e", e, s),
                               rtol=1e-12)  # fmt: skip
    np.testing.assert_allclose(wr.tangent(*LAW, e), np.broadcast_to(D, (200, 3, 3)), rtol=1e-14)


def test_wrinkled_state_is_uniaxial_tension_and_slack_is_free():
    e = strains_from(np.array([2e-3, -1e-3]), np.array([-1e-3, -3e-3]), np.array([0.4, 1.1]))
    s = wr.stress(*LAW, e)
    n1 = np.array([np.cos(0.4), np.sin(0.4)])
    np.testing.assert_allclose(s[0], E_MOD * 2e-3 * np.outer(n1, n1), rtol=1e-12)
    np.testing.assert_allclose(wr.energy_density(*LAW, e), [0.5 * E_MOD * 4e-6, 0.0], rtol=1e-12)
    assert np.all(s[1] == 0.0)


def test_no_compressive_principal_stress():
    rng = np.random.default_rng(1)
    s = wr.stress(*LAW, random_strains(rng, 2000))
    assert np.min(np.linalg.eigvalsh(s)) >= -1e-9 * np.max(np.abs(s))


def test_stress_is_the_energy_gradient_and_tangent_its_derivative():
    """Central differences in every state (points away from the state boundaries)."""
    rng = np.random.default_rng(2)
    e = random_strains(rng, 300)
    h = 1e-7
    for i, j in ((0, 0), (1, 1), (0, 1)):
        de = np.zeros((1, 2, 2))
        de[0, i, j] = de[0, j, i] = h
        dw = (wr.energy_density(*LAW, e + de) - wr.energy_density(*LAW, e - de)) / (2 * h)
        factor = 1.0 if i == j else 2.0
        np.testing.assert_allclose(dw, factor * wr.stress(*LAW, e)[:, i, j], rtol=1e-5,
                                   atol=1e-6 * E_MOD * 1e-2)  # fmt: skip
    k = wr.tangent(*LAW, e)
    for col, (i, j, f) in enumerate(((0, 0, 1.0), (1, 1, 1.0), (0, 1, 0.5))):
        de = np.zeros((1, 2, 2))
        de[0, i, j] = de[0, j, i] = f * h  # Voigt column: engineering shear 2E12 = h
        ds = (wr.stress(*LAW, e + de) - wr.stress(*LAW, e - de)) / (2 * h)
        dsv = np.stack([ds[:, 0, 0], ds[:, 1, 1], ds[:, 0, 1]], -1)
        np.testing.assert_allclose(dsv, k[:, :, col], rtol=1e-4, atol=1e-6 * E_MOD)


def test_energy_and_stress_are_continuous_across_the_wrinkling_boundary():
    e1 = np.full(2, 1e-3)
    on = -NU * 1e-3
    e = strains_from(e1, np.array([on * (1 - 1e-9), on * (1 + 1e-9)]), np.full(2, 0.3))
    assert wr.states(*wr.principal_strains(e)[:2], NU)[0].tolist() == [False, True]
    w = wr.energy_density(*LAW, e)
    s = wr.stress(*LAW, e)
    assert abs(w[0] - w[1]) < 1e-7 * w[0]
    np.testing.assert_allclose(s[0], s[1], atol=1e-6 * np.max(np.abs(s)))


def test_discrete_gradient_gives_the_exact_work():
    rng = np.random.default_rng(3)
    e0, e1 = random_strains(rng, 500), random_strains(rng, 500)
    sbar = wr.discrete_gradient_stress(*LAW, e0, e1)
    work = np.einsum("eij,eij->e", sbar, e1 - e0)
    dw = wr.energy_density(*LAW, e1) - wr.energy_density(*LAW, e0)
    np.testing.assert_allclose(work, dw, rtol=1e-10, atol=1e-12 * E_MOD * 1e-4)


def two_triangles(tension_field):
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]]) * 0.1
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    return pts, membrane_set(tri, pts, 1e-4, E_MOD, NU, 900.0, tension_field=tension_field)


@pytest.mark.parametrize("stretch", [(1.01, 0.99), (0.99, 0.98), (1.02, 1.01)])
def test_element_force_and_stiffness_are_consistent(stretch):
    pts, mem = two_triangles(True)
    rng = np.random.default_rng(4)
    x = pts * np.array([stretch[0], stretch[1], 1.0]) + rng.normal(scale=1e-4, size=pts.shape)
    f = np.zeros_like(x)
    np.add.at(f, mem.conn, mem.force(x))
    h = 1e-8
    fd = np.zeros_like(x)
    for a in range(4):
        for i in range(3):
            dx = np.zeros_like(x)
            dx[a, i] = h
            fd[a, i] = (mem.energy(x + dx) - mem.energy(x - dx)) / (2 * h)
    np.testing.assert_allclose(f, fd, rtol=1e-5, atol=1e-7 * np.max(np.abs(f)) + 1e-12)
    k = mem.stiffness(x)[0]
    e0 = mem.conn[0]
    kd = np.zeros((9, 9))
    for b in range(3):
        for j in range(3):
            dx = np.zeros_like(x)
            dx[e0[b], j] = h
            kd[:, 3 * b + j] = ((mem.force(x + dx)[0] - mem.force(x - dx)[0]) / (2 * h)).ravel()
    np.testing.assert_allclose(k, kd, rtol=1e-4, atol=1e-6 * np.max(np.abs(k)))


def test_full_order_step_force_does_the_exact_work_through_wrinkling():
    pts, mem = two_triangles(True)
    structure = Structure(pts, np.ones(4, bool), (mem,), sp.identity(4, format="csr"),
                          np.zeros((4, 3), bool))  # fmt: skip
    rng = np.random.default_rng(5)
    for _ in range(20):
        x0 = pts * 1.01 + rng.normal(scale=5e-4, size=pts.shape)
        x1 = x0 + rng.normal(scale=5e-4, size=pts.shape)
        f = step_force(structure, x0, x1, step_strains(structure, x0))
        work = float(np.sum(f * (x1 - x0)))
        assert abs(work - (mem.energy(x1) - mem.energy(x0))) < 1e-10 * max(mem.energy(x1), 1e-12)


def test_tension_field_leaves_a_taut_membrane_unchanged():
    pts, relaxed = two_triangles(True)
    _, svk = two_triangles(False)
    x = pts * np.array([1.02, 1.01, 1.0])
    assert relaxed.energy(x) == pytest.approx(svk.energy(x), rel=1e-13)
    np.testing.assert_allclose(relaxed.force(x), svk.force(x), rtol=1e-13)
    np.testing.assert_allclose(relaxed.stiffness(x), svk.stiffness(x), rtol=1e-12, atol=1e-9)


def test_fast_step_kernel_matches_the_reference_through_wrinkling():
    """The full order's step kernel of a wrinkling membrane (fullorder.kernels) gives the
    reference step force and Newton block (fullorder.step / fullorder.newton)."""
    from quadmodes.fullorder.kernels import StepOperators
    from quadmodes.fullorder.newton import _membrane_block

    pts, mem = two_triangles(True)
    structure = Structure(pts, np.ones(4, bool), (mem,), sp.identity(4, format="csr"),
                          np.zeros((4, 3), bool))  # fmt: skip
    ops = StepOperators.build(structure, sp.identity(12, format="csr"), np.arange(12), True)
    (kernel,) = ops.kernels
    rng = np.random.default_rng(6)
    x0 = pts * np.array([1.01, 0.995, 1.0]) + rng.normal(scale=5e-4, size=pts.shape)
    x1 = x0 + rng.normal(scale=5e-4, size=pts.shape)
    ref = step_force(structure, x0, x1, step_strains(structure, x0))
    np.testing.assert_allclose(kernel.force(kernel.start(x0), x1), ref, rtol=1e-10,
                               atol=1e-10 * np.max(np.abs(ref)))  # fmt: skip
    block = _membrane_block(mem, x0, x1, 0.5 * (x0 + x1))
    np.testing.assert_allclose(kernel.block(x0, x1), block, rtol=1e-10,
                               atol=1e-10 * np.max(np.abs(block)))  # fmt: skip
    assert ops.energy(x1) == pytest.approx(mem.energy(x1), rel=1e-12)
