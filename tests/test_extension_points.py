"""The two extension points, each used by writing one class (docs/architecture.md, "Extension
points"):

* a new element set (``quadmodes.fe.elements.ElementSet``) integrated by the full order: a
  Hookean spring set (energy ½k(|d| − L)², not a polynomial) whose only full-order method is
  its discrete-gradient ``step_force`` (the rest are the base class's defaults); on a regular
  tetrahedron of four point masses the breathing motion is exactly harmonic, ω² = 4k/m, at any
  amplitude, and the energy of any motion is kept to the Newton tolerance;
* a new reduced stepper (``quadmodes.rom.stepper.Stepper``) passed to ``integrate(method=…)``:
  the classical explicit Runge–Kutta method of order 4.
"""

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp
from test_integrators import hand_model, spinner_state

from quadmodes.fe.elements import ElementSet
from quadmodes.fe.model import Structure
from quadmodes.fullorder import FullOrderOptions, integrate_full_order
from quadmodes.rom import system as rsys
from quadmodes.rom.dynamics import rhs
from quadmodes.rom.integrators import integrate
from quadmodes.rom.stepper import Stepper, StepResult

# --------------------------------------------------------------------------- a new element set


class HookeSprings(ElementSet):
    """Springs between node pairs ``conn`` (ne, 2): stiffness k (N/m), rest length L (m) per
    spring, energy ``½k(r − L)²``, r = |x_b − x_a|; massless. Written with ψ(q) = ½k(√q − L)²,
    q = r², so that the force is ``f_b = 2ψ'(q) d``."""

    def __init__(self, conn, k, length):
        self.conn, self.k, self.length = np.asarray(conn), np.asarray(k, float), np.asarray(length, float)

    def _d(self, x):
        return x[self.conn[:, 1]] - x[self.conn[:, 0]]

    def _psi(self, q, order):
        """ψ and its q-derivatives 1..3 (per spring)."""
        k, L, r = self.k, self.length, np.sqrt(q)
        return [0.5 * k * (r - L) ** 2, 0.5 * k * (1 - L / r), 0.25 * k * L / r**3,
                -0.375 * k * L / r**5][order]  # fmt: skip

    def energy(self, x):
        d = self._d(x)
        return float(np.sum(self._psi(np.sum(d * d, 1), 0)))

    def force(self, x):
        d = self._d(x)
        fb = 2.0 * self._psi(np.sum(d * d, 1), 1)[:, None] * d
        return np.stack([-fb, fb], 1)

    def stiffness(self, x):
        d = self._d(x)
        q = np.sum(d * d, 1)
        kb = (4.0 * self._psi(q, 2)[:, None, None] * np.einsum("ei,ej->eij", d, d)
              + 2.0 * self._psi(q, 1)[:, None, None] * np.eye(3))  # fmt: skip
        return np.block([[kb, -kb], [-kb, kb]])

    def second_order(self, x, u, v):
        d, du, dv = self._d(x), self._d(u), self._d(v)
        q = np.sum(d * d, 1)
        a, b, uv = np.sum(d * du, 1), np.sum(d * dv, 1), np.sum(du * dv, 1)
        fb = (8.0 * self._psi(q, 3) * a * b)[:, None] * d + 4.0 * self._psi(q, 2)[:, None] * (
            uv[:, None] * d + a[:, None] * dv + b[:, None] * du)  # fmt: skip
        return 0.5 * np.stack([-fb, fb], 1)

    def mass(self):
        return None

    def step_force(self, x0, x1, start=None):
        """Gonzalez's discrete gradient: ``2 [ψ(q₁) − ψ(q₀)]/(q₁ − q₀) d½`` (q is quadratic in
        x, so the work over the step is exactly ψ(q₁) − ψ(q₀))."""
        d0, d1 = self._d(x0), self._d(x1)
        q0, q1 = np.sum(d0 * d0, 1), np.sum(d1 * d1, 1)
        dq = q1 - q0
        close = np.abs(dq) <= 1e-12 * q0
        slope = np.where(close, self._psi(0.5 * (q0 + q1), 1),
                         (self._psi(q1, 0) - self._psi(q0, 0)) / np.where(close, 1.0, dq))  # fmt: skip
        fb = slope[:, None] * (d0 + d1)
        return np.stack([-fb, fb], 1)


