"""Campbell diagrams: Kane beam on a spinning hub, Southwell stiffening, linear-mode softening,
MAC tracking through a crossing, and the free spinning body (relative equilibrium)."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import assert_cf_file
from scipy.integrate import solve_ivp

from quadmodes.analysis.campbell import campbell
from quadmodes.analysis.campbell_output import campbell_main, plot_campbell, write_campbell
from quadmodes.analysis.reduced_linearisation import relative_equilibrium
from quadmodes.models.beam import kane_model
from quadmodes.rom import dynamics as dy
from quadmodes.rom import system as rsys
from quadmodes.runs.spinup import KANE_REFERENCE_CHORDWISE

OMEGA_1 = 3.516 * np.sqrt(7e10 * 2e-7 / (3000 * 4e-4 * 10.0**4))  # 3.798 rad/s


@pytest.fixture(scope="module")
def beam():
    """Kane beam: four in-plane and four out-of-plane bending modes (pure planes)."""
    return kane_model(n_modes=4, out_of_plane=True)


def test_kane_chordwise_frequencies(beam):
    spins = sorted(KANE_REFERENCE_CHORDWISE)
    r = campbell(beam, [0.0, *spins], axis=[0, 0, 1], formulation="Q")
    b = r.branch("in-plane bending 1")
    assert r.frequency[0, b] == pytest.approx(OMEGA_1, rel=2e-4)
    for i, w in enumerate(spins, start=1):
        assert r.frequency[i, b] == pytest.approx(KANE_REFERENCE_CHORDWISE[w], rel=0.01)
    assert not r.unstable.any()


def test_southwell_coefficient_flapwise(beam):
    spins = np.linspace(0.0, 1.5, 7)
    r = campbell(beam, spins, axis=[0, 0, 1])
    f = r.frequency[:, r.branch("out-of-plane bending 1")]
    k_s = np.polyfit(spins**2, f**2 - f[0] ** 2, 1)[0]
    assert k_s == pytest.approx(1.19, rel=0.05)
    # chordwise: the same stiffening minus the centrifugal softening σ = 1
    g = r.frequency[:, r.branch("in-plane bending 1")]
    assert np.polyfit(spins**2, g**2 - g[0] ** 2, 1)[0] == pytest.approx(k_s - 1.0, abs=1e-3)


def test_linear_modes_lose_in_plane_stiffness_above_omega1(beam):
    spins = np.linspace(0.0, 6.0, 25)
    lin = campbell(beam, spins, axis=[0, 0, 1], formulation="L")
    quad = campbell(beam, spins, axis=[0, 0, 1], formulation="Q")
    above = spins > OMEGA_1 * 1.001
    assert np.all(lin.min_stiffness[~above] > 0.0) and np.all(lin.min_stiffness[above] < 0.0)
    omega1 = 2 * np.pi * beam.frequencies_hz[0]
    np.testing.assert_allclose(lin.min_stiffness, omega1**2 - spins**2, rtol=0, atol=1e-8)
    b = lin.branch("in-plane bending 1")
    assert np.all(lin.growth[above, b] > 0.0) and np.all(lin.frequency[above, b] == 0.0)
    assert not lin.unstable[~above].any()
    # the out-of-plane (flapwise) mode of L neither stiffens nor softens
    np.testing.assert_allclose(
        lin.frequency[:, lin.branch("out-of-plane bending 1")], OMEGA_1, rtol=2e-4
    )
    assert np.all(quad.min_stiffness > 0.0) and not quad.unstable.any()


def test_mac_tracking_through_a_crossing(beam):
    """A blade stiffer in its plane of rotation (EI_chord = 1.69 EI_flap): the chordwise
    branch starts above the flapwise one, which stiffens faster and crosses it near Ω = 3.2."""
    inplane = np.array([lab.startswith("in-plane") for lab in beam.labels])
    factor = np.where(inplane, 1.69, 1.0)
    blade = replace(
        beam,
        Lam=beam.Lam * np.sqrt(np.outer(factor, factor)),
        frequencies_hz=beam.frequencies_hz * np.sqrt(factor),
    )
    spins = np.linspace(0.0, 6.0, 25)
    r = campbell(blade, spins, axis=[0, 0, 1])
    chord = r.frequency[:, r.branch("in-plane bending 1")]
    flap = r.frequency[:, r.branch("out-of-plane bending 1")]
    # identity kept: each branch follows its own analytic curve ω² = ω0² + (k − σ)Ω²
    k_s = 1.19
    np.testing.assert_allclose(chord, np.sqrt(1.69 * OMEGA_1**2 + (k_s - 1) * spins**2), rtol=0.01)
    np.testing.assert_allclose(flap, np.sqrt(OMEGA_1**2 + k_s * spins**2), rtol=0.01)
    assert chord[0] > flap[0] and chord[-1] < flap[-1]  # they do cross
    assert r.mac.min() > 0.95
    # sorting would have swapped them: the lowest sorted frequency changes identity
    lowest = np.sort(r.frequency, axis=1)[:, 0]
    np.testing.assert_allclose(lowest, np.minimum(chord, flap))


def test_degenerate_start_gets_clean_labels(beam):
    """At Ω = 0 the y/z pairs are degenerate; the branches still start on pure planes."""
    r = campbell(beam, [0.0, 0.5, 1.0], axis=[0, 0, 1])
    assert set(r.labels) == set(beam.labels)
    assert r.mac[1:].min() > 0.99


# ----------------------------------------------------------------------------------------------
# free body


@pytest.fixture(scope="module")
def capsule(small_reduced_model):
    return small_reduced_model


def test_free_rigid_limit_is_nutation(capsule):
    """N = 0: the body-frame nutation frequency of a rigid body spinning about principal axis a,
    Ω √((I_a − I_b)(I_a − I_c)/(I_b I_c)) (= |I_t − I_a| Ω / I_t when I_b = I_c = I_t)."""
    rigid = capsule.rigid()
    lam, vec = np.linalg.eigh(rigid.J0)
    spins = np.linspace(0.0, 300.0, 4)
    for a in (0, 2):
        # the eigenvector itself: the capsule's transverse moments are equal to 1.2e-5, so the
        # name "major" would be the body axis x projected onto their plane (spin_axis rule)
        r = campbell(rigid, spins, axis=vec[:, a])
        i_a, (i_b, i_c) = lam[a], np.delete(lam, a)
        assert r.labels == ("nutation",)
        expected = spins * np.sqrt((i_a - i_b) * (i_a - i_c) / (i_b * i_c))
        np.testing.assert_allclose(r.frequency[:, 0], expected, rtol=1e-6)
        assert r.frequency[0, 0] == 0.0 and not r.unstable.any()
    # the intermediate axis is unstable: a real root, growth at that same rate
    r = campbell(rigid, spins[1:], axis=vec[:, 1])
    i_a, (i_b, i_c) = lam[1], np.delete(lam, 1)
    growth = spins[1:] * np.sqrt(-(i_a - i_b) * (i_a - i_c) / (i_b * i_c))
    np.testing.assert_allclose(r.growth[:, 0], growth, rtol=1e-5)
    assert r.unstable.all()


def test_free_body_branches(capsule):
    spins = np.linspace(0.0, 300.0, 7)
    r = campbell(capsule, spins)  # default: symmetry (minor) axis
    assert abs(abs(r.axis[2]) - 1.0) < 1e-6
    assert r.labels[0] == "nutation" and len(r.labels) == capsule.n_modes + 1
    # at rest: the modal frequencies; spinning: stable, split gyroscopic pairs
    np.testing.assert_allclose(
        np.sort(r.frequency[0, 1:]), 2 * np.pi * capsule.frequencies_hz, rtol=1e-7
    )
    assert not r.unstable.any()
    assert r.mac.min() > 0.8
    lam = np.linalg.eigvalsh(capsule.J0)
    rigid_nutation = (lam[1:].mean() - lam[0]) / lam[1:].mean() * spins
    np.testing.assert_allclose(r.frequency[:, 0], rigid_nutation, rtol=0.01)
    # centrifugal deformation s* is small and the equilibrium is exact
    sys = rsys.reduced_system(capsule, "Q")
    _, s, residual = relative_equilibrium(sys, 300.0, r.axis)
    assert residual < 1e-10
    np.testing.assert_allclose(s, r.s_eq[-1])


def test_free_linearisation_matches_nonlinear_motion(capsule):
    """Start at the relative equilibrium plus a small multiple of a branch eigenvector: the
    nonlinear Q equations follow Re(ε v e^{λt}) for two periods."""
    spin = 300.0
    r = campbell(capsule, [spin])
    sys = rsys.with_damping(rsys.reduced_system(capsule, "Q"), np.zeros((capsule.n_modes,) * 2))
    n = sys.n_modes
    z0 = np.concatenate([r.spin_axis[0] * spin, r.s_eq[0], np.zeros(n)])
    for b in (r.branch("nutation"), 1):
        v = r.vectors[0, b]
        lam = r.growth[0, b] + 1j * r.frequency[0, b]
        eps = 1e-4 * spin / np.abs(v[:3]).max() if b == 0 else 1e-6 / np.abs(v[3 : 3 + n]).max()
        t = np.linspace(0.0, 4 * np.pi / abs(lam.imag), 40)
        sol = solve_ivp(
            lambda tt, y: dy.rhs(sys, tt, y),
            (0.0, t[-1]),
            np.concatenate([[1.0, 0.0, 0.0, 0.0], z0 + eps * v.real]),
            method="DOP853",
            rtol=1e-12,
            atol=1e-16,
            t_eval=t,
        )
        pred = eps * (v[None, :] * np.exp(lam * t)[:, None]).real
        err = np.abs(sol.y[4:].T - z0 - pred).max() / np.abs(pred).max()
        assert err < 1e-4, (r.labels[b], err)


# ----------------------------------------------------------------------------------------------
# output


def test_write_campbell_outputs(beam, tmp_path):
    import xarray as xr

    r = campbell(beam.select([0, 1]), np.linspace(0.0, 6.0, 7), [0, 0, 1], "L")
    paths = write_campbell(r, tmp_path / "out")
    assert {p.name for p in paths.values()} == {"campbell.png", "campbell.nc", "campbell.csv"}
    with xr.open_dataset(paths["nc"], engine="h5netcdf") as ds:
        assert ds["frequency"].attrs["units"] == "rad/s"
        assert ds["spin"].attrs["units"] == "rad/s"
        np.testing.assert_allclose(ds["frequency"].values, r.frequency)
        assert list(ds["branch_label"].values) == list(r.labels)
        assert list(ds["branch"].values) == [1, 2] and ds["mode"].values[0] == 1
    assert_cf_file(paths["nc"])
    lines = paths["csv"].read_text().splitlines()
    assert len(lines) == 1 + 7 * 2 and lines[0].startswith("spin_rad_s")
    fig = plot_campbell(r)
    assert len(fig.axes) == 2  # the unstable L branch adds the growth-rate panel


def test_campbell_main_from_case(tmp_path):
    r, paths = campbell_main("kane-beam", 0.0, 6.0, 4, output_dir=tmp_path)
    assert paths["png"].exists() and paths["nc"].exists()
    b = [i for i, lab in enumerate(r.labels) if lab.startswith("bending y (0")][0]
    assert r.frequency[-1, b] == pytest.approx(KANE_REFERENCE_CHORDWISE[6.0], rel=0.01)


# ----------------------------------------------------------------------------------------------
# through a divergence


@pytest.fixture(scope="module")
def membrane_coarse():
    """The coarse seed membrane about rest: its rotating stiffness is lost near 42 Hz."""
    from quadmodes.analysis.campbell_output import model_for_case

    return model_for_case("paper-membrane-coarse")


@pytest.mark.parametrize("points", [3, 5, 10, 41])
def test_campbell_through_a_divergence(membrane_coarse, points, tmp_path):
    """0–45 Hz crosses the divergence: any number of points gives the same divergence spin
    (where the smallest eigenvalue of Λ − ωᵀJ2ω is zero), every branch ends before it, the
    branches after it start there, and the figure and dataset carry it."""
    import xarray as xr

    from quadmodes.rom import rotating_frame as rf
    from quadmodes.rom import system as rsys

    spins = np.linspace(0.0, 2 * np.pi * 45.0, points)
    r = campbell(membrane_coarse, spins)
    assert r.divergence.shape == (1,)
    w_d = r.divergence[0]
    before, after = spins < w_d, spins > w_d
    assert np.all(r.min_stiffness[before] > 0.0) and np.all(r.min_stiffness[after] < 0.0)
    # the independent check: the rotating stiffness about the symmetry axis is singular at w_d
    sys = rsys.reduced_system(membrane_coarse, "Q")
    k = rf.rotating_frame_matrices(sys, w_d * r.spin_axis[0])[2]
    kmin0 = np.linalg.eigvalsh(rf.rotating_frame_matrices(sys, 0 * r.axis)[2]).min()
    assert abs(np.linalg.eigvalsh(k).min()) < 1e-6 * kmin0
    first_after = int(np.argmax(after))
    for b in range(len(r.labels)):
        alive = np.isfinite(r.frequency[:, b])
        assert not (alive[before].any() and alive[after].any()), r.labels[b]
        if alive[after].any():
            assert r.start[b] == first_after
    assert np.isfinite(r.frequency[before]).any() and np.isfinite(r.frequency[after]).any()
    paths = write_campbell(r, tmp_path)
    with xr.open_dataset(paths["nc"]) as ds:
        np.testing.assert_allclose(ds["divergence_spin"].values, r.divergence)
        assert ds["divergence_spin"].attrs["units"] == "rad/s"


def test_divergence_spin_does_not_depend_on_the_grid(membrane_coarse):
    found = [campbell(membrane_coarse, np.linspace(0.0, 2 * np.pi * 45.0, n)).divergence[0]
             for n in (3, 10)]  # fmt: skip
    assert found[0] == pytest.approx(found[1], rel=1e-6)


def test_campbell_command_through_the_divergence(tmp_path):
    """``quadmodes campbell paper-membrane-coarse --spin-max "45 Hz" --points 10`` succeeds (it
    ended in "matrix contains invalid numeric entries") and reports the divergence."""
    import json

    from typer.testing import CliRunner

    from quadmodes.cli import app

    res = CliRunner().invoke(app, ["campbell", "paper-membrane-coarse", "--spin-max", "45 Hz",
                                   "--points", "10", "--json", "-o", str(tmp_path)])  # fmt: skip
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert len(summary["divergence_spin_hz"]) == 1 and 40.0 < summary["divergence_spin_hz"][0] < 45.0
    assert (tmp_path / "campbell.png").is_file()
