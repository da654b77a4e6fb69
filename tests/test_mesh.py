"""Tests for the geometry/mesh stage (quadmodes.mesh). Lengths in metres."""

import meshio
import numpy as np
import pytest

from quadmodes.mesh import (
    TriangleSurface,
    boundary_edges,
    capsule_profile,
    capsule_surface,
    check_closed_surface,
    enclosed_volume,
    flat_cylinder_profile,
    flat_cylinder_surface,
    is_consistently_oriented,
    is_watertight,
    min_angle_deg,
    nodes_near_pole,
    non_manifold_edges,
    orient_outward,
    read_surface,
    sphere_cone_profile,
    sphere_cone_surface,
    sphere_profile,
    sphere_surface,
    surface_area,
    surface_report,
    triangle_angles_deg,
    write_surface,
)

# ---------------------------------------------------------------------------------------------
# analytic references


def cap_volume(radius, height):
    """Spherical cap of sphere ``radius`` cut at ``height`` from its pole."""
    return np.pi * height**2 * (3.0 * radius - height) / 3.0


def frustum_volume(r1, r2, height):
    return np.pi * height * (r1**2 + r1 * r2 + r2**2) / 3.0


def sphere_cone_volume(length, rf, rr):
    """Front cap + tangent cone frustum + rear cap."""
    d = length - rf - rr
    sin_a = (rr - rf) / d
    cos_a = np.sqrt(1.0 - sin_a**2)
    h_front = rf * (1.0 - sin_a)  # pole to front tangent plane
    h_rear = rr * (1.0 + sin_a)  # rear tangent plane to pole
    h_cone = length - h_front - h_rear  # = d cos^2(alpha)
    return (
        cap_volume(rf, h_front)
        + frustum_volume(rf * cos_a, rr * cos_a, h_cone)
        + cap_volume(rr, h_rear)
    )


def capsule_volume(radius, length):
    return np.pi * radius**2 * (length - 2.0 * radius) + 4.0 / 3.0 * np.pi * radius**3


def unit_cube():
    """Closed, outward-oriented unit cube [0,1]^3 with 12 triangles."""
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    quads = [
        (0, 2, 3, 1),  # z = 0, normal -z
        (4, 5, 7, 6),  # z = 1, normal +z
        (0, 1, 5, 4),  # y = 0, normal -y
        (2, 6, 7, 3),  # y = 1, normal +y
        (0, 4, 6, 2),  # x = 0, normal -x
        (1, 3, 7, 5),  # x = 1, normal +x
    ]
    tri = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return TriangleSurface(pts, np.array(tri))


SHAPES = {
    "sphere": lambda h: sphere_surface(0.5, h),
    "capsule": lambda h: capsule_surface(0.3, 1.5, h),
    "sphere_cone": lambda h: sphere_cone_surface(1.2, 0.1, 0.35, h),
    "cone_reversed": lambda h: sphere_cone_surface(1.2, 0.35, 0.1, h),
    "flat_cylinder": lambda h: flat_cylinder_surface(0.4, 0.8, h),
}


# ---------------------------------------------------------------------------------------------
# surface utilities


def test_cube_volume_area_and_topology():
    cube = unit_cube()
    assert enclosed_volume(cube.points, cube.triangles) == pytest.approx(1.0, abs=1e-14)
    assert surface_area(cube.points, cube.triangles) == pytest.approx(6.0, abs=1e-14)
    assert is_watertight(cube.triangles)
    assert is_consistently_oriented(cube.triangles)
    check_closed_surface(cube)
    rep = surface_report(cube)
    assert rep["n_points"] == 8 and rep["n_triangles"] == 12
    assert rep["min_edge_m"] == pytest.approx(1.0)
    assert rep["max_edge_m"] == pytest.approx(np.sqrt(2.0))
    assert rep["min_angle_deg"] == pytest.approx(45.0)


def test_triangle_angles_sum_to_180():
    surf = sphere_surface(1.0, 0.3)
    ang = triangle_angles_deg(surf.points, surf.triangles)
    assert ang.shape == (surf.n_triangles, 3)
    np.testing.assert_allclose(ang.sum(axis=1), 180.0, atol=1e-9)
    corner = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    right = triangle_angles_deg(corner, np.array([[0, 1, 2]]))
    np.testing.assert_allclose(right[0], [90.0, 45.0, 45.0])


