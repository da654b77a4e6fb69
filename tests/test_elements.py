"""Element kernels: patch tests, frame invariance, tangent and second-order term by finite
differences, for membrane, pressure (constant and gas law) and bar sets."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from quadmodes.fe.assembly import assemble_matrix, assemble_vector
from quadmodes.fe.bar import bar_set
from quadmodes.fe.membrane import membrane_set
from quadmodes.fe.pressure import PressureSet, enclosed_volume

RNG = np.random.default_rng(7)

OCTA_POINTS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
OCTA_TRIS = np.array(
    [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
)


def _sets():
    x0 = OCTA_POINTS * 0.3
    mem = membrane_set(OCTA_TRIS, x0, 1e-4, 3e8, 0.3, 900.0)
    bars = bar_set(np.array([[0, 1], [2, 3], [4, 5], [0, 4]]), x0, 1e3)
    vol0 = enclosed_volume(x0, OCTA_TRIS)
    return x0, {
        "membrane": mem,
        "pressure": PressureSet(OCTA_TRIS, 2000.0),
        "gas": PressureSet(OCTA_TRIS, 2000.0, gas_law_exponent=1.4, reference_volume=vol0),
        "bar": bars,
    }


def _global_force(es, x):
    f = assemble_vector(es.conn, es.force(x), x.shape[0])
    if isinstance(es, PressureSet) and es.gas_law_exponent:
        pass  # gas-law force is still elementwise (-p(V) ∇V per triangle)
    return f


def _global_stiffness(es, x):
    k = assemble_matrix(es.conn, es.stiffness(x), x.shape[0]).toarray()
    if isinstance(es, PressureSet) and es.gas_law_exponent:
        from quadmodes.fe.pressure import gas_rank_one

        c, v = gas_rank_one(es, x)
        k = k + c * np.outer(v, v)
    return k


def _global_b(es, x, u, v):
    b = assemble_vector(es.conn, es.second_order(x, u, v), x.shape[0])
    if isinstance(es, PressureSet):
        from quadmodes.fe.pressure import gas_second_order

        b = b + gas_second_order(es, x, u, v)
    return b


def _deformed(x0, scale=0.05):
    return x0 + scale * RNG.standard_normal(x0.shape) * np.abs(x0).max()


@pytest.mark.parametrize("name", ["membrane", "pressure", "gas", "bar"])
def test_force_is_energy_gradient_and_tangent_is_force_derivative(name):
    x0, sets = _sets()
    es = sets[name]
    x = _deformed(x0)
    f = _global_force(es, x)
    k = _global_stiffness(es, x)
    h = 1e-6
    w = RNG.standard_normal(x.shape)
    de = (es.energy(x + h * w) - es.energy(x - h * w)) / (2 * h)
    assert de == pytest.approx(np.sum(f * w), rel=1e-6)
    df = (_global_force(es, x + h * w) - _global_force(es, x - h * w)) / (2 * h)
    assert np.linalg.norm(df.ravel() - k @ w.ravel()) <= 1e-6 * np.linalg.norm(df)
    assert np.allclose(k, k.T, rtol=0, atol=1e-9 * np.abs(k).max())


@pytest.mark.parametrize("name", ["membrane", "pressure", "gas", "bar"])
def test_second_order_term_is_half_second_derivative(name):
    x0, sets = _sets()
    es = sets[name]
    x = _deformed(x0)
    u, v = RNG.standard_normal(x.shape), RNG.standard_normal(x.shape)
    h = 1e-4
    fd = (
        _global_force(es, x + h * (u + v))
        - _global_force(es, x + h * (u - v))
        - _global_force(es, x - h * (u - v))
        + _global_force(es, x - h * (u + v))
    ) / (4 * h * h)
    b = _global_b(es, x, u, v)
    assert np.linalg.norm(2 * b - fd) <= 1e-6 * np.linalg.norm(fd)
    assert np.allclose(b, _global_b(es, x, v, u), rtol=1e-12, atol=1e-12 * np.abs(b).max())


@pytest.mark.parametrize("name", ["membrane", "pressure", "gas", "bar"])
def test_frame_invariance(name):
    x0, sets = _sets()
    es = sets[name]
    x = _deformed(x0)
    q = Rotation.from_rotvec([0.7, -1.9, 0.4]).as_matrix()
    shift = np.array([0.3, -2.0, 1.1])
    xr = x @ q.T + shift
    e, er = es.energy(x), es.energy(xr)
    assert abs(er - e) <= 1e-10 * abs(e)
    f, fr = _global_force(es, x), _global_force(es, xr)
    assert np.linalg.norm(fr - f @ q.T) <= 1e-10 * np.linalg.norm(f)


def test_membrane_patch_uniform_biaxial_stretch():
    # Flat square patch of 8 triangles; a homogeneous deformation must give the same stress in
    # every element, zero net force at the interior node, and the analytic SVK stress.
    pts = np.array([[i, j, 0.0] for j in range(3) for i in range(3)], float) * 0.1
    tris = []
    for j in range(2):
        for i in range(2):
            a = 3 * j + i
            tris += [[a, a + 1, a + 4], [a, a + 4, a + 3]]
    e_mod, nu, t = 2e8, 0.3, 1e-4
    mem = membrane_set(np.array(tris), pts, t, e_mod, nu, 1000.0)
    stretch = np.diag([1.02, 0.99, 1.0])
    rot = Rotation.from_rotvec([0.3, 0.2, 1.0]).as_matrix()
    x = pts @ (rot @ stretch).T
    _, strain, stress = mem.strain_stress(x)
    e11 = 0.5 * (1.02**2 - 1)
    e22 = 0.5 * (0.99**2 - 1)
    s11 = e_mod / (1 - nu**2) * (e11 + nu * e22)
    s22 = e_mod / (1 - nu**2) * (e22 + nu * e11)
    # local element axes differ between triangles: compare the tensor invariants
    assert np.allclose(np.trace(strain, axis1=1, axis2=2), e11 + e22, rtol=1e-12)
    assert np.allclose(np.linalg.det(strain), e11 * e22, rtol=1e-10)
    assert np.allclose(np.trace(stress, axis1=1, axis2=2), s11 + s22, rtol=1e-12)
    assert np.allclose(np.linalg.det(stress), s11 * s22, rtol=1e-10)
    f = assemble_vector(mem.conn, mem.force(x), len(pts))
    assert np.linalg.norm(f[4]) <= 1e-10 * np.abs(f).max()


def test_pressure_on_closed_surface_is_self_equilibrated():
    x0, sets = _sets()
    x = _deformed(x0, 0.1)
    f = _global_force(sets["pressure"], x)
    assert np.linalg.norm(f.sum(0)) <= 1e-12 * np.abs(f).max()
    assert np.linalg.norm(np.cross(x, f).sum(0)) <= 1e-12 * np.abs(f).max()
    # total outward force magnitude on the +x half-octahedron: p times projected area
    vol = enclosed_volume(x0, OCTA_TRIS)
    assert vol == pytest.approx(4 / 3 * 0.3**3)


def test_gas_law_pressure_follows_p_v_kappa():
    x0, sets = _sets()
    gas = sets["gas"]
    x = 1.1 * x0
    assert gas.pressure(x) == pytest.approx(2000.0 * (1 / 1.1**3) ** 1.4, rel=1e-12)


def _reference_membrane_stiffness(mem, x):
    """The membrane tangent as written before the batched products (einsum over the element)."""
    f, e, s = mem.strain_stress(x)
    g = mem.gradients
    bm = np.stack([np.einsum("ei,ea->eai", f[:, :, 0], g[:, :, 0]),
                   np.einsum("ei,ea->eai", f[:, :, 1], g[:, :, 1]),
                   np.einsum("ei,ea->eai", f[:, :, 0], g[:, :, 1])
                   + np.einsum("ei,ea->eai", f[:, :, 1], g[:, :, 0])], 1).reshape(-1, 3, 9)  # fmt: skip
    k_mat = np.einsum("epa,epq,eqb->eab", bm, mem.material_tangent(e), bm)
    k_geo = np.einsum("eab,ij->eaibj", np.einsum("eak,ekl,ebl->eab", g, s, g), np.eye(3))
    return mem._volume()[:, None, None] * (k_mat + k_geo.reshape(-1, 9, 9))


@pytest.mark.parametrize("tension_field", [False, True])
def test_membrane_kernels_equal_the_element_formulas(tension_field):
    """Batched-product kernels: force ``V F S G_a`` and tangent ``V (Bᵀ D B + G S Gᵀ ⊗ I)`` as the
    einsum formulas give them (to round-off), also under the wrinkling law (per-element D)."""
    x0 = OCTA_POINTS * 0.3
    mem = membrane_set(OCTA_TRIS, x0, 1e-4, 3e8, 0.3, 900.0, tension_field=tension_field)
    # stretched (taut) and squeezed (wrinkled) elements alike
    x = x0 * np.array([1.02, 0.99, 1.0]) + 2e-3 * RNG.standard_normal(x0.shape)
    k = mem.stiffness(x)
    ref = _reference_membrane_stiffness(mem, x)
    assert np.abs(k - ref).max() <= 1e-13 * np.abs(ref).max()
    f, _, s = mem.strain_stress(x)
    ref_f = mem._volume()[:, None, None] * np.einsum("eij,ejk,eak->eai", f, s, mem.gradients)
    assert np.abs(mem.force(x) - ref_f).max() <= 1e-13 * np.abs(ref_f).max()


def test_volume_hessian_is_the_derivative_of_the_volume_gradient():
    """Element Hessian of the enclosed volume: blocks ``∓[x]x / 6`` (against the cross-product
    matrices) and the central difference of ``∂V/∂x_a``."""
    from quadmodes.fe.pressure import volume_gradient_elements, volume_hessian_elements
    from quadmodes.rotations import skew

    xe = _deformed(OCTA_POINTS * 0.3)[OCTA_TRIS]
    h = volume_hessian_elements(xe)
    ref = np.zeros((len(xe), 3, 3, 3, 3))
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        ref[:, a, :, b, :] = -skew(xe[:, c]) / 6.0
        ref[:, a, :, c, :] = skew(xe[:, b]) / 6.0
    np.testing.assert_allclose(h, ref.reshape(-1, 9, 9), rtol=0, atol=1e-15)
    w, eps = RNG.standard_normal(xe.shape), 1e-6
    fd = (volume_gradient_elements(xe + eps * w) - volume_gradient_elements(xe - eps * w)) / (2 * eps)
    np.testing.assert_allclose(np.einsum("eab,eb->ea", h, w.reshape(-1, 9)), fd.reshape(-1, 9),
                               rtol=0, atol=1e-9 * np.abs(fd).max())  # fmt: skip


def test_sets_on_one_connectivity_share_their_slots():
    """connectivity_groups: equal connectivities (a membrane and the pressure on it) map to one
    entry, in order of first appearance; different ones (bars) get their own."""
    from quadmodes.fe.model import connectivity_groups

    bars = np.array([[0, 1], [2, 3]])
    distinct, groups = connectivity_groups([OCTA_TRIS, bars, OCTA_TRIS.copy(), bars[:1]])
    assert groups == (0, 1, 0, 2)
    assert [d.shape for d in distinct] == [(8, 3), (2, 2), (1, 2)]
