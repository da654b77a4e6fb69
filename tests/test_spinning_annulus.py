"""A flat membrane annulus clamped to a free rigid hub (issue 26, second increment): the exact
image clamp, the spinning equilibrium against the clamped annulus's Lamé solution, and the
rotating-frame frequencies against the membrane equation with that prestress
(tests/reference/spinning_annulus.py, no quadmodes code), hub translation (n = 0) and gyroscopic
hub tilt (n = 1) included."""

import sys
from pathlib import Path

import numpy as np
import pytest
from reference.spinning_annulus import frequency_ratios, hub_parameters, lamb_southwell

from quadmodes.case import CaseError, case_from_toml, load_case
from quadmodes.case.editing import edit
from quadmodes.fe.build import MembraneSpec
from quadmodes.fe.hub import HubSpec
from quadmodes.fe.hub_membrane import build_hub_membrane_structure
from quadmodes.fe.model import internal_force, strain_energy, tangent_stiffness, total_mass
from quadmodes.mesh.hub_flat import annulus_surface, corner_nodes, hub_ring_nodes, square_surface
from quadmodes.mesh.surface import boundary_edges, min_angle_deg, surface_area
from quadmodes.rotations import rotation_matrix

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.studies.bench_spinning_annulus import (  # noqa: E402
    equilibrium_errors,
    fe_branches,
    model_at,
    reference_branches,
)

NU = 0.3


@pytest.fixture(scope="module")
def annulus10():
    """spinning-annulus at R/10 (362 DOFs) at 1 rad/s, 20 modes (up to 3.2 Ω)."""
    return model_at(10, 1.0, 20)


def test_meshes():
    s = annulus_surface(1.0, 0.25, 0.1)
    ring = hub_ring_nodes(s.points, 0.25)
    assert min_angle_deg(s.points, s.triangles) > 35.0
    assert set(ring) <= set(np.unique(boundary_edges(s.triangles)))
    assert len(ring) >= 16 and np.isclose(surface_area(s.points, s.triangles),
                                          np.pi * (1 - 0.25**2), rtol=0.02)  # fmt: skip
    q = square_surface(14.0, 0.8, 1.0)
    assert min_angle_deg(q.points, q.triangles) > 25.0
    corners = corner_nodes(q.points, 14.0)
    np.testing.assert_allclose(np.abs(q.points[list(corners.values()), :2]), 7.0)
    assert np.isclose(surface_area(q.points, q.triangles), 196 - np.pi * 0.64, rtol=0.01)


def _structure():
    s = annulus_surface(1.0, 0.3, 0.15)
    spec = MembraneSpec(7.5e-6, 3e9, NU, 1420.0, 0.0)
    return build_hub_membrane_structure(s.points, s.triangles, spec, HubSpec(10.0, (1.0, 1.0, 1.5)),
                                        hub_ring_nodes(s.points, 0.3))  # fmt: skip


def test_image_clamp_is_exact_for_finite_rotations():
    """The hub's rim nodes are images of the hub's DOFs: a finite rigid rotation and
    translation of hub and membrane together stores no energy and leaves no force; the force is
    the energy's gradient and the tangent the force's; the mass is hub + membrane."""
    st = _structure()
    r = rotation_matrix(np.array([0.8, 0.3, -0.5, 0.9]))  # a quaternion
    x = st.reference @ r.T + np.outer(st.translational, [1.0, 2.0, 3.0])
    assert strain_energy(st, x) < 1e-20
    k_triad = float(st.elements[0].moduli.max())  # the triad's penalty: round-off of it
    assert np.abs(internal_force(st, x)).max() < 1e-14 * k_triad
    rng = np.random.default_rng(0)
    x1 = st.reference + 1e-3 * rng.normal(size=x.shape)
    d = 1e-7 * rng.normal(size=x.shape)
    de = strain_energy(st, x1 + d) - strain_energy(st, x1 - d)
    assert np.isclose(de / 2, np.sum(internal_force(st, x1) * d), rtol=1e-6)
    df = (internal_force(st, x1 + d) - internal_force(st, x1 - d)).ravel() / 2
    kd = tangent_stiffness(st, x1) @ d.ravel()
    assert np.abs(df - kd).max() < 1e-6 * np.abs(kd).max()
    area = np.pi * (1.0 - 0.09)
    assert np.isclose(total_mass(st), 10.0 + 1420 * 7.5e-6 * area, rtol=1e-3)