def test_edge_classification():
    cube = unit_cube()
    assert len(boundary_edges(cube.triangles)) == 0
    assert len(non_manifold_edges(cube.triangles)) == 0
    open_tri = cube.triangles[1:]
    assert boundary_edges(open_tri).shape == (3, 2)
    assert not is_watertight(open_tri)
    doubled = np.vstack([cube.triangles, cube.triangles[:1]])
    assert len(non_manifold_edges(doubled)) == 3
    assert not is_watertight(doubled)


def test_triangle_surface_validates_shapes():
    with pytest.raises(ValueError, match="points"):
        TriangleSurface(np.zeros((4, 2)), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="indices"):
        TriangleSurface(np.zeros((3, 3)), np.array([[0, 1, 3]]))


# ---------------------------------------------------------------------------------------------
# check_closed_surface failures


@pytest.fixture(scope="module")
def sphere():
    return sphere_surface(1.0, 0.25)


def _one_line(exc):
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("mesh:")
    return msg


def test_check_open_surface(sphere):
    holed = TriangleSurface(sphere.points, sphere.triangles[1:])
    with pytest.raises(ValueError, match=r"open \(3 boundary edges\)") as exc:
        check_closed_surface(holed)
    _one_line(exc)


def test_check_inward_surface(sphere):
    flipped = TriangleSurface(sphere.points, sphere.triangles[:, ::-1])
    assert is_watertight(flipped.triangles) and is_consistently_oriented(flipped.triangles)
    with pytest.raises(ValueError, match="inward") as exc:
        check_closed_surface(flipped)
    assert "flip the normals" in _one_line(exc) and "geometry.file" in _one_line(exc)
    fixed = orient_outward(flipped)
    check_closed_surface(fixed)
    assert orient_outward(sphere) is sphere


def test_check_one_flipped_triangle(sphere):
    tri = sphere.triangles.copy()
    tri[7] = tri[7, ::-1]
    assert not is_consistently_oriented(tri)
    with pytest.raises(ValueError, match="inconsistent") as exc:
        check_closed_surface(TriangleSurface(sphere.points, tri))
    _one_line(exc)


def test_check_non_manifold_and_degenerate():
    cube = unit_cube()
    doubled = TriangleSurface(cube.points, np.vstack([cube.triangles, cube.triangles[:1, ::-1]]))
    with pytest.raises(ValueError, match="non-manifold") as exc:
        check_closed_surface(doubled)
    _one_line(exc)
    # Tetrahedron whose apex sits on a base corner: triangles through that edge have no area.
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0.0]])
    tet = TriangleSurface(pts, np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]]))
    with pytest.raises(ValueError, match="degenerate") as exc:
        check_closed_surface(tet)
    _one_line(exc)
    with pytest.raises(ValueError, match="no triangles"):
        check_closed_surface(TriangleSurface(pts, np.zeros((0, 3), dtype=int)))


# ---------------------------------------------------------------------------------------------
# profiles


def test_sphere_cone_profile_geometry():
    length, rf, rr = 1.2, 0.1, 0.35
    prof = sphere_cone_profile(length, rf, rr)
    assert prof.r[0] == 0.0 and prof.r[-1] == 0.0
    assert prof.z[0] == pytest.approx(0.0) and prof.z[-1] == pytest.approx(length)
    d = length - rf - rr
    alpha = np.arcsin((rr - rf) / d)
    s1, s2 = prof.features
    assert s1 == pytest.approx(rf * (np.pi / 2 - alpha), rel=1e-6)
    assert s2 - s1 == pytest.approx(d * np.cos(alpha), rel=1e-9)
    assert prof.arc_length == pytest.approx(
        rf * (np.pi / 2 - alpha) + d * np.cos(alpha) + rr * (np.pi / 2 + alpha), rel=1e-6
    )
    r1, z1 = prof.point_at(s1)
    r2, z2 = prof.point_at(s2)
    # Tangent points lie on the spheres and the cone between them has half-angle alpha.
    assert np.hypot(r1, z1 - rf) == pytest.approx(rf, rel=1e-12)
    assert np.hypot(r2, z2 - (length - rr)) == pytest.approx(rr, rel=1e-12)
    assert np.arctan2(r2 - r1, z2 - z1) == pytest.approx(alpha, rel=1e-12)
    # Every sample lies on one of the three primitives.
    on_front = np.abs(np.hypot(prof.r, prof.z - rf) - rf) < 1e-12
    on_rear = np.abs(np.hypot(prof.r, prof.z - (length - rr)) - rr) < 1e-12
    assert np.all(on_front | on_rear)


