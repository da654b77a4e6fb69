"""Closed bodies of revolution about the z axis, meshed with near-equilateral triangles.

A body is described by its meridian :class:`Profile`, a polyline in the (r, z) half-plane
running from the front pole (r = 0, smallest z) to the rear pole (r = 0, largest z).
:func:`mesh_revolution` places rings of nodes along the meridian and zips consecutive rings
together. All lengths are in metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from quadmodes.mesh.surface import TriangleSurface, orient_outward

__all__ = [
    "Profile",
    "sphere_cone_profile",
    "sphere_profile",
    "capsule_profile",
    "flat_cylinder_profile",
    "mesh_revolution",
    "nodes_near_pole",
    "sphere_cone_surface",
    "sphere_surface",
    "capsule_surface",
    "flat_cylinder_surface",
]

# Polyline sampling of circular arcs: segments per full turn. The chord sag is then
# (2 pi / 4096)^2 / 8 ~ 3e-7 of the radius, far below any mesh discretisation error.
_ARC_SEGMENTS_PER_TURN = 4096

# Trial rotations per node spacing when a ring's node count differs from its neighbour's.
_PHASE_TRIALS = 8


@dataclass(frozen=True, eq=False)
class Profile:
    """Meridian of a closed body of revolution about the z axis.

    Attributes
    ----------
    r, z : (m,) float arrays, metres
        Densely sampled polyline from the front pole to the rear pole; ``r[0] = r[-1] = 0``
        and ``r > 0`` in between.
    features : tuple of float, metres
        Arc-length positions (measured from the front pole) of points that must become mesh
        rings: tangent points between primitives and corners.
    s : (m,) float array, metres (derived)
        Cumulative arc length at each polyline vertex.
    """

    r: np.ndarray
    z: np.ndarray
    features: tuple[float, ...] = ()
    s: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        r = np.asarray(self.r, dtype=float).ravel()
        z = np.asarray(self.z, dtype=float).ravel()
        if r.shape != z.shape or r.size < 2:
            raise ValueError("profile: r and z must be 1-D arrays of equal length >= 2")
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(z))):
            raise ValueError("profile: r and z contain NaN or inf; fix the meridian samples")
        seg = np.hypot(np.diff(r), np.diff(z))
        # Drop repeated samples so that arc length is strictly increasing (for interpolation).
        keep = np.concatenate([[True], seg > 0.0])
        r, z = r[keep], z[keep]
        s = np.concatenate([[0.0], np.cumsum(seg[seg > 0.0])])
        if r.size < 3:
            raise ValueError("profile: meridian needs at least three distinct points")
        tol = 1e-9 * s[-1]
        if abs(r[0]) > tol or abs(r[-1]) > tol:
            raise ValueError("profile: meridian must start and end on the axis (r = 0 at poles)")
        if np.any(r[1:-1] <= tol):
            raise ValueError(
                "profile: r must be > 0 between the poles; a meridian touching the axis "
                "would give a non-manifold surface"
            )
        r[0] = r[-1] = 0.0
        feats = np.sort(np.asarray(self.features, dtype=float).ravel())
        if feats.size and (feats[0] < -tol or feats[-1] > s[-1] + tol):
            raise ValueError(f"profile: features must lie within the arc length [0, {s[-1]:.6g}] m")
        object.__setattr__(self, "r", r)
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "s", s)
        object.__setattr__(self, "features", tuple(float(f) for f in feats))

    @property
    def arc_length(self) -> float:
        """Total meridian length from front pole to rear pole, metres."""
        return float(self.s[-1])

    def point_at(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, z) in metres at arc-length positions ``s`` (metres, any shape)."""
        s = np.asarray(s, dtype=float)
        return np.interp(s, self.s, self.r), np.interp(s, self.s, self.z)


def _arc(zc: float, radius: float, a0: float, a1: float) -> np.ndarray:
    """Samples (k, 2) of (r, z) on a circle centred on the axis at z = zc.

    The angle a is measured from the -z direction: (r, z) = (R sin a, zc - R cos a).
    """
    n = max(8, int(np.ceil(abs(a1 - a0) / (2.0 * np.pi) * _ARC_SEGMENTS_PER_TURN)))
    a = np.linspace(a0, a1, n + 1)
    return np.column_stack([radius * np.sin(a), zc - radius * np.cos(a)])


