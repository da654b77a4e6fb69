"""The energy-sink estimate of the coning rate of a quasi-rigid spinner (docs/sweeps.md).

Assumptions: the body moves as the torque-free *rigid* body whose inertia is that of the
reduced model at its relative equilibrium, J̃(s*) (nearly axisymmetric: axial I_a, transverse
I_t = mean of the two transverse principal values), spinning at Ω about the axis e_a with cone
angle θ between the angular momentum H and e_a. Its body-frame angular velocity is

    ω(t) = Ω e_a + ω_t (cos νt e1 + sin νt e2),   ω_t = (I_a/I_t) Ω tan θ,   ν = (I_a − I_t)/I_t Ω

(e1, e2, e_a right-handed; ν < 0 for a minor-axis, prolate, spinner). The elastic modes are
driven by this *prescribed* rotation (the rotation is not fed back: quasi-rigid) through the
modal row of the reduced equations (:func:`quadmodes.rom.dynamics.prescribed_rhs`), linearised
about (s*, ṡ = 0, ω0 = Ω e_a):

    μ δs̈ + D δṡ + K δs = F_ω δω + F_ω̇ δω̇,    δω = Re(ŵ e^{iνt}),  ŵ = ω_t (e1 − i e2)

so the steady response is ŝ = (K + iνD − ν²μ)⁻¹ (F_ω + iν F_ω̇) ŵ and the mean power dissipated
by the modal damping C is P = ½ ν² Re(ŝᴴ C ŝ). The energy-sink law: H is conserved, the kinetic
energy T = H²/2 (cos²θ/I_a + sin²θ/I_t) falls by P, so

    θ̇ = P / (H² sin θ cos θ (1/I_a − 1/I_t)) = P I_t cos θ / (I_a Ω² sin θ (I_t − I_a))

(H = I_a Ω / cos θ): θ grows for a minor-axis spinner (I_a < I_t) and decays for a major-axis
one. P ∝ sin²θ for small θ, so θ̇ ∝ θ: the coning time constant is τ = θ/θ̇ (an e-folding time;
negative: decay). The estimate is *quasi-rigid* where the elastic response changes the body's
angular momentum little: ``elastic_momentum_ratio`` = |δh_elastic| / (I_t ω_t) ≤
:data:`QUASI_RIGID_LIMIT`, δh_elastic = δJ̃(ŝ) ω0 + A(s*)ᵀ iν ŝ. Near a resonance of ν with a
rotating-frame branch the ratio is large and the estimate is not to be trusted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from quadmodes.rom import dynamics as dy
from quadmodes.rom import system as rsys

#: The estimate counts as quasi-rigid when the elastic angular momentum is at most this fraction
#: of the rigid transverse angular momentum I_t ω_t.
QUASI_RIGID_LIMIT = 0.1
#: Cone angle (rad) used for the rate θ̇/θ when the run's cone angle is 0 (the ratio has a limit).
SMALL_CONE = 1e-3


@dataclass(frozen=True)
class EnergySink:
    """The energy-sink estimate at one point (SI).

    power W: mean dissipated power P. cone_rate rad/s: θ̇ at the given cone angle.
    growth_rate 1/s: θ̇/θ. time_constant s: θ/θ̇ (inf without dissipation, negative: decay).
    nutation_frequency rad/s: body-frame nutation rate ν (signed). axial_inertia,
    transverse_inertia kg m²: I_a, I_t of J̃(s*). elastic_momentum_ratio: |δh_el|/(I_t ω_t).
    quasi_rigid: the ratio ≤ :data:`QUASI_RIGID_LIMIT`."""

    power: float
    cone_rate: float
    growth_rate: float
    time_constant: float
    nutation_frequency: float
    axial_inertia: float
    transverse_inertia: float
    elastic_momentum_ratio: float
    quasi_rigid: bool


def steady_response(mass, damping, stiffness, force, nu: float) -> np.ndarray:
    """Complex amplitude ŝ (N,) of the steady response of ``μ s̈ + D ṡ + K s = Re(F e^{iνt})``:
    ``(K + iνD − ν²μ)⁻¹ F``. mass, damping, stiffness (N,N); force (N,) complex; nu rad/s."""
    a = np.asarray(stiffness, complex) + 1j * nu * np.asarray(damping) - nu**2 * np.asarray(mass)
    return np.linalg.solve(a, np.asarray(force, complex))


def mean_dissipated_power(damping_matrix, amplitude, nu: float) -> float:
    """Mean of ṡᵀCṡ over a period (W) for s = Re(ŝ e^{iνt}): ``½ ν² Re(ŝᴴ C ŝ)``."""
    s = np.asarray(amplitude, complex)
    return float(0.5 * nu**2 * np.real(s.conj() @ np.asarray(damping_matrix) @ s))


def energy_sink_cone_rate(power: float, axial: float, transverse: float, spin: float,
                          cone: float) -> float:  # fmt: skip
    """θ̇ (rad/s) of a torque-free body losing ``power`` (W) at constant angular momentum:
    ``P I_t cos θ / (I_a Ω² sin θ (I_t − I_a))`` (module docstring); I_a, I_t kg m², Ω rad/s,
    θ rad (> 0)."""
    return power * transverse * math.cos(cone) / (
        axial * spin**2 * math.sin(cone) * (transverse - axial))


def nutation_axes(inertia: np.ndarray, axis: np.ndarray):
    """``(I_a, I_t, e1, e2)`` of the inertia (3,3) kg m² about the spin ``axis`` (3,): the
    principal axis nearest ``axis`` carries I_a, I_t is the mean of the other two, e1 the first
    of them and e2 = e_a × e1."""
    lam, vec = np.linalg.eigh(0.5 * (inertia + inertia.T))
    e_a = np.asarray(axis, float) / np.linalg.norm(axis)
    j = int(np.argmax(np.abs(vec.T @ e_a)))
    others = [k for k in range(3) if k != j]
    e1 = vec[:, others[0]] - (vec[:, others[0]] @ e_a) * e_a
    e1 /= np.linalg.norm(e1)
    return float(lam[j]), float(np.mean(lam[others])), e1, np.cross(e_a, e1)


def linear_modal_row(sys: rsys.ReducedSystem, s_eq: np.ndarray, omega0: np.ndarray):
    """``(μ, D, K, F_ω, F_ω̇)`` of the modal row linearised about (s*, ṡ = 0, ω0): the
    (N,N) matrices and the (N,3) input matrices of δω, δω̇ (module docstring). The row is
    polynomial (quadratic in ω, linear in ṡ and ω̇), so central differences are exact to
    round-off."""
    n = sys.n_modes
    base = np.concatenate([s_eq, np.zeros(n), omega0, np.zeros(3)])

    def row(x):
        w, wd = x[2 * n : 2 * n + 3], x[2 * n + 3 :]
        y = np.concatenate([x[:n], x[n : 2 * n]])
        return sys.mu @ dy.prescribed_rhs(sys, 0.0, y, lambda t: w, lambda t: wd)[n:]

    scale = np.concatenate([np.full(2 * n, max(np.linalg.norm(s_eq), 1e-6)),
                            np.full(6, max(np.linalg.norm(omega0), 1.0))]) * 1e-6  # fmt: skip
    jac = np.empty((n, base.size))
    for j in range(base.size):
        xp, xm = base.copy(), base.copy()
        xp[j] += scale[j]
        xm[j] -= scale[j]
        jac[:, j] = (row(xp) - row(xm)) / (2 * scale[j])
    k, d = -jac[:, :n], -jac[:, n : 2 * n]
    return sys.mu, d, k, jac[:, 2 * n : 2 * n + 3], jac[:, 2 * n + 3 :]


def _elastic_momentum(sys, s_eq, omega0, s_hat, nu) -> np.ndarray:
    """δh_el (3,) complex: δJ̃(ŝ) ω0 + A(s*)ᵀ iν ŝ."""
    dj = np.einsum("k,kab->ab", s_hat, sys.J1) + np.einsum(
        "m,n,mnab->ab", s_eq, s_hat, sys.J2 + np.swapaxes(sys.J2, 0, 1))
    a = dy.coupling_rows(sys, s_eq)
    return dj @ omega0 + a.T @ (1j * nu * s_hat)


def energy_sink(sys: rsys.ReducedSystem, s_eq: np.ndarray, omega0: np.ndarray,
                cone: float) -> EnergySink:  # fmt: skip
    """The energy-sink estimate (module docstring) of ``sys`` about its relative equilibrium
    (s* (N,) √kg·m, ω0 (3,) rad/s along the spin axis) at cone angle ``cone`` (rad)."""
    spin = float(np.linalg.norm(omega0))
    axial, transverse, e1, e2 = nutation_axes(dy.inertia_tensor(sys, s_eq), omega0)
    theta = cone if cone > 0 else SMALL_CONE
    nu = (axial - transverse) / transverse * spin
    w_t = axial / transverse * spin * math.tan(theta)
    w_hat = w_t * (e1 - 1j * e2)
    if sys.n_modes == 0:
        power, ratio = 0.0, 0.0
    else:
        mu, d, k, f_w, f_wd = linear_modal_row(sys, s_eq, omega0)
        s_hat = steady_response(mu, d, k, (f_w + 1j * nu * f_wd) @ w_hat, nu)
        power = mean_dissipated_power(sys.C, s_hat, nu)
        h_el = _elastic_momentum(sys, s_eq, omega0, s_hat, nu)
        ratio = float(np.linalg.norm(h_el) / (transverse * abs(w_t)))
    rate = energy_sink_cone_rate(power, axial, transverse, spin, theta)
    cone_rate = rate if cone > 0 else 0.0
    growth = rate / theta
    tau = 1.0 / growth if growth != 0.0 else math.inf
    return EnergySink(power if cone > 0 else 0.0, cone_rate, growth, tau, nu, axial, transverse,
                      ratio, ratio <= QUASI_RIGID_LIMIT)  # fmt: skip
