"""Reduced models expanded about the spinning state (``reduced.reference = "spinning"``,
quadmodes.rom.spinning_reduction): the reference is a relative equilibrium of the reduced
equations, the rotating-frame frequencies converge to the full order's linearisation, the
zero-spin limit is the model at rest, the projected damping reduces to ζ on the modes, the time
step conserves |H| and the energy with the linear potential term, and the artifact keeps it."""

import dataclasses

import numpy as np
import pytest

from quadmodes.analysis.rotating_comparison import case_state, rotating_frequency_comparison
from quadmodes.case import load_run_case
from quadmodes.rom import artifact
from quadmodes.rom import diagnostics as dg
from quadmodes.rom import dynamics as dy
from quadmodes.rom import integrators as it
from quadmodes.rom import system as rsys
from quadmodes.rom.spinning_reduction import minor_axis, reduce_spinning, spinning_modes
from quadmodes.structure.damping import modes_below, projected_damping

ZETA = 0.02


def spinning_model(modal, n_modes: int, spin: float):
    """Reduced model of ``modal`` (a ModalModel) about its relative equilibrium at ``spin``."""
    eq, modes, labels = spinning_modes(modal.structure, modal.x, n_modes + 1, spin)
    return reduce_spinning(modal.structure, modal.x, eq, modes.frequencies_hz[:n_modes],
                           modes.shapes[:n_modes], labels[:n_modes], ZETA)  # fmt: skip


@pytest.fixture(scope="module")
def capsule_spinning(small_modal_model):
    """The small capsule about its relative equilibrium at 300 rad/s, N = 5."""
    return spinning_model(small_modal_model, 5, 300.0)


def test_reference_is_a_relative_equilibrium(capsule_spinning):
    """At the reference spin about the reference axis, s = ṡ = 0 is steady: the linear
    potential force F1 balances the centrifugal modal force ½ ωᵀJ1ω (both large)."""
    m = capsule_spinning
    sys = rsys.reduced_system(m, "Q")
    w = m.reference_spin * m.reference_axis
    centrifugal = 0.5 * np.einsum("kab,a,b->k", sys.J1, w, w)
    assert np.abs(m.F1).max() > 1e-3 * np.abs(np.diag(m.Lam)).max() * 1e-3  # not trivial
    np.testing.assert_allclose(m.F1, centrifugal, atol=1e-8 * np.abs(centrifugal).max())
    d = dy.rhs(sys, 0.0, rsys.pack_state(sys, omega=w))
    assert np.abs(d[7:]).max() <= 1e-8 * np.abs(centrifugal).max()
    assert np.abs(d[4:7]).max() <= 1e-10 * m.reference_spin**2


def test_zero_spin_limit_is_the_model_at_rest(small_modal_model, small_reduced_model):
    """A spinning reference at a vanishing spin reproduces the model at rest: frequencies,
    stiffness, F1 = 0 and damping diag(2ζω) (the projection onto the modes themselves)."""
    m = spinning_model(small_modal_model, 5, 1e-4)
    rest = small_reduced_model
    np.testing.assert_allclose(m.frequencies_hz, rest.frequencies_hz, rtol=1e-7)
    np.testing.assert_allclose(np.diag(m.Lam), np.diag(rest.Lam), rtol=1e-6)
    assert np.abs(m.F1).max() <= 1e-9 * np.sqrt(np.abs(np.diag(rest.Lam)).max())
    np.testing.assert_allclose(m.C, rest.C, atol=1e-6 * np.abs(rest.C).max())


def test_projected_damping_is_diagonal_on_damping_modes(small_modal_model):
    """The projection of ζ on every mode below the cutoff onto a subset of those modes is
    diag(2ζω) (mass-orthonormal modes); onto a mixture it is the energy-weighted average."""
    mm = small_modal_model
    f, shapes, _ = modes_below(mm.structure, mm.x, 1.5 * mm.modes.frequencies_hz[-1])
    c = projected_damping(mm.structure, shapes[:3], f, shapes, ZETA)
    np.testing.assert_allclose(c, np.diag(2 * ZETA * 2 * np.pi * f[:3]), atol=1e-9 * c.max())
    mix = (shapes[0] + shapes[2]) / np.sqrt(2.0)
    c_mix = projected_damping(mm.structure, mix[None], f, shapes, ZETA)
    assert c_mix[0, 0] == pytest.approx(ZETA * 2 * np.pi * (f[0] + f[2]), rel=1e-9)