def _assemble(pieces: list[np.ndarray]) -> Profile:
    """Concatenate (k, 2) polyline pieces; every interior joint becomes a feature point."""
    pts = [pieces[0]]
    joints = []
    for piece in pieces[1:]:
        joints.append(sum(len(p) for p in pts) - 1)
        pts.append(piece[1:])  # first sample duplicates the previous piece's last one
    rz = np.concatenate(pts)
    seg = np.hypot(*np.diff(rz, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    feats = sorted({float(s[j]) for j in joints if 0.0 < s[j] < s[-1]})
    return Profile(rz[:, 0], rz[:, 1], tuple(feats))


def _check_positive(**kwargs: float) -> None:
    for name, value in kwargs.items():
        if not (np.isfinite(value) and value > 0.0):
            raise ValueError(f"profile: {name} must be a positive finite length in m, got {value}")


def sphere_cone_profile(length: float, front_radius: float, rear_radius: float) -> Profile:
    """Front sphere + tangent cone + rear sphere, poles at z = 0 (front) and z = ``length``.

    Sphere centres lie on the z axis at z = front_radius and z = length - rear_radius, a
    distance d = length - front_radius - rear_radius apart; the cone half-angle alpha obeys
    sin(alpha) = (rear_radius - front_radius) / d, so the meridian is tangent-continuous.
    Both tangent points are feature points. All arguments in metres.
    """
    _check_positive(length=length, front_radius=front_radius, rear_radius=rear_radius)
    d = length - front_radius - rear_radius
    dr = rear_radius - front_radius
    if d <= abs(dr):
        raise ValueError(
            f"profile: length - front_radius - rear_radius = {d:.6g} m must exceed "
            f"|rear_radius - front_radius| = {abs(dr):.6g} m; increase length"
        )
    alpha = float(np.arcsin(dr / d))
    zf, zr = front_radius, length - rear_radius
    front = _arc(zf, front_radius, 0.0, 0.5 * np.pi - alpha)
    rear = _arc(zr, rear_radius, 0.5 * np.pi - alpha, np.pi)
    # The cone is the straight segment between the two tangent points (the arcs' ends).
    return _assemble([front, np.vstack([front[-1], rear[0]]), rear])


def sphere_profile(radius: float) -> Profile:
    """Sphere of ``radius`` (m) centred at z = radius; poles at z = 0 and z = 2 radius."""
    _check_positive(radius=radius)
    return _assemble([_arc(radius, radius, 0.0, np.pi)])


def capsule_profile(radius: float, length: float) -> Profile:
    """Cylinder closed by hemispherical caps; total length ``length`` (m) pole to pole.

    Poles at z = 0 and z = length; the cap/cylinder junctions are feature points.
    """
    _check_positive(radius=radius, length=length)
    if length < 2.0 * radius:
        raise ValueError(
            f"profile: capsule length {length:.6g} m must be >= 2*radius = {2 * radius:.6g} m"
        )
    front = _arc(radius, radius, 0.0, 0.5 * np.pi)
    rear = _arc(length - radius, radius, 0.5 * np.pi, np.pi)
    if length == 2.0 * radius:
        return _assemble([np.vstack([front, rear[1:]])])
    return _assemble([front, np.vstack([front[-1], rear[0]]), rear])


def flat_cylinder_profile(radius: float, length: float) -> Profile:
    """Cylinder of ``radius`` and ``length`` (m) closed by flat discs at z = 0 and z = length.

    The two rim corners are feature points.
    """
    _check_positive(radius=radius, length=length)
    corners = np.array([[0.0, 0.0], [radius, 0.0], [radius, length], [0.0, length]])
    return _assemble([corners[0:2], corners[1:3], corners[2:4]])


def local_edge_length(
    profile: Profile,
    s: np.ndarray,
    edge_length: float,
    elements_per_radius: float | None = None,
    refine_at: tuple[tuple[float, float], ...] = (),
    gradation: float = 0.3,
) -> np.ndarray:
    """Target edge length (m) at arc lengths ``s`` (m).

    ``edge_length``, reduced where the hoop radius of curvature ``ρ = r / |dz/ds|`` is small so
    that there are at least ``elements_per_radius`` edges per ``ρ`` (never below
    ``edge_length / 10``), and near each ``(s_ring, h_ring)`` of ``refine_at`` to
    ``h_ring + gradation · |s − s_ring|`` (e.g. at the edge of a rigid attachment, where the
    membrane stress is singular and frequencies converge only at first order in h).
    """
    s = np.asarray(s, float)
    h = np.full(s.shape, float(edge_length))
    if elements_per_radius:
        dz = np.gradient(profile.z, profile.s)
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = np.where(np.abs(dz) > 1e-9, profile.r / np.abs(dz), np.inf)
        # at the poles r -> 0 and dz/ds -> 0: take the neighbouring value (the cap radius)
        rho[0], rho[-1] = rho[1], rho[-2]
        rho_s = np.interp(s, profile.s, rho)
        h = np.minimum(h, np.maximum(rho_s / elements_per_radius, edge_length / 10.0))
    for s_ring, h_ring in refine_at:
        h = np.minimum(h, h_ring + gradation * np.abs(s - s_ring))
    return h


def _ring_positions(profile: Profile, step, n_fine: int = 4000) -> np.ndarray:
    """Arc-length positions of all rings including both poles, hitting every feature.

    ``step`` is a row height (m) or a callable ``step(s)`` for graded meshes: rings are placed at
    equal increments of ``∫ ds / step(s)`` between features.
    """
    knots = np.unique(np.concatenate([[0.0], profile.features, [profile.arc_length]]))
    pieces = []
    for a, b in zip(knots[:-1], knots[1:], strict=True):
        fine = np.linspace(a, b, n_fine)
        local = step(fine) if callable(step) else np.full(n_fine, float(step))
        count = np.concatenate(
            [[0.0], np.cumsum(np.diff(fine) * 0.5 / local[1:] + np.diff(fine) * 0.5 / local[:-1])]
        )
        n = max(1, int(round(count[-1])))
        pieces.append(np.interp(np.linspace(0.0, count[-1], n + 1)[:-1], count, fine))
    s = np.concatenate(pieces + [[profile.arc_length]])
    if len(s) == 2:
        # At least one ring between the poles, otherwise nothing closes.
        s = np.array([0.0, 0.5 * profile.arc_length, profile.arc_length])
    return s


def _zip_rings(ia: np.ndarray, phi_a: float, ib: np.ndarray, phi_b: float) -> np.ndarray:
    """Triangulate the band between ring A (nodes ``ia``) and ring B (nodes ``ib``).

    Ring nodes sit at angles ``phi + 2 pi k / n``. Walking around the band, the next
    triangle advances on whichever ring has the next smaller angle (a merge of two sorted
    angle lists), so rings with different node counts join without gaps. A is the ring
    nearer the front pole. Returns (len(ia) + len(ib), 3) int triangles oriented like
    ``(A_k, A_k+1, B)`` / ``(A, B_k+1, B_k)``; a single-node ring (a pole) gives a fan of
    len(ib) or len(ia) triangles instead.
    """
    na, nb = len(ia), len(ib)
    # Start B at the node whose angle is nearest to A's first node.
    jb = np.arange(nb)
    diff = np.angle(np.exp(1j * (phi_b + 2 * np.pi * jb / nb - phi_a)))
    b0 = int(np.argmin(np.abs(diff)))
    psi0 = phi_a + diff[b0]
    chi = phi_a + 2 * np.pi * np.arange(1, na + 1) / na
    psi = psi0 + 2 * np.pi * np.arange(1, nb + 1) / nb
    from_a = np.concatenate([np.ones(na, bool), np.zeros(nb, bool)])
    order = np.argsort(np.concatenate([chi, psi]), kind="stable")
    from_a = from_a[order]
    i = np.cumsum(from_a) - from_a  # A nodes passed before this step
    j = np.cumsum(~from_a) - ~from_a  # B nodes passed before this step
    a_cur, a_next = ia[i % na], ia[(i + 1) % na]
    b_cur, b_next = ib[(b0 + j) % nb], ib[(b0 + j + 1) % nb]
    tri = np.where(
        from_a[:, None],
        np.column_stack([a_cur, a_next, b_cur]),
        np.column_stack([a_cur, b_next, b_cur]),
    )
    # Fans at a pole produce zero-area "triangles" on the single-node ring; drop them.
    keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 2] != tri[:, 0])
    return tri[keep]


