"""Ritz ingredients of the independent rotating-beam reference (no quadmodes code): Legendre
bases, Gauss quadrature, the steady spinning state and the matrices of one field.

A straight uniform beam lies along x on the span [x₀, x₁] of the frame rotating at Ω about z
(the free-free rotor: [−L/2, L/2]; a blade on a hub of radius r: [r, r + ℓ]); ξ ∈ [−1, 1] maps
to x = c + hξ with c = (x₀ + x₁)/2, h = (x₁ − x₀)/2. Units SI (m, kg, s, N).
"""

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from numpy.polynomial import legendre as leg
from numpy.polynomial import polynomial as poly


@dataclass(frozen=True)
class SpinningBeam:
    """Uniform beam properties (SI). ``ea = math.inf`` makes the beam inextensible.

    ``ei_flap``: EI for bending out of the spin plane (w, along the spin axis z) [N m²];
    ``ei_lag``: EI for bending in the spin plane (v, along y) [N m²]; ``ea`` [N]; ``rho_a``:
    mass per length [kg/m]; ``rho_i_flap`` / ``rho_i_lag``: section rotary inertia per length
    ρI_y / ρI_z [kg m] (the section's polar inertia is their sum)."""

    ei_flap: float
    ei_lag: float
    ea: float
    rho_a: float
    rho_i_flap: float = 0.0
    rho_i_lag: float = 0.0


@dataclass(frozen=True)
class Span:
    """Where the beam lies along x [m]: from ``start`` to the free tip ``end``; ``anchor`` is
    the material point that does not move axially in the steady state (the rotor's centre, or a
    blade's clamped root)."""

    start: float
    end: float
    anchor: float

    @property
    def centre(self) -> float:
        return 0.5 * (self.start + self.end)

    @property
    def half(self) -> float:
        return 0.5 * (self.end - self.start)


@dataclass(frozen=True)
class Quadrature:
    """Gauss–Legendre nodes ξ and weights on [−1, 1]."""

    xi: np.ndarray
    weights: np.ndarray


@dataclass(frozen=True)
class Basis:
    """Ritz functions evaluated at some points ξ, with their ξ-derivatives: ``value``,
    ``slope``, ``curvature``, each (n_points, n_functions)."""

    value: np.ndarray
    slope: np.ndarray
    curvature: np.ndarray

    @property
    def size(self) -> int:
        return self.value.shape[1]


@dataclass(frozen=True)
class SteadyState:
    """Steady spinning state at the nodes: tension [N], stretch ratio λ [-], dλ/dξ [-] and the
    steady axial displacement u₀ [m]."""

    tension: np.ndarray
    stretch: np.ndarray
    stretch_slope: np.ndarray
    axial_offset: np.ndarray


def quadrature(n_nodes: int) -> Quadrature:
    xi, wts = leg.leggauss(n_nodes)
    return Quadrature(xi, wts)


def points(xi) -> Quadrature:
    """Evaluation points (no weights) in the form :func:`basis` takes."""
    xi = np.atleast_1d(np.asarray(xi, dtype=float))
    return Quadrature(xi, np.ones_like(xi))


def _orthonormal_legendre(k: int) -> np.ndarray:
    c = np.zeros(k + 1)
    c[k] = math.sqrt((2 * k + 1) / 2.0)
    return c


def _coefficients(n_functions: int, order: int) -> list[np.ndarray]:
    """Legendre coefficients of the Ritz functions: the ``order`` lowest orthonormal Legendre
    polynomials (the rigid motions), then ``order``-fold integrals of P̃_k with their components
    along those removed, so that their ``order``-th derivative is exactly P̃_k (a stiffness
    matrix close to diagonal, and low frequencies that stay accurate to round-off)."""
    out = [_orthonormal_legendre(k) for k in range(min(order, n_functions))]
    for k in range(n_functions - len(out)):
        c = leg.legint(_orthonormal_legendre(k), m=order)
        c[:order] = 0.0
        out.append(c)
    return out


def basis(n_functions: int, order: int, parity: int | None, at: Quadrature) -> Basis:
    """The first ``n_functions`` of the transverse (``order`` = 2) or axial (``order`` = 1)
    family, keeping those of one parity in ξ (0 even, 1 odd; None: all)."""
    coefs = [c for i, c in enumerate(_coefficients(n_functions, order))
             if parity is None or i % 2 == parity]  # fmt: skip
    if not coefs:
        empty = np.zeros((at.xi.size, 0))
        return Basis(empty, empty, empty)
    cols = [(leg.legval(at.xi, c), leg.legval(at.xi, leg.legder(c)),
             leg.legval(at.xi, leg.legder(c, 2))) for c in coefs]  # fmt: skip
    value, slope, curv = (np.stack(parts, axis=1) for parts in zip(*cols, strict=True))
    return Basis(value, slope, curv)


