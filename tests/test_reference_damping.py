"""The full order's independent damping (quadmodes.fullorder.damping): modal damping with the
case's ζ on every prestressed FE mode below a cutoff, through ``W = Π M 𝒬 Φ_d``.

On the small capsule of conftest.py (≈400 nodes, ζ = 2 %; elastic modes 122.45/122.46 Hz
ovalling pair, 147.96/148.24 Hz bending pair, 164.9 Hz axial, then 198.7 Hz)."""

from __future__ import annotations

import numpy as np
import pytest

from quadmodes.fullorder import damping as fd
from quadmodes.fullorder.setup import setup_problem
from quadmodes.fullorder.step import damping_force, step_damping
from quadmodes.rom.reduced import reduce
from quadmodes.rotations import axis_rotation

ZETA = 0.02
#: Between the 5th (164.9 Hz) and 6th (198.7 Hz) elastic modes: exactly the retained five.
CUTOFF_RETAINED = 180.0
CUTOFF = 300.0


@pytest.fixture(scope="module")
def independent(small_modal_model):
    """The independent basis below 300 Hz (no cache)."""
    m = small_modal_model
    f, shapes, _ = fd.modes_below(m.structure, m.x, CUTOFF)
    return fd.modal_damping(f, shapes, ZETA, "independent", CUTOFF)


def _problem(modal, model, damping):
    return setup_problem(
        modal.structure, modal.x, (0.0, 1e-3), 1e-3, model=model, damping=damping, hub=None,
        newton_tol=1e-11, energy_momentum=True, rotation_map=True,
    )  # fmt: skip


def _random_state(modal, model, seed, rigid_velocity=False):
    """A deformed, rotated and translated state (≈1 mm in the retained modes) and a random
    velocity (or a pure rigid velocity)."""
    rng = np.random.default_rng(seed)
    u = np.einsum("k,kia->ia", rng.normal(size=model.n_modes), model.Phi)
    u *= 1e-3 / np.abs(u).max()
    rot = axis_rotation(rng.normal(size=3), 0.7)
    x = (modal.x + u) @ rot.T + rng.normal(size=3)
    if rigid_velocity:
        c = x.mean(axis=0)
        v = rng.normal(size=3) + np.cross(rng.normal(size=3) * 50.0, x - c)
    else:
        v = rng.normal(size=x.shape)
    return x, v


def test_cutoff_at_the_retained_modes_reproduces_the_rom_damping(
    small_modal_model, small_reduced_model
):
    m = small_modal_model
    f, shapes, _ = fd.modes_below(m.structure, m.x, CUTOFF_RETAINED)
    np.testing.assert_allclose(f, small_reduced_model.frequencies_hz, rtol=1e-9)
    modes = fd.modal_damping(f, shapes, ZETA, "independent", CUTOFF_RETAINED)
    np.testing.assert_allclose(np.diag(modes.C), np.diag(small_reduced_model.C), rtol=1e-9)
    new, old = _problem(m, small_reduced_model, modes), _problem(m, small_reduced_model, True)
    for seed in range(3):
        x, v = _random_state(m, small_reduced_model, seed)
        f_new, f_old = step_damping(new, 0.0, x, v), step_damping(old, 0.0, x, v)
        assert np.abs(f_new - f_old).max() <= 1e-8 * np.abs(f_old).max()


def test_force_is_equilibrated_and_dissipative(small_modal_model, small_reduced_model, independent):
    m = small_modal_model
    assert independent.n_modes > small_reduced_model.n_modes
    prob = _problem(m, small_reduced_model, independent)
    for seed in range(5):
        x, v = _random_state(m, small_reduced_model, seed)
        f = step_damping(prob, 0.0, x, v)
        c = prob.body.w @ x / prob.body.mass
        scale = np.abs(f).max()
        assert np.abs(f.sum(axis=0)).max() <= 1e-12 * scale
        lever = np.abs(x - c).max()
        assert np.abs(np.cross(x - c, f).sum(axis=0)).max() <= 1e-12 * scale * lever
        assert float(np.sum(v * f)) >= 0.0
        # and it does work: the elastic part of a random velocity is damped
        assert float(np.sum(v * f)) > 1e-6 * scale * np.abs(v).max()


def test_rigid_velocity_is_not_damped(small_modal_model, small_reduced_model, independent):
    m = small_modal_model
    prob = _problem(m, small_reduced_model, independent)
    for seed in range(3):
        x, v = _random_state(m, small_reduced_model, seed, rigid_velocity=True)
        f = step_damping(prob, 0.0, x, v)
        # against the force of a unit-size elastic velocity at the same state
        f_ref = step_damping(prob, 0.0, x, _random_state(m, small_reduced_model, seed)[1])
        assert np.abs(f).max() <= 1e-12 * np.abs(v).max() * np.abs(f_ref).max()


