"""Candidate reduced potentials (rom.manifold_energy) on the small capsule, N = 5: the exact FE
energies agree with ½sᵀΛs to first relative order, Q4 agrees with the condensed energy W_c to
fourth order, the feasible sets are nested (W_c ≤ W_red ≤ QE), and ∇W_c = Λs + O(|s|²)."""

import numpy as np
import pytest

from quadmodes.rom import manifold_energy as me

#: amplitudes r (m, nominal largest nodal displacement) for the order checks: 1 mm and 0.5 mm on
#: a 0.76 m capsule, where the cubic term dominates the error of Q and the round-off (1e-11
#: relative) is far below the quintic error of Q4.
R_ORDER = (1e-3, 5e-4)


@pytest.fixture(scope="module")
def setup(small_modal_model, small_reduced_model):
    """The small capsule, N = 5. Its near-degenerate pairs can come out of the eigensolver in a
    different orientation from one process to the next (observed: the same sample gave a
    different W_red alone and in the full suite), so the amplitudes are kept where every
    orientation tried converges."""
    m, model = small_modal_model, small_reduced_model
    ctx = me.energy_context(m.structure, m.x, model)
    t = np.asarray(model.translational, bool)
    scale = np.array([np.max(np.linalg.norm(p[t], axis=1)) for p in model.Phi])
    return ctx, model, me.quartic_system(model), scale


def directions(n_modes, count, seed):
    d = np.random.default_rng(seed).standard_normal((count, n_modes))
    return d / np.linalg.norm(d, axis=1)[:, None]


def test_potential_force_is_the_gradient_of_the_potential(setup):
    """∇Π̃ = f − f(x0) (internal_force): central difference of Π̃ along a random direction."""
    ctx, model, _, scale = setup
    rng = np.random.default_rng(0)
    u = me.manifold_displacement(ctx, 3e-3 * directions(model.n_modes, 1, 1)[0] / scale)
    e = rng.standard_normal(u.size)
    e *= 1e-4 / np.abs(e).max()
    h = 1e-4  # largest nodal step 1e-8 m: truncation (stiff ties) and round-off both < 1e-8
    fd = (me.total_potential(ctx, u + h * e) - me.total_potential(ctx, u - h * e)) / (2 * h)
    exact = me.potential_force(ctx, u) @ e
    assert abs(fd - exact) <= 1e-6 * abs(exact)


def test_energies_agree_with_quadratic_to_first_order_and_q4_to_fourth(setup):
    """Relative error to ½sᵀΛs halves when s halves (cubic term) for QE, W_red and W_c; the
    error of Q4 against W_c falls at least fourfold (expected eightfold: W_c − QE = O(s⁶), Q4 −
    QE = O(s⁵))."""
    ctx, model, q4, scale = setup
    for d in directions(model.n_modes, 2, 2):
        errs = {k: [] for k in ("QE", "W_red", "W_c", "Q4")}
        for r in R_ORDER:
            s = r * d / scale
            q = me.quadratic_potential(model, s)
            wc = me.condensed_energy(ctx, s)
            assert wc.converged
            vals = {
                "QE": me.manifold_energy(ctx, s),
                "W_red": me.condensed_quadratic_mode_energy(ctx, s).value,
                "W_c": wc.value,
            }
            for k, v in vals.items():
                errs[k].append(abs(v - q) / q)
            errs["Q4"].append(abs(me.quartic_potential(q4, s) - wc.value) / wc.value)
        for k in ("QE", "W_red", "W_c"):
            ratio = errs[k][0] / errs[k][1]
            assert 1.7 < ratio < 2.3, (k, errs[k])
            assert errs[k][0] < 0.1
        assert errs["Q4"][0] / errs["Q4"][1] > 4.0, errs["Q4"]
        assert errs["Q4"][0] < 0.01 * errs["W_c"][0]


def test_nested_minima_and_positive_condensed_energy(setup):
    """W_c ≤ W_red ≤ QE (within the Newton tolerance) and W_c > 0 at sampled points up to
    4 mm, each ray by continuation in amplitude. (From about 6 mm on some rays the membrane
    goes into compression, W_c drops to ~0.7 W_red and Newton needs 40–60 iterations; which
    rays depends on the orientation of the degenerate mode pairs.)"""
    ctx, model, _, scale = setup
    for d in directions(model.n_modes, 3, 3):
        y, eta = None, None
        for r in (1e-3, 2e-3, 4e-3):
            s = r * d / scale
            qe = me.manifold_energy(ctx, s)
            wr = me.condensed_quadratic_mode_energy(ctx, s, eta)
            wc = me.condensed_energy(ctx, s, me.best_start(ctx, s, [ctx.g_perp @ wr.unknowns, y]))
            assert wr.converged and wc.converged
            tol = 1e-9 * qe
            assert wc.value <= wr.value + tol
            assert wr.value <= qe + tol
            assert wc.value > 0.0
            y, eta = wc.unknowns, wr.unknowns


def test_condensed_energy_gradient_is_lambda_s_to_first_order(setup):
    """Central-difference ∇W_c(s) = Λs + O(|s|²): relative error O(|s|), halving with s."""
    ctx, model, _, scale = setup
    d = directions(model.n_modes, 1, 4)[0]
    errs = []
    for r in R_ORDER:
        s = r * d / scale
        centre = me.condensed_energy(ctx, s)
        h = 1e-3 * np.abs(s).max()
        grad = np.zeros(model.n_modes)
        for k in range(model.n_modes):
            e = np.zeros(model.n_modes)
            e[k] = h
            plus = me.condensed_energy(ctx, s + e, centre.unknowns).value
            minus = me.condensed_energy(ctx, s - e, centre.unknowns).value
            grad[k] = (plus - minus) / (2 * h)
        lam_s = model.Lam @ s
        errs.append(np.linalg.norm(grad - lam_s) / np.linalg.norm(lam_s))
    assert errs[0] < 0.1
    assert 1.6 < errs[0] / errs[1] < 2.4, errs
