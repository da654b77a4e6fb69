"""Inflation and prestressed modes: thin-wall stress resultants, volume change, rigid-body modes
of the free prestressed body, frame conditions of the elastic modes, beam frequencies, and the
paper model's calibrated frequencies."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq

from quadmodes.case import load_case
from quadmodes.fe.build import MembraneSpec, build_membrane_structure
from quadmodes.fe.membrane import MembraneSet
from quadmodes.fe.model import (
    internal_force,
    mass_matrix,
    rigid_body_modes,
    tangent_stiffness,
)
from quadmodes.fe.pressure import PressureSet
from quadmodes.mesh.revolution import capsule_surface, sphere_surface
from quadmodes.structure.modes import compute_modes
from quadmodes.structure.pipeline import build_modal_model
from quadmodes.structure.prestress import inflate

# The seed's membrane: E = 0.05 Mpsi, nu = 0.3, t = 0.0045 in, rho = 0.0335 lb/in^3, 0.3 psi.
E, NU, T, RHO, P = 344.7379e6, 0.3, 1.143e-4, 927.28, 2068.43
SPEC = MembraneSpec(T, E, NU, RHO, P)


def _area_weighted(values, structure):
    membrane = next(e for e in structure.elements if isinstance(e, MembraneSet))
    w = membrane.area0
    return np.sum(values * w) / np.sum(w)


@pytest.fixture(scope="module")
def inflated_sphere():
    radius = 0.127
    surface = sphere_surface(radius, radius / 12)
    structure = build_membrane_structure(surface.points, surface.triangles, SPEC)
    return radius, structure, inflate(structure)


def test_sphere_stress_resultant_and_volume_match_finite_strain_membrane(inflated_sphere):
    radius, structure, state = inflated_sphere
    # Exact SVK sphere: t*E/(1-nu)*(l^2-1)/2 = p*R*l/2 for the stretch l; resultant n = p R l / 2.
    stretch = brentq(lambda s: T * E / (1 - NU) * (s * s - 1) - P * radius * s, 1.0, 1.5)
    n_exact = P * radius * stretch / 2
    mean = _area_weighted(state.stress_resultants.mean(1), structure)
    assert mean == pytest.approx(n_exact, rel=0.01)
    assert state.volume_change == pytest.approx(stretch**3 - 1, rel=0.01)
    assert state.residual_norm < 1e-9
    assert np.all(state.stress_resultants > 0)  # taut everywhere


def test_capsule_hoop_and_axial_resultants_mid_length():
    radius, length = 0.127, 0.762
    surface = capsule_surface(radius, length, radius / 8)
    structure = build_membrane_structure(surface.points, surface.triangles, SPEC)
    state = inflate(structure)
    tri = surface.triangles
    centroid = state.x[tri].mean(1)
    mid = np.abs(centroid[:, 2] - length / 2) < 0.15 * length
    nodes = np.unique(tri[mid])
    r_def = np.mean(np.linalg.norm(state.x[nodes, :2], axis=1))
    axial, hoop = state.stress_resultants[mid, 0], state.stress_resultants[mid, 1]
    assert np.mean(hoop) == pytest.approx(P * r_def, rel=0.01)
    assert np.mean(axial) == pytest.approx(P * r_def / 2, rel=0.01)
    # the volume change is consistent with these resultants: the cylinder's hoop strain
    hoop_strain = (P * r_def / T - NU * P * r_def / (2 * T)) / E
    assert r_def / radius - 1 == pytest.approx(hoop_strain, rel=0.03)


def test_free_prestressed_body_has_six_rigid_modes_in_the_kernel_of_k(inflated_sphere):
    _, structure, state = inflated_sphere
    x = state.x
    k = tangent_stiffness(structure, x)
    psi = rigid_body_modes(structure, x)
    scale = abs(k).sum(axis=1).max() * np.linalg.norm(psi, axis=0)
    assert np.all(np.linalg.norm(k @ psi, axis=0) / scale < 1e-12)
    # negative control: without the pressure load stiffness the rotations are not in the kernel
    no_load = replace(
        structure, elements=tuple(e for e in structure.elements if not isinstance(e, PressureSet))
    )
    k_bad = tangent_stiffness(no_load, x)
    assert np.max(np.linalg.norm(k_bad @ psi, axis=0)[3:] / scale[3:]) > 1e-8
    # equilibrium: the internal force (membrane + pressure) vanishes
    assert np.linalg.norm(internal_force(structure, x)) < 1e-9 * P * 0.127**2
    modes = compute_modes(structure, x, 6)
    assert len(modes.rigid_frequencies_hz) == 6
    assert np.all(np.abs(modes.rigid_frequencies_hz) < 1e-3 * modes.frequencies_hz[0])


def test_elastic_modes_are_mass_normalised_and_satisfy_frame_conditions(inflated_sphere):
    _, structure, state = inflated_sphere
    x = state.x
    modes = compute_modes(structure, x, 8)
    m = mass_matrix(structure)
    phi = modes.shapes.reshape(len(modes.frequencies_hz), -1).T
    assert np.allclose(phi.T @ (m @ phi), np.eye(phi.shape[1]), atol=1e-9)
    # centre of mass (S1) and mean axes (c = C(X, u)) of every mode vanish
    ms = structure.mass_scalar
    w = ms @ np.ones(structure.n)
    xc = x - (w @ x) / w.sum()
    for shape in modes.shapes:
        s1 = w @ shape
        c = np.cross(xc, ms @ shape).sum(0)
        scale = np.sqrt(w.sum()) * np.abs(shape).max()
        assert np.linalg.norm(s1) < 1e-10 * scale
        assert np.linalg.norm(c) < 1e-10 * scale * np.abs(xc).max()
    # degenerate sets are kept whole: the last kept frequency is not split from a partner
    f = modes.frequencies_hz
    k_eig = np.array([(2 * np.pi * fk) ** 2 for fk in f])
    kphi = tangent_stiffness(structure, x) @ phi
    residual = np.linalg.norm(kphi - (m @ phi) * k_eig, axis=0) / np.linalg.norm(kphi, axis=0)
    assert np.all(residual < 1e-6)


def test_kane_beam_cantilever_frequencies_through_the_pipeline():
    model = build_modal_model(load_case("kane-beam"))
    scale = np.sqrt(1.2 * 10.0**4 / 1.4e4)
    bending = model.modes.omega * scale
    expected = np.repeat([3.5160, 22.0345, 61.6972], 2)
    assert np.allclose(bending[:6], expected, rtol=0.005)
    assert all(lab.startswith("bending") for lab in model.labels[:6])
    assert len(model.modes.rigid_frequencies_hz) == 0


def test_paper_membrane_calibrated_frequencies():
    model = build_modal_model(load_case("paper-membrane"))
    f, labels = model.modes.frequencies_hz, model.labels
    rocking = [fk for fk, lab in zip(f, labels, strict=True) if lab == "rocking (rear mass)"]
    bending = [fk for fk, lab in zip(f, labels, strict=True) if lab == "bending"]
    axial = [fk for fk, lab in zip(f, labels, strict=True) if lab == "axial (rear mass)"]
    assert len(rocking) >= 2 and len(bending) >= 2 and axial
    assert np.mean(rocking[:2]) == pytest.approx(31.2, rel=0.01)
    assert np.mean(bending[:2]) == pytest.approx(38.0, rel=0.01)
    # the seed's order: rocking pair (modes 1-2), rear axial (3), bending pair (4-5)
    assert labels[:5] == ["rocking (rear mass)"] * 2 + ["axial (rear mass)"] + ["bending"] * 2
    assert np.all(np.abs(model.modes.rigid_frequencies_hz) < 1e-3 * f[0])


def test_gas_law_adds_volume_stiffness_only_to_volume_changing_modes():
    from quadmodes.case import case_from_toml

    base = """