@pytest.mark.parametrize("k", [0, 4, 7, -1])
def test_single_mode_velocity_gives_its_modal_damping(small_modal_model, independent, k):
    m = small_modal_model
    modes = independent
    mphi = np.stack([m.structure.mass_scalar @ p for p in modes.shapes])
    body = _problem(m, None, modes).body
    nu = 0.37
    f = damping_force(body, modes.C, m.x, nu * modes.shapes[k], mphi=mphi)
    omega = 2 * np.pi * modes.frequencies_hz[k]
    expected = 2 * ZETA * omega * nu * mphi[k]
    assert np.abs(f - expected).max() <= 1e-9 * np.abs(expected).max()


def test_independent_damping_does_not_depend_on_the_reduced_basis(small_modal_model, independent):
    m = small_modal_model
    # 2 and 5 retained modes (a 3-mode cut would split the 148 Hz bending pair)
    roms = [reduce(m.structure, m.x, m.modes.frequencies_hz[:n], m.modes.shapes[:n],
                   m.labels[:n], ZETA) for n in (2, 5)]  # fmt: skip
    x, v = _random_state(m, roms[1], 11)
    f_ind = [step_damping(_problem(m, r, independent), 0.0, x, v) for r in roms]
    f_ret = [step_damping(_problem(m, r, True), 0.0, x, v) for r in roms]
    assert np.abs(f_ind[0] - f_ind[1]).max() <= 1e-12 * np.abs(f_ind[1]).max()
    # the old reference changed with the basis
    assert np.abs(f_ret[0] - f_ret[1]).max() > 0.1 * np.abs(f_ret[1]).max()


def test_pairs_at_the_cutoff_are_kept_whole(small_modal_model):
    m = small_modal_model
    f, labels = m.modes.frequencies_hz, m.labels
    assert fd.pairs_whole(f, labels, 122.452) == 2  # between the ovalling pair's members
    assert fd.pairs_whole(f, labels, 148.0) == 4  # between the bending pair's members
    assert fd.pairs_whole(f, labels, 150.0) == 4
    assert fd.pairs_whole(f, labels, 100.0) == 0


def test_damping_modes_are_cached(small_modal_model, tmp_path, monkeypatch):
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path))
    m = small_modal_model
    case = m.case
    infos = [{}, {}]
    got = [fd.independent_damping_for(case, m.structure, m.x, CUTOFF_RETAINED, ZETA, info=i)
           for i in infos]  # fmt: skip
    assert [i["cache"] for i in infos] == ["miss", "hit"]
    np.testing.assert_array_equal(got[0].shapes, got[1].shapes)
    assert got[1].n_modes == 5 and got[1].cutoff_hz == CUTOFF_RETAINED
    assert "5 FE modes below the cutoff 180 Hz" in got[1].describe()
    with pytest.raises(ValueError, match="cutoff"):
        fd.independent_damping_for(case, m.structure, m.x, -1.0, ZETA, use_cache=False)


@pytest.mark.parametrize("value", ["-5 Hz", "2 m"])
def test_compare_bad_damping_cutoff(tmp_path, value):
    from typer.testing import CliRunner

    from quadmodes.cli.app import app

    out = tmp_path / "cmp"
    result = CliRunner().invoke(app, ["compare", "paper-41hz-coarse", "--damping-cutoff", value, "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert "--damping-cutoff" in result.output and len(result.output.strip().splitlines()) == 1
    assert not out.exists()


def test_clamped_beam_damps_its_clamped_modes_relative_to_the_hub():
    # hub-driven spin-up path: clamped modes below the cutoff, velocity relative to the hub
    from quadmodes.case import load_case
    from quadmodes.fullorder.kinematics import HubDrive
    from quadmodes.structure import pipeline

    s = pipeline.structure_for_case(load_case("kane-beam"))
    f, shapes, _ = fd.modes_below(s, s.reference, 40.0)
    assert len(f) == 10 and np.all(f[1::2] - f[::2] < 1e-6 * f[::2])  # five pairs, whole
    modes = fd.modal_damping(f, shapes, ZETA, "independent", 40.0)
    rate = 3.0  # rad/s about z, hub at angle 0 at t = 0
    hub = HubDrive(angle=lambda t: (rate * t, rate))
    prob = setup_problem(s, s.reference, (0.0, 1e-2), 1e-2, model=None, damping=modes, hub=hub,
                         newton_tol=1e-11, energy_momentum=True, rotation_map=True)  # fmt: skip
    x = s.reference
    rigid = np.cross([0.0, 0.0, rate], x)  # slope rows rotate too (hub point at the origin)
    assert np.abs(step_damping(prob, 0.0, x, rigid)).max() == pytest.approx(0.0, abs=1e-14)
    k, nu = 3, 0.2
    got = step_damping(prob, 0.0, x, rigid + nu * shapes[k])
    expected = 2 * ZETA * 2 * np.pi * f[k] * nu * (s.mass_scalar @ shapes[k])
    assert np.abs(got - expected).max() <= 1e-9 * np.abs(expected).max()
