"""The condensed potential on a snapshot-augmented basis (experimental.condensed_potential) on the
small capsule, N = 5: its gradient and Hessian are those of its energy (central differences; SVK,
tension-field where elements wrinkle, gas law), it lies between the condensed energies of the
nested feasible sets (W_c ≤ W_B ≤ W_red), it is W_c at a training point, its Hessian at 0 is Λ,
and its nonlinear parts vanish to second order."""

import numpy as np
import pytest
from conftest import SMALL_CAPSULE

from quadmodes.case import case_from_toml
from quadmodes.experimental import candidate_potentials as cand
from quadmodes.experimental import condensed_potential as cp
from quadmodes.fe import wrinkling as wr
from quadmodes.fe.membrane import MembraneSet, green_strain
from quadmodes.fe.model import with_tension_field
from quadmodes.rom import manifold_energy as me
from quadmodes.rom.reduced import reduce
from quadmodes.structure.pipeline import build_modal_model

#: Training amplitudes (m, largest nodal displacement) on the 0.76 m capsule: the tension-field
#: membrane wrinkles next to the end body from about 1 mm on.
TRAIN_M = (3e-3, 6e-3)


def wrinkled_elements(structure, x) -> int:
    """Membrane elements wrinkled or slack (principal Green strains) at ``x`` ``(n, 3)``."""
    count = 0
    for e in structure.elements:
        if isinstance(e, MembraneSet):
            _, strain = green_strain(e.gradients, x[e.conn])
            e1, e2, _, _ = wr.principal_strains(strain)
            wrinkled, slack = wr.states(e1, e2, e.poisson_ratio)
            count += int(np.sum(wrinkled | slack))
    return count


def direction(n_modes, seed):
    d = np.random.default_rng(seed).standard_normal(n_modes)
    return d / np.linalg.norm(d)


def potential(structure, x, model, seed=0, tol=1e-8):
    """(ctx, CondensedPotential, report, D) with the basis trained on one random direction and
    ± each bending mode at TRAIN_M."""
    ctx = me.energy_context(structure, x, model)
    points = cp.training_points(model, TRAIN_M, 1, seed=seed)
    basis, report = cp.snapshot_basis(ctx, points, tol=tol)
    return ctx, cp.CondensedPotential(ctx, basis), report, cp.modal_scale(model)


@pytest.fixture(scope="module")
def svk(small_modal_model, small_reduced_model):
    m, model = small_modal_model, small_reduced_model
    return (m.structure, m.x, model, *potential(m.structure, m.x, model))


@pytest.fixture(scope="module")
def tension_field(small_modal_model, small_reduced_model):
    m = small_modal_model
    st = with_tension_field(m.structure, True)
    return (st, m.x, small_reduced_model, *potential(st, m.x, small_reduced_model))


@pytest.fixture(scope="module")
def gas_law():
    """The capsule with a gas-law pressure (κ = 1.4: the rank-one tangent term)."""
    text = SMALL_CAPSULE.replace('value = "0.3 psi"', 'value = "0.3 psi"\ngas_law_exponent = 1.4')
    m = build_modal_model(case_from_toml(text, source="small-capsule-gas"))
    model = reduce(m.structure, m.x, m.modes.frequencies_hz, m.modes.shapes, m.labels, 0.02)
    return (m.structure, m.x, model, *potential(m.structure, m.x, model))


