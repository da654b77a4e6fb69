"""A formulation without a cubic or quartic potential (Q, P, L) keeps no V3, V4 tensors in
memory (N⁴ numbers: 7 MB and ~20 ms a system at N = 31, built for nothing): they are zeros of
no memory, never multiplied, and the motion is that of the same model with its tensors set to
zero, bit for bit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from quadmodes.rom import dynamics as dy
from quadmodes.rom import integrators as it
from quadmodes.rom import system as rsys


def _spinner(sys):
    w = dy.coning_omega(sys.J0, 300.0, np.radians(6.0))
    return rsys.pack_state(sys, omega=w, s=1e-4 * (-1.0) ** np.arange(sys.n_modes))


def test_q_keeps_no_quartic_tensors(small_reduced_model):
    sys = rsys.reduced_system(small_reduced_model, "Q")
    n = sys.n_modes
    assert sys.V4.shape == (n,) * 4 and not sys.V4.any() and sys.V4.strides == (0,) * 4
    assert sys.V3.strides == (0,) * 3 and sys.flat.V3g.size == 0 and sys.flat.V4g.size == 0
    s = np.linspace(-1e-3, 1e-3, n)
    assert np.array_equal(dy.potential_nonlinear_force(sys, s), np.zeros(n))
    assert np.array_equal(dy.potential_hessian(sys, s), sys.Lam)
    assert dy.potential_nonlinear_energy(sys, s) == 0.0


@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_q_moves_as_q4_with_zero_tensors_bit_for_bit(small_reduced_model, backend):
    """The Q4 equations with V3 = V4 = 0 (real arrays multiplied, as Q's were before) are the Q
    equations: the same samples, bit for bit, and the energy conserved alike."""
    if backend == "numba":
        pytest.importorskip("numba")
    m = small_reduced_model
    n = m.n_modes
    zero = dataclasses.replace(m, V3=np.zeros((n,) * 3), V4=np.zeros((n,) * 4),
                               manifold_potential=True)  # fmt: skip
    q, q4 = rsys.reduced_system(m, "Q"), rsys.reduced_system(zero, "Q4")
    assert q4.flat.V4g.shape == (n, n**3)  # the tensors are there, and zero
    y0 = _spinner(q)
    a = it.integrate(q, y0, (0.0, 0.02), "midpoint", dt=1e-4, backend=backend)
    b = it.integrate(q4, y0, (0.0, 0.02), "midpoint", dt=1e-4, backend=backend)
    assert a.status == 0 and np.array_equal(a.y, b.y) and np.array_equal(a.t, b.t)