def _min_angle(points: np.ndarray, triangles: np.ndarray) -> float:
    """Smallest triangle angle in degrees; lean version for the many small trial bands."""
    p = points[triangles]  # (nt, 3, 3)
    l2 = np.sum((np.roll(p, -1, axis=1) - p) ** 2, axis=2)  # squared edge lengths (nt, 3)
    l2.sort(axis=1)
    a2, b2, c2 = l2.T  # the smallest angle is opposite the shortest edge (a)
    cos = (b2 + c2 - a2) / (2.0 * np.sqrt(b2 * c2))
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).min())


def mesh_revolution(
    profile: Profile,
    edge_length: float,
    elements_per_radius: float | None = None,
    refine_at: tuple[tuple[float, float], ...] = (),
) -> TriangleSurface:
    """Mesh the closed surface of revolution of ``profile`` with edges ~ ``edge_length`` (m).

    Rings of nodes are placed along the meridian with arc-length spacing close to
    ``edge_length * sqrt(3) / 2`` (the row height of equilateral triangles), hitting every
    feature point exactly. A ring of radius r gets ``max(3, round(2 pi r / edge_length))``
    equally spaced nodes; successive rings with equal counts are rotated by half a spacing,
    and where the count changes the rotation maximising the band's smallest angle is chosen
    from a few trials. Consecutive rings are joined by an angle-merging zipper; the poles are
    single nodes joined to their neighbouring ring by fans.

    With ``elements_per_radius`` the edge length is graded down where the hoop radius of
    curvature is small (see :func:`local_edge_length`), e.g. on a small front cap.

    Returns a watertight, consistently outward-oriented :class:`TriangleSurface`.
    """
    if not (np.isfinite(edge_length) and edge_length > 0.0):
        raise ValueError(f"mesh: edge_length must be a positive length in m, got {edge_length}")

    def row_height(s_: np.ndarray) -> np.ndarray:
        h_ = local_edge_length(profile, s_, edge_length, elements_per_radius, refine_at)
        return h_ * np.sqrt(3) / 2

    s = _ring_positions(profile, row_height)
    r, z = profile.point_at(s)
    r[0] = r[-1] = 0.0
    h_ring = local_edge_length(profile, s, edge_length, elements_per_radius, refine_at)
    counts = np.maximum(3, np.rint(2.0 * np.pi * r / h_ring).astype(np.int64))
    counts[0] = counts[-1] = 1
    offsets = np.concatenate([[0], np.cumsum(counts)])

    def ring_points(k: int, phase: float) -> np.ndarray:
        theta = phase + 2.0 * np.pi * np.arange(counts[k]) / counts[k]
        return np.column_stack(
            [r[k] * np.cos(theta), r[k] * np.sin(theta), np.full(counts[k], z[k])]
        )

    # Ring phases: equal counts are staggered by half a spacing (equilateral rows). When the
    # count changes no stagger is exact, so take the best of a few trial rotations, judged by
    # the smallest angle of the band they create (greedy, ring by ring from the front pole).
    phases = np.zeros(len(s))
    blocks = [ring_points(0, 0.0)]
    bands = []
    for k in range(1, len(s)):
        n_prev, n_cur = counts[k - 1], counts[k]
        ia, ib = np.arange(n_prev), n_prev + np.arange(n_cur)  # band-local node numbers
        if n_cur == n_prev:
            trials = [phases[k - 1] + np.pi / n_cur]
        elif n_cur == 1 or n_prev == 1:
            trials = [phases[k - 1]]  # a pole fan: rotation does not matter
        else:
            trials = phases[k - 1] + 2.0 * np.pi / n_cur * np.arange(_PHASE_TRIALS) / _PHASE_TRIALS
        best_quality = -np.inf
        for phase in trials:
            pts = ring_points(k, phase)
            tri = _zip_rings(ia, phases[k - 1], ib, phase)
            quality = _min_angle(np.vstack([blocks[-1], pts]), tri) if len(trials) > 1 else 0.0
            if quality > best_quality:
                best_quality, phases[k], best_pts, best_tri = quality, phase, pts, tri
        blocks.append(best_pts)
        # Band-local -> global: ring k-1 starts at offsets[k-1] = offsets[k] - n_prev.
        bands.append(best_tri + offsets[k] - n_prev)
    points = np.vstack(blocks)
    # Orientation depends on the meridian's direction of travel; fix it globally.
    return orient_outward(TriangleSurface(points, np.concatenate(bands)))


