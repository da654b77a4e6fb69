"""Spin axis chosen explicitly (exact for equal principal moments) and Campbell branch tracking
that refuses a poor MAC and follows degenerate roots by their span."""

from dataclasses import replace

import numpy as np
import pytest

from quadmodes.analysis import campbell_tracking as tr
from quadmodes.analysis.campbell import campbell
from quadmodes.analysis.reduced_linearisation import relative_equilibrium
from quadmodes.models.beam import kane_model
from quadmodes.rom import dynamics as dy
from quadmodes.rom import system as rsys
from quadmodes.rom.spin_axis import (
    axis_for_inertia,
    equilibrium_direction,
    named_principal_axis,
    parse_axis,
    principal_direction,
)

ROD = np.diag([1.0e-4, 2.0, 2.0])  # a free rod along x: diag(Jp, J, J), kg m²


def _rotation(seed: int) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    return q * np.sign(np.linalg.det(q))


# ----------------------------------------------------------------------------- the axis rule


def test_parse_axis_accepts_names_indices_and_numbers():
    assert parse_axis("Z", "--axis") == "z" and parse_axis("major", "--axis") == "major"
    assert parse_axis(2) == 2 and parse_axis(None) is None
    np.testing.assert_allclose(parse_axis("0, 0, 2"), [0.0, 0.0, 1.0])
    np.testing.assert_allclose(parse_axis([3.0, 4.0, 0.0]), [0.6, 0.8, 0.0])
    for bad in ("q", "1,2", "0,0,0", "1,nan,0", 3, True):
        with pytest.raises(ValueError, match="^--axis: .*give x, y, z, minor"):
            parse_axis(bad, "--axis")


def test_equal_moments_spin_exactly_about_the_requested_axis():
    """Any axis in the plane of equal moments is principal: the one asked for is kept to
    round-off, whatever basis eigh returns for the plane (a rotated rod)."""
    for seed in range(5):
        r = _rotation(seed)
        inertia = r @ ROD @ r.T
        for angle in (0.0, 0.3, 1.1, 2.5):
            e = r @ np.array([0.0, np.cos(angle), np.sin(angle)])
            got = principal_direction(inertia, e, "--axis")
            np.testing.assert_allclose(got, e, rtol=0, atol=1e-12)
            np.testing.assert_allclose(equilibrium_direction(inertia, e), e, rtol=0, atol=1e-12)
        # the rod's own axis is a single moment: its eigenvector
        np.testing.assert_allclose(abs(principal_direction(inertia, r[:, 0]) @ r[:, 0]), 1.0)


