"""Quadratic modes and the reduced-model arrays: frame conditions, g as half the static modal
derivative, the second-order accuracy of the quadratic manifold, the spin-stiffening identity,
and the NetCDF artifact."""

import numpy as np
import pytest

from quadmodes.fe.model import internal_force, mass_matrix, second_order_force, tangent_stiffness
from quadmodes.rom.artifact import ArtifactError, load_reduced_model, save_reduced_model
from quadmodes.structure.bordered import bordered_solver
from quadmodes.structure.modes import remove_rigid_part


def test_frame_condition_arrays_vanish(small_reduced_model):
    r = small_reduced_model
    scale = np.sqrt(r.mass) * np.abs(r.X).max()
    for name in ("S1", "S2", "c", "Cxg"):
        assert np.abs(getattr(r, name)).max() <= 1e-10 * scale, name
    assert np.allclose(r.mu, np.eye(r.n_modes), atol=1e-12)
    assert np.allclose(np.diag(r.Lam), (2 * np.pi * r.frequencies_hz) ** 2, rtol=1e-8)
    assert np.allclose(r.G, np.swapaxes(r.G, 0, 1))
    assert np.allclose(r.Cuu, -np.swapaxes(r.Cuu, 0, 1))


def test_g_is_half_the_static_modal_derivative(small_modal_model, small_reduced_model):
    m, r = small_modal_model, small_reduced_model
    s, x = m.structure, m.x
    u, v = r.Phi[0], r.Phi[2]
    h = 1e-4 / np.abs(u).max()
    # dK/dU . u applied to v, by central differences of the tangent
    dk_u_v = (
        tangent_stiffness(s, x + h * u) @ v.ravel() - tangent_stiffness(s, x - h * u) @ v.ravel()
    ) / (2 * h)
    k = tangent_stiffness(s, x)
    # K theta = -Pi^T (dK.u) v with the frame conditions: theta = 2 g
    theta = bordered_solver(k, (mass_matrix(s) @ _rigid(s, x)), [])(-dk_u_v)
    theta = remove_rigid_part(s, x, theta[:, None])[:, 0].reshape(-1, 3)
    g = r.G[0, 2]
    assert np.linalg.norm(theta - 2 * g) <= 1e-5 * np.linalg.norm(theta)


def _rigid(s, x):
    from quadmodes.fe.model import rigid_body_modes

    return rigid_body_modes(s, x)


def test_quadratic_manifold_residual_is_third_order(small_modal_model, small_reduced_model):
    # Equilibrium residual of U(s) under the basis loads, projected off the rigid modes:
    # cubic in s with g, quadratic with linear modes only (theory §5).
    m, r = small_modal_model, small_reduced_model
    s_, x = m.structure, m.x
    k = tangent_stiffness(s_, x)
    direction = np.array([1.0, 0.5, -0.7, 0.3, 0.2])

    def residual(amplitude, with_g):
        q = amplitude * direction
        u = np.einsum("k,kia->ia", q, r.Phi)
        if with_g:
            u = u + np.einsum("m,n,mnia->ia", q, q, r.G)
        f = internal_force(s_, x + u).ravel() - k @ np.einsum("k,kia->ia", q, r.Phi).ravel()
        return np.linalg.norm(_project(s_, x, f))

    a = 2e-3
    ratio_q = residual(a, True) / residual(a / 2, True)
    ratio_l = residual(a, False) / residual(a / 2, False)
    assert ratio_q == pytest.approx(8.0, rel=0.15)
    assert ratio_l == pytest.approx(4.0, rel=0.15)


def _project(s, x, f):
    """Pi^T f: remove the rigid-body (inertia-relief) part of a load."""
    from quadmodes.structure.modes import rigid_projector_basis

    q = rigid_projector_basis(s, x)
    m = mass_matrix(s)
    return f - m @ (q @ (q.T @ f))


def test_spin_stiffening_equals_centrifugal_geometric_stiffness(
    small_modal_model, small_reduced_model
):
    # -w^T J2g_mn w = u^m . K'(u_c) u^n with u_c the static response to the centrifugal load
    m, r = small_modal_model, small_reduced_model
    s, x = m.structure, m.x
    omega = np.array([3.0, -2.0, 5.0])
    xr = r.X
    fc = -(s.mass_scalar @ np.cross(omega, np.cross(omega, xr)))  # centrifugal load -M Ω² X
    k = tangent_stiffness(s, x)
    solve = bordered_solver(k, mass_matrix(s) @ _rigid(s, x), [])
    uc = solve(_project(s, x, fc.ravel())).reshape(-1, 3)  # K u_c = Πᵀ f_c
    for mi, ni in [(0, 0), (2, 3), (4, 4)]:
        lhs = -omega @ r.J2g[mi, ni] @ omega
        rhs = 2 * np.sum(r.Phi[mi] * second_order_force(s, x, uc, r.Phi[ni]))
        assert lhs == pytest.approx(rhs, rel=1e-6, abs=1e-9 * abs(omega @ r.J0 @ omega))


def test_artifact_round_trip_and_bad_files(small_reduced_model, tmp_path):
    path = save_reduced_model(small_reduced_model, tmp_path / "model.nc")
    back = load_reduced_model(path)
    for name in ("J0", "J1", "J2u", "J2g", "Cuu", "Cxg", "mu", "Lam", "C", "Phi", "G", "X"):
        assert np.array_equal(getattr(back, name), getattr(small_reduced_model, name)), name
    assert back.labels == small_reduced_model.labels and back.free is True
    bad = tmp_path / "bad.nc"
    bad.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(ArtifactError, match="rebuild"):
        load_reduced_model(bad)
    with pytest.raises(ArtifactError, match="no such"):
        load_reduced_model(tmp_path / "missing.nc")
