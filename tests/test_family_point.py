"""The full order from a point of a spin-family path (``compare RUN --at`` of a run case with
``reduced.path_model = "spin-family"``, quadmodes.analysis.family_point).

The small capsule spun at 300 rad/s, coning 10°, its members 1e-5 apart in spin (its spin
wanders by ±1e-5: three switches in 40 ms, one at 20 ms just before the point at 22 ms). Asserted: results.nc says which member integrated each
sample (rad/s, the switch times of the run); the point located on the samples is the state of
the path there, in its member's chart (the path's |H| to round-off; read from results.nc or
integrated, the same state); the full order's reconstructed field is the member's manifold
field at the point (its modal coordinates the point's, its |H| the reduced one's to the
stretch outside the retained modes); the comparison names the member."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_run import run_toml

from quadmodes.analysis import comparison_run as runner
from quadmodes.analysis import family_point as fp
from quadmodes.case import load_run_case
from quadmodes.fullorder import kinematics as kin
from quadmodes.rom import dynamics as dyn
from quadmodes.runs import family_samples as fs
from quadmodes.runs import results as res
from quadmodes.runs import simulate as sim
from quadmodes.runs.spin_family import manifold_field

AT = "time 0.022 s"  # the sample before it is a switch's own (the old member's chart)


def _family_case(workdir) -> str:
    text = run_toml(spin='"300 rad/s"', cone='"10 deg"', amplitude='"0 in"', duration='"0.04 s"',
                    dt='"0.2 ms"', save_every="25")  # fmt: skip
    text = text.replace('formulation = "Q"', 'formulation = "Q"\nreference = "spinning"\n'
                        'path_model = "spin-family"\npath_switch = 1e-5')  # fmt: skip
    (workdir / "fam.toml").write_text(text, encoding="utf-8")
    return str(workdir / "fam.toml")


@pytest.fixture(scope="module")
def family(tmp_path_factory):
    """(run case path, the family RunResult, its results.nc), the members in a private cache."""
    from conftest import SMALL_CAPSULE

    mp = pytest.MonkeyPatch()
    folder = tmp_path_factory.mktemp("family")
    (folder / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    mp.setenv("QUADMODES_CACHE", str(folder / "cache"))
    name = _family_case(folder)
    result = sim.simulate(load_run_case(name))
    nc = res.write_dataset(res.to_dataset(result), folder / "results.nc")
    yield name, result, nc
    mp.undo()


def test_results_say_which_member_integrated_each_sample(family):
    _, result, nc = family
    assert len(result.family) >= 2  # several members before the point
    ds = res.load_results(nc)
    var = ds[fs.MEMBER_SPIN_VARIABLE]
    assert var.attrs["units"] == "rad/s" and "member" in var.attrs["long_name"]
    spins, t = var.values, ds["time"].values
    assert spins[0] == pytest.approx(300.0, rel=1e-6)
    for sw in result.family:  # the switch's own sample is the old member's, the next the new's
        k = int(np.argmin(np.abs(t - sw.time)))
        assert spins[k] == sw.spin_from and spins[k + 1] == sw.spin_to
    # the centrifugal departure is each sample's from its own member: within the switch rule
    assert np.max(ds["centrifugal_departure"].values) < 0.02


def _point(family, source):
    name, result, nc = family
    run = result.run  # its modes resolved
    return run, fp.family_path_point(run, AT, results=nc if source == "results" else None)


@pytest.mark.parametrize("source", ["results", "integrated"])
def test_point_is_the_paths_state_in_its_members_chart(family, source):
    _, result, _ = family
    run, point = _point(family, source)
    spins = fs.sample_member_spins(result.diagnostics.t, result.model.reference_spin, result.family)
    k = int(np.searchsorted(result.diagnostics.t, point.time))  # the first sample past it
    assert point.step == 110 and point.member_spin == spins[k]
    assert point.member_spin != result.model.reference_spin  # a later member's chart
    sys_m = fs.Members(run).system(point.member_spin)
    # |H| of the point (its member's chart) is the path's, kept to round-off by every switch
    h_point = np.linalg.norm(dyn.momentum_inertial(sys_m, point.y[None])[0])
    h_path = result.diagnostics.H_norm
    assert abs(h_point / h_path[0] - 1.0) <= 1e-11
    # the cone angle at the point lies between the samples around it
    cone = result.diagnostics.cone_angle[k - 1 : k + 1]
    assert min(cone) - 1e-9 <= point.cone_angle <= max(cone) + 1e-9


def test_read_and_integrated_points_agree(family):
    _, read = _point(family, "results")
    _, integrated = _point(family, "integrated")
    assert read.step == integrated.step and read.member_spin == integrated.member_spin
    assert np.max(np.abs(read.y - integrated.y)) <= 1e-9 * np.max(np.abs(read.y))


def test_full_order_field_is_the_members_manifold_field(family):
    name, result, nc = family
    run, setup, point = runner.prepare_path_comparison(load_run_case(name), 0.002, AT, results=nc)
    model = setup.model
    assert model.reference_spin == pytest.approx(point.member_spin, rel=1e-12)
    assert run.reduced.path_model == "fixed" and run.initial.spin_rate == point.member_spin
    n = model.n_modes
    s = point.y[7 : 7 + n]
    body_k = kin.make_body(setup.structure.mass_scalar, setup.structure.translational, model.X,
                           model, False)  # fmt: skip
    smp = kin.sample(body_k, setup.x0, setup.v0, None, None)
    # the full state's modal coordinates (M-projection, quadratic modes) are the point's
    assert np.max(np.abs(smp.s - s)) <= 1e-6 * np.max(np.abs(s))
    # its field in the body frame (the point's attitude, centres of mass): the member's
    # manifold field X + Φs + Σ s s g at the point plus the deformation relaxed outside the
    # retained modes (1 % of the modal deflection here) and the centrifugal stretch of ω
    # outside them (added apart: it is the coning ω's, not the path's deformation)
    from quadmodes.analysis.full_order_runs import full_state_from_reduced
    from quadmodes.fe.model import centre_of_mass
    from quadmodes.rotations import rotation_matrix

    w = np.asarray(model.weights, float)

    def body(x):
        return (x - w @ x / w.sum()) @ rotation_matrix(point.y[:4])

    centre = centre_of_mass(setup.structure, setup.x_rest)
    x_relaxed, _, _ = full_state_from_reduced(setup.structure, setup.x_ref, model, point.y, centre,
                                              stretch=False)  # fmt: skip
    x_man = manifold_field(model, s)
    x_man = x_man - w @ x_man / w.sum()
    deflection = np.max(np.linalg.norm(x_man - (model.X - w @ model.X / w.sum()), axis=1))
    assert np.max(np.linalg.norm(body(x_relaxed) - x_man, axis=1)) <= 0.05 * deflection
    # what the stretch adds has no retained-mode content to 1 % of the point's
    extra = body(setup.x0) - x_man
    proj = np.einsum("kia,i,ia->k", model.Phi, w, extra)
    assert np.max(np.abs(proj)) <= 1e-2 * np.max(np.abs(np.einsum("kia,i,ia->k", model.Phi, w,
                                                                   x_man - model.X + w @ model.X / w.sum())))  # fmt: skip
    # |H| of the reconstructed state: the reduced one's (3.6e-7 measured: the rate of the
    # relaxed part by a central difference); the stretch of the coning ω outside the retained
    # modes then tilts it by 2.5e-4, as it does in the map that starts a comparison at t = 0
    # (2.5e-4 on this run too)
    h_r = dyn.momentum_inertial(setup_system(setup), point.y[None])[0]
    x_r, v_r, _ = full_state_from_reduced(setup.structure, setup.x_ref, model, point.y, centre,
                                          stretch=False)  # fmt: skip
    h_relaxed = kin.sample(body_k, x_r, v_r, None, None).H
    assert np.linalg.norm(h_relaxed - h_r) <= 1e-5 * np.linalg.norm(h_r)
    assert np.linalg.norm(smp.H - h_r) <= 1e-3 * np.linalg.norm(h_r)


def test_the_full_orders_instrument_reads_a_manifold_field_as_its_state(family):
    """Closed form: Φ and every g^{mn} satisfy the linear mean-axes conditions (Σ M X × φ = 0),
    so for the field x = p + R(X + Φs + Σ s s g) the mass-weighted best-fit frame is R exactly
    (the polar factor of Σ M (x − p) Xᵀ = R(XᵀMX + UᵀMX), the bracket symmetric) and the
    projection ``s + ΦᵀM Σ s s g = ΦᵀM u`` has s as its root: the full order's amplitude of a
    reduced state's own field is that state's ‖s‖ to round-off, at amplitudes where the
    quadratic modes matter (Φᵀ M g s up to 0.4 here, 0.23 at the coarse path's 45° point)."""
    from quadmodes.rotations import rotation_matrix

    name, result, nc = family
    _, setup, point = runner.prepare_path_comparison(load_run_case(name), 0.002, AT, results=nc)
    model = setup.model
    body = kin.make_body(setup.structure.mass_scalar, setup.structure.translational, model.X,
                         model, False)  # fmt: skip
    n = model.n_modes
    rng = np.random.default_rng(3)
    direction = rng.standard_normal(n)
    direction /= np.linalg.norm(direction)
    # the amplitude where the quadratic modes' share ‖2 Φᵀ M g s‖ is 0.4
    share = np.linalg.norm(2 * np.einsum("kmn,n->km", body.GM, direction), 2)
    q = rng.standard_normal(4)
    rot, p = rotation_matrix(q / np.linalg.norm(q)), np.array([0.3, -1.2, 2.0])
    for fraction in (0.01, 0.1, 0.4):
        s = fraction / share * direction
        x = p + manifold_field(model, s) @ rot.T
        got = kin.sample(body, x, np.zeros_like(x), None, None).s
        assert np.max(np.abs(got - s)) <= 1e-10 * np.max(np.abs(s))


def setup_system(setup):
    from quadmodes.rom import system as rsys

    return rsys.reduced_system(setup.model, "Q")


def test_compare_at_names_the_member(family, tmp_path):
    """``quadmodes compare FAMILY --at ... --results``: the comparison starts at the point, its
    summary (notes, comparison.json, comparison.nc) names the member's spin."""
    from typer.testing import CliRunner

    from quadmodes.cli.app import app

    name, _, nc = family
    _, point = _point(family, "results")
    out = tmp_path / "cmp"
    got = CliRunner().invoke(app, ["compare", name, "--at", AT, "--results", str(nc), "--window",
                                   "2 ms", "--formulation", "Q", "--yes", "--no-plots", "-o",
                                   str(out), "--json"])  # fmt: skip
    assert got.exit_code == 0, got.output
    payload = json.loads((out / "comparison.json").read_text(encoding="utf-8"))
    hz = point.member_spin / (2 * np.pi)
    assert payload["start"]["member_spin_hz"] == pytest.approx(hz, rel=1e-12)
    assert f"spin-family member about {hz:.6g} Hz" in payload["notes"][0]
    ds = res.load_results(out / "comparison.nc")
    assert ds.attrs["start_member_spin"] == pytest.approx(point.member_spin, rel=1e-12)
    assert ds.attrs["start_member_spin_units"] == "rad/s"
    # both sides start at the point: the same modal amplitude
    q = payload["formulations"]["Q"]
    assert q["complete"]


def test_one_models_reader_refuses_a_family_path(family):
    """path_point reads one model's path; given a family run it says which reader to use (one
    line, --at) rather than locate the point in the wrong chart."""
    from quadmodes.analysis.path_point import path_point
    from quadmodes.case import CaseError

    _, result, nc = family
    for source in (None, nc):
        with pytest.raises(CaseError, match="--at: .*family_path_point") as exc:
            path_point(result.run, AT, results=source)
        assert "\n" not in str(exc.value)


def test_a_member_without_samples_is_checked(family, tmp_path):
    """Members 1e-6 apart, below the resolution members' spins are rounded to (1e-4 Hz: 2e-6
    of 47.7 Hz): a new member can switch on its first sample and leave the path no sample of
    its own. The path check then runs (it crashed on the empty segment) and |H| is kept."""
    name, _, _ = family
    text = open(name, encoding="utf-8").read().replace("path_switch = 1e-5", "path_switch = 1e-6")
    (tmp_path / "fam6.toml").write_text(text.replace('model = "small.toml"',
                                                     f'model = "{Path(name).parent / "small.toml"}"'),
                                        encoding="utf-8")  # fmt: skip
    result = sim.simulate(load_run_case(tmp_path / "fam6.toml"))
    assert result.complete and len(result.family) >= 3 and result.path is not None
    h = result.diagnostics.H_norm
    assert np.max(np.abs(h / h[0] - 1.0)) <= 1e-12


def test_member_run_of_an_adaptive_family_is_a_one_model_run(tmp_path):
    """An adaptive family (``path_tolerance``, no ``path_switch``) maps onto its member's
    one-model run too (compare --at on such a path needs it): the member about the given
    spin, with neither family field left."""
    from conftest import SMALL_CAPSULE

    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    text = Path(_family_case(tmp_path)).read_text(encoding="utf-8")
    (tmp_path / "adaptive.toml").write_text(text.replace("path_switch = 1e-5", "path_tolerance = 0.01"),
                                            encoding="utf-8")  # fmt: skip
    run = fs.member_run(load_run_case(str(tmp_path / "adaptive.toml")), 290.0)
    assert run.reduced.path_model == "fixed"
    assert run.reduced.path_tolerance is None and run.reduced.path_switch is None
    assert run.initial.spin_rate == pytest.approx(290.0, rel=1e-15)
