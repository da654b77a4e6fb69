"""The hub is rigid in fact (issue 26 item 3): a two-blade rotor stiffened by spin alone
(built-in string-blade-rotor: two 10 m 3-D beams of negligible bending stiffness clamped on a
thin disc hub) at DEFAULT settings — its nutation root equals the spin, the capture check
passes, and its flap and lag frequencies converge to the closed form of strings with
centrifugal tension on a free hub of finite radius (tests/reference/string_blade.py)."""

from __future__ import annotations

import numpy as np
import pytest
from reference.string_blade import string_blade_ratios

from quadmodes.analysis.rotating_comparison import rotating_frequency_comparison
from quadmodes.analysis.rotating_matching import CaptureError, check_capture
from quadmodes.analysis.rotating_modes import rotating_roots
from quadmodes.case import load_case
from quadmodes.case.editing import edit
from quadmodes.fe.model import inertia_tensor
from quadmodes.rom.spinning_reduction import spinning_modes
from quadmodes.structure.pipeline import structure_for_case
from quadmodes.structure.spinning import neutral_modes, relative_equilibrium

E_Z = np.array([0.0, 0.0, 1.0])
R0, LENGTH, MU = 0.5, 10.0, 1420.0 * 1e-5  # hub rim (m), blade (m), kg/m
HUB = (10.0, 0.62508333, 0.62508333, 1.25)  # m_h (kg), I_x, I_y, I_z (kg m²)


def rotor(elements: int | None = None):
    """The structure of the built-in case, with ``elements`` per blade if given."""
    case = load_case("string-blade-rotor")
    changes = [(("boom", i, "elements"), elements) for i in (0, 1)] if elements else []
    return structure_for_case(edit(case, changes, "test"))


def roots_near(structure, spin: float, ratios) -> np.ndarray:
    """Rotating-frame roots ω/Ω (ascending) of the full order about its relative equilibrium at
    ``spin`` (rad/s) about z, searched near ``ratios`` × spin."""
    eq = relative_equilibrium(structure, structure.reference, spin, E_Z)
    r = rotating_roots(structure, eq.x, spin, E_Z, [q * spin / (2 * np.pi) for q in ratios],
                       per_target=6)  # fmt: skip
    return np.sort(r.lam.imag / spin)


def nearest(values: np.ndarray, target: float) -> float:
    return float(values[np.argmin(np.abs(values - target))])


@pytest.mark.parametrize("spin", [1.0, 2.0, 4.0])
def test_nutation_root_is_the_spin_at_default_settings(spin):
    """A flat body (blades in the plane of a thin hub) nutates at exactly its spin in the
    rotating frame: λ² = Ω²(I_z − I_x)(I_z − I_y)/(I_x I_y) = Ω² when I_z = I_x + I_y; here the
    hub's 1 cm thickness leaves 1.3e-4."""
    s = rotor()
    got = nearest(roots_near(s, spin, [0.9]), 0.9999)
    i = np.linalg.eigvalsh(inertia_tensor(s, s.reference))  # I_x (smallest), I_y, I_z
    rigid = np.sqrt((i[2] - i[0]) * (i[2] - i[1]) / (i[0] * i[1]))
    assert abs(got - 1.0) < 1e-3
    assert got == pytest.approx(rigid, rel=2e-5)


def test_a_heavy_hub_stays_rigid_in_fact():
    """The same blades on a hub 10⁵ times heavier (10⁶ kg): the triad's distortion modes stay
    above the blades' first axial frequency (the dynamic floor), so the nutation is still the
    flat body's rigid value and the flap that of a string hinged at the rim (a fixed hub). (With
    the bending-based penalty of before this hub's nutation came out at 1.11 Ω at 1 rad/s with
    capture shares of 4200; without the axial floor its triad modes fell to 1.2 Ω and displaced
    the string frequencies, docs/sails.md.)"""
    changes = [(("hub", "mass"), "1e6 kg"), (("hub", "inertia_x"), "0.62508333e5 kg*m^2"),
               (("hub", "inertia_y"), "0.62508333e5 kg*m^2"),
               (("hub", "inertia_z"), "1.25e5 kg*m^2")]  # fmt: skip
    s = structure_for_case(edit(load_case("string-blade-rotor"), changes, "test"))
    i = np.linalg.eigvalsh(inertia_tensor(s, s.reference))
    rigid = np.sqrt((i[2] - i[0]) * (i[2] - i[1]) / (i[0] * i[1]))
    roots = roots_near(s, 1.0, [0.9, 1.04])
    assert nearest(roots, rigid) == pytest.approx(rigid, rel=2e-5)
    hinged = string_blade_ratios("hinged-flap", R0, LENGTH, MU)[0]  # the hub is a fixed hinge
    assert nearest(roots, hinged) == pytest.approx(hinged, rel=5e-3)  # 40 el.: +0.24 %


