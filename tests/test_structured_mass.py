"""The mass matrix by blocks (:mod:`quadmodes.rom.structured_mass`) against the dense mass tensor
it replaces: the same products to round-off, the same midpoint trajectories on both back ends,
and the dense tensors (O(N⁴) numbers) built only when asked for."""

import importlib.util

import numpy as np
import pytest
from test_dynamics import synthetic_model

from quadmodes.rom import dynamics as dy
from quadmodes.rom import structured_mass as sm
from quadmodes.rom import system as rsys
from quadmodes.rom.fixed_step import run_fixed
from quadmodes.rom.midpoint import MidpointStep

HAVE_NUMBA = importlib.util.find_spec("numba") is not None


def _close(a, b, rtol=1e-13):
    return np.abs(a - b).max() <= rtol * np.abs(b).max()


@pytest.mark.parametrize("formulation", ["Q", "P", "L"])
@pytest.mark.parametrize("n", [1, 4])
def test_block_products_equal_dense_ones(formulation, n):
    """𝕄(s), ½(∂𝕄/∂s_k)ν with the energy and the momenta arrays, and ωᵀJ2_kjω, at a random
    state of a model with every term active (P: rotational rows differ from modal ones)."""
    sys = rsys.reduced_system(synthetic_model(n, seed=3), formulation)
    rng = np.random.default_rng(0)
    z = np.r_[1.0, rng.normal(size=n)]
    nu = rng.normal(size=3 + n)
    blk, den = sm.BlockMass(sys.mass_blocks), sm.DenseMass(sys.flat)
    assert _close(blk.matrix(z), den.matrix(z))
    assert _close(dy.mass_matrix(sys, z[1:]), den.matrix(z))
    for energy in (True, False):
        assert _close(blk.products(z, nu, energy), den.products(z, nu, energy))
    assert _close(blk.second(nu), den.second(nu))


def _run(sys, y0, dt, n_steps, dense, kernel):
    idx = np.arange(0, n_steps + 1, 10)
    if kernel:
        from quadmodes.rom import midpoint_kernel

        out = midpoint_kernel.fixed_run(sys, y0, n_steps, dt, idx, 1e-13, 25, 0.0, "m", dense)
    else:
        out = run_fixed(
            MidpointStep(sys, dt, dense), sys, y0, n_steps, dt, idx, 1e-13, 25, 0.0, "m"
        )
    assert out[4] == 0, out[5]
    return out[0], out[3]


@pytest.mark.parametrize("kernel", [False, pytest.param(True, marks=pytest.mark.skipif(
    not HAVE_NUMBA, reason="numba not installed"))])  # fmt: skip
@pytest.mark.parametrize("formulation", ["Q", "P", "L", "Q4", "rigid"])
def test_block_step_reproduces_dense_step(small_reduced_model, formulation, kernel):
    """1000 damped midpoint steps of the capsule (300 rad/s, 5° cone, modal disturbance): the
    states by blocks equal the dense tensor's to 1e-10 relative (measured ≲1e-12), with the
    same Newton iterations."""
    sys = rsys.reduced_system(small_reduced_model, formulation)
    w = dy.coning_omega(sys.J0, 300.0, np.radians(5.0))
    y0 = rsys.pack_state(sys, omega=w, s=1e-4 * (-1.0) ** np.arange(sys.n_modes))
    a, sa = _run(sys, y0, 2e-4, 1000, True, kernel)
    b, sb = _run(sys, y0, 2e-4, 1000, False, kernel)
    scale = np.abs(a).max(axis=0)
    scale[scale == 0.0] = 1.0
    assert float((np.abs(a - b) / scale).max()) <= 1e-10
    assert sa["n_newton"] == sb["n_newton"] and sa["n_jac"] == sb["n_jac"]


def test_dense_tensors_only_on_demand():
    """A system's dense mass tensors ((N+1)²(3+N)² numbers each) are built on first use only:
    neither building a system nor its midpoint step at N ≥ NUMPY_BLOCKS_FROM touches them."""
    n = sm.NUMPY_BLOCKS_FROM
    sys = rsys.reduced_system(synthetic_model(n, seed=1), "Q")
    step = MidpointStep(sys, 1e-4)
    assert isinstance(step.mass, sm.BlockMass)
    assert "Mt" not in vars(sys.flat) and "_tensors" not in vars(sys.flat)
    small = rsys.reduced_system(synthetic_model(3, seed=1), "Q")
    assert isinstance(MidpointStep(small, 1e-4).mass, sm.DenseMass)  # cheaper at a few modes
    assert sys.flat.Mt.shape == ((n + 1) ** 2, (n + 3) ** 2)  # still there when asked for