def nodes_near_pole(
    points: np.ndarray | TriangleSurface,
    pole: str,
    radius: float,
    triangles: np.ndarray | None = None,
) -> np.ndarray:
    """Indices of nodes on the cap at a pole within ``radius`` (m) of the z axis.

    The pole node is the on-axis node with the smallest z (``pole='front'``) or the largest
    z (``pole='rear'``); if no node lies on the axis, the extreme-z node nearest the axis.
    With connectivity (``triangles`` given, or a :class:`TriangleSurface` passed as
    ``points``) the cap is the set of nodes with distance to the axis <= radius connected to
    the pole through such nodes. Without it, the cap is those nodes lying on the pole's
    side of the mid-plane between the two extreme z values.

    Returns a sorted (k,) int array that always contains the pole node.
    """
    if isinstance(points, TriangleSurface):
        triangles = points.triangles if triangles is None else triangles
        points = points.points
    pts = np.asarray(points, dtype=float)
    if pole not in ("front", "rear"):
        raise ValueError(f"mesh: pole must be 'front' or 'rear', got {pole!r}")
    if not (np.isfinite(radius) and radius >= 0.0):
        raise ValueError(f"mesh: radius must be a non-negative length in m, got {radius}")
    sign = 1.0 if pole == "front" else -1.0
    z = sign * pts[:, 2]  # "front" distance: smaller means nearer the chosen pole
    rho = np.hypot(pts[:, 0], pts[:, 1])
    scale = float(np.ptp(pts, axis=0).max()) if len(pts) else 0.0
    on_axis = np.flatnonzero(rho <= 1e-9 * scale)
    if on_axis.size:
        pole_node = int(on_axis[np.argmin(z[on_axis])])
    else:
        pole_node = int(np.lexsort((rho, z))[0])
    inside = rho <= radius
    inside[pole_node] = True
    if triangles is None:
        z_mid = 0.5 * (z.min() + z.max())
        mask = inside & (z <= z_mid)
        mask[pole_node] = True
        return np.flatnonzero(mask)
    # Flood fill from the pole through nodes inside the radius; one sweep per edge ring.
    t = np.asarray(triangles, dtype=np.int64)
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    e = e[inside[e[:, 0]] & inside[e[:, 1]]]
    reached = np.zeros(len(pts), dtype=bool)
    reached[pole_node] = True
    while True:
        new = reached.copy()
        new[e[reached[e[:, 0]], 1]] = True
        if np.array_equal(new, reached):
            break
        reached = new
    return np.flatnonzero(reached)


