"""A general nonlinear potential N(s) added to a reduced system (``nonlinear_potential``):
the same physics as Q4's tensors when N is Q4's quartic, an exact discrete gradient (energy
conserved to the Newton tolerance) when N is not a polynomial, and the analytic period of a
one-mode oscillator."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import quad
from test_integrators import hand_model, spinner_state

from quadmodes.rom import dynamics as dy
from quadmodes.rom import integrators as it
from quadmodes.rom import system as rsys


class QuarticAsGeneral:
    """Q4's cubic and quartic terms of ``sys`` presented as a general nonlinear potential."""

    def __init__(self, sys):
        self.sys = sys

    def nonlinear_energy(self, s):
        return dy.potential_nonlinear_energy(self.sys, s)

    def nonlinear_force(self, s):
        return dy.potential_nonlinear_force(self.sys, s)

    def nonlinear_hessian(self, s):
        return dy.potential_hessian(self.sys, s) - self.sys.Lam


class SoftTanh:
    """A softening, non-polynomial potential per mode: N = Σ k b² [log cosh(s/b) − ½ (s/b)²]
    (force k b tanh(s/b) − k s: the spring softens to a constant force at |s| ≫ b)."""

    def __init__(self, k, b):
        self.k, self.b = np.asarray(k, float), float(b)

    def nonlinear_energy(self, s):
        x = s / self.b
        return float(np.sum(self.k * self.b**2 * (np.logaddexp(x, -x) - np.log(2) - 0.5 * x * x)))

    def nonlinear_force(self, s):
        return self.k * (self.b * np.tanh(s / self.b) - s)

    def nonlinear_hessian(self, s):
        return np.diag(self.k * (1.0 / np.cosh(s / self.b) ** 2 - 1.0))


def test_general_potential_reproduces_q4(small_reduced_model):
    """Q with Q4's quartic as a general nonlinear potential = formulation Q4 (numpy back end):
    the Gonzalez correction vanishes where Simpson's rule is exact."""
    model = dataclasses.replace(small_reduced_model, C=0 * small_reduced_model.C)
    q4 = rsys.reduced_system(model, "Q4")
    general = rsys.with_nonlinear_potential(rsys.reduced_system(model, "Q"), QuarticAsGeneral(q4))
    y0 = spinner_state(q4, 20.0, 6.0, s_amp=2e-4)
    a = it.integrate(q4, y0, (0.0, 0.05), dt=5e-4, backend="numpy")
    b = it.integrate(general, y0, (0.0, 0.05), dt=5e-4)
    assert a.status == 0 and b.status == 0 and b.stats["backend"] == "numpy"
    nl = [np.linalg.norm(QuarticAsGeneral(q4).nonlinear_force(s)) for s in a.y[:, 7:7 + q4.n_modes]]
    assert max(nl) > 1e-4 * np.abs(a.y[:, 7:7 + q4.n_modes] @ q4.Lam).max()  # N matters
    scale = np.abs(a.y).max(axis=0) + 1e-30
    assert np.max(np.abs(a.y - b.y) / scale) < 1e-9


def test_non_polynomial_potential_conserves_energy():
    """Undamped, spinning, a strongly softening non-polynomial potential: the energy error of
    the midpoint stays at the Newton tolerance (an exact discrete gradient), not O(Δt²)."""
    lam = np.array([(2 * np.pi * 3.0) ** 2, (2 * np.pi * 4.5) ** 2])
    base = rsys.reduced_system(hand_model(np.diag([2.0, 2.5, 1.0]), lam), "Q")
    soft = rsys.with_nonlinear_potential(base, SoftTanh(lam, 0.01))
    y0 = spinner_state(soft, 1.0, 5.0, s_amp=0.05)  # five times the softening scale b
    sol = it.integrate(soft, y0, (0.0, 2.0), dt=2e-3, newton_tol=1e-14)
    e = dy.energy(soft, sol.y)
    assert sol.status == 0
    assert np.max(np.abs(e - e[0])) / e[0] < 1e-11
    with pytest.raises(ValueError, match="nonlinear potential"):
        it.integrate(soft, y0, (0.0, 0.01), dt=2e-3, backend="numba")


def test_period_of_softening_oscillator():
    """One mode, no rotation coupling: the period of the tanh-softened spring from its energy
    integral T = 4 ∫₀^a ds / √(2(V(a) − V(s))) against the midpoint's zero crossings."""
    k, b, a = (2 * np.pi * 5.0) ** 2, 0.01, 0.04
    base = rsys.reduced_system(hand_model(np.eye(3), [k]), "Q")
    pot = SoftTanh([k], b)
    sys = rsys.with_nonlinear_potential(base, pot)

    def v(s):
        return 0.5 * k * s * s + pot.nonlinear_energy(np.array([s]))

    period = 4.0 * quad(lambda s: 1.0 / np.sqrt(2.0 * (v(a) - v(s))), 0.0, a, limit=200)[0]
    y0 = rsys.pack_state(sys, s=[a])
    sol = it.integrate(sys, y0, (0.0, 3.0 * period), dt=period / 2000)
    s = sol.y[:, 7]
    i = np.flatnonzero((s[:-1] > 0) & (s[1:] <= 0))
    tc = sol.t[i] + s[i] * (sol.t[i + 1] - sol.t[i]) / (s[i] - s[i + 1])
    measured = (tc[-1] - tc[0]) / (len(tc) - 1)
    assert measured == pytest.approx(period, rel=2e-5)