def test_simple_profiles():
    sp = sphere_profile(0.5)
    assert sp.z[-1] == pytest.approx(1.0) and sp.arc_length == pytest.approx(np.pi * 0.5, 1e-6)
    cp = capsule_profile(0.3, 1.5)
    assert cp.z[-1] == pytest.approx(1.5) and len(cp.features) == 2
    assert cp.features[1] - cp.features[0] == pytest.approx(0.9)
    fp = flat_cylinder_profile(0.4, 0.8)
    assert fp.features == pytest.approx((0.4, 1.2)) and fp.arc_length == pytest.approx(1.6)


@pytest.mark.parametrize(
    "call, word",
    [
        (lambda: sphere_cone_profile(1.0, 0.1, 0.9), "length"),
        (lambda: sphere_cone_profile(1.0, -0.1, 0.2), "front_radius"),
        (lambda: sphere_cone_profile(1.0, 0.1, 0.0), "rear_radius"),
        (lambda: capsule_profile(0.5, 0.8), "length"),
        (lambda: sphere_profile(float("nan")), "radius"),
        (lambda: flat_cylinder_profile(0.2, 0.0), "length"),
        (lambda: sphere_surface(1.0, 0.0), "edge_length"),
    ],
)
def test_invalid_arguments(call, word):
    with pytest.raises(ValueError, match=word) as exc:
        call()
    assert "\n" not in str(exc.value)


# ---------------------------------------------------------------------------------------------
# generated meshes


def test_sphere_converges():
    radius = 1.0
    v_ref, a_ref = 4.0 / 3.0 * np.pi * radius**3, 4.0 * np.pi * radius**2
    errors = []
    for h in (radius / 5, radius / 10, radius / 20):
        s = sphere_surface(radius, h)
        v = enclosed_volume(s.points, s.triangles)
        a = surface_area(s.points, s.triangles)
        errors.append((abs(v - v_ref) / v_ref, abs(a - a_ref) / a_ref))
        # Nodes lie on the sphere (centre at z = radius).
        dist = np.linalg.norm(s.points - [0.0, 0.0, radius], axis=1)
        np.testing.assert_allclose(dist, radius, rtol=1e-6)
    errors = np.array(errors)
    assert np.all(np.diff(errors, axis=0) < 0.0)
    assert errors[-1, 0] < 0.01 and errors[-1, 1] < 0.01


@pytest.mark.parametrize("rf, rr", [(0.1, 0.35), (0.35, 0.1), (0.2, 0.2)])
def test_sphere_cone_volume(rf, rr):
    length = 1.2
    s = sphere_cone_surface(length, rf, rr, 0.03)
    v = enclosed_volume(s.points, s.triangles)
    assert v == pytest.approx(sphere_cone_volume(length, rf, rr), rel=0.01)
    assert s.points[:, 2].min() == pytest.approx(0.0, abs=1e-12)
    assert s.points[:, 2].max() == pytest.approx(length, abs=1e-12)


def test_capsule_and_flat_cylinder_volume():
    s = capsule_surface(0.3, 1.5, 0.03)
    assert enclosed_volume(s.points, s.triangles) == pytest.approx(
        capsule_volume(0.3, 1.5), rel=0.01
    )
    f = flat_cylinder_surface(0.4, 0.8, 0.04)
    assert enclosed_volume(f.points, f.triangles) == pytest.approx(
        np.pi * 0.4**2 * 0.8, rel=0.01
    )
    # Corners are mesh rings: every node is on a disc or on the wall, and rims are present.
    rho = np.hypot(f.points[:, 0], f.points[:, 1])
    z = f.points[:, 2]
    on_disc = np.isclose(z, 0.0, atol=1e-12) | np.isclose(z, 0.8, atol=1e-12)
    assert np.all(on_disc | np.isclose(rho, 0.4, rtol=1e-9))
    assert np.count_nonzero(np.isclose(rho, 0.4) & np.isclose(z, 0.0, atol=1e-12)) >= 3


