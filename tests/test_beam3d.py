"""The 3-D beam (torsion, section rotary inertia) and the rigid hub with booms: derivatives,
frame invariance, rigid-body modes, closed-form frequencies, inertia and the exact clamp."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl
from scipy.spatial.transform import Rotation

from quadmodes.fe.assembly import assemble_matrix, assemble_scalar_matrix, assemble_vector
from quadmodes.fe.beam import beam_sets, chain_connectivity, solid_section, straight_beam_nodes
from quadmodes.fe.hub import BoomSpec, HubSpec, build_hub_structure
from quadmodes.fe.model import (
    Structure,
    inertia_tensor,
    internal_force,
    mass_matrix,
    strain_energy,
    tangent_stiffness,
    total_mass,
)

E, RHO, RADIUS = 7e10, 2700.0, 0.01
AREA, SECOND = np.pi * RADIUS**2, np.pi * RADIUS**4 / 4
G = E / 2.6


def free_rod(length=2.0, n_elements=24) -> Structure:
    ref, tr = straight_beam_nodes([-length / 2, 0, 0], [length / 2, 0, 0], n_elements)
    conn = chain_connectivity(0, n_elements)
    sets = beam_sets(conn, length / n_elements, solid_section(AREA, SECOND, E, RHO))
    n = len(ref)
    return Structure(ref, tr, sets, assemble_scalar_matrix(conn, sets[0].mass(), n),
                     np.zeros((n, 3), bool))  # fmt: skip


def hub_with_booms(hub_mass=20.0, inertia=(1.0, 1.2, 0.8), n_elements=8) -> Structure:
    section = solid_section(AREA, SECOND, E, RHO)
    booms = [
        BoomSpec(f"b{k}", (0.3 * np.cos(a), 0.3 * np.sin(a), 0.0), (np.cos(a), np.sin(a), 0.0),
                 1.5, n_elements, section, (0.0, 0.0, 1.0))  # fmt: skip
        for k, a in enumerate(np.arange(4) * np.pi / 2)
    ]
    return build_hub_structure(HubSpec(hub_mass, inertia), booms)


def frequencies_hz(structure: Structure) -> np.ndarray:
    k = tangent_stiffness(structure, structure.reference).toarray()
    w2 = sl.eigh(k, mass_matrix(structure).toarray(), eigvals_only=True)
    return np.sqrt(np.abs(w2)) / (2 * np.pi)


@pytest.mark.parametrize("make", [free_rod, hub_with_booms])
def test_force_tangent_and_second_order_are_the_derivatives_of_the_energy(make):
    s = make()
    rng = np.random.default_rng(3)
    x = s.reference + 0.03 * rng.standard_normal(s.reference.shape)
    dx, u, v = (rng.standard_normal(x.shape) for _ in range(3))
    h = 1e-6
    dw = (strain_energy(s, x + h * dx) - strain_energy(s, x - h * dx)) / (2 * h)
    assert np.sum(internal_force(s, x) * dx) == pytest.approx(dw, rel=1e-6)
    kdx = tangent_stiffness(s, x) @ dx.ravel()
    fd = (internal_force(s, x + h * dx) - internal_force(s, x - h * dx)).ravel() / (2 * h)
    assert np.linalg.norm(fd - kdx) < 1e-6 * np.linalg.norm(kdx)
    b = sum(assemble_vector(e.conn, e.second_order(x, u, v), s.n) for e in s.elements)
    dk = (tangent_stiffness(s, x + h * v) - tangent_stiffness(s, x - h * v)) / (2 * h)
    b_fd = 0.5 * (dk @ u.ravel())
    assert np.linalg.norm(b.ravel() - b_fd) < 1e-6 * np.linalg.norm(b_fd)


def test_energy_momentum_step_force_does_exact_work_and_its_block_is_its_jacobian():
    s = hub_with_booms()
    rng = np.random.default_rng(4)
    x0 = s.reference + 0.02 * rng.standard_normal(s.reference.shape)
    x1 = x0 + 0.02 * rng.standard_normal(x0.shape)

    def step(y):
        return sum(assemble_vector(e.conn, e.step_force(x0, y), s.n) for e in s.elements)

    work = float(np.sum(step(x1) * (x1 - x0)))
    assert work == pytest.approx(strain_energy(s, x1) - strain_energy(s, x0), rel=1e-10)
    jac = sum(assemble_matrix(e.conn, e.step_block(x0, x1), s.n) for e in s.elements)
    d, h = rng.standard_normal(x0.shape), 1e-6
    fd = (step(x1 + h * d) - step(x1 - h * d)).ravel() / (2 * h)
    assert np.linalg.norm(fd - jac @ d.ravel()) < 1e-6 * np.linalg.norm(fd)


@pytest.mark.parametrize("make", [free_rod, hub_with_booms])
def test_energy_is_invariant_under_finite_rigid_motions(make):
    s = make()
    rng = np.random.default_rng(5)
    x = s.reference + 0.01 * rng.standard_normal(s.reference.shape)
    q = Rotation.from_rotvec([1.1, -0.7, 2.3]).as_matrix()
    moved = x @ q.T + np.outer(s.translational, [3.0, -1.0, 0.5])
    assert strain_energy(s, moved) == pytest.approx(strain_energy(s, x), rel=1e-12)


@pytest.mark.parametrize("make", [free_rod, hub_with_booms])
def test_a_free_body_has_exactly_six_rigid_body_modes(make):
    f = frequencies_hz(make())
    assert np.all(f[:6] < 1e-2) and f[6] > 1e3 * max(f[5], 1e-6)


def test_free_free_rod_frequencies_match_closed_forms():
    """Euler–Bernoulli bending (βL = 4.7300, 7.8532, 10.9956) lowered by the section's rotary
    inertia by about ½ (r_g β)² (Rayleigh beam; 0.5–4e-4 here), St Venant torsion f = (1/2L)√(G/ρ) (circular: J = I_p) and
    extension f = (1/2L)√(E/ρ), on 24 elements."""
    length = 2.0
    f = frequencies_hz(free_rod(length))
    elastic = f[6:]
    bending = [b**2 / (2 * np.pi * length**2) * np.sqrt(E * SECOND / (RHO * AREA))
               for b in (4.730040745, 7.853204624, 10.99560784)]  # fmt: skip
    r_g2 = SECOND / AREA  # radius of gyration² of the section
    for k, (fb, bl) in enumerate(zip(bending, (4.730040745, 7.853204624, 10.99560784),
                                     strict=True)):  # fmt: skip
        # rotary inertia lowers a mode by about ½ (r_g β)² (Rayleigh); bound it by (r_g β)²
        drop = 1.0 - elastic[2 * k : 2 * k + 2] / fb  # degenerate pair (y and z)
        assert np.all(drop > 0.1 * r_g2 * (bl / length) ** 2), drop
        assert np.all(drop < r_g2 * (bl / length) ** 2 + 5e-5), drop
    # twist: linear directors with consistent mass over-estimate by (kh)²/24 (k = π/L)
    kh = np.pi / 24
    torsion = np.sqrt(G / RHO) / (2 * length) * (1 + kh**2 / 24)
    axial = np.sqrt(E / RHO) / (2 * length)  # cubic Hermite centreline: converged
    assert np.min(np.abs(elastic / torsion - 1)) < 1e-4
    assert np.min(np.abs(elastic / axial - 1)) < 1e-4


def test_free_rod_inertia_includes_the_polar_rotary_inertia():
    length = 2.0
    s = free_rod(length)
    m = RHO * AREA * length
    j = inertia_tensor(s, s.reference)
    assert total_mass(s) == pytest.approx(m, rel=1e-12)
    assert j[0, 0] == pytest.approx(RHO * 2 * SECOND * length, rel=1e-12)
    assert j[1, 1] == pytest.approx(m * length**2 / 12 + RHO * SECOND * length, rel=1e-12)
    assert j[2, 2] == pytest.approx(j[1, 1], rel=1e-12)


def test_hub_with_booms_mass_and_inertia_are_the_sums_of_the_parts():
    s = hub_with_booms(inertia=(1.0, 1.2, 0.8))
    rho_a, length, r0 = RHO * AREA, 1.5, 0.3
    boom_mass = rho_a * length
    # a boom along x from r0 to r0 + L: ∫ρA x² dx about the hub centre; section terms ρI L
    along = rho_a * ((r0 + length) ** 3 - r0**3) / 3
    section = RHO * SECOND * length
    assert total_mass(s) == pytest.approx(20.0 + 4 * boom_mass, rel=1e-12)
    j = inertia_tensor(s, s.reference)
    # two booms along x (I_yy, I_zz get ∫x²; I_xx the polar 2ρI L), two along y
    ixx = 1.0 + 2 * (along + section) + 2 * (2 * section)
    izz = 0.8 + 4 * (along + section)
    assert j[0, 0] == pytest.approx(ixx, rel=1e-10)
    assert j[1, 1] == pytest.approx(1.2 - 1.0 + ixx, rel=1e-10)
    assert j[2, 2] == pytest.approx(izz, rel=1e-10)


def test_booms_on_a_very_heavy_hub_vibrate_as_clamped_cantilevers():
    """The root is tied to the hub exactly: with a hub 1e6 times heavier the boom modes are the
    clamped–free Euler–Bernoulli frequencies (β L = 1.8751, 4.6941), four booms × two planes."""
    s = hub_with_booms(hub_mass=1e8, inertia=(1e7, 1.2e7, 0.8e7), n_elements=16)
    f = frequencies_hz(s)[6:]
    length = 1.5
    for k, b in enumerate((1.875104069, 4.694091133)):
        fc = b**2 / (2 * np.pi * length**2) * np.sqrt(E * SECOND / (RHO * AREA))
        group = f[8 * k : 8 * k + 8]
        assert np.allclose(group, fc, rtol=1e-3), (group, fc)
