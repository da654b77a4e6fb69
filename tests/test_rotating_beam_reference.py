"""The independent rotating-beam reference (tests/reference, no quadmodes code) checked on its
own: zero-spin free-free roots, the rigid-body roots it sets apart, convergence in the number of
Ritz functions, closed-form limits (rotating string, Southwell coefficients, rotary inertia,
lag = flap − Ω² when inextensible, the rigid-beam axial limit), an ODE shooting solution, the
rotor's classes against half-blade problems on another discretisation, and published values.
See docs/rotating-beam-reference.md."""

import math

import numpy as np
import pytest
from reference.closed_forms import (
    free_free_beta_l,
    free_free_slope_ratio,
    rotating_string_flap,
    rotating_string_lag,
    shooting_frequencies,
    southwell_coefficient,
)
from reference.ritz import SpinningBeam
from reference.rotating_beam import blade_roots, class_roots, rotating_free_beam

# the lead's default: a steel rod 2 m long, circular section of radius 1 cm
E, RHO, RADIUS, LENGTH = 210e9, 7850.0, 0.01, 2.0
AREA, SECOND_MOMENT = math.pi * RADIUS**2, math.pi * RADIUS**4 / 4
ROD = {"L": LENGTH, "EI_flap": E * SECOND_MOMENT, "EI_lag": E * SECOND_MOMENT, "EA": E * AREA,
       "rho_A": RHO * AREA, "rho_I_flap": RHO * SECOND_MOMENT, "rho_I_lag": RHO * SECOND_MOMENT}  # fmt: skip
OMEGA_1 = free_free_beta_l(1) ** 2 * math.sqrt(E * SECOND_MOMENT / (RHO * AREA)) / LENGTH**2


def _rel(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b)) / np.abs(np.asarray(b)))


def test_zero_spin_gives_the_free_free_beam_roots():
    out = rotating_free_beam(LENGTH, 1.0, 2.0, math.inf, 1.0, 0.0, n_modes=6)
    beta = np.array([free_free_beta_l(n) for n in range(1, 7)])
    np.testing.assert_allclose(
        beta, [4.73004, 7.85320, 10.9956, 14.1372, 17.2788, 20.4204], atol=1e-4
    )
    assert _rel(out["flap"], beta**2 / LENGTH**2) < 1e-10
    assert _rel(out["lag"], beta**2 * math.sqrt(2.0) / LENGTH**2) < 1e-10
    assert _rel(out["flap_sym"][:3], beta[0::2] ** 2 / LENGTH**2) < 1e-10  # even modes


@pytest.mark.parametrize("stretch", [False, True])
def test_rigid_roots_are_found_and_kept_out(stretch):
    omega = 2.0 * OMEGA_1
    out = rotating_free_beam(**ROD, Omega=omega, stretch=stretch)
    rigid = out["rigid"]
    assert [
        rigid[k].size for k in ("flap_translation", "flap_tilt", "lag_spin", "lag_translation")
    ] == [2, 2, 2, 4]
    assert np.all(rigid["flap_translation"] < 1e-6 * omega)
    assert np.all(np.abs(rigid["flap_tilt"] / omega - 1.0) < 1e-10)  # exact, with rotary inertia
    assert np.all(rigid["lag_spin"] < 1e-5 * omega)  # a Jordan pair at 0: split ~ sqrt(eps)
    assert np.all(np.abs(rigid["lag_translation"] / omega - 1.0) < 1e-5)  # Jordan pairs at ±Ω
    assert out["flap"][0] > 1.5 * omega and out["lag"][0] > 1.2 * omega
    assert out["max_real_part_ratio"] < 1e-9


def test_frequencies_converge_with_the_number_of_ritz_functions():
    for omega in (0.0, OMEGA_1, 3.0 * OMEGA_1):
        coarse = rotating_free_beam(**ROD, Omega=omega, n_basis=32)
        fine = rotating_free_beam(**ROD, Omega=omega, n_basis=48)
        for fam in ("flap", "lag"):
            assert _rel(coarse[fam], fine[fam]) < 1e-8, (omega, fam)