def test_training_points_are_scaled_rays_and_bending_modes(small_reduced_model):
    model = small_reduced_model
    pts = cp.training_points(model, (2e-3, 1e-3), 3, seed=4)
    bend = cp.bending_modes(model)
    assert len(bend) == 2
    assert pts.shape == ((3 + 2 * len(bend)) * 2, model.n_modes)
    amp = np.linalg.norm(pts * cp.modal_scale(model), axis=1)
    np.testing.assert_allclose(amp, np.tile([1e-3, 2e-3], len(pts) // 2), rtol=1e-12)
    for k in bend:  # ± the bending mode alone, 2 mm at the node that moves most
        alone = [p for p in pts if np.count_nonzero(p) == 1 and p[k] != 0.0]
        assert sorted(np.sign([p[k] for p in alone])) == [-1, -1, 1, 1]


@pytest.mark.parametrize("name", ["svk", "tension_field", "gas_law"])
def test_basis_is_m_orthonormal_contains_g_perp_and_avoids_retained_modes(name, request):
    _, _, _, ctx, pot, report, _ = request.getfixturevalue(name)
    b, mass = pot.basis, ctx.mass
    np.testing.assert_allclose(b.T @ (mass @ b), np.eye(b.shape[1]), atol=1e-9)
    assert np.abs(ctx.basis.T @ (mass @ b)).max() < 1e-9 * np.abs(ctx.basis).max()
    gp = ctx.g_perp  # G⊥ ⊂ span B: its M-projection on B is itself
    np.testing.assert_allclose(b @ (b.T @ (mass @ gp)), gp, atol=1e-9 * np.abs(gp).max())
    assert report.n_pod > 0 and report.n_basis == b.shape[1]
    assert all(r.converged for r in report.snapshots)


@pytest.mark.parametrize(
    "name, radius, wrinkles",
    [("svk", 4e-3, None), ("tension_field", 3e-4, False), ("tension_field", 8e-3, True),
     ("gas_law", 4e-3, None)],
)  # fmt: skip
def test_gradient_and_hessian_are_the_derivatives_of_the_energy(name, radius, wrinkles, request):
    """Central differences of W_B (gradient) and of the gradient (Hessian), step 1e-4 of the
    largest |s_k|; held-out direction. The tension-field cases are checked for the state
    claimed: every element taut, or some wrinkled at the minimiser."""
    structure, x, model, ctx, pot, _, scale = request.getfixturevalue(name)
    s = radius * direction(model.n_modes, 11) / scale
    m = pot.minimum(s)
    assert m.converged
    if wrinkles is not None:
        assert (wrinkled_elements(structure, x + m.u.reshape(-1, 3)) > 0) == wrinkles
    grad, hess = pot.gradient(s), pot.hessian(s)
    h = 1e-4 * np.abs(s).max()
    fd_g, fd_h = np.zeros_like(grad), np.zeros_like(hess)
    for k in range(model.n_modes):
        e = np.zeros(model.n_modes)
        e[k] = h
        fd_g[k] = (pot.energy(s + e) - pot.energy(s - e)) / (2 * h)
        fd_h[:, k] = (pot.gradient(s + e) - pot.gradient(s - e)) / (2 * h)
    assert np.linalg.norm(fd_g - grad) <= 1e-6 * np.linalg.norm(grad)
    assert np.linalg.norm(fd_h - hess) <= 1e-5 * np.linalg.norm(hess)


@pytest.mark.parametrize("name", ["svk", "tension_field"])
def test_condensed_potential_lies_between_the_nested_minima(name, request):
    """W_c ≤ W_B ≤ W_red (feasible sets G⊥ ⊂ span B ⊂ {y ⊥_M [Φ Ψ]}) at held-out points, each
    minimum computed on its own (W_c by continuation along the ray, the others from the
    quadratic-manifold point); the tension-field membrane wrinkles at the larger ones."""
    _, _, model, ctx, pot, _, scale = request.getfixturevalue(name)
    for seed in (21, 22):
        for r in (2e-3, 8e-3):
            s = r * direction(model.n_modes, seed) / scale
            pot.clear()
            wb = pot.minimum(s)
            wred = cand.condensed_quadratic_mode_energy(ctx, s)
            wc = me.condensed_energy_along_ray(ctx, s)
            assert wb.converged and wred.converged and wc.converged
            tol = 1e-9 * wred.value
            assert wc.value <= wb.value + tol
            assert wb.value <= wred.value + tol


def test_condensed_potential_is_the_condensed_energy_at_a_training_point(tension_field):
    """At a training point whose W_c minimiser is in span B (no POD truncation), W_B = W_c;
    the membrane is wrinkled there."""
    structure, x, model, ctx, pot, report, scale = tension_field
    s = cp.training_points(model, TRAIN_M, 1, seed=0)[1]  # the random direction at 6 mm
    wc = report.snapshots[1]
    assert wrinkled_elements(structure, x + (me.manifold_displacement(ctx, s) + wc.unknowns)
                            .reshape(-1, 3)) > 0  # fmt: skip
    assert report.captured > 1.0 - 1e-8
    pot.clear()
    wb = pot.minimum(s)
    assert wb.converged
    assert abs(wb.value - wc.value) <= 1e-8 * wc.value


def test_hessian_at_rest_is_lambda(svk):
    """About the inflated equilibrium Φ are the K-M eigenvectors and B ⊥_M Φ, so ΦᵀKB = 0 and
    H0 = ΦᵀKΦ = Λ = diag(ω²)."""
    _, _, model, _, pot, _, _ = svk
    lam = np.asarray(model.Lam, float)
    assert np.abs(pot.hessian0 - lam).max() <= 1e-6 * np.abs(lam).max()


@pytest.mark.parametrize("name", ["svk", "tension_field"])
def test_nonlinear_parts_vanish_to_second_order(name, request):
    """Halving s: the nonlinear energy falls ~8× (cubic), force ~4×, Hessian ~2×, at 0.3 and
    0.15 mm, where the tension-field membrane is still taut."""
    structure, x, model, _, pot, _, scale = request.getfixturevalue(name)
    d = direction(model.n_modes, 31)
    parts = []
    for r in (3e-4, 1.5e-4):
        s = r * d / scale
        m = pot.minimum(s)
        assert wrinkled_elements(structure, x + m.u.reshape(-1, 3)) == 0
        parts.append((abs(pot.nonlinear_energy(s)), np.linalg.norm(pot.nonlinear_force(s)),
                      np.linalg.norm(pot.nonlinear_hessian(s)), pot.energy(s)))  # fmt: skip
    (e1, f1, h1, w1), (e2, f2, h2, _) = parts
    assert 6.0 < e1 / e2 < 10.0
    assert 3.4 < f1 / f2 < 4.6
    assert 1.7 < h1 / h2 < 2.3
    assert e1 < 0.05 * w1


def test_pod_of_known_snapshots(svk):
    """Snapshots ``V diag(σ) Q`` (V M-orthonormal, ⊥_M [Φ Ψ G⊥], Q orthonormal rows) have POD
    eigenvalues σ²; the truncation keeps the fewest modes whose discarded share is ≤ tol, at
    most max_vectors, all of them for tol = 0; their span is that of V."""
    _, _, _, ctx, _, _, _ = svk
    rng = np.random.default_rng(7)
    v = rng.standard_normal((ctx.g_perp.shape[0], 3))
    v = cp._m_project_out(ctx.mass, np.hstack([ctx.basis, ctx.g_perp]), v)
    v = me.m_orthonormal(ctx.mass, v)
    sigma = np.array([1.0, 0.1, 0.01])
    q = np.linalg.qr(rng.standard_normal((12, 3)))[0].T  # (3, 12) orthonormal rows
    snaps = (v @ np.diag(sigma) @ q).T
    n_q = ctx.g_perp.shape[1]
    b, lam, captured = cp.pod_basis(ctx, snaps, tol=0.0)
    np.testing.assert_allclose(lam[:3], sigma**2, rtol=1e-8)
    assert b.shape[1] == n_q + 3 and captured == pytest.approx(1.0)
    pod = b[:, n_q:]
    np.testing.assert_allclose(pod @ (pod.T @ (ctx.mass @ v)), v, atol=1e-8 * np.abs(v).max())
    share = sigma[2] ** 2 / np.sum(sigma**2)  # discarded by keeping two
    assert cp.pod_basis(ctx, snaps, tol=1.01 * share)[0].shape[1] == n_q + 2
    assert cp.pod_basis(ctx, snaps, tol=0.99 * share)[0].shape[1] == n_q + 3
    assert cp.pod_basis(ctx, snaps, tol=0.0, max_vectors=1)[0].shape[1] == n_q + 1