def test_reference_limits():
    """The reference itself: as the hub shrinks (β → 0, n ≥ 2) Lamb & Southwell's free disc,
    and the whole body's tilt at exactly Ω among the gyroscopic n = 1 roots."""
    for n in (2, 3):
        np.testing.assert_allclose(frequency_ratios(n, 1e-3, NU, 3.6),
                                   [lamb_southwell(n, s, NU) for s in (0, 1)], rtol=1e-5)  # fmt: skip
    p = hub_parameters(307.0, 65.49, 98.24, 1420.0, 7.5e-6, 5.0)
    roots = frequency_ratios(1, 0.16, NU, 3.0, ("tilt", {**p, "gyro": 1}))
    assert np.min(np.abs(roots + 1.0)) < 1e-9


def test_equilibrium_against_lame(annulus10):
    eq = annulus10.spinning
    assert eq is not None and eq.residual < 1e-6
    pos = annulus10.structure.translational
    np.testing.assert_allclose(eq.x[pos, 2], 0.0, atol=1e-15)  # flat, hub in its plane
    stress, displacement = equilibrium_errors(annulus10)
    assert displacement < 0.015  # 1.31 % at R/10 (0.32 % at R/20)
    assert stress < 0.2  # the first ring of CSTs at the clamp, O(h): 18 % (R/10), 11 % (R/20)
    a = annulus10.x[1:4]
    np.testing.assert_allclose(a @ a.T, np.eye(3), atol=1e-8)  # the hub stays rigid


def test_branches_against_the_membrane_equation(annulus10):
    """Every branch below 3.2 Ω within 2 % at R/10 (n = 0 with the hub's mass, n = 1 with its
    inertia and gyroscopic coupling, n ≥ 2 with the hub still), the gyroscopic n = 1 within
    1.1 %; ω/Ω the same at 3 rad/s."""
    expected = reference_branches(annulus10.case, 3.2)
    found = fe_branches(annulus10, 3.2)
    assert len(expected) == 11
    for ns, ref in expected.items():
        assert abs(found[ns] / ref - 1) < 0.02, ns
    fast = fe_branches(model_at(10, 3.0, 20), 3.2)
    for ns, r in found.items():
        assert abs(fast[ns] / r - 1) < 1e-5


def test_mesh_convergence():
    """Second order: halving the edge cuts the (2, 0) and (0, 1) errors by more than 3, the
    hub-coupled (0, 0) one (0.22 % → 0.08 %) by more than 2."""
    base = load_case("spinning-annulus")
    expected = reference_branches(base, 2.5)
    coarse, fine = (fe_branches(model_at(k, 1.0, 10), 2.5) for k in (10, 20))
    for ns, factor in (((2, 0), 3), ((0, 1), 3), ((0, 0), 2)):
        assert abs(coarse[ns] / expected[ns] - 1) > factor * abs(fine[ns] / expected[ns] - 1)


def test_case_rules():
    ann = load_case("spinning-annulus")
    assert case_from_toml(ann.to_toml()) == ann
    with pytest.raises(CaseError, match=r"needs a \[hub\] table"):
        edit(ann, {"hub": None}, "test")
    with pytest.raises(CaseError, match="must be below 0.9"):
        edit(ann, {"geometry.inner_diameter": "9.5 m"}, "test")
    with pytest.raises(CaseError, match="material.damping_ratio"):
        edit(ann, {"hub.damping_ratio": 0.02}, "test")
    with pytest.raises(CaseError, match='only used with geometry.shape = "square"'):
        edit(ann, {"tip_mass": [{"name": "a", "corner": "+x+y", "mass": "1 kg",
                                 "patch": "0.2 m"}]}, "test")  # fmt: skip
    with pytest.raises(CaseError, match="inner_diameter"):
        edit(ann, {"geometry.inner_diameter": None}, "test")


