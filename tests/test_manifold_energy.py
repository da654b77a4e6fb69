"""The FE model's statically condensed energy (rom.manifold_energy) on the small capsule, N = 5:
the gradient of Π̃ is the internal force, and ∇W_c = Λs + O(|s|²). The candidate potentials
compared with W_c are tested in tests/test_experimental_candidate_potentials.py."""

import numpy as np
import pytest

from quadmodes.rom import manifold_energy as me

#: amplitudes r (m, nominal largest nodal displacement) for the order checks: 1 mm and 0.5 mm on
#: a 0.76 m capsule, where the cubic term dominates the error of Q and the round-off (1e-11
#: relative) is far below the quintic error of Q4.
R_ORDER = (1e-3, 5e-4)


@pytest.fixture(scope="module")
def setup(capsule_energy_context):
    return capsule_energy_context


def directions(n_modes, count, seed):
    d = np.random.default_rng(seed).standard_normal((count, n_modes))
    return d / np.linalg.norm(d, axis=1)[:, None]


def test_potential_force_is_the_gradient_of_the_potential(setup):
    """∇Π̃ = f − f(x0) (internal_force): central difference of Π̃ along a random direction."""
    ctx, model, scale = setup
    rng = np.random.default_rng(0)
    u = me.manifold_displacement(ctx, 3e-3 * directions(model.n_modes, 1, 1)[0] / scale)
    e = rng.standard_normal(u.size)
    e *= 1e-4 / np.abs(e).max()
    h = 1e-4  # largest nodal step 1e-8 m: truncation (stiff ties) and round-off both < 1e-8
    fd = (me.total_potential(ctx, u + h * e) - me.total_potential(ctx, u - h * e)) / (2 * h)
    exact = me.potential_force(ctx, u) @ e
    assert abs(fd - exact) <= 1e-6 * abs(exact)


def test_condensed_energy_gradient_is_lambda_s_to_first_order(setup):
    """Central-difference ∇W_c(s) = Λs + O(|s|²): relative error O(|s|), halving with s."""
    ctx, model, scale = setup
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