def sphere_cone_surface(
    length: float, front_radius: float, rear_radius: float, edge_length: float
) -> TriangleSurface:
    """Mesh of :func:`sphere_cone_profile` with edges ~ ``edge_length`` (all in m)."""
    return mesh_revolution(sphere_cone_profile(length, front_radius, rear_radius), edge_length)


def sphere_surface(radius: float, edge_length: float) -> TriangleSurface:
    """Mesh of a sphere (poles at z = 0 and z = 2 radius) with edges ~ ``edge_length`` (m)."""
    return mesh_revolution(sphere_profile(radius), edge_length)


def capsule_surface(radius: float, length: float, edge_length: float) -> TriangleSurface:
    """Mesh of :func:`capsule_profile` with edges ~ ``edge_length`` (all in m)."""
    return mesh_revolution(capsule_profile(radius, length), edge_length)


def flat_cylinder_surface(radius: float, length: float, edge_length: float) -> TriangleSurface:
    """Mesh of :func:`flat_cylinder_profile` with edges ~ ``edge_length`` (all in m)."""
    return mesh_revolution(flat_cylinder_profile(radius, length), edge_length)


def ring_arc_length(profile: Profile, pole: str, radius: float) -> float:
    """Arc length (m, from the front pole) where the meridian first reaches ``radius`` (m)
    coming from ``pole``."""
    r = profile.r if pole == "front" else profile.r[::-1]
    s = profile.s if pole == "front" else profile.arc_length - profile.s[::-1]
    beyond = np.flatnonzero(r >= radius)
    if radius <= 0.0 or beyond.size == 0:
        raise ValueError(
            f"profile: no point at radius {radius:.4g} m from the {pole} pole; "
            "use a smaller attach_radius"
        )
    i = beyond[0]
    s_ring = float(np.interp(radius, [r[i - 1], r[i]], [s[i - 1], s[i]]))
    return s_ring if pole == "front" else profile.arc_length - s_ring


def with_ring_at_radius(profile: Profile, pole: str, radius: float) -> Profile:
    """``profile`` with a mesh ring forced where the meridian first reaches ``radius`` (m) from
    the ``pole`` ("front" or "rear"), so an attachment patch of that radius has a sharp edge."""
    return Profile(
        profile.r, profile.z, (*profile.features, ring_arc_length(profile, pole, radius))
    )