def test_reduced_comparison_passes_the_capture_check_and_matches_the_nutation():
    """`quadmodes rotating string-blade-rotor` at default settings: no capture error, the
    nutation branch equals the spin to 0.1 % at 1, 2, 4 rad/s."""
    spins_hz = [w / (2 * np.pi) for w in (1.0, 2.0, 4.0)]
    table = rotating_frequency_comparison("string-blade-rotor", spins_hz, 9, ("Q",), axis="z")
    for f in spins_hz:
        row = table.row(f, "nutation")
        assert row.full_hz == pytest.approx(f, rel=1e-3)
        assert row.captured <= 1.0 + 1e-6
    assert all(r.captured <= 1.0 + 1e-6 for r in table.rows + table.extra)


def test_capture_above_one_is_an_error():
    check_capture(np.array([0.2, 1.0, 1.04]), np.array([1.0, 2.0, 3.0]), 1.0)
    with pytest.raises(CaptureError, match="capture check failed.*1684.*hub. rigidity"):
        check_capture(np.array([0.2, 1684.0]), np.array([1.0, 2.0]), 0.5)


FAMILIES = [("collective-flap", 1.05), ("cyclic-flap", 1.55), ("collective-lag", 0.86)]


@pytest.fixture(scope="module")
def refined_roots():
    """Full-order roots ω/Ω at 1 rad/s with 40 and 80 elements per blade."""
    targets = [q for _, q in FAMILIES]
    return {n: roots_near(rotor(n), 1.0, targets) for n in (40, 80)}


@pytest.mark.parametrize(("family", "guess"), FAMILIES)
def test_string_blade_frequencies_converge_to_the_closed_form(refined_roots, family, guess):
    """The clamp of a blade with no bending stiffness is a boundary layer ~√(EI/T) = mm long,
    unresolved by 25 cm elements: the error in ω² is first order in the element length (halves
    with it) and its Richardson extrapolation meets the closed form."""
    exact = string_blade_ratios(family, R0, LENGTH, MU, HUB, count=2)
    target = exact[1] if family == "cyclic-flap" else exact[0]  # exact[0] = 1: the nutation
    lam = {n: nearest(r, guess) ** 2 for n, r in refined_roots.items()}
    err40, err80 = lam[40] - target**2, lam[80] - target**2
    assert 0.0 < err80 < 0.6 * err40  # first order, from above
    assert np.sqrt(2.0 * lam[80] - lam[40]) == pytest.approx(target, rel=2e-3)
    assert nearest(refined_roots[80], guess) == pytest.approx(target, rel=0.03)  # raw, 80 el.


def test_frequency_ratios_do_not_depend_on_the_spin():
    """Every frequency of a spin-stiffened blade scales with the spin."""
    targets = [q for _, q in FAMILIES]
    s = rotor()
    at1, at4 = roots_near(s, 1.0, targets), roots_near(s, 4.0, targets)
    for _, q in FAMILIES:
        assert nearest(at4, q) == pytest.approx(nearest(at1, q), rel=2e-3)


def test_hub_strains_a_hundredth_of_the_blade_roots_at_any_spin():
    """The default penalty (rigidity 100 × the roots' stiffness on the hub axes) keeps the
    hub's triad strain ~1 % of the blades' root strain, whatever the spin."""
    s = rotor()
    for spin in (1.0, 4.0):
        x = relative_equilibrium(s, s.reference, spin, E_Z).x
        a = x[1:4]
        triad = np.abs(a @ a.T - np.eye(3)).max()
        t0 = MU * spin**2 * ((R0 + LENGTH) ** 2 - R0**2) / 2.0  # root tension (N)
        root_strain = t0 / (3e9 * 1e-5)
        assert triad < 0.05 * root_strain