def tetrahedron(k=50.0, m=0.2, edge=0.3):
    """Four point masses m (kg) at the corners of a regular tetrahedron (edge m), springs k
    (N/m) on its six edges, stress-free."""
    pts = edge / math.sqrt(8.0) * np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1.0]])
    conn = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])
    springs = HookeSprings(conn, np.full(6, k), np.full(6, edge))
    return Structure(pts, np.ones(4, bool), (springs,), sp.identity(4, format="csr") * m,
                     np.zeros((4, 3), bool))  # fmt: skip


@pytest.mark.parametrize("full_newton", [False, True])
def test_a_new_element_set_integrates_in_the_full_order(full_newton):
    k, m = 50.0, 0.2
    structure = tetrahedron(k, m)
    x_ref = structure.reference
    amplitude = 0.1  # breathing by 10 %: the spring force is far from linear in x
    x0, v0 = (1.0 + amplitude) * x_ref, np.zeros_like(x_ref)
    omega = 2.0 * math.sqrt(k / m)
    h = 2 * math.pi / omega / 50
    radius = []
    sol = integrate_full_order(
        structure, x_ref, x0, v0, (0.0, 6 * 2 * math.pi / omega), h,
        FullOrderOptions(full_newton=full_newton, newton_tol=1e-13),
        on_sample=lambda t, x: radius.append(np.linalg.norm(x[0] - x.mean(0))),
    )
    assert sol.status == 0
    assert np.abs(sol.E - sol.E[0]).max() <= 1e-10 * sol.E[0]
    assert sol.V[0] == pytest.approx(6 * 0.5 * k * (amplitude * 0.3) ** 2, rel=1e-12)
    # exactly harmonic breathing at ω² = 4k/m; the midpoint's frequency (2/h) atan(ωh/2)
    a = np.asarray(radius) / np.linalg.norm(x_ref[0]) - 1.0
    np.testing.assert_allclose(np.abs(a).max(), amplitude, rtol=1e-9)
    omega_h = 2.0 / h * math.atan(omega * h / 2)
    np.testing.assert_allclose(a, amplitude * np.cos(omega_h * sol.t), atol=1e-8 * amplitude)


class PlainHookeSprings(HookeSprings):
    """The same springs with the default step force (the plain midpoint ``f(x½)``)."""

    step_force = ElementSet.step_force


def test_its_discrete_gradient_keeps_the_energy_of_a_large_deformation():
    k, m = 50.0, 0.2
    structure = tetrahedron(k, m)
    (springs,) = structure.elements
    plain = replace(structure, elements=(PlainHookeSprings(springs.conn, springs.k,
                                                           springs.length),))  # fmt: skip
    x_ref = structure.reference
    x0 = x_ref + 0.05 * np.random.default_rng(2).standard_normal((4, 3))  # 5 cm on 30 cm edges
    period = math.pi * math.sqrt(m / k)
    drift = {}
    for label, s in (("gonzalez", structure), ("plain", plain)):
        sol = integrate_full_order(s, x_ref, x0, np.zeros_like(x0), (0.0, 6 * period),
                                   period / 50, FullOrderOptions(newton_tol=1e-13))  # fmt: skip
        assert sol.status == 0
        drift[label] = np.abs(sol.E - sol.E[0]).max() / sol.E[0]
    assert drift["gonzalez"] <= 1e-9  # the Newton tolerance's share only
    assert drift["plain"] >= 1e-5  # 4e-4: what the one overridden method buys


def test_the_old_keyword_arguments_still_work_for_one_release():
    structure = tetrahedron()
    x_ref = structure.reference
    x0 = 1.05 * x_ref
    args = (structure, x_ref, x0, np.zeros_like(x0), (0.0, 0.02), 1e-3)
    new = integrate_full_order(*args, FullOrderOptions(save_every=4, newton_tol=1e-12))
    with pytest.warns(DeprecationWarning, match="FullOrderOptions"):
        old = integrate_full_order(*args, save_every=4, newton_tol=1e-12)
    np.testing.assert_array_equal(old.t, new.t)
    np.testing.assert_array_equal(old.E, new.E)
    with pytest.raises(TypeError, match="unknown full-order option"), pytest.warns(DeprecationWarning):
        integrate_full_order(*args, newton_tolerance=1e-12)


