"""Full-order rotating-frame analysis (quadmodes.analysis.rotating_*): centrifugal relative equilibrium,
gyroscopic eigenproblem, and its comparison with the reduced model's Campbell frequencies on the
coarse paper model; the clamped Kane beam against its published chordwise frequencies and the
Southwell coefficient."""

import numpy as np
import pytest

from quadmodes.analysis.campbell import campbell
from quadmodes.analysis.rotating_comparison import case_state, rotating_frequency_comparison
from quadmodes.analysis.rotating_matching import rotation_and_modal_parts
from quadmodes.analysis.rotating_modes import rotating_roots
from quadmodes.fe.build import build_beam_structure
from quadmodes.fe.model import centre_of_mass, inertia_tensor
from quadmodes.models.beam import KANE_BEAM
from quadmodes.models.build import build_reduced_model
from quadmodes.runs.spinup import KANE_REFERENCE_CHORDWISE
from quadmodes.structure.spinning import (
    centrifugal_force,
    relative_equilibrium,
    rotating_residual,
)

SPINS_HZ = (0.0, 20.0, 41.0)


@pytest.fixture(scope="module")
def coarse():
    """Coarse paper model: case, vibration structure, inflated state, 5-mode reduced model."""
    case, structure, x0 = case_state("paper-membrane-coarse")
    return case, structure, x0, build_reduced_model(case, 5)


@pytest.fixture(scope="module")
def table5(coarse):
    case, _, _, rom = coarse
    return rotating_frequency_comparison(case, SPINS_HZ, model=rom, formulations=("Q", "L"))


@pytest.fixture(scope="module")
def table8(coarse):
    """Q with 8 modes (adds the 42.6 Hz torsion, 52.1 Hz and 57.7 Hz modes)."""
    case = coarse[0]
    rom = build_reduced_model(case, 8)
    return rotating_frequency_comparison(case, (20.0, 41.0), model=rom, formulations=("Q",))


def test_zero_spin_reproduces_modal_frequencies(table5, coarse):
    rom = coarse[3]
    rows = [r for r in table5.rows if r.spin_hz == 0.0 and r.label != "nutation"]
    full = np.array([r.full_hz for r in rows])
    np.testing.assert_allclose(np.sort(full), rom.frequencies_hz, rtol=1e-6)
    for r in rows:
        assert r.mac["Q"] > 0.999 and r.rigid_fraction < 1e-6


def test_relative_equilibrium(table5, coarse):
    _, structure, x0, _ = coarse
    e, c = table5.axis, centre_of_mass(structure, x0)
    for eq in table5.equilibria[1:]:
        assert eq.residual < 1e-9
        res = rotating_residual(structure, eq.x, eq.spin, e, c)
        fc = centrifugal_force(structure, eq.x, eq.spin, e, c)
        assert np.linalg.norm(res) < 1e-8 * np.linalg.norm(fc)
        # the two frame conditions only remove null directions: no reaction
        assert eq.multiplier_ratio < 1e-9
        # the centre of mass stays on the axis; the axis is a principal axis of the deformed body
        assert np.linalg.norm(centre_of_mass(structure, eq.x) - c) < 1e-12
        j = inertia_tensor(structure, eq.x)
        assert np.linalg.norm(np.cross(e, j @ e)) < 1e-9 * np.trace(j)
    # constant pressure: the centrifugal load inflates the body, ΔV/V ∝ Ω² (linear regime)
    dv = np.array([eq.volume_change for eq in table5.equilibria])
    assert dv[0] == 0.0 and 0.0 < dv[1] < dv[2] < 0.02
    assert dv[2] / dv[1] == pytest.approx((41.0 / 20.0) ** 2, rel=0.02)


def test_centrifugal_deformation_matches_reduced_quasi_static(coarse):
    """Linear regime (5 Hz): the modal content of the full-order centrifugal deformation equals
    the reduced model's relative-equilibrium coordinates s* (same centrifugal load convention)."""
    _, structure, x0, rom = coarse
    r = campbell(rom, [2 * np.pi * 5.0], 0, "Q")
    e = r.axis
    eq = relative_equilibrium(structure, x0, 2 * np.pi * 5.0, e, centre_of_mass(structure, x0))
    _, a = rotation_and_modal_parts(structure, eq.x, rom.Phi, (eq.x - x0)[None])
    np.testing.assert_allclose(a[0].real, r.s_eq[0], rtol=0, atol=2e-3 * np.abs(r.s_eq[0]).max())