def test_open_mesh_file_without_pressure(tmp_path):
    """A flat open surface read from a mesh file (meshio) with a ``[spin]`` and no pressure: the
    annulus's own mesh as a .vtu, on the same hub (``geometry.inner_diameter``), has the
    built-in case's modes; without a hub the disc's; a surface that is not flat is refused."""
    import meshio

    from quadmodes.mesh.flat import disc_surface
    from quadmodes.structure.pipeline import build_modal_model

    ann = edit(load_case("spinning-annulus"), {"modes.count": 6}, "test")
    s = annulus_surface(5.0, 0.8, 0.5)
    meshio.write(tmp_path / "ann.vtu", meshio.Mesh(s.points, [("triangle", s.triangles)]))
    geometry = {"shape": "file", "file": str(tmp_path / "ann.vtu"), "inner_diameter": "1.6 m"}
    from_file = edit(ann, {"geometry": geometry}, "test")
    a, b = build_modal_model(ann), build_modal_model(from_file)
    np.testing.assert_allclose(b.modes.frequencies_hz, a.modes.frequencies_hz, rtol=1e-9)
    d = disc_surface(1.0, 0.125)
    meshio.write(tmp_path / "disc.vtu", meshio.Mesh(d.points, [("triangle", d.triangles)]))
    disc = edit(load_case("spinning-disc"), {"mesh.edge_length": "0.125 m", "geometry.diameter": "2 m",
                                             "modes.count": 5}, "test")  # fmt: skip
    disc_file = edit(disc, {"geometry": {"shape": "file", "file": str(tmp_path / "disc.vtu")}},
                     "test")  # fmt: skip
    np.testing.assert_allclose(build_modal_model(disc_file).modes.frequencies_hz,
                               build_modal_model(disc).modes.frequencies_hz, rtol=1e-9)  # fmt: skip
    bent = d.points.copy()
    bent[:, 2] = 0.01 * bent[:, 0] ** 2
    meshio.write(tmp_path / "bent.vtu", meshio.Mesh(bent, [("triangle", d.triangles)]))
    with pytest.raises(ValueError, match="must be flat in a plane normal to z"):
        build_modal_model(edit(disc_file, {"geometry.file": str(tmp_path / "bent.vtu")}, "test"))
    with pytest.raises(CaseError, match="needs both"):
        edit(from_file, {"geometry.inner_diameter": None}, "test")


def test_image_set_energy_momentum_step():
    """The full order's step of the hub-clamped triangles: its force is a discrete gradient
    (work = energy change exactly) and its block the force's Jacobian."""
    from quadmodes.fe.assembly import assemble_matrix, assemble_vector
    from quadmodes.fe.hub_membrane import ImageSet

    st = _structure()
    rng = np.random.default_rng(1)
    x0 = st.reference + 1e-4 * rng.normal(size=st.reference.shape)
    x1 = x0 + 1e-4 * rng.normal(size=x0.shape)
    sets = [e for e in st.elements if isinstance(e, ImageSet)]
    assert len(sets) == 2  # one and two nodes on the hub

    def step(e, x):
        return assemble_vector(e.conn, e.step_force(x0, x, e.step_start(x0)), st.n)

    for e in sets:
        work = np.sum(step(e, x1) * (x1 - x0))
        assert np.isclose(work, e.energy(x1) - e.energy(x0), rtol=1e-10)
        d = 1e-9 * rng.normal(size=x0.shape)
        fd = (step(e, x1 + d) - step(e, x1 - d)).ravel() / 2
        kd = assemble_matrix(e.conn, e.step_block(x0, x1), st.n) @ d.ravel()
        assert np.abs(fd - kd).max() < 1e-6 * np.abs(kd).max()