def steady_state(beam: SpinningBeam, span: Span, omega: float, quad: Quadrature,
                 stretch: bool) -> SteadyState:  # fmt: skip
    """Centrifugal tension T₀(x) = ½ρAΩ²(x₁² − x²) [N] (free tip at x₁); with ``stretch`` and a
    finite EA also the steady stretch u₀ = ∫_anchor^x T₀/EA to first order in ρΩ²x₁²/E, the
    tension it adds, T₁ = ρAΩ² ∫ₓ^{x₁} u₀, and the stretch ratio λ = 1 + T₀/EA."""
    x = span.centre + span.half * quad.xi
    load = beam.rho_a * omega**2  # centrifugal load per length per unit radius [N/m²]
    t0 = 0.5 * load * (span.end**2 - x**2)
    ones, zeros = np.ones_like(x), np.zeros_like(x)
    if not stretch or math.isinf(beam.ea) or omega == 0.0:
        return SteadyState(t0, ones, zeros, zeros)
    t0_poly = poly.Polynomial([0.5 * load * span.end**2, 0.0, -0.5 * load]) / beam.ea
    u0_poly = t0_poly.integ(lbnd=span.anchor)
    u0_int = u0_poly.integ()
    t1 = load * (u0_int(span.end) - u0_int(x))
    lam = 1.0 + t0 / beam.ea
    lam_slope = -load * x * span.half / beam.ea
    return SteadyState(t0 + t1, lam, lam_slope, u0_poly(x))


def gram(quad: Quadrature, f: np.ndarray, g: np.ndarray, weight) -> np.ndarray:
    """∫ weight f_i g_j dξ by the quadrature (f, g: (n_nodes, n))."""
    return (f * (quad.weights * weight)[:, None]).T @ g


def transverse_matrices(beam: SpinningBeam, span: Span, ei: float, rho_i: float, b: Basis,
                        quad: Quadrature, st: SteadyState) -> dict[str, np.ndarray]:  # fmt: skip
    """Ritz matrices of one transverse field (SI, per unit coefficients): 'mass' ∫ρA φφ dx,
    'rotary' ∫ρI θθ dx with the section rotation θ = φ'/λ, 'bending' ∫EI κκ dx with the
    curvature of the stretched line κ = (1/λ)(φ'/λ)', 'geometric' ∫(T/λ) φ'φ' dx."""
    h, lam = span.half, st.stretch[:, None]
    rot = b.slope / (h * lam)
    kappa = (b.curvature / lam - b.slope * st.stretch_slope[:, None] / lam**2) / (h**2 * lam)
    return {
        "mass": gram(quad, b.value, b.value, beam.rho_a * h),
        "rotary": gram(quad, rot, rot, rho_i * h),
        "bending": gram(quad, kappa, kappa, ei * h),
        "geometric": gram(quad, b.slope / h, b.slope / h, st.tension / st.stretch * h),
    }


def flap_system(beam: SpinningBeam, span: Span, omega: float, tb: Basis, quad: Quadrature,
                st: SteadyState):  # fmt: skip
    """(M, G, K) of flap w: M = mass + rotary; K = bending + geometric + Ω²·rotary (the
    section's centrifugal term ½Ω²(ρJ_x − ρI_z)θ² = ½Ω²ρI_y θ²); G = 0."""
    m = transverse_matrices(beam, span, beam.ei_flap, beam.rho_i_flap, tb, quad, st)
    mass = m["mass"] + m["rotary"]
    stiff = m["bending"] + m["geometric"] + omega**2 * m["rotary"]
    return mass, np.zeros_like(mass), stiff


def lag_system(beam: SpinningBeam, span: Span, omega: float, tb: Basis, ab: Basis,
               quad: Quadrature, st: SteadyState):  # fmt: skip
    """(M, G, K) of lag v coupled to axial u (coefficients stacked [v, u]): centrifugal
    softening −Ω²ρA in both, axial stiffness ∫EA u'u', Coriolis G = [[0, 2ΩC], [−2ΩC^T, 0]]
    with C = ∫ρA φ_v φ_u dx. With EA = inf the axial basis holds only rigid motions."""
    h = span.half
    m = transverse_matrices(beam, span, beam.ei_lag, beam.rho_i_lag, tb, quad, st)
    mu = gram(quad, ab.value, ab.value, beam.rho_a * h)
    ku = np.zeros_like(mu) if math.isinf(beam.ea) else gram(quad, ab.slope, ab.slope, beam.ea / h)
    c = gram(quad, tb.value, ab.value, beam.rho_a * h)
    nv, nu = tb.size, ab.size
    mass = sla.block_diag(m["mass"] + m["rotary"], mu)
    stiff = sla.block_diag(m["bending"] + m["geometric"] - omega**2 * m["mass"],
                           ku - omega**2 * mu)  # fmt: skip
    gyro = np.zeros((nv + nu, nv + nu))
    gyro[:nv, nv:] = 2.0 * omega * c
    gyro[nv:, :nv] = -2.0 * omega * c.T
    return mass, gyro, stiff


def fit(b: Basis, values: np.ndarray) -> np.ndarray:
    """Coefficients of a function given at the nodes (least squares; exact inside the span)."""
    if b.size == 0:
        return np.zeros(0)
    return np.linalg.lstsq(b.value, values, rcond=None)[0]