def test_closed_form_limits():
    """The reference on its own: hinged on the axis, ω²/Ω² = k(2k − 1) in flap and one less in
    lag; a hub of huge inertia is a fixed hinge; the free hub's tilt is the nutation (λ = 1)."""
    flap = string_blade_ratios("hinged-flap", 1e-9, LENGTH, MU) ** 2
    lag = string_blade_ratios("hinged-lag", 1e-9, LENGTH, MU) ** 2
    np.testing.assert_allclose(flap[:3], [1.0, 6.0, 15.0], rtol=1e-8)
    np.testing.assert_allclose(lag[:3], [5.0, 14.0, 27.0], rtol=1e-8)  # 0: the neutral lag
    heavy = (1e9, 1e9, 1e9, 2e9)
    for kind, hinged in (("collective-flap", "hinged-flap"), ("collective-lag", "hinged-lag")):
        np.testing.assert_allclose(string_blade_ratios(kind, R0, LENGTH, MU, heavy, count=3),
                                   string_blade_ratios(hinged, R0, LENGTH, MU, count=3),
                                   rtol=1e-6)  # fmt: skip
    assert string_blade_ratios("cyclic-flap", R0, LENGTH, MU, HUB)[0] == pytest.approx(1.0)


def test_spinning_reference_about_the_blade_axis_is_refused_naming_the_axis():
    """About its minor axis (x, along the blades) the rotor's slack blades lie on the spin axis
    and are softened by it with no tension to hold them: a true divergence, refused, and the
    message names the axis. About its normal (z) the same body has a spinning reference."""
    s = rotor()
    with pytest.raises(ValueError, match=r"axis \(1, 0, 0\) is not positive definite"):
        spinning_modes(s, s.reference, 6, 1.0)
    _, modes, _ = spinning_modes(s, s.reference, 6, 1.0, E_Z)
    assert np.all(modes.frequencies_hz > 0.0)


def test_neutral_modes_are_the_frequencies_below_a_thousandth_of_the_spin():
    f = np.array([-2e-4, 1e-5, 0.1, -0.2]) / (2 * np.pi)  # ω (rad/s) at Ω = 1 rad/s
    np.testing.assert_array_equal(neutral_modes(f, 1.0), [True, True, False, False])


def test_failed_capture_stops_the_cli_with_one_line_and_exit_2(monkeypatch):
    """With the limit forced below the measured shares, `quadmodes rotating` stops: exit 2, one
    error line (progress lines before it), no table."""
    from typer.testing import CliRunner

    import quadmodes.analysis.rotating_matching as matching
    from quadmodes.cli.app import app

    monkeypatch.setattr(matching, "CAPTURE_LIMIT", 0.5)
    result = CliRunner().invoke(app, ["rotating", "string-blade-rotor", "--axis", "z", "--spins",
                                      "0.1591549 Hz", "--modes", "9", "--formulations", "Q"])  # fmt: skip
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and result.stdout == ""
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("error: capture check failed at 0.159155 Hz") and "rigidity" in last


def test_reduced_model_about_the_spinning_state_about_the_normal_matches_the_full_order():
    """Expanded about its spinning state about z (a run's ``initial.spin_axis``, here
    "major"), the rotor's reduced model is the full order's linearisation projected on the
    modes of its rotating-frame stiffness: every branch within 0.1 % at 1 and 2 rad/s (about
    rest the same 9 modes are 2–29 % off: string modes at rest are not the spinning shapes)."""
    import quadmodes as qm

    case = load_case("string-blade-rotor")
    model = qm.reduced_model(case, 9, spin="1 rad/s", spin_axis="major")
    np.testing.assert_allclose(model.reference_axis, E_Z, atol=1e-12)
    table = rotating_frequency_comparison(case, [1.0 / (2 * np.pi), 2.0 / (2 * np.pi)], 9,
                                          ("Q",), axis="z", model=model)  # fmt: skip
    assert len(table.rows) == 20 and table.max_error("Q") < 1e-3


def test_a_run_about_the_spinning_state_spins_its_reference_about_its_own_axis(tmp_path):
    """``reduced.reference = "spinning"`` with ``initial.spin_axis = "major"``: the reference
    turns about the normal z (before: always the minor axis, the blade axis, refused)."""
    from quadmodes.case import load_run_case
    from quadmodes.runs.simulate import prepare

    path = tmp_path / "rotor-run.toml"
    path.write_text(
        'name = "rotor-run"\nkind = "run"\nmodel = "string-blade-rotor"\n'
        '[reduced]\nmodes = 9\nformulation = "Q"\nreference = "spinning"\n'
        '[initial]\nspin_rate = "1 rad/s"\ncone_angle = "0.2 deg"\nbending_amplitude = "0 m"\n'
        'spin_axis = "major"\n[integration]\ndt = "20 ms"\nduration = "1 s"\n'
    )
    run = load_run_case(path)
    assert run.reference_axis == "major"
    setup = prepare(run)
    np.testing.assert_allclose(setup.model.reference_axis, E_Z, atol=1e-12)
    assert setup.validity.valid, setup.validity.message()
    np.testing.assert_allclose(setup.initial.spin_axis, E_Z, atol=1e-9)