def test_midpoint_conserves_h_and_energy_with_linear_term(capsule_spinning):
    """Undamped, coning at 5° about the reference spin: |H| to round-off; the energy error is
    the midpoint's bounded O(Δt²) one (the constant force F1 is its own discrete gradient, it
    adds none): small, and about four times smaller at half the step; the compiled kernel
    reproduces the numpy stepper to round-off."""
    m = dataclasses.replace(capsule_spinning, C=0 * capsule_spinning.C)
    sys = rsys.reduced_system(m, "Q")
    w = dy.coning_omega(sys.J0, m.reference_spin, np.radians(5.0))
    y0 = rsys.pack_state(sys, omega=w, s=1e-4 * (-1.0) ** np.arange(5))
    errors = []
    for dt, every in ((1e-3, 1), (5e-4, 2)):
        sol = it.integrate(sys, y0, (0, 0.5), "midpoint", dt=dt, backend="numpy",
                           save_every=every)  # fmt: skip
        d = dg.diagnostics(sys, sol)
        assert np.abs(d.H_norm / d.H_norm[0] - 1).max() <= 1e-12
        errors.append(np.abs(d.E / d.E[0] - 1).max())
    assert errors[0] < 2e-6 and errors[0] / errors[1] > 3.0  # measured 7.4e-7, ratio 6.8
    if it.numba_kernel() is not None:
        sols = {b: it.integrate(sys, y0, (0, 0.2), "midpoint", dt=1e-3, backend=b)
                for b in ("numpy", "numba")}  # fmt: skip
        y_np, y_nb = sols["numpy"].y, sols["numba"].y
        assert np.abs(y_np - y_nb).max() <= 1e-11 * np.abs(y_np).max()


def test_artifact_round_trip(capsule_spinning, tmp_path):
    m = capsule_spinning
    back = artifact.load_reduced_model(artifact.save_reduced_model(m, tmp_path / "m.nc"))
    np.testing.assert_array_equal(back.F1, m.F1)
    np.testing.assert_array_equal(back.reference_axis, m.reference_axis)
    assert back.reference_spin == m.reference_spin
    np.testing.assert_array_equal(back.select([0, 2]).F1, m.F1[[0, 2]])


def test_run_case_reference_field():
    seed = load_run_case("paper-41hz-seed")
    assert seed.reference_spin == 0.0 and seed.reduced.modes == 5
    run = load_run_case("paper-41hz")  # the default: about the spinning state, modes "auto"
    assert run.reference_spin == pytest.approx(2 * np.pi * 41.0) and run.reduced.modes == "auto"
    assert 'reference = "spinning"' in run.to_toml()
    back = seed.model_copy(update={"reduced": run.reduced})
    assert back.reference_spin == run.reference_spin


@pytest.fixture(scope="module")
def coarse_state():
    return case_state("paper-membrane-coarse")


@pytest.mark.parametrize("spin_hz", [20.0, 41.0])
def test_rotating_frequencies_match_full_order(coarse_state, spin_hz):
    """Every branch of the 8-mode model about the spinning state within 0.8 % of the full
    order's rotating-frame roots about its own relative equilibrium, including the near-critical
    backward bending branch at 41 Hz (1.14 Hz; the model about the state at rest: 1.17 Hz)."""
    case, structure, x0 = coarse_state
    modal = dataclasses.make_dataclass("M", ["structure", "x"])(structure, x0)
    rom = spinning_model(modal, 8, 2 * np.pi * spin_hz)
    np.testing.assert_allclose(rom.reference_axis, minor_axis(structure, x0), atol=1e-9)
    table = rotating_frequency_comparison(case, [spin_hz], 8, ("Q",), model=rom)
    assert len(table.rows) >= 8
    for r in table.rows:
        assert r.mac["Q"] > 0.99 and r.captured > 0.95, r
        assert abs(r.rel_error["Q"]) < 0.008, r


def test_effective_potential_bounded_below(coarse_state):
    """10⁴ random directions up to 100 × the largest modal amplitude of the 41 Hz run: the
    effective potential of the default formulation (Q about the spinning state) never lies
    below its reference value by more than 1 % of the run's peak modal potential energy (it is
    the positive quadratic form of the rotating stiffness)."""
    case, structure, x0 = coarse_state
    modal = dataclasses.make_dataclass("M", ["structure", "x"])(structure, x0)
    rom = spinning_model(modal, 8, 2 * np.pi * 41.0)
    sys = rsys.reduced_system(rom, "Q")
    w = dy.coning_omega(sys.J0, rom.reference_spin, np.radians(6.0))
    sol = it.integrate(sys, rsys.pack_state(sys, omega=w), (0, 0.5), "midpoint", dt=5e-4)
    s_run = sol.y[:, 7 : 7 + rom.n_modes]
    peak = dy.effective_potential(sys, s_run).max()
    assert peak > 0.0
    d = np.random.default_rng(1).standard_normal((10_000, rom.n_modes))
    d /= np.linalg.norm(d, axis=1)[:, None]
    r = 100.0 * np.linalg.norm(s_run, axis=1).max() * np.random.default_rng(2).random(10_000)
    v = dy.effective_potential(sys, r[:, None] * d)
    assert v.min() >= -0.01 * peak