def test_the_default_step_of_an_element_set_is_the_plain_midpoint():
    structure = tetrahedron()
    (springs,) = structure.elements
    rng = np.random.default_rng(1)
    x0 = structure.reference + 0.01 * rng.standard_normal((4, 3))
    x1 = x0 + 0.01 * rng.standard_normal((4, 3))
    plain = ElementSet.step_force(springs, x0, x1)
    np.testing.assert_array_equal(plain, springs.force(0.5 * (x0 + x1)))
    np.testing.assert_array_equal(springs.step_block(x0, x1),
                                  0.5 * springs.stiffness(0.5 * (x0 + x1)))  # fmt: skip
    work = float(np.sum(springs.step_force(x0, x1) * (x1 - x0)[springs.conn]))
    assert work == pytest.approx(springs.energy(x1) - springs.energy(x0), rel=1e-12)


# ------------------------------------------------------------------------------ a new stepper


class RungeKutta4:
    """The classical explicit Runge–Kutta method on ``[q_rel, ω, s, ṡ, E_d]`` with q_rel the
    attitude change over the step (identity at its start)."""

    name = "rk4"
    order = 4

    def __init__(self, sys, dt):
        self.sys, self.dt = sys, dt

    def _f(self, z):
        n = self.sys.n_modes
        dz = np.empty_like(z)
        dz[:-1] = rhs(self.sys, 0.0, z[:-1])
        sd = z[7 + n : 7 + 2 * n]
        dz[-1] = sd @ self.sys.C @ sd
        return dz

    def step(self, nu0, s0, nu_prev, newton) -> StepResult:
        n, h = self.sys.n_modes, self.dt
        z = np.concatenate([[1.0, 0, 0, 0], nu0[:3], s0, nu0[3:], [0.0]])
        k1 = self._f(z)
        k2 = self._f(z + 0.5 * h * k1)
        k3 = self._f(z + 0.5 * h * k2)
        k4 = self._f(z + h * k3)
        z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        q = z[:4] / np.linalg.norm(z[:4])
        vec = np.linalg.norm(q[1:])
        phi = 2.0 * math.atan2(vec, q[0]) / max(vec, 1e-300) * q[1:]  # q_rel = exp(φ/2)
        nu1 = np.concatenate([z[4:7], z[7 + n : 7 + 2 * n]])
        return StepResult(nu1, z[7 : 7 + n], phi, float(z[-1]), 4, 0, 0)


def test_a_new_stepper_integrates_by_class():
    sys = rsys.reduced_system(hand_model(np.diag([1.0, 2.0, 3.0]), [40.0, 90.0], zeta=0.05), "Q")
    y0 = spinner_state(sys, 1.0, 10.0, s_amp=0.05)
    span = (0.0, 2.0)
    ref = integrate(sys, y0, span, method="DOP853", rtol=1e-13, atol=1e-14, t_eval=[2.0])
    errors = []
    for dt in (0.02, 0.01):
        sol = integrate(sys, y0, span, method=RungeKutta4, dt=dt, save_every=10**6)
        assert sol.success and sol.method == "rk4" and sol.stats["backend"] == "numpy"
        assert sol.stats["n_rhs"] == 4 * sol.stats["n_steps"] and sol.stats["n_newton"] == 0
        errors.append(np.abs(sol.y[-1] - ref.y[-1]).max())
        assert sol.dissipated[-1] == pytest.approx(ref.dissipated[-1], rel=1e-5)
    assert 13.0 < errors[0] / errors[1] < 19.0  # order 4: a factor 16 per halving
    assert isinstance(RungeKutta4(sys, 0.01), Stepper)


def test_the_built_in_steppers_by_name_and_by_class_agree():
    sys = rsys.reduced_system(hand_model(np.diag([1.0, 2.0, 3.0]), [40.0], zeta=0.02), "Q")
    y0 = spinner_state(sys, 1.0, 5.0, s_amp=0.05)
    from quadmodes.rom.integrators import STEPPERS

    for name, cls in STEPPERS.items():
        by_name = integrate(sys, y0, (0.0, 0.5), method=name, dt=0.01, backend="numpy")
        by_class = integrate(sys, y0, (0.0, 0.5), method=cls, dt=0.01, backend="numpy")
        np.testing.assert_array_equal(by_name.y, by_class.y)
        assert by_class.method == name == cls.name and cls.order in (1, 2)
    with pytest.raises(ValueError, match="unknown method"):
        integrate(sys, y0, (0.0, 0.5), method="rk4", dt=0.01)
    with pytest.raises(ValueError, match="numba"):
        integrate(sys, y0, (0.0, 0.5), method=RungeKutta4, dt=0.01, backend="numba")
