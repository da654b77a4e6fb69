"""The free spinning membrane disc (issue 26): a flat membrane with no stiffness at rest, its
spinning relative equilibrium against the plane-stress closed form, and its rotating-frame
frequencies against Lamb & Southwell's (tests/reference/spinning_disc.py, no quadmodes code)."""

import re

import numpy as np
import pytest
from reference.spinning_disc import (
    frequency_ratio,
    hoop_stress,
    mode_shape,
    radial_displacement,
    radial_stress,
)

from quadmodes.case import CaseError, case_from_toml, load_case
from quadmodes.case.editing import edit
from quadmodes.fe.membrane import MembraneSet
from quadmodes.mesh.flat import disc_node_count, disc_surface
from quadmodes.mesh.surface import boundary_edges, min_angle_deg
from quadmodes.structure.pipeline import build_modal_model

RADIUS = 1.0  # m: a 2 m disc keeps the centrifugal strain below 1e-5 (linear theory holds)


def disc_case(edge_length: float, spin: float = 1.0, count: int = 9):
    """The built-in spinning-disc with a 2 m diameter, mesh edge (m), spin (rad/s), modes."""
    changes = {
        "geometry.diameter": f"{2 * RADIUS} m",
        "mesh.edge_length": f"{edge_length} m",
        "spin.rate": f"{spin} rad/s",
        "modes.count": count,
    }
    return edit(load_case("spinning-disc"), changes, "test")


def mode_numbers(labels) -> list[tuple[int, int]]:
    """(n, s) of every "disc (n=…, s=…)" label."""
    return [tuple(int(v) for v in re.findall(r"\d+", lab)) for lab in labels]


@pytest.fixture(scope="module")
def disc12():
    """Modal model of the 2 m disc on a R/12 mesh at 1 rad/s (469 nodes)."""
    return build_modal_model(disc_case(RADIUS / 12))


def test_disc_mesh():
    s = disc_surface(RADIUS, RADIUS / 8)
    assert s.n_points == disc_node_count(RADIUS, RADIUS / 8) == 1 + 3 * 8 * 9
    assert min_angle_deg(s.points, s.triangles) > 40.0
    p = s.points[s.triangles]
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(normals[:, 2] > 0.0) and np.allclose(normals[:, :2], 0.0)
    rim = np.unique(boundary_edges(s.triangles))
    assert rim.size == 6 * 8
    np.testing.assert_allclose(np.hypot(*s.points[rim, :2].T), RADIUS, rtol=1e-14)
    assert np.isclose(0.5 * np.sum(normals[:, 2]), np.pi * RADIUS**2, rtol=0.01)


def test_equilibrium_against_plane_stress_closed_form(disc12):
    """Radial displacement and principal stress resultants (σ_r < σ_θ everywhere) of the
    spinning state against the Lamé-type solution of the free spinning disc."""
    case, eq, st = disc12.case, disc12.spinning, disc12.structure
    m, spin = case.material, case.spin.rate
    assert eq is not None and disc12.prestress is None and eq.residual < 1e-6
    x0 = st.reference
    r0 = np.hypot(*x0[:, :2].T)
    u = np.einsum("ij,ij->i", (eq.x - x0)[:, :2], x0[:, :2]) / np.maximum(r0, 1e-300)
    u_ref = radial_displacement(r0, RADIUS, m.density, spin, m.poisson_ratio, m.youngs_modulus)
    assert np.max(np.abs(u - u_ref)) < 0.01 * np.max(u_ref)  # 0.47 % at the rim (R/12)
    np.testing.assert_allclose(eq.x[:, 2], 0.0, atol=1e-15)  # flat: out of the plane exactly
    membrane = next(e for e in st.elements if isinstance(e, MembraneSet))
    resultants = membrane.principal_stress_resultants(eq.x)
    rc = np.hypot(*x0[membrane.conn].mean(axis=1)[:, :2].T)
    args = (RADIUS, m.density, spin, m.poisson_ratio)
    scale = m.thickness * hoop_stress(0.0, *args)
    for k, ref in ((0, radial_stress), (1, hoop_stress)):  # constant-strain triangles: O(h)
        err = np.abs(resultants[:, k] - m.thickness * ref(rc, *args))
        assert np.max(err) < 0.025 * scale  # 1.9 % (σ_r) and 1.5 % (σ_θ) at R/12, half at R/24


