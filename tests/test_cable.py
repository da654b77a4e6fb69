"""Tests of the ANCF cable element (:mod:`quadmodes.fe.cable`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from quadmodes.fe.assembly import (
    assemble_matrix,
    assemble_scalar_matrix,
    assemble_vector,
    expand_scalar_matrix,
)
from quadmodes.fe.cable import CableSet, clamped_mask, straight_cable

# Kane beam data
L = 10.0  # m
EA = 2.8e7  # N
EI = 1.4e4  # N m^2
RHO_A = 1.2  # kg/m


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def _deformed(rng: np.random.Generator, n_el: int = 4, amp: float = 0.05):
    """A randomly deformed (stretched, bent, twisted-out-of-plane) cable state."""
    ref, trans, cable = straight_cable([0.0, 0.0, 0.0], [L, 0.0, 0.0], n_el, EA, EI, RHO_A)
    x = ref + amp * rng.standard_normal(ref.shape) * np.where(trans, L / n_el, 1.0)[:, None]
    return ref, trans, cable, x


def _global_force(cable: CableSet, x: np.ndarray) -> np.ndarray:
    return assemble_vector(cable.conn, cable.force(x), x.shape[0])


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


# --------------------------------------------------------------------------- invariance
def test_frame_invariance():
    rng = np.random.default_rng(0)
    _, trans, cable, x = _deformed(rng)
    q = _rotation(rng)
    t = rng.standard_normal(3)
    xr = x @ q.T
    xr[trans] += t  # positions translate, slopes do not
    e0, e1 = cable.energy(x), cable.energy(xr)
    assert e0 > 0
    assert abs(e1 - e0) <= 1e-10 * e0
    f0, f1 = cable.force(x), cable.force(xr)
    assert _rel(f1, f0 @ q.T) < 1e-10


# --------------------------------------------------------------------------- derivatives
def test_force_is_energy_gradient():
    rng = np.random.default_rng(1)
    _, _, cable, x = _deformed(rng)
    f = _global_force(cable, x)
    d = rng.standard_normal(x.shape)
    h = 1e-6
    fd = (cable.energy(x + h * d) - cable.energy(x - h * d)) / (2 * h)
    assert abs(fd - np.sum(f * d)) < 1e-6 * np.linalg.norm(f) * np.linalg.norm(d)


def test_tangent_matches_finite_difference():
    rng = np.random.default_rng(2)
    _, _, cable, x = _deformed(rng)
    n = x.shape[0]
    k = assemble_matrix(cable.conn, cable.stiffness(x), n)
    assert spla.norm(k - k.T) <= 1e-12 * spla.norm(k)
    for _ in range(3):
        d = rng.standard_normal(x.shape)
        h = 1e-6
        fd = (_global_force(cable, x + h * d) - _global_force(cable, x - h * d)) / (2 * h)
        kd = (k @ d.ravel()).reshape(n, 3)
        assert _rel(kd, fd) < 1e-6


def test_second_order_matches_finite_difference():
    rng = np.random.default_rng(3)
    _, _, cable, x = _deformed(rng)
    n = x.shape[0]
    u = rng.standard_normal(x.shape)
    v = rng.standard_normal(x.shape)
    b_uv = assemble_vector(cable.conn, cable.second_order(x, u, v), n)
    b_vu = assemble_vector(cable.conn, cable.second_order(x, v, u), n)
    # symmetric in (u, v)
    assert _rel(b_vu, b_uv) < 1e-13

    # central mixed difference: exact for a cubic force up to round-off
    h = 1e-3
    fpp = _global_force(cable, x + h * (u + v))
    fpm = _global_force(cable, x + h * (u - v))
    fmp = _global_force(cable, x - h * (u - v))
    fmm = _global_force(cable, x - h * (u + v))
    d2f = (fpp - fpm - fmp + fmm) / (4 * h * h)
    assert _rel(b_uv, 0.5 * d2f) < 1e-6

    # polarisation identity B(u, v) = ¼ [B(u+v, u+v) − B(u−v, u−v)]
    def b(a, c):
        return assemble_vector(cable.conn, cable.second_order(x, a, c), n)

    pol = 0.25 * (b(u + v, u + v) - b(u - v, u - v))
    assert _rel(pol, b_uv) < 1e-12

    # cubic force: f(x+u) + f(x−u) − 2 f(x) = 2 B(u, u) exactly
    s = 0.1
    even = (
        _global_force(cable, x + s * u)
        + _global_force(cable, x - s * u)
        - 2 * _global_force(cable, x)
    )
    assert _rel(even, 2 * s * s * b(u, u)) < 1e-8


# --------------------------------------------------------------------------- patch tests
def test_rigid_motion_gives_zero_force():
    rng = np.random.default_rng(4)
    ref, trans, cable = straight_cable([0.0, 0.0, 0.0], [L, 0.0, 0.0], 5, EA, EI, RHO_A)
    q = _rotation(rng)
    x = ref @ q.T
    x[trans] += rng.standard_normal(3)
    f = cable.force(x)
    # scale: axial force EA at unit strain
    assert np.abs(f).max() < 1e-9 * EA
    assert cable.energy(x) < 1e-12 * EA * L


def test_uniform_stretch_gives_exact_axial_force():
    ref, trans, cable = straight_cable([0.0, 0.0, 0.0], [L, 0.0, 0.0], 4, EA, EI, RHO_A)
    lam = 1.01
    x = ref.copy()
    x[trans] *= lam  # r = λ x e
    x[~trans] *= lam  # r' = λ e
    eps = 0.5 * (lam**2 - 1)
    f = _global_force(cable, x)
    e = np.array([1.0, 0.0, 0.0])
    # work-conjugate end force of a Green-strain bar: EA ε λ (the 2nd PK force times stretch)
    p = EA * eps * lam
    assert np.allclose(f[0], -p * e, rtol=0, atol=1e-9 * p)
    assert np.allclose(f[-2], p * e, rtol=0, atol=1e-9 * p)
    f_int = np.delete(f, [0, f.shape[0] - 2], axis=0)  # interior nodes and all slopes
    assert np.abs(f_int).max() < 1e-9 * p
    assert cable.energy(x) == pytest.approx(0.5 * EA * eps**2 * L, rel=1e-12)


def test_uniform_curvature_gives_end_moments():
    n_el = 3
    ref, trans, cable = straight_cable([0.0, 0.0, 0.0], [L, 0.0, 0.0], n_el, EA, EI, RHO_A)
    kappa = 1e-4  # 1/m
    e = np.array([1.0, 0.0, 0.0])
    nvec = np.array([0.0, 0.6, 0.8])
    s = ref[trans, 0]  # arc length of the nodes
    x = np.empty_like(ref)
    x[trans] = s[:, None] * e + 0.5 * kappa * s[:, None] ** 2 * nvec  # r'' = κ n exactly
    x[~trans] = e + kappa * s[:, None] * nvec

    # bending only: exact to round-off
    bend = dataclasses.replace(cable, EA=0.0)
    u_bend = 0.5 * EI * kappa**2 * L
    assert bend.energy(x) == pytest.approx(u_bend, rel=1e-12)
    f = _global_force(bend, x)
    m = EI * kappa
    assert np.allclose(f[1], -m * nvec, rtol=0, atol=1e-10 * m)  # slope DOF at x = 0
    assert np.allclose(f[-1], m * nvec, rtol=0, atol=1e-10 * m)  # slope DOF at x = L
    assert np.abs(f[2:-1]).max() < 1e-10 * m
    assert np.abs(f[0]).max() < 1e-10 * m

    # full element: the axial energy of the parabola is EA κ⁴ L⁵ / 40 (second order in κ²)
    u_full = cable.energy(x)
    assert u_full == pytest.approx(u_bend + EA * kappa**4 * L**5 / 40, rel=1e-10)


def test_mass_matrix():
    ref, trans, cable = straight_cable([0.0, 0.0, 0.0], [L, 0.0, 0.0], 4, EA, EI, RHO_A)
    ms = assemble_scalar_matrix(cable.conn, cable.mass(), ref.shape[0]).toarray()
    assert np.allclose(ms, ms.T)
    assert np.all(np.linalg.eigvalsh(ms) > 0)
    # rigid translation: the position DOFs carry the full mass ρA L
    one = trans.astype(float)
    assert one @ ms @ one == pytest.approx(RHO_A * L, rel=1e-13)
    # rigid rotation about the root: r = s e_y, r' = e_y → kinetic moment ∫ ρA s² = ρA L³/3
    w = np.where(trans, ref[:, 0], 1.0)
    assert w @ ms @ w == pytest.approx(RHO_A * L**3 / 3, rel=1e-13)


# --------------------------------------------------------------------------- cantilever
def _cantilever(n_el: int, free_stretch_axis: int | None = None):
    ref, trans, cable = straight_cable([0.0, 0.0, 0.0], [L, 0.0, 0.0], n_el, EA, EI, RHO_A)
    n = ref.shape[0]
    free = clamped_mask(n, 0, free_stretch_axis)
    k = assemble_matrix(cable.conn, cable.stiffness(ref), n)[free][:, free].toarray()
    ms = assemble_scalar_matrix(cable.conn, cable.mass(), n)
    m = expand_scalar_matrix(ms)[free][:, free].toarray()
    return ref, trans, cable, free, k, m


def test_clamped_mask():
    free = clamped_mask(8, [0, 3])
    assert free.shape == (24,)
    assert not free[:6].any() and not free[18:].any() and free[6:18].all()
    free = clamped_mask(8, 0, free_stretch_axis=0)
    assert free[3] and not free[:3].any() and not free[4:6].any() and free[6:].all()


def test_cantilever_bending_frequencies():
    ref, trans, cable, free, k, m = _cantilever(12)
    w2, modes = sla.eigh(k, m)
    omega = np.sqrt(w2[:6])
    scale = np.sqrt(RHO_A * L**4 / EI)
    wbar = omega * scale
    expected = np.array([3.5160, 22.0345, 61.6972])
    # each bending frequency appears twice (two bending planes), no torsion, axial is far higher
    assert np.allclose(wbar[0::2], expected, rtol=5e-3)
    assert np.allclose(wbar[1::2], expected, rtol=5e-3)
    assert np.allclose(wbar[0::2], wbar[1::2], rtol=1e-8)
    # the six lowest modes are transverse (no axial component in the position DOFs)
    full = np.zeros((free.size, modes.shape[1]))
    full[free] = modes
    pos = full.reshape(-1, 3, modes.shape[1])[trans]
    axial_share = np.abs(pos[:, 0, :]).max(0) / np.abs(pos).max((0, 1))
    assert axial_share[:6].max() < 1e-8
    # the first axial mode (a clamped-free bar: ω = π/2 √(EA/ρA) / L) is far above; fixing the
    # whole root slope imposes ε(0) = 0 and stiffens it by ~1 %
    first_axial = int(np.argmax(axial_share > 0.5))
    assert first_axial >= 6
    axial = 0.5 * np.pi * np.sqrt(EA / RHO_A) / L
    assert np.sqrt(w2[first_axial]) == pytest.approx(axial, rel=2e-2)


def test_cantilever_with_free_root_stretch():
    """Leaving the axial slope component free at the clamp: same bending, exact axial mode."""
    _, trans, _, free, k, m = _cantilever(12, free_stretch_axis=0)
    w2, modes = sla.eigh(k, m)
    w2_fixed = sla.eigh(*_cantilever(12)[4:], eigvals_only=True)
    full = np.zeros((free.size, modes.shape[1]))
    full[free] = modes
    pos = full.reshape(-1, 3, modes.shape[1])[trans]
    axial_share = np.abs(pos[:, 0, :]).max(0) / np.abs(pos).max((0, 1))
    bending = axial_share < 0.5
    assert np.allclose(w2[bending][:16], w2_fixed[:16], rtol=1e-10)
    first_axial = int(np.argmax(~bending))
    axial = 0.5 * np.pi * np.sqrt(EA / RHO_A) / L
    assert np.sqrt(w2[first_axial]) == pytest.approx(axial, rel=1e-4)


def test_foreshortening_of_first_bending_mode():
    n_el = 16
    ref, trans, cable, free, k, m = _cantilever(n_el)
    n = ref.shape[0]
    w2, modes = sla.eigh(k, m, subset_by_index=[0, 1])
    full = np.zeros((free.size, 2))
    full[free] = modes
    full = full.reshape(n, 3, 2)
    # combination of the degenerate pair with unit tip deflection in y and none in z
    tip = full[-2, 1:, :]  # (y, z) x 2 modes
    c = np.linalg.solve(tip, np.array([1.0, 0.0]))
    w = full @ c  # (n, 3)
    assert w[-2] == pytest.approx([0.0, 1.0, 0.0], abs=1e-10)
    assert np.abs(w[:, 2]).max() < 1e-8

    # ∫ w'² dx = 1.16194 / L for the tip-normalised first mode
    _, sp, _, dx = cable._shape
    wp = np.einsum("egj,ejk->egk", sp, w[cable.conn])
    int_wp2 = float(np.sum(dx * np.einsum("egk,egk->eg", wp, wp)))
    assert int_wp2 == pytest.approx(1.16194 / L, rel=1e-3)

    b = assemble_vector(cable.conn, cable.second_order(ref, w, w), n)
    g = np.zeros(free.size)
    g[free] = np.linalg.solve(k, -b.ravel()[free])
    g = g.reshape(n, 3)
    axial_tip = g[-2, 0]
    assert axial_tip == pytest.approx(-0.58097 / L, rel=1e-2)
    assert axial_tip == pytest.approx(-0.5 * int_wp2, rel=1e-3)
    assert np.abs(g[:, 1:]).max() < 1e-8 * abs(axial_tip)