def test_conventions_match_nutation_and_whirl(table5):
    """Frames and signs agree: the nutation root (rigid-dominated, Coriolis- and
    centrifugal-sensitive) matches to 0.1 %, and every Q branch has its full-order partner (MAC)."""
    for f in SPINS_HZ[1:]:
        r = table5.row(f, "nutation")
        assert r.rel_error["Q"] == pytest.approx(0.0, abs=1e-3)
        assert r.rigid_fraction > 0.99
    assert all(r.mac["Q"] > 0.9 for r in table5.rows if r.spin_hz > 0)
    tilts = [r for r in table5.extra if r.label == "tilt"]
    assert [t.full_hz for t in tilts] == pytest.approx([20.0, 41.0], rel=1e-6)


@pytest.mark.xfail(
    strict=True,
    reason="issue 4 item 4: with 5 modes Q misses the Coriolis coupling to the omitted 42.6/52.1/"
    "57.7 Hz modes (Ω comparable to the frequencies): 20 Hz backward rocking +9.6 %, 41 Hz lowest "
    "branch 7.13 vs 1.14 Hz; with 8 modes all branches converge (test below)",
)
def test_q_within_two_percent_with_five_modes(table5):
    assert table5.max_error("Q") <= 0.02


def test_q_converges_to_full_order_with_eight_modes(table8):
    """With the modes that the gyroscopic coupling needs, Q is within 1 % of full order on every
    branch; a near-zero backward branch (41 Hz: 1.14 Hz) is compared in absolute terms."""
    for r in table8.rows:
        assert r.mac["Q"] > 0.99 and r.captured > 0.95  # the top branch leaks to mode 9+
        if r.full_hz > 0.1 * r.spin_hz:
            assert abs(r.rel_error["Q"]) < 0.01, r
        else:
            assert abs(r.rom_hz["Q"] - r.full_hz) < 0.05, r


def test_linear_modes_error_is_reported(table5):
    """L has no spin stiffening; its error is computed for every branch (reported, not bounded:
    at 41 Hz its lowest branch is divergent, growth Re λ > 0)."""
    rows = [r for r in table5.rows if r.spin_hz > 0]
    # an L branch the tracking ended (a poor MAC at a coalescence, divergence) has no root to
    # compare: its row is NaN for L; every other row has a finite error, and most rows do
    matched = [r for r in rows if np.isfinite(r.rom_hz["L"]) and np.isfinite(r.full_hz)]
    assert all(np.isfinite(r.rel_error["L"]) for r in matched)
    assert len(matched) >= 0.75 * len(rows)
    assert "| L (Hz) |" in table5.to_text()


def test_kane_beam_full_order_chordwise_and_southwell():
    """Clamped Kane beam on a hub spinning about z: full-order chordwise frequencies against the
    published values, and the flapwise Southwell coefficient k_S ≈ 1.19 (ω² = ω0² + k_S Ω²)."""
    b = KANE_BEAM
    s = build_beam_structure(
        b["length"],
        20,
        b["youngs_modulus"] * b["area"],
        b["youngs_modulus"] * b["second_moment"],
        b["density"] * b["area"],
    )
    z = np.array([0.0, 0.0, 1.0])
    w0 = 3.516 * np.sqrt(b["youngs_modulus"] * b["second_moment"] / (b["density"] * b["area"]))
    w0 /= b["length"] ** 2
    x, prev, found = s.reference, 0.0, {}
    for om in (1.0, *sorted(KANE_REFERENCE_CHORDWISE)):
        eq = relative_equilibrium(s, x, om, z, start_spin=prev)
        assert eq.residual < 1e-8
        x, prev = eq.x, om
        roots = rotating_roots(s, x, om, z, [w0 / (2 * np.pi), (w0 + om) / (2 * np.pi)], 4)
        shapes = roots.shapes[:, s.translational]
        inplane = np.sum(np.abs(shapes[..., 1]) ** 2, 1) / np.sum(np.abs(shapes) ** 2, (1, 2))
        low = np.argsort(roots.lam.imag)
        chord = next(i for i in low if inplane[i] > 0.9)
        flap = next(i for i in low if inplane[i] < 0.1)
        found[om] = (roots.lam[chord].imag, roots.lam[flap].imag)
    for om, ref in KANE_REFERENCE_CHORDWISE.items():
        assert found[om][0] == pytest.approx(ref, rel=5e-4)
    k_s = (found[1.0][1] ** 2 - w0**2) / 1.0**2
    assert k_s == pytest.approx(1.193, abs=0.01)