def test_frequencies_against_lamb_southwell(disc12):
    """Every branch below 2.6 Ω within 1 % of the closed form (R/12 mesh), pairs whole; the
    modes are out of the plane, and their radial shapes are the terminating series."""
    ratios = 2 * np.pi * disc12.modes.frequencies_hz / disc12.case.spin.rate
    nus = mode_numbers(disc12.labels)
    expected = sorted(
        (frequency_ratio(n, s, 0.3), n, s) for n in range(8) for s in range(3)
        if (n, s) not in ((0, 0), (1, 0)) and frequency_ratio(n, s, 0.3) < 2.6
    )  # fmt: skip
    found = [(r, ns) for r, ns in zip(ratios, nus, strict=True) if r < 2.62]
    want = [(ref, (n, s)) for ref, n, s in expected for _ in range(1 if n == 0 else 2)]
    assert [ns for _, ns in found] == [ns for _, ns in want]
    for (r, ns), (ref, _) in zip(found, want, strict=True):
        assert abs(r / ref - 1.0) < 0.01, (ns, r, ref)
    # the (0, 1) shape: W = 1 − 2x² (its node circle at r = a/√2)
    i = nus.index((0, 1))
    x = disc12.structure.reference
    w = disc12.modes.shapes[i][:, 2]
    ref = mode_shape(0, 1, np.hypot(*x[:, :2].T) / RADIUS)
    assert abs(np.corrcoef(w, ref)[0, 1]) > 0.999


def test_ratios_do_not_depend_on_spin(disc12):
    """ω/Ω at 1 and 3 rad/s agree (the only stiffness is the centrifugal prestress ∝ Ω²)."""
    other = build_modal_model(disc_case(RADIUS / 12, spin=3.0))
    r1 = 2 * np.pi * disc12.modes.frequencies_hz / 1.0
    r3 = 2 * np.pi * other.modes.frequencies_hz / 3.0
    np.testing.assert_allclose(r3, r1, rtol=1e-5)
    assert other.labels == disc12.labels


def test_mesh_convergence():
    """The error against the closed form falls as h² (R/6 → R/12)."""
    errors = []
    for k in (6, 12):
        model = build_modal_model(disc_case(RADIUS / k, count=3))
        r = 2 * np.pi * model.modes.frequencies_hz[:3]
        ns = mode_numbers(model.labels)[:3]
        assert ns == [(2, 0), (2, 0), (0, 1)]
        errors.append(
            np.array([r[0] / frequency_ratio(2, 0, 0.3), r[2] / frequency_ratio(0, 1, 0.3)]) - 1
        )
    errors = np.abs(errors)
    assert np.all(errors[0] / errors[1] > 3.0)


def test_rotating_frame_roots_are_the_stiffness_modes(disc12):
    """The full order's gyroscopic roots (Coriolis included) at the spinning state equal the
    modes of its rotating-frame stiffness: out-of-plane motion meets no Coriolis force."""
    from quadmodes.analysis.rotating_modes import rotating_roots

    eq, f = disc12.spinning, disc12.modes.frequencies_hz
    roots = rotating_roots(disc12.structure, eq.x, eq.spin, eq.axis, list(f[:5]))
    elastic = np.sort(roots.frequency_hz[np.array(roots.kind) == "elastic"])
    for fk in f[:5]:
        assert np.min(np.abs(elastic - fk)) < 1e-6 * fk
    tilt = roots.frequency_hz[np.array(roots.kind) == "tilt"]
    np.testing.assert_allclose(tilt, eq.spin / (2 * np.pi), rtol=1e-6)  # (n, s) = (1, 0)


def test_case_rules():
    disc = load_case("spinning-disc")
    assert disc.pressure is None and disc.spin.rate == 1.0
    assert case_from_toml(disc.to_toml()) == disc
    with pytest.raises(CaseError, match=r"needs a \[spin\] table"):
        edit(disc, {"spin": None}, "test")
    with pytest.raises(CaseError, match="an open membrane holds no pressure"):
        edit(disc, {"pressure": {"value": "1 Pa"}}, "test")
    with pytest.raises(CaseError, match="must be positive"):
        edit(disc, {"spin.rate": "0 rad/s"}, "test")
    paper = load_case("paper-membrane")
    with pytest.raises(CaseError, match="only used for a membrane without pressure"):
        edit(paper, {"spin": {"rate": "1 rad/s"}}, "test")
    with pytest.raises(CaseError, match=r'missing; kind = "membrane" needs a \[pressure\] table'):
        edit(paper, {"pressure": None}, "test")