def test_membrane_string_limit_is_the_legendre_spectrum():
    omega = 3.0
    out = rotating_free_beam(LENGTH, 0.0, 0.0, math.inf, 1.0, omega, n_modes=4)
    assert _rel(out["flap_sym"], [omega * rotating_string_flap(n) for n in (2, 4, 6, 8)]) < 1e-9
    assert _rel(out["flap_anti"], [omega * rotating_string_flap(n) for n in (3, 5, 7, 9)]) < 1e-9
    assert _rel(out["lag_sym"], [omega * rotating_string_lag(n) for n in (3, 5, 7, 9)]) < 1e-9
    assert _rel(out["lag_anti"], [omega * rotating_string_lag(n) for n in (2, 4, 6, 8)]) < 1e-9
    assert rotating_string_flap(2) == pytest.approx(math.sqrt(3.0))


def test_stiff_beam_limit_follows_the_southwell_coefficients():
    """EI → ∞ at a fixed spin: ω² = ω₀² + K Ω² (flap), ω₀² + (K − 1)Ω² (lag, inextensible),
    K from the exact free-free mode shapes (closed_forms)."""
    w0 = np.array([free_free_beta_l(n) ** 2 for n in range(1, 5)]) / LENGTH**2
    omega = 1e-3 * w0[0]
    out = rotating_free_beam(LENGTH, 1.0, 1.0, math.inf, 1.0, omega, n_modes=4)
    k = np.array([southwell_coefficient(n) for n in range(1, 5)])
    assert _rel((out["flap"] ** 2 - w0**2) / omega**2, k) < 1e-5
    assert _rel((out["lag"] ** 2 - w0**2) / omega**2, k - 1.0) < 1e-5


def test_rigid_lag_limit_leaves_the_axial_rod():
    """EI_lag → ∞: the even (anti) axial modes have zero mean, so no Coriolis force on the
    translation: ω² = (2kπ/L)² EA/ρA − Ω²."""
    omega, ea = 5.0, 1.0e4
    beam = SpinningBeam(1.0, 1.0e12, ea, 1.0)
    roots = class_roots(beam, LENGTH, omega, "lag", 0, 32, stretch=False)
    expected = [math.sqrt((2 * k * math.pi / LENGTH) ** 2 * ea - omega**2) for k in (1, 2, 3)]
    assert _rel(roots.axial[:3], expected) < 1e-6


def test_inextensible_lag_is_flap_less_spin_squared():
    for omega in (0.5, 4.0, 20.0):
        out = rotating_free_beam(LENGTH, 1.0, 1.0, math.inf, 1.0, omega, n_modes=5)
        assert _rel(out["lag_sym"] ** 2 + omega**2, out["flap_anti"] ** 2) < 1e-10
        assert _rel(out["lag_anti"] ** 2 + omega**2, out["flap_sym"] ** 2) < 1e-10


def test_rotary_inertia_first_order():
    """At rest: δ(ω²) = −ω₀² (ρI/ρA) ∫φ'²/∫φ² with the exact free-free shapes, for flap and lag
    alike. (Spinning, the section's centrifugal term keeps the flap tilt at exactly Ω: see
    test_rigid_roots_are_found_and_kept_out, run with the rod's rotary inertia.)"""
    r_g2 = 1e-6  # ρI/ρA [m²]
    w0 = np.array([free_free_beta_l(n) ** 2 for n in range(1, 4)]) / LENGTH**2
    out = rotating_free_beam(LENGTH, 1.0, 1.0, math.inf, 1.0, 0.0, rho_I_flap=r_g2,
                             rho_I_lag=2 * r_g2, n_modes=3)  # fmt: skip
    ratio = np.array([free_free_slope_ratio(n) for n in range(1, 4)]) / LENGTH**2
    np.testing.assert_allclose(out["flap"] ** 2 - w0**2, -(w0**2) * r_g2 * ratio, rtol=1e-3)
    np.testing.assert_allclose(out["lag"] ** 2 - w0**2, -2 * (w0**2) * r_g2 * ratio, rtol=1e-3)


# The Ritz roots are converged to 2e-14 here (32 against 40 functions), so the agreement is
# limited by the shooting: its roots move by up to 4.0e-9 between ODE tolerances 1e-11 and
# 1e-13 (DOP853), and the difference is machine dependent (6.2e-9 on one machine, 1.02e-8 on
# another). The tolerance is five times the larger: a real error of the rotor's equations shows
# up at 1e-4 and above.
SHOOTING_RTOL = 5e-8


