"""The path check lists every failing check, not only the first (``PathValidity.failures``,
the message, results.nc ``path_failure_*``, the summary's ``path_validity.failures``); and why a
spin change's range is judged by the frequencies only: the energy-sink coning rate of its
driven modes is zero (no cone forces them), so it measures nothing there.

The string-blade rotor with 12 elements per blade (a model in seconds)."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from quadmodes.case import load_case
from quadmodes.rom import system as rsys
from quadmodes.runs import spin_check
from quadmodes.runs.path_results import path_attrs, path_summary
from quadmodes.runs.spin_change import spin_change, spin_change_model, spin_change_path

BUILTIN = Path(__file__).resolve().parents[1] / "src" / "quadmodes" / "case" / "builtin"


@pytest.fixture(scope="module")
def rotor(tmp_path_factory):
    """(case, spin-change model about 1 rad/s with its 2 lowest driven modes) of the rotor."""
    folder = tmp_path_factory.mktemp("rotor")
    text = (BUILTIN / "string-blade-rotor.toml").read_text()
    text = text.replace("elements = 40", "elements = 12")
    text = text.replace('name = "string-blade-rotor"', 'name = "rotor-12"')
    (folder / "rotor-12.toml").write_text(text)
    case = load_case(folder / "rotor-12.toml")
    return case, spin_change_model(case, 2, 1.0)


def test_every_failing_check_is_listed(rotor):
    """Formulation L drops the spin stiffening that is this body's whole stiffness: the
    rotating-frame stiffness fails at t = 0, and with no stiffness the lag grows until the
    reduced potential is nothing like the FE model's condensed energy (1 → 1.2 rad/s). Both are
    listed, in time order, in the message and the summary (before: the first only); the first
    is where the path leaves."""
    case, model = rotor
    r = spin_change(model, 1.0, 1.2, 50.0, 50.0, formulation="L", n_out=201)
    path = spin_change_path(model, r, case, "L")
    assert not path.valid and path.left_at == 0.0
    times = [when for when, _ in path.failures]
    reasons = [reason for _, reason in path.failures]
    assert len(path.failures) >= 2 and times == sorted(times)
    assert path.failures[0] == (path.left_at, path.left_reason)
    assert any("rotating-frame stiffness" in x for x in reasons)
    assert any("condensed energy" in x for x in reasons)
    message = path.message()
    for reason in reasons:
        assert reason in message
    assert "also failing" in message
    # the same list in results.nc's attributes and read back into the summary
    attrs = path_attrs(SimpleNamespace(path=path, run=SimpleNamespace(integration=None)))
    summary = path_summary(xr.Dataset(attrs=attrs))["path_validity"]
    assert [f["reason"] for f in summary["failures"]] == reasons
    assert [f["time_s"] for f in summary["failures"]] == pytest.approx(times)


def test_a_cone_does_not_force_a_spin_changes_driven_modes(rotor):
    """The driven modes of a flat rotor spun about its normal e are in-plane (lag): moving its
    points in the plane keeps Σ m (r·e)(r·t) = 0, so J1_k has no axial–in-plane component and
    the coning (ω tilted off e, forcing ½ωᵀJ1ω at the nutation frequency) does not reach them:
    the energy-sink coning rate θ̇/θ is 0 at any cone. A rate of 0 against 0 measures nothing,
    hence the frequencies alone judge a spin change's range (the answer, the lag, is set by
    the driven modes' frequencies)."""
    _, model = rotor
    sys = rsys.reduced_system(model, "Q")
    e = np.asarray(model.reference_axis, float)
    e = e / np.linalg.norm(e)
    t1 = np.cross(e, [1.0, 0.0, 0.0] if abs(e[0]) < 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(e, t1)
    j1 = np.asarray(sys.J1, float)
    scale = np.max(np.abs(j1))
    cross = np.abs(np.einsum("kab,a,b->k", j1, e, t1)) + np.abs(np.einsum("kab,a,b->k", j1, e, t2))
    assert np.max(cross) <= 1e-9 * scale
    for cone in (0.01, 0.1, 0.3):
        rate = spin_check.coning_rate(sys, 1.0, e, cone)
        assert rate == 0.0 or abs(rate) <= 1e-12 * 1.0 / math.radians(1.0)
