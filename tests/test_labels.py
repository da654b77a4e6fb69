"""Mode labels: "breathing" only for the uniform radial mode of the closed sphere; flap and lag
for beam bending about a given spin axis."""

import re

import numpy as np
import pytest

from quadmodes.case import case_from_toml, load_case
from quadmodes.fe.model import centre_of_mass
from quadmodes.structure.labels import label_modes
from quadmodes.structure.pipeline import build_modal_model


@pytest.fixture(scope="module")
def coarse_sphere():
    """The built-in sphere on a 2 in mesh (361 nodes) with 250 modes (before: 8 "breathing")."""
    text = re.sub(r"edge_length = .*", 'edge_length = "2 in"', load_case("sphere").to_toml())
    text = re.sub(r"count = \d+", "count = 250", text)
    return build_modal_model(case_from_toml(text, source="coarse-sphere"))


def _uniform_radial_share(m, shape) -> float:
    """Share of the kinetic energy in the uniform displacement along the sphere's radius:
    (Σ m u·r̂)² / (Σ m · Σ m |u|²), with the lumped masses (independent of the labeller's
    axis and bins)."""
    w = np.asarray(m.structure.mass_scalar.sum(axis=1)).ravel()
    rel = m.x - centre_of_mass(m.structure, m.x)
    ur = np.einsum("ij,ij->i", shape, rel / np.linalg.norm(rel, axis=1)[:, None])
    return float(np.sum(w * ur) ** 2 / (w.sum() * np.sum(w * np.einsum("ij,ij->i", shape, shape))))


def test_only_the_uniform_radial_mode_of_the_sphere_is_breathing(coarse_sphere):
    m = coarse_sphere
    labels = label_modes(m.structure, m.x, m.modes.shapes)
    shares = np.array([_uniform_radial_share(m, s) for s in m.modes.shapes])
    breathing = [k for k, lab in enumerate(labels) if lab == "breathing"]
    assert breathing == [int(np.argmax(shares))] and shares[breathing[0]] > 0.8
    others = [k for k, lab in enumerate(labels) if lab.startswith("axisymmetric radial")]
    assert len(others) >= 5 and shares[others].max() < 0.05  # the old "breathing" modes
    # a pressurised membrane sphere: the uniform mode is the only one that changes the volume
    assert np.sort(shares)[-2] < 0.05


def test_beam_bending_named_flap_and_lag_about_the_spin_axis():
    """Kane's beam along x on a hub spinning about z: bending along z is flap, along y lag."""
    m = build_modal_model(load_case("kane-beam"))
    plain = label_modes(m.structure, m.x, m.modes.shapes)
    spun = label_modes(m.structure, m.x, m.modes.shapes, spin_axis=[0.0, 0.0, 1.0])
    for a, b in zip(plain, spun, strict=True):
        if a.startswith("bending z"):
            assert b == a.replace("bending z", "flap bending")
        elif a.startswith("bending y"):
            assert b == a.replace("bending y", "lag bending")
        else:
            assert b == a
    assert any(b.startswith("flap") for b in spun) and any(b.startswith("lag") for b in spun)
    # spinning about its own axis there is no plane of rotation: the plain labels
    assert label_modes(m.structure, m.x, m.modes.shapes, spin_axis=[1.0, 0.0, 0.0]) == plain