@pytest.mark.parametrize("spin, expected", [("41 Hz", 16), ("20 Hz", 8), ("10 Hz", 8)])
def test_auto_modes_about_the_spinning_state(spin, expected):
    """"auto" about the spinning state counts the rotating-frame stiffness's own modes up to
    3.2 × the spin, pairs whole: at 41 Hz the second bending pair (125 Hz) is in, the next mode
    (171 Hz) out; at 20 Hz the front-mass rocking pair (54/60 Hz) is in; at 10 Hz the cutoff is
    raised to twice the lowest mode (31 Hz), which keeps the same 8."""
    from quadmodes.runs import simulate
    from quadmodes.runs.mode_choice import resolve_modes

    run = simulate.apply_overrides(load_run_case("paper-41hz-coarse"), spin_rate=spin)
    _, choice = resolve_modes(run)
    assert choice.n_modes == expected and choice.margin == pytest.approx(3.2)
    assert "rotating-frame stiffness" in choice.rule


def test_full_order_initial_deformation_is_relaxed(small_modal_model, small_reduced_model):
    """The full order starts an initial modal deformation from the FE model's statically
    condensed state: the correction keeps the retained modal coordinates and the frame
    ([Φ Ψ]ᵀ M y = 0), lowers the total potential below the quadratic-manifold point's to the
    condensed minimum (zero force outside the constraints), and vanishes faster than s² as
    s → 0 (the manifold is exact to second order)."""
    from quadmodes.analysis.full_order_runs import relaxed_deformation
    from quadmodes.fe.model import internal_force, mass_matrix, rigid_body_modes, strain_energy

    mm, m = small_modal_model, small_reduced_model
    st, x0 = mm.structure, mm.x
    mass = mass_matrix(st)
    basis = np.hstack([m.Phi.reshape(m.n_modes, -1).T, rigid_body_modes(st, x0)])
    sizes = []
    for a in (1e-4, 2e-4):
        s = np.zeros(m.n_modes)
        s[0] = a
        y = relaxed_deformation(st, x0, m, s)
        u = np.einsum("k,kia->ia", s, m.Phi) + np.einsum("m,n,mnia->ia", s, s, m.G)
        my = mass @ y.ravel()
        assert np.abs(basis.T @ my).max() <= 1e-9 * np.abs(basis).max() * np.abs(my).sum()
        e_qm, e_c = (strain_energy(st, x0 + u + d) - strain_energy(st, x0) for d in (0 * y, y))
        assert e_c <= e_qm
        f = internal_force(st, x0 + u + y).ravel()
        coeff = np.linalg.lstsq(mass @ basis, f, rcond=None)[0]  # f in the span of the reactions
        assert np.linalg.norm(f - mass @ basis @ coeff) <= 1e-6 * np.linalg.norm(f) + 1e-12
        sizes.append(np.abs(y).max())
    assert sizes[1] / sizes[0] > 4.5  # O(s³): 8 for an exact cube, 4 would be O(s²)


def test_damping_modes_at_rest_solved_once_for_every_spin(small_modal_model, monkeypatch):
    """Models about 300 and 306 rad/s sharing the modal model's solved modes (its
    ``SolvedModes``, as every member of a spin family does): the eigenproblems at rest (the
    damping modes, the stiffness check's lowest mode) solved for the first spin only, half the
    solves of two models solved afresh; each model the same as solved afresh, bit for bit."""
    from quadmodes.structure import damping as sd

    m, calls, real = small_modal_model, [], sd.compute_modes
    monkeypatch.setattr(sd, "compute_modes", lambda s, x, n, **k: calls.append(n) or real(s, x, n, **k))

    def model(spin, memo):
        eq, modes, labels = spinning_modes(m.structure, m.x, 6, spin)
        return reduce_spinning(m.structure, m.x, eq, modes.frequencies_hz[:5], modes.shapes[:5],
                               labels[:5], ZETA, memo=memo)  # fmt: skip

    memo = sd.SolvedModes()
    shared = [model(w, memo) for w in (300.0, 306.0)]
    n_shared = len(calls)
    fresh = [model(w, None) for w in (300.0, 306.0)]
    assert n_shared >= 2 and len(calls) - n_shared == 2 * n_shared
    for a, b in zip(shared, fresh, strict=True):
        for name in ("C", "Phi", "X", "frequencies_hz"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