def test_shooting_solution_of_the_half_rotor_agrees():
    omega = 30.0
    beam = SpinningBeam(1.0, 1.0, math.inf, 1.0)
    for fam, parity, centre in (("flap", 0, "guided"), ("flap", 1, "pinned"), ("lag", 0, "guided")):
        ritz = class_roots(beam, LENGTH, omega, fam, parity, 32, stretch=False).bending
        shot = shooting_frequencies(1.0, 1.0, LENGTH, omega, centre, f_max=170.0, n_grid=12,
                                    lag=fam == "lag")  # fmt: skip
        if fam == "flap" and parity == 1:
            shot = shot[1:]  # the tilt, ω = Ω, is a root of the pinned half-rotor too
        assert shot.size >= 2
        assert _rel(ritz[: shot.size], shot) < SHOOTING_RTOL, fam


@pytest.mark.parametrize("omega", [0.0, 3.0, 9.0])
def test_rotor_classes_equal_half_blades_on_another_discretisation(omega):
    """By symmetry each class of the rotor is a half-beam of length L/2 with a centre condition:
    w even = guided, w odd = hinged; v, u odd = hinged with u = 0; v, u even = guided, u free."""
    beam = SpinningBeam(1.0, 1.3, 900.0, 1.0, 1e-4, 2e-4)
    cases = (
        ("flap", 0, "guided"),
        ("flap", 1, "hinged"),
        ("lag", 1, "hinged"),
        ("lag", 0, "guided"),
    )
    for fam, parity, root in cases:
        rotor = class_roots(beam, LENGTH, omega, fam, parity, 32)
        half = blade_roots(beam, 0.5 * LENGTH, 0.0, omega, fam, root, 32)
        bend = half.bending[1:] if (fam, root) == ("flap", "hinged") and omega else half.bending
        assert _rel(rotor.bending[:4], bend[:4]) < 1e-9, (fam, parity)
        assert _rel(rotor.axial[:2], half.axial[:2]) < 1e-9 if fam == "lag" else True


# Published: Hamza Cherif S.M. & Houmat A., "Natural frequencies of rotating cantilever
# flexible beams by using the p-version of the finite element method", ICAS 2004 (24th
# Congress), Table 2: uniform cantilever clamped at the axis (no hub), slenderness
# L/sqrt(I/A) = 70, ω/sqrt(EI/(ρA L⁴)) against μ = Ω sqrt(ρA L⁴/EI); values as quoted in the
# Octave "mboct-fem-pkg" test suite (fem_tests.m, TEST 60). The flapwise column is the classic
# inextensible result (also Wright, Smith, Thresher & Wang 1982; Hodges & Rutkowski 1981); the
# chordwise column includes the Coriolis coupling with axial motion (finite EA), without the
# steady stretch. Boundary conditions differ from the free-free rotor (clamped root), so this
# checks the equations and the solver, not the rotor's own boundary conditions.
MU = [2.0, 4.0, 6.0, 8.0, 10.0, 50.0]
FLAPWISE = [4.1373, 5.5850, 7.3603, 9.2568, 11.2023, 51.0805]
CHORDWISE = [3.6195, 3.888, 4.2393, 4.6105, 4.97, 7.3362]


def test_published_rotating_cantilever_values():
    beam = SpinningBeam(1.0, 1.0, 70.0**2, 1.0)  # ℓ = 1, EI = ρA = 1, EA = EI (L/r_g)²
    for mu, flap, chord in zip(MU, FLAPWISE, CHORDWISE, strict=True):
        f = blade_roots(beam, 1.0, 0.0, mu, "flap", "clamped", 32, stretch=False).bending[0]
        c = blade_roots(beam, 1.0, 0.0, mu, "lag", "clamped", 32, stretch=False).bending[0]
        assert f == pytest.approx(flap, rel=2e-5 if mu < 50 else 5e-5)
        assert c == pytest.approx(chord, rel=2e-4 if mu < 50 else 5e-4)  # μ = 50: 25 % strain


def test_zero_spin_cantilever_and_pinned_free_roots():
    """Blevins' βL: clamped-free 1.8751, 4.6941, 7.8548; pinned-free 3.9266, 7.0686."""
    beam = SpinningBeam(1.0, 1.0, math.inf, 1.0)
    clamped = blade_roots(beam, 1.0, 0.0, 0.0, "flap", "clamped", 32).bending[:3]
    hinged = blade_roots(beam, 1.0, 0.0, 0.0, "flap", "hinged", 32).bending[:2]
    np.testing.assert_allclose(np.sqrt(clamped), [1.8751, 4.6941, 7.8548], atol=1e-4)
    np.testing.assert_allclose(np.sqrt(hinged), [3.9266, 7.0686], atol=1e-4)
