"""Closed-form and semi-analytic values the rotating-beam reference is checked against (no
quadmodes code): free-free beam roots and mode shapes, Southwell coefficients, the rotating
string (Legendre) spectrum, and an ODE shooting solution of the rotating half-beam.

Units: SI; frequencies in rad/s unless a function says it returns a ratio.
"""

import math

import numpy as np
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq


def free_free_beta_l(n: int) -> float:
    """n-th (n ≥ 1) nonzero root βL of cos βL cosh βL = 1 (free-free beam: ω = (βL)²
    sqrt(EI/(ρA L⁴)))."""
    guess = (n + 0.5) * math.pi
    return brentq(lambda x: math.cos(x) * math.cosh(x) - 1.0, guess - 0.5, guess + 0.5, xtol=1e-15)


def free_free_mode(n: int, s: float, length: float) -> tuple[float, float]:
    """Value and slope d/ds of the n-th free-free mode at s ∈ [0, L] (arbitrary scale):
    cosh βs + cos βs − σ(sinh βs + sin βs), σ = (cosh βL − cos βL)/(sinh βL − sin βL)."""
    bl = free_free_beta_l(n)
    b = bl / length
    sig = (math.cosh(bl) - math.cos(bl)) / (math.sinh(bl) - math.sin(bl))
    x = b * s
    val = math.cosh(x) + math.cos(x) - sig * (math.sinh(x) + math.sin(x))
    slope = b * (math.sinh(x) - math.sin(x) - sig * (math.cosh(x) + math.cos(x)))
    return val, slope


def southwell_coefficient(n: int) -> float:
    """K_n with ω² = ω₀² + K_n Ω² + O(Ω⁴) for the flap of the n-th free-free mode of a beam
    spun about its centre (first-order perturbation: K = ∫T̂ φ'² / ∫φ² with T̂ = ½(a² − x²),
    the tension per ρAΩ²). Lag: K_n − 1 (inextensible). Dimensionless; independent of L."""
    length, a = 1.0, 0.5

    def num(s):
        return 0.5 * (a**2 - (s - a) ** 2) * free_free_mode(n, s, length)[1] ** 2

    def den(s):
        return free_free_mode(n, s, length)[0] ** 2

    opts = {"epsabs": 0.0, "epsrel": 1e-13, "limit": 200}
    return quad(num, 0.0, length, **opts)[0] / quad(den, 0.0, length, **opts)[0]


def rotating_string_flap(n: int) -> float:
    """ω/Ω of the flap of a free-free string spun about its centre (EI = 0, inextensible):
    (a² − x²)w'' − 2x w' + (2ω²/Ω²) w = 0 is Legendre's equation, bounded at both ends only
    for w = P_n, so ω/Ω = sqrt(n(n + 1)/2); n = 0 translation, n = 1 tilt (ω = Ω), n ≥ 2
    elastic (even n: sym, odd n: anti)."""
    return math.sqrt(n * (n + 1) / 2.0)


def rotating_string_lag(n: int) -> float:
    """ω/Ω of the lag of that string, inextensible: the extra −Ω²ρA v gives
    ω² = Ω²(n(n + 1)/2 − 1) (n = 1: the spin rotation, 0; P_n for n ≥ 1 has zero mean, so the
    Coriolis force on the axial translation vanishes)."""
    return math.sqrt(n * (n + 1) / 2.0 - 1.0)


def _shoot(ei, rho_a, a, omega, freq, softening):
    """Integrate EI w'''' = T w'' + T' w' + ρA(ω² + softening Ω²) w from the free tip x = a
    (w'' = w''' = 0, T(a) = 0) to the axis for the two tip starts; returns the states at x = 0
    (2, 4): rows w, w', w'', w''' for tip (w, w') = (1, 0) and (0, 1)."""
    load = rho_a * omega**2
    lam2 = rho_a * (freq**2 + softening * omega**2)

    def rhs(x, y):  # both tip starts at once: y holds w and its first three derivatives, twice
        t, dt = 0.5 * load * (a**2 - x**2), -load * x
        y = y.reshape(2, 4)
        d4 = (t * y[:, 2] + dt * y[:, 1] + lam2 * y[:, 0]) / ei
        return np.column_stack([y[:, 1], y[:, 2], y[:, 3], d4]).ravel()

    start = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]).ravel()
    sol = solve_ivp(rhs, (a, 0.0), start, method="DOP853", rtol=1e-11, atol=1e-13)
    return sol.y[:, -1].reshape(2, 4)


def _root_residual(ei, rho_a, a, omega, freq, softening, centre):
    """Determinant of the centre conditions: 'pinned' w = w'' = 0 (the rotor's odd class),
    'guided' w' = w''' = 0 (even class; zero shear since w' = 0)."""
    y = _shoot(ei, rho_a, a, omega, freq, softening)
    i, j = (0, 2) if centre == "pinned" else (1, 3)
    return y[0, i] * y[1, j] - y[1, i] * y[0, j]


def shooting_frequencies(ei: float, rho_a: float, length: float, omega: float, centre: str,
                         f_max: float, n_grid: int = 400, lag: bool = False) -> np.ndarray:  # fmt: skip
    """Roots in (0, f_max] [rad/s] of the half-rotor's transverse problem (inextensible, no
    rotary inertia) with the given centre condition, by shooting from the tip and bracketing
    sign changes of the determinant on a grid; ``lag`` adds the centrifugal softening −Ω²ρA.
    An ODE solution independent of the Ritz discretisation."""
    a = 0.5 * length
    grid = np.linspace(f_max / n_grid, f_max, n_grid)
    soft = 1.0 if lag else 0.0
    vals = [_root_residual(ei, rho_a, a, omega, f, soft, centre) for f in grid]
    roots = []
    for f0, f1, v0, v1 in zip(grid[:-1], grid[1:], vals[:-1], vals[1:], strict=True):
        if v0 == 0.0 or v0 * v1 < 0.0:
            roots.append(brentq(lambda f: _root_residual(ei, rho_a, a, omega, f, soft, centre),
                                f0, f1, xtol=1e-13, rtol=1e-14))  # fmt: skip
    return np.array(roots)


def free_free_slope_ratio(n: int) -> float:
    """∫φ'² dx / ∫φ² dx × L² of the n-th free-free mode (dimensionless): the first-order
    rotary-inertia correction is δ(ω²) = (Ω² − ω₀²) (ρI/ρA) × this / L² for flap (the section's
    centrifugal term adds the Ω²) and −ω₀² (ρI/ρA) × this / L² for lag."""
    opts = {"epsabs": 0.0, "epsrel": 1e-13, "limit": 200}
    num = quad(lambda s: free_free_mode(n, s, 1.0)[1] ** 2, 0.0, 1.0, **opts)[0]
    return num / quad(lambda s: free_free_mode(n, s, 1.0)[0] ** 2, 0.0, 1.0, **opts)[0]
