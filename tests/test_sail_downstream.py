"""Downstream analyses on a body with no stiffness at rest (issue 26 items 5–7): the Campbell
sweep from spin 0, the default spin axis of `rotating`, branch tracking between far-apart
spins. On the free spinning membrane disc (2 m, R/6 mesh), whose every frequency is ∝ Ω."""

import numpy as np
import pytest

from quadmodes.case import load_case
from quadmodes.case.editing import edit

RADIUS = 1.0  # m


def disc_case(edge_length: float, spin: float = 1.0):
    changes = {"geometry.diameter": f"{2 * RADIUS} m", "mesh.edge_length": f"{edge_length} m",
               "spin.rate": f"{spin} rad/s"}  # fmt: skip
    return edit(load_case("spinning-disc"), changes, "test")


@pytest.fixture(scope="module")
def disc_rom():
    """Reduced model (Q, 7 modes: the nutation-free tilt is the frame; (2, 0) pair, (0, 1),
    (3, 0) pair, (1, 1) pair) of the 2 m disc about its state at 1 rad/s."""
    from quadmodes.models.build import reduced_model_for

    return reduced_model_for(disc_case(RADIUS / 6), 7, use_cache=False)


def test_campbell_from_rest_starts_above_zero(disc_rom):
    """Swept "from 0" with three widely spaced spins (0, 1.5, 3 rad/s requested): the sweep
    starts at 5 % of the reference spin with a note, no divergence is reported, no branch
    ends (one branch per root: exactly degenerate pairs stay whole), and along every branch
    ω/Ω is the same at every spin (a body stiffened by its spin alone: ω ∝ Ω) — which a
    branch that swapped roots between the points would not be (the ratios differ by ≥ 1e-3)."""
    from quadmodes.analysis.campbell import stiffless_at_rest
    from quadmodes.analysis.campbell_output import campbell_with_full_order

    assert stiffless_at_rest(disc_rom)
    res, _, _ = campbell_with_full_order(disc_rom, 0.0, 3.0, 3)
    np.testing.assert_allclose(res.spin, [0.05, 1.525, 3.0])
    assert res.notes and "instead of 0" in res.notes[0]
    assert res.divergence.size == 0 and np.all(res.min_stiffness > 0)
    assert len(res.labels) == disc_rom.n_modes + 1 and np.all(res.start == 0)
    ratio = res.ratio
    assert np.all(np.isfinite(ratio))
    np.testing.assert_allclose(ratio, ratio[[-1]].repeat(3, 0), rtol=2e-4)
    np.testing.assert_allclose(ratio[:, res.branch("nutation")], 1.0, rtol=1e-6)
    # the distinct ratios are far apart: agreement above is not a coincidence of a swap
    distinct = np.unique(np.round(ratio[-1], 3))
    assert np.diff(distinct).min() > 1e-3


def test_campbell_of_a_body_stiff_at_rest_is_unchanged():
    """A model about rest (reference spin 0) is not 'stiffless': no note, the sweep as asked."""
    from types import SimpleNamespace

    from quadmodes.analysis.campbell_output import sweep_spins

    rest = SimpleNamespace(reference_spin=0.0, n_modes=2, Lam=np.eye(2))  # the fields it reads
    spins, notes = sweep_spins(rest, 0.0, 2.0, 3)
    assert notes == () and spins[0] == 0.0


def test_rotating_defaults_to_the_reference_axis(disc_rom):
    """`rotating` without --axis: the spinning reference's axis (the disc's normal z), not the
    minor axis (in its plane, about which the disc has no spinning state)."""
    from quadmodes.rom.spin_axis import resolve_axis

    np.testing.assert_allclose(np.abs(resolve_axis(disc_rom, None, default=0)), [0, 0, 1],
                               atol=1e-12)  # fmt: skip
    minor = resolve_axis(disc_rom, 0)
    assert abs(minor[2]) < 1e-9  # the minor axis lies in the plane


def test_balanced_mac_is_spin_free():
    """The same shape with its velocity block scaled by two different |λ| (one eigenvector at
    two spins of a spin-stiffened body) compares as 1 after balancing, ≈ ½ without; a root at
    λ = 0 (no velocity) keeps its displacement."""
    from quadmodes.analysis import campbell_tracking as tr

    rng = np.random.default_rng(0)
    n = 4
    w = np.diag(rng.uniform(1, 2, 2 * n))
    disp = np.r_[np.ones(n, bool), np.zeros(n, bool)]
    phi = rng.normal(size=n)
    a = np.r_[phi, 0.05j * phi][:, None]
    b = np.r_[phi, 3.0j * phi][:, None]
    assert tr.mac(a, b, w, disp)[0, 0] < 0.6
    ba, bb = tr.balanced(a, w, disp), tr.balanced(b, w, disp)
    np.testing.assert_allclose(tr.mac(ba, bb, w, disp)[0, 0], 1.0, rtol=1e-12)
    static = np.r_[phi, np.zeros(n)][:, None]
    out = tr.balanced(static, w, disp)
    np.testing.assert_allclose(np.real(out.conj().T @ w @ out), [[1.0]], rtol=1e-12)