name = "gas-sphere"
kind = "membrane"
[geometry]
shape = "sphere"
diameter = "10 in"
[mesh]
edge_length = "1.5 in"
[material]
density = "0.0335 lb/in^3"
youngs_modulus = "0.05 Mpsi"
poisson_ratio = 0.3
thickness = "0.0045 in"
[pressure]
value = "0.3 psi"
gas_law_exponent = KAPPA
[modes]
count = 40
"""
    const = build_modal_model(case_from_toml(base.replace("KAPPA", "0")))
    gas = build_modal_model(case_from_toml(base.replace("KAPPA", "1.4")))
    # modes with n >= 1 keep the volume to first order: unchanged frequencies
    assert np.allclose(gas.modes.frequencies_hz[:8], const.modes.frequencies_hz[:8], rtol=1e-6)
    # a uniform radial (breathing) motion gains exactly the gas stiffness κ p (∇V·u)² / V
    from quadmodes.fe.model import tangent_low_rank
    from quadmodes.fe.pressure import volume_gradient

    x = gas.x
    u = (x - x.mean(0)) / np.linalg.norm(x - x.mean(0), axis=1)[:, None]
    ((coef, vec),) = tangent_low_rank(gas.structure, x)
    grad = volume_gradient(x, gas.structure.elements[1].conn)
    volume = gas.structure.elements[1].volume(x)
    assert coef == pytest.approx(1.4 * P / volume, rel=1e-3)
    assert coef * (vec @ u.ravel()) ** 2 == pytest.approx(
        1.4 * P * np.sum(grad * u) ** 2 / volume, rel=1e-3
    )