def test_named_axes_of_equal_moments_are_body_axes():
    """"major" of a rod along x is y (the first body axis in the plane), "minor" its axis."""
    np.testing.assert_allclose(named_principal_axis(ROD, 2), [0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(axis_for_inertia(ROD, "major"), [0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(axis_for_inertia(ROD, "minor"), [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(axis_for_inertia(ROD, "z"), [0.0, 0.0, 1.0], atol=0)


def test_a_request_off_the_principal_axes_is_refused():
    with pytest.raises(ValueError, match=r"^--axis: \(0\.6, 0, 0\.8\) is not a principal axis.*"
                       r"minor \(1, 0, 0\) 0\.0001 kg m²; intermediate .*major .* kg m²"):
        axis_for_inertia(ROD, "0.6,0,0.8", "--axis")
    # a clamped body spins about whatever axis its hub turns about: no check
    np.testing.assert_allclose(axis_for_inertia(ROD, "0.6,0,0.8", check=False), [0.6, 0, 0.8])


def test_free_capsule_spins_about_the_axis_asked_for(small_reduced_model):
    """The capsule's transverse moments are equal to 1.2e-5 (mesh): spun about a transverse
    axis, the relative equilibrium keeps exactly that axis at every spin rate (before, the
    eigenvector of J̃(s*) nearest it, which round-off and mesh noise turn by up to 0.7 rad),
    and the centrifugal deformation leaves it principal to the tolerance."""
    model = small_reduced_model
    spins = np.linspace(0.0, 300.0, 7)
    for request in ("x", "0.6,0.8,0", "major"):
        r = campbell(model, spins, axis=request)
        assert abs(r.axis[2]) < 1e-4  # the request projected onto the plane of equal moments
        np.testing.assert_allclose(r.spin_axis, np.tile(r.axis, (spins.size, 1)), atol=1e-12)
        assert not np.isnan(r.frequency).any() and r.mac.min() >= tr.MAC_REFUSE
    sys = rsys.reduced_system(model, "Q")
    w, s, _ = relative_equilibrium(sys, 300.0, r.axis)
    np.testing.assert_allclose(w / 300.0, r.axis, atol=1e-12)
    jt = dy.inertia_tensor(sys, s, "rot")
    assert np.linalg.norm(np.cross(r.axis, jt @ r.axis)) < 1e-4 * np.abs(jt).max()


def test_free_capsule_refuses_an_axis_that_is_not_principal(small_reduced_model):
    with pytest.raises(ValueError, match=r"^--axis: .* not a principal axis .*minor .*major"):
        campbell(small_reduced_model, [0.0, 10.0], axis="1,0,1", axis_option="--axis")


# ----------------------------------------------------------------------------- tracking


def test_degenerate_pair_is_matched_by_its_span():
    """Two bases of the same exactly degenerate pair, rotated arbitrarily: the plain MAC of
    their members is about 0.5, the span MAC 1; after the Procrustes rotation each member
    continues its own branch with MAC 1 and the match is clear."""
    rng = np.random.default_rng(3)
    m = 8
    wgt = np.diag(rng.uniform(0.5, 2.0, m))
    base = tr.normalise(rng.standard_normal((m, 3)) + 1j * rng.standard_normal((m, 3)), wgt)
    root_w = np.sqrt(np.diag(wgt))[:, None]
    base[:, :2] = np.linalg.qr(root_w * base[:, :2])[0] / root_w  # a W-orthonormal pair
    lam0 = np.array([1j, 1j, 3j])
    c, s = np.cos(0.8), np.sin(0.8)
    v1 = base.copy()
    v1[:, :2] = base[:, :2] @ np.array([[c, -s], [s, c]])
    v1 = v1[:, [2, 1, 0]]  # shuffled too
    lam1 = lam0[[2, 1, 0]]
    plain = tr.mac(base, v1, wgt)
    assert plain[0, 2] < 0.9 and plain[1, 1] < 0.9  # the members alone do not match
    assert tr.span_mac(base[:, :2], v1[:, [2, 1]], wgt) == pytest.approx(1.0, abs=1e-12)
    aligned = tr.align_degenerate(base, v1, lam1, wgt, 3.0)
    order, measure, ok = tr.match(base, lam0, aligned, lam1, wgt, 3.0)
    assert ok and order[2] == 0 and set(order[:2]) == {1, 2}
    np.testing.assert_allclose(measure, 1.0, atol=1e-12)
    np.testing.assert_allclose(np.diag(tr.mac(base, aligned[:, order], wgt)), 1.0, atol=1e-12)


@pytest.fixture(scope="module")
def veering_blade():
    """Kane's blade stiffer in its plane (EI_chord = 1.69 EI_flap) with a weak stiffness
    coupling of flap and lag: the branches veer where the uncoupled ones would cross,
    Ω_c = √0.69 ω₁, their shapes exchanging within about 0.05 rad/s."""
    beam = kane_model(n_modes=1, out_of_plane=True)
    inplane = np.array([lab.startswith("in-plane") for lab in beam.labels])
    factor = np.where(inplane, 1.69, 1.0)
    lam = beam.Lam * np.sqrt(np.outer(factor, factor)) + 0.05 * (1.0 - np.eye(2))
    blade = replace(beam, Lam=lam, frequencies_hz=beam.frequencies_hz * np.sqrt(factor))
    return blade, np.sqrt(0.69 * beam.Lam[0, 0])


def test_poor_mac_step_is_refused(veering_blade):
    """A spin rate in the middle of the veering, without halving the steps: the shapes there are
    45° mixtures (MAC ≈ 0.5 with either branch), so both branches end and new ones start; the
    old labels keep their frequencies (NaN afterwards) and nothing is relabelled."""
    blade, wc = veering_blade
    spins = [0.0, 1.0, 2.0, 3.0, wc, 5.0, 6.0]
    r = campbell(blade, spins, axis="z", max_bisections=0)
    assert r.labels[:2] == ("out-of-plane bending 1", "in-plane bending 1")
    assert len(r.labels) > 2 and list(r.start[:2]) == [0, 0] and r.start[2] == 4
    assert np.isnan(r.frequency[4:, :2]).all() and np.isfinite(r.frequency[:4, :2]).all()
    assert len(set(r.labels)) == len(r.labels)
    assert (np.isfinite(r.frequency).sum(axis=1) == 2).all()  # two roots at every spin rate
    assert np.nanmin(r.mac) >= tr.MAC_REFUSE


def test_labels_stay_with_their_branches_through_a_veering(veering_blade):
    """Steps of 0.25 rad/s over a veering 0.05 rad/s wide: the tracking follows the shapes
    across it (as through a crossing), so at every spin rate away from the veering each branch
    is still dominated by the mode of its label; two branches over the whole sweep."""
    blade, wc = veering_blade
    spins = np.linspace(0.0, 6.0, 25)
    r = campbell(blade, spins, axis="z")
    assert len(r.labels) == 2 and not np.isnan(r.frequency).any()
    assert r.mac.min() >= tr.MAC_REFUSE
    n = blade.n_modes
    for i in np.flatnonzero(np.abs(spins - wc) > 0.2):
        for b, label in enumerate(r.labels):
            ds = r.vectors[i, b, :n]
            assert blade.labels[int(np.argmax(np.abs(ds)))] == label, (spins[i], label)


# ----------------------------------------------------------------------------- runs


def test_initial_spin_axis_of_a_run(small_reduced_model):
    """``initial.spin_axis``: a transverse axis of the capsule (equal moments) is kept exactly,
    with the cone angle measured from it; the default stays the minor axis; a bad value is one
    field error."""
    from types import SimpleNamespace

    from pydantic import ValidationError

    from quadmodes.case.run_sections import RunInitial
    from quadmodes.runs.initial import initial_state

    model = small_reduced_model
    sys = rsys.reduced_system(model, "Q")
    spin, cone = 2 * np.pi * 20.0, np.radians(6.0)
    for text, stored in (("X", "x"), ([0.6, 0.8, 0], "0.6,0.8,0.0")):
        init = RunInitial.model_validate({"spin_rate": "20 Hz", "cone_angle": "6 deg",
                                          "spin_axis": text})  # fmt: skip
        assert init.spin_axis == stored
        state = initial_state(sys, model, SimpleNamespace(initial=init))
        e = state.spin_axis
        request = np.array([1.0, 0, 0]) if stored == "x" else np.array([0.6, 0.8, 0])
        assert np.linalg.norm(e - request) < 1e-4 and abs(e[2]) < 1e-4
        omega = state.y0[4:7]
        assert omega @ e == pytest.approx(spin, rel=1e-12)
        h = state.inertia @ omega
        angle = np.arctan2(np.linalg.norm(np.cross(h, e)), h @ e)
        assert angle == pytest.approx(cone, rel=1e-6)  # e principal to the mesh asymmetry
    default = initial_state(sys, model, SimpleNamespace(
        initial=RunInitial.model_validate({"spin_rate": "20 Hz"})))  # fmt: skip
    assert abs(default.spin_axis[2]) == pytest.approx(1.0, abs=1e-6)  # the minor axis
    with pytest.raises(ValidationError, match="(?s)spin_axis.*'sideways' is not an axis"):
        RunInitial.model_validate({"spin_rate": "20 Hz", "spin_axis": "sideways"})
    bad = RunInitial.model_validate({"spin_rate": "20 Hz", "spin_axis": "1,0,1"})
    with pytest.raises(ValueError, match="^initial.spin_axis: .*not a principal axis"):
        initial_state(sys, model, SimpleNamespace(initial=bad))


def test_campbell_cli_axis_option():
    """``campbell --axis``: a clamped beam spins about the axis given; the help no longer says
    free bodies spin about their minor axis."""
    import json

    from typer.testing import CliRunner

    from quadmodes.cli.app import app

    runner = CliRunner()
    args = ["campbell", "kane-beam", "--spin-max", "2 rad/s", "-n", "2", "--json"]
    res = runner.invoke(app, [*args, "--axis", "0, 0, 2"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["axis"] == [0.0, 0.0, 1.0]
    help_text = runner.invoke(app, ["campbell", "--help"]).stdout
    assert "--axis" in help_text and "minor principal axis" not in help_text