def test_reduced_model_about_the_spinning_state():
    """The reduced model of a disc is expanded about its spinning state (its only reference);
    linearised at its own spin it reproduces the modes, and at twice the spin the Q
    formulation keeps ω/Ω (the prestress grows as Ω² through the quadratic modes)."""
    from quadmodes.analysis.campbell import campbell
    from quadmodes.models.build import reduced_model_for

    case = disc_case(RADIUS / 6)
    rom = reduced_model_for(case, 3, use_cache=False)
    assert rom.reference_spin == case.spin.rate
    res = campbell(rom, np.array([1.0, 2.0]), np.array([0.0, 0.0, 1.0]), formulation="Q")
    for label in ("disc (n=2, s=0)", "disc (n=0, s=1)"):
        b = res.branch(label)
        w = res.frequency_hz[:, b] * 2 * np.pi
        np.testing.assert_allclose(w[0], rom.frequencies_hz[rom.labels.index(label)] * 2 * np.pi,
                                   rtol=1e-6)  # fmt: skip
        np.testing.assert_allclose(w[1] / 2.0, w[0], rtol=1e-4)


def test_run_about_the_spinning_state():
    """A reduced run of the disc spinning about its normal with a 5° cone (the built-in run case
    on a coarse mesh, 5 modes, 5 s): undamped, the cone, the spin rate and the energy keep; the
    path is inside the model's range from t = 0 (the 9.92° tilt of ω is a rigid rotation of a
    planar body; its in-plane departure, 3.06 %, measured against the model rebuilt about |ω|)
    and the membrane stays taut (it is not deformed above round-off)."""
    import quadmodes as qm
    from quadmodes.case import load_run_case

    changes = {"reduced.modes": 5, "integration.duration": "5 s"}
    run = edit(load_run_case("spinning-disc-nutation"), changes, "test")
    result = qm.simulate(run, model_case=disc_case(RADIUS / 6))
    s = qm.summary(result)
    assert s["reference"] == "spinning" and s["n_modes"] == 5
    assert abs(s["cone_angle_end_deg"] - 5.0) < 1e-6 and abs(s["cone_angle_max_deg"] - 5.0) < 1e-6
    assert abs(s["spin_rate_end_hz"] * 2 * np.pi - 1.0) < 1e-9
    assert s["energy_balance_relative_error"] < 1e-10
    path = s["path_validity"]
    assert s["valid"] and path["valid"] and path["left_range_at_s"] is None, path["message"]
    assert "membrane tension" in path["checked"] and path["taut"] is True
    assert path["centrifugal_departure_max"] == pytest.approx(np.tan(np.radians(9.92)) ** 2, rel=0.01)


def test_rotating_comparison_matches_every_branch():
    """`rotating` on the disc: the full order linearised at 1 and 3 rad/s against the reduced
    model about 1 rad/s (Q): every branch matched (the nutation, at exactly Ω for a thin disc,
    to the nutation-like root at Ω that the full order calls a tilt; the exactly degenerate
    (1, 1) pair to its own roots, not to a root outside the basis) and equal to 1e-5."""
    from quadmodes.analysis.rotating_comparison import rotating_frequency_comparison

    case = disc_case(RADIUS / 6)
    spins_hz = (1 / (2 * np.pi), 3 / (2 * np.pi))
    table = rotating_frequency_comparison(case, spins_hz, 9, ("Q",), axis="z")
    labels = {r.label for r in table.rows}
    assert {"nutation", "disc (n=1, s=1)", "disc (n=1, s=1) #2"} <= labels
    assert len(table.rows) == 2 * 10
    for r in table.rows:
        assert abs(r.rel_error["Q"]) < 1e-5, (r.spin_hz, r.label, r.full_hz)
    nutation = [r for r in table.rows if r.label == "nutation"]
    np.testing.assert_allclose([r.full_hz for r in nutation], spins_hz, rtol=1e-6)
