"""Assembled structure: end-body clusters, and the global B(u, v) and tangent of the paper model
(membrane + pressure + tie bars) against finite differences at the inflated state."""

import numpy as np
import pytest

from quadmodes.case import load_case
from quadmodes.fe.model import (
    centre_of_mass,
    inertia_tensor,
    internal_force,
    second_order_force,
    tangent_stiffness,
    total_mass,
)
from quadmodes.fe.rigid import point_mass_cluster
from quadmodes.structure.pipeline import reference_state, structure_for_case


def test_point_mass_cluster_reproduces_mass_and_inertia():
    centre = np.array([0.1, -0.2, 0.3])
    axis = np.array([0.3, 0.4, 1.0])
    pts, m = point_mass_cluster(centre, axis, 0.7, 3e-4, 2e-4, 0.05)
    assert m.sum() == pytest.approx(0.7, rel=1e-14)
    assert (m @ pts) / m.sum() == pytest.approx(centre, abs=1e-15)
    r = pts - centre
    inertia = np.trace(r.T @ (m[:, None] * r)) * np.eye(3) - r.T @ (m[:, None] * r)
    e = axis / np.linalg.norm(axis)
    expected = 2e-4 * np.eye(3) + (3e-4 - 2e-4) * np.outer(e, e)
    assert np.allclose(inertia, expected, rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="arm"):
        point_mass_cluster(centre, axis, 0.01, 3e-4, 2e-4, 0.05)


@pytest.fixture(scope="module")
def paper():
    case = load_case("paper-membrane")
    structure = structure_for_case(case)
    x, _ = reference_state(case, structure)
    return case, structure, x


def test_paper_model_mass_properties(paper):
    case, structure, x = paper
    body_mass = sum(b.mass for b in case.end_body)
    assert total_mass(structure) > body_mass
    inertia = inertia_tensor(structure, x)
    # axisymmetric about z: two equal transverse moments, the axial one smallest (minor axis)
    assert inertia[0, 0] == pytest.approx(inertia[1, 1], rel=1e-3)
    assert inertia[2, 2] < 0.1 * inertia[0, 0]
    assert np.abs(centre_of_mass(structure, x)[:2]).max() < 1e-4


def test_paper_model_tangent_and_second_order_by_finite_differences(paper):
    _, structure, x = paper
    rng = np.random.default_rng(3)
    u = 1e-3 * rng.standard_normal(x.shape)
    v = 1e-3 * rng.standard_normal(x.shape)
    h = 1e-3
    k = tangent_stiffness(structure, x)
    df = (internal_force(structure, x + h * u) - internal_force(structure, x - h * u)) / (2 * h)
    assert np.linalg.norm(df.ravel() - k @ u.ravel()) < 1e-6 * np.linalg.norm(df)
    fd2 = (
        internal_force(structure, x + h * (u + v))
        - internal_force(structure, x + h * (u - v))
        - internal_force(structure, x - h * (u - v))
        + internal_force(structure, x - h * (u + v))
    ) / (4 * h * h)
    b = second_order_force(structure, x, u, v)
    assert np.linalg.norm(2 * b - fd2) < 1e-5 * np.linalg.norm(fd2)


def test_tangent_through_the_csr_pattern_equals_the_element_sum(paper):
    """The precomputed CSR scatter map sums exactly the element matrices (against COO assembly of
    each set), and the pattern is shared by the load-stepped copy of the structure."""
    from quadmodes.fe.assembly import assemble_matrix
    from quadmodes.fe.model import stiffness_pattern, with_load_factor

    _, structure, x = paper
    k = tangent_stiffness(structure, x)
    reference = sum(assemble_matrix(e.conn, e.stiffness(x), structure.n) for e in structure.elements)
    assert k.has_canonical_format
    assert abs(k - reference).max() <= 1e-12 * abs(reference).max()
    assert stiffness_pattern(with_load_factor(structure, 0.5)) is stiffness_pattern(structure)