@pytest.mark.parametrize("name", sorted(SHAPES))
@pytest.mark.parametrize("h", [0.2, 0.07, 0.025])
def test_generated_surfaces_are_valid(name, h):
    s = SHAPES[name](h)
    assert is_watertight(s.triangles)
    assert is_consistently_oriented(s.triangles)
    assert enclosed_volume(s.points, s.triangles) > 0.0
    check_closed_surface(s)
    assert min_angle_deg(s.points, s.triangles) >= 25.0
    rep = surface_report(s)
    if rep["n_points"] > 200:  # edge lengths track the request once the mesh resolves the body
        assert 0.6 * h < rep["min_edge_m"] and rep["max_edge_m"] < 1.8 * h


def test_coarse_mesh_still_closed():
    s = sphere_surface(1.0, 10.0)  # edge far longer than the body: minimal bipyramid
    check_closed_surface(s)
    assert s.n_points >= 5


# ---------------------------------------------------------------------------------------------
# pole selection


@pytest.mark.parametrize("use_connectivity", [False, True])
def test_nodes_near_pole(use_connectivity):
    radius, cap = 1.0, 0.3
    s = sphere_surface(radius, 0.1)
    rho = np.hypot(s.points[:, 0], s.points[:, 1])
    z = s.points[:, 2]
    for pole, z_pole in (("front", 0.0), ("rear", 2 * radius)):
        if use_connectivity:
            idx = nodes_near_pole(s, pole, cap)
        else:
            idx = nodes_near_pole(s.points, pole, cap)
        pole_node = np.flatnonzero((rho < 1e-12) & np.isclose(z, z_pole, atol=1e-12))
        assert len(pole_node) == 1 and pole_node[0] in idx
        assert np.all(rho[idx] <= cap)
        assert np.all(np.abs(z[idx] - z_pole) < radius)
        expected = np.flatnonzero((rho <= cap) & (np.abs(z - z_pole) < radius))
        np.testing.assert_array_equal(np.sort(idx), expected)


def test_nodes_near_pole_flat_disc_uses_connectivity():
    f = flat_cylinder_surface(0.4, 0.8, 0.05)
    rho = np.hypot(f.points[:, 0], f.points[:, 1])
    idx = nodes_near_pole(f, "rear", 0.2)
    assert np.all(np.isclose(f.points[idx, 2], 0.8)) and np.all(rho[idx] <= 0.2)
    assert len(idx) == np.count_nonzero(np.isclose(f.points[:, 2], 0.8) & (rho <= 0.2))
    with pytest.raises(ValueError, match="pole"):
        nodes_near_pole(f, "top", 0.2)


# ---------------------------------------------------------------------------------------------
# io


def test_vtu_round_trip(tmp_path):
    s = capsule_surface(0.3, 1.0, 0.1)
    path = tmp_path / "capsule.vtu"
    pressure = np.linspace(0.0, 1.0, s.n_triangles)
    write_surface(path, s, point_data={"u": s.points * 2.0}, cell_data={"p": pressure})
    back = read_surface(path)
    np.testing.assert_array_equal(back.triangles, s.triangles)
    np.testing.assert_allclose(back.points, s.points, rtol=0, atol=1e-15)
    raw = meshio.read(path)
    np.testing.assert_allclose(raw.point_data["u"], s.points * 2.0)
    np.testing.assert_allclose(raw.cell_data["p"][0], pressure)
    with pytest.raises(ValueError, match="point_data"):
        write_surface(path, s, point_data={"bad": np.zeros(3)})


def test_read_errors_name_the_file(tmp_path):
    missing = tmp_path / "missing.vtu"
    with pytest.raises(ValueError, match="missing.vtu") as exc:
        read_surface(missing)
    assert "\n" not in str(exc.value)
    lines = tmp_path / "lines.vtu"
    meshio.write(lines, meshio.Mesh(np.zeros((2, 3)), [("line", np.array([[0, 1]]))]))
    with pytest.raises(ValueError, match=r"lines\.vtu.*no triangle"):
        read_surface(lines)


def test_read_drops_unused_points(tmp_path):
    cube = unit_cube()
    pts = np.vstack([[9.0, 9.0, 9.0], cube.points])  # unused node 0
    path = tmp_path / "cube.vtu"
    meshio.write(path, meshio.Mesh(pts, [("triangle", cube.triangles + 1)]))
    back = read_surface(path)
    assert back.n_points == 8
    check_closed_surface(back)
    assert enclosed_volume(back.points, back.triangles) == pytest.approx(1.0)
