"""The free 3-D beam spun about its centre (built-in two-blade-rotor) against the independent
spectral reference (tests/reference, docs/rotating-beam-reference.md): flap and lag
rotating-frame frequencies from rest to three times the first bending frequency."""

from __future__ import annotations

import numpy as np
import pytest
from reference.rotating_beam import rotating_free_beam

import quadmodes as qm
from quadmodes.analysis.campbell import campbell

L, RADIUS, E, RHO = 2.0, 0.01, 7e10, 2700.0
AREA, SECOND = np.pi * RADIUS**2, np.pi * RADIUS**4 / 4
OMEGA_1 = 4.730040745**2 / L**2 * np.sqrt(E * SECOND / (RHO * AREA))  # free-free, rad/s


def family(label: str) -> str:
    """flap: motion along the spin axis z; lag: in the plane of rotation (y)."""
    if "flap" in label or "bending z" in label:
        return "flap"
    if "lag" in label or "bending y" in label:
        return "lag"
    return "other"


@pytest.fixture(scope="module")
def sweep():
    model = qm.reduced_model("two-blade-rotor", 16)
    spins = OMEGA_1 * np.linspace(0.0, 3.0, 7)
    return spins, campbell(model, spins, axis=[0.0, 0.0, 1.0])


def test_spin_axis_is_exactly_the_requested_transverse_axis(sweep):
    _, c = sweep
    assert np.abs(c.spin_axis - [0.0, 0.0, 1.0]).max() < 1e-12


@pytest.mark.parametrize("which", ["flap", "lag"])
def test_flap_and_lag_frequencies_match_the_independent_reference(sweep, which):
    spins, c = sweep
    cols = [i for i, lab in enumerate(c.labels) if family(lab) == which]
    assert len(cols) >= 6
    for k, om in enumerate(spins):
        ref = rotating_free_beam(L, E * SECOND, E * SECOND, E * AREA, RHO * AREA, om,
                                 rho_I_flap=RHO * SECOND, rho_I_lag=RHO * SECOND)  # fmt: skip
        got = np.sort(c.frequency[k, cols])[:3]
        np.testing.assert_allclose(got, ref[which][:3], rtol=5e-3, err_msg=f"Ω = {om:.1f}")


def test_flap_and_lag_branches_keep_their_family_over_the_whole_sweep(sweep):
    """Every bending branch stays a pure flap (along the spin axis) or a pure lag (in the plane
    of rotation) motion at every spin rate, and its label says which."""
    spins, c = sweep
    model = qm.reduced_model("two-blade-rotor", 16)
    phi = np.asarray(model.Phi)  # (N, n, 3)
    pos = np.asarray(model.translational, bool)
    n = model.n_modes
    for j, lab in enumerate(c.labels):
        fam = family(lab)
        if fam == "other":
            continue
        for k in range(spins.size):
            ds = c.vectors[k, j, 3 : 3 + n]
            u = np.einsum("k,kia->ia", ds, phi)[pos]  # positions only
            along = np.sum(np.abs(u[:, 2]) ** 2)
            total = np.sum(np.abs(u[:, 1:]) ** 2)
            share = along / total if fam == "flap" else 1.0 - along / total
            assert share > 0.99, (lab, k, share)