def test_damping_modes_of_a_spin_stiffened_rotor_are_those_of_its_spinning_state():
    """The string-blade rotor (20 elements per blade): its lowest elastic frequency at rest is
    ~1e-3 of a 1 rad/s spin (EI ≈ 0), so a modal damping ζ·2ω on its modes at rest would vanish;
    the damping modes are those of its spinning state, whose lowest frequency (of K_T there:
    lag and flap stiffened by the tension) is of the order of the spin (above 0.3 Ω). A
    structure stiff at rest (the same rotor with EI × 1e8: first bending ≈ 16 rad/s) keeps its
    state at rest."""
    from quadmodes.rom.spinning_reduction import spinning_modes
    from quadmodes.structure.damping import damping_state, modes_below
    from quadmodes.structure.pipeline import structure_for_case

    def rotor(second_moment: str):
        changes = [(("boom", i, key), v) for i in (0, 1)
                   for key, v in (("elements", 20), ("second_moment", second_moment))]  # fmt: skip
        return structure_for_case(edit(load_case("string-blade-rotor"), changes, "test"))

    s = rotor("1e-14 m^4")
    eq, _, _ = spinning_modes(s, s.reference, 3, 1.0, np.array([0.0, 0.0, 1.0]))
    x, state = damping_state(s, s.reference, eq.x, 1.0)
    assert state == "spinning" and x is eq.x
    f, _, _ = modes_below(s, x, 0.5)
    assert f.size and 2 * np.pi * f[0] > 0.3
    stiff = rotor("1e-6 m^4")
    eq, _, _ = spinning_modes(stiff, stiff.reference, 3, 1.0, np.array([0.0, 0.0, 1.0]))
    assert damping_state(stiff, stiff.reference, eq.x, 1.0)[1] == "rest"


def test_spin_range_check_rebuilds_about_the_runs_own_axis(tmp_path):
    """The path check's rebuilt model (the same case about the measured spin) turns about the
    run's ``initial.spin_axis`` (the rotor's normal), as the run's model does; before, about
    the minor axis (the rotor's blades), which has no spinning state: the check raised."""
    from quadmodes.case import load_run_case
    from quadmodes.runs.simulate import prepare
    from quadmodes.runs.spin_check import measured_error

    path = tmp_path / "rotor-run.toml"
    path.write_text(
        'name = "rotor-run"\nkind = "run"\nmodel = "string-blade-rotor"\n'
        '[reduced]\nmodes = 5\nformulation = "Q"\nreference = "spinning"\n'
        '[initial]\nspin_rate = "1 rad/s"\ncone_angle = "0.2 deg"\nspin_axis = "major"\n'
        '[integration]\ndt = "20 ms"\nduration = "1 s"\n'
    )
    setup = prepare(load_run_case(path))
    spin, eps = measured_error(setup, np.array([0.0, 0.0, 0.98]))
    assert spin == pytest.approx(0.98)
    # the same spin-stiffened body about 0.98 rad/s: the frequencies at that ω agree (the model
    # about 1 rad/s carries the 4 % prestress change through its quadratic modes)
    assert eps < 1e-2


def test_initial_deformation_of_a_disc_is_its_lowest_mode():
    """``initial.bending_amplitude`` on a model about a spinning state with no mode labelled
    bending (the disc's are "disc (n, s)"): the lowest mode (the (2, 0) pair's first member) is
    deformed to that largest nodal displacement, with a note (before: refused)."""
    from quadmodes.case import load_run_case
    from quadmodes.runs.initial import largest_nodal_displacement
    from quadmodes.runs.simulate import prepare

    changes = {"reduced.modes": 5, "initial.bending_amplitude": "2 mm",
               "integration.duration": "1 s"}  # fmt: skip
    run = edit(load_run_case("spinning-disc-nutation"), changes, "test")
    setup = prepare(run, model_case=disc_case(RADIUS / 6))
    model, init = setup.model, setup.initial
    assert init.bending_modes == (0, 1) and model.labels[0] == "disc (n=2, s=0)"
    s0 = init.y0[7 : 7 + model.n_modes]
    assert s0[0] * largest_nodal_displacement(model, 0) == pytest.approx(2e-3, rel=1e-12)
    assert not np.any(s0[1:])
    assert any("no mode is labelled bending" in n for n in init.notes)
