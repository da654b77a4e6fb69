"""A family of reduced models along a path (``reduced.path_model = "spin-family"``,
quadmodes.runs.spin_family): the chart fit inverts a member's own field, the map onto the same
member is the identity, a switch keeps the body-frame angular momentum exactly and the path's
energy (T + V + Π(X_k)) to the map's accuracy, and a run through switches conserves |H| and
E + E_d as a single model does."""

import dataclasses

import numpy as np
import pytest
from test_run import run_toml, workdir  # noqa: F401  (fixture)
from test_spinning_reference import spinning_model

from quadmodes.case import CaseError, load_run_case
from quadmodes.fe.model import strain_energy
from quadmodes.rom import dynamics as dy
from quadmodes.rom import system as rsys
from quadmodes.runs import simulate as sim
from quadmodes.runs import spin_family as sf

SPIN = 300.0  # rad/s


@pytest.fixture(scope="module")
def members(small_modal_model):
    """The small capsule about its relative equilibria at 300, 306 and 303 rad/s, N = 5."""
    return tuple(spinning_model(small_modal_model, 5, f * SPIN) for f in (1.0, 1.02, 1.01))


def _state(model, scale=1.0, seed=0):
    """A coning state of ``model``: ω 3° off its axis, modal coordinates of about 1 mm."""
    rng = np.random.default_rng(seed)
    sys = rsys.reduced_system(model, "Q")
    d = np.max(np.abs(model.Phi), axis=(1, 2))  # largest nodal displacement per unit s (m)
    s = scale * 1e-3 * rng.standard_normal(model.n_modes) / d
    sd = 2 * np.pi * 40.0 * s[::-1]
    e = model.reference_axis
    w = model.reference_spin * (np.cos(0.05) * e + np.sin(0.05) * np.cross(e, [1.0, 0, 0]))
    return sys, rsys.pack_state(sys, omega=w, s=s, sdot=sd, q=[0.9, 0.1, 0.3, np.sqrt(0.09)])



def stop_at_chunk(monkeypatch, n: int, exc) -> list:
    """Make the family's switch monitor raise ``exc`` after its ``n``-th chunk (the chunks'
    step counts are appended to the list returned)."""
    calls, original = [], sf.SwitchMonitor.after_chunk

    def after_chunk(self, state, integ, h):
        calls.append(state.steps)
        if len(calls) == n:
            raise exc
        return original(self, state, integ, h)

    monkeypatch.setattr(sf.SwitchMonitor, "after_chunk", after_chunk)
    return calls

def test_chart_fit_inverts_the_members_field(members):
    m = members[0]
    _, y = _state(m)
    s = y[7 : 7 + m.n_modes]
    np.testing.assert_allclose(sf.chart_fit(m, sf.manifold_field(m, s)), s, rtol=0, atol=1e-9 * np.abs(s).max())


def test_map_onto_the_same_member_is_the_identity(members):
    m = members[0]
    sys, y = _state(m)
    np.testing.assert_allclose(sf.mapped_state(sys, m, sys, m, y), y, rtol=1e-9, atol=1e-9 * np.abs(y).max())


def test_switch_keeps_h_exactly_and_the_energy(members, small_modal_model):
    """300 → 306 rad/s: h = J̃ω + Aᵀṡ the same to round-off; the mapped field the least-squares
    one; the path's energy T + V + Π(X) changed by the map (a fit, not exact) by a defect that
    vanishes with the spin step (300 → 303 rad/s: less than half of it)."""
    m0, m1, m_half = members
    sys0, y0 = _state(m0)
    sys1 = rsys.reduced_system(m1, "Q")
    y1 = sf.mapped_state(sys0, m0, sys1, m1, y0)
    h0, h1 = dy.body_momentum(sys0, y0), dy.body_momentum(sys1, y1)
    assert np.linalg.norm(h1 - h0) <= 1e-13 * np.linalg.norm(h0)
    x0 = sf.manifold_field(m0, y0[7 : 7 + m0.n_modes])
    x1 = sf.manifold_field(m1, y1[7 : 7 + m1.n_modes])
    # the least-squares fit: the residual is mass-orthogonal to the new chart's tangent
    w = np.asarray(m1.weights)
    jac = m1.Phi + 2 * np.einsum("n,mnia->mia", y1[7 : 7 + m1.n_modes], m1.G)
    proj = np.einsum("mia,i,ia->m", jac, w, x0 - x1)
    scale = np.sqrt(np.einsum("mia,i,mia->m", jac, w, jac) * np.einsum("i,ia->", w, (x0 - x1) ** 2))
    assert np.all(np.abs(proj) <= 1e-8 * scale)
    st = small_modal_model.structure

    def energy(sys, m, y):
        return float(dy.kinetic_energy(sys, y) + dy.potential_energy(sys, y) + strain_energy(st, m.X))

    sys_h = rsys.reduced_system(m_half, "Q")
    y_h = sf.mapped_state(sys0, m0, sys_h, m_half, y0)
    defect = abs(energy(sys1, m1, y1) - energy(sys0, m0, y0))
    assert abs(energy(sys_h, m_half, y_h) - energy(sys0, m0, y0)) <= 0.5 * defect
    assert defect <= 1e-4 * float(dy.kinetic_energy(sys0, y0))  # 2 % of spin: a small part


def _family_run(workdir, switch: str, duration: str = '"0.04 s"'):  # noqa: F811
    text = run_toml(spin='"300 rad/s"', cone='"10 deg"', amplitude='"0 in"', duration=duration,
                    dt='"0.2 ms"', save_every="50")  # fmt: skip
    text = text.replace("formulation = \"Q\"", 'formulation = "Q"\nreference = "spinning"' + switch)
    (workdir / "fam.toml").write_text(text, encoding="utf-8")
    return load_run_case(workdir / "fam.toml")


def test_family_run_conserves_h_and_energy_through_switches(workdir):  # noqa: F811
    """A tolerance far below the path's spin change: a switch at every chunk; |H| and E + E_d
    as constant as a single model keeps them, the times on one grid, the members' spins those
    of the path."""
    run = _family_run(workdir, '\npath_model = "spin-family"\npath_switch = 1e-6')
    result = sim.simulate(run)
    assert result.complete and len(result.family) >= 1
    d = result.diagnostics
    assert np.max(np.abs(d.H_norm - d.H_norm[0])) <= 1e-10 * d.H_norm[0]
    eb = d.E + d.E_d
    assert np.max(np.abs(eb - eb[0])) <= 1e-6 * abs(eb[0])
    np.testing.assert_allclose(np.diff(d.t), 50 * 0.2e-3, rtol=1e-9)
    for sw in result.family:
        assert sw.h_change <= 1e-12 and abs(sw.spin_to - sw.spin_from) > 0
    fixed = sim.simulate(_family_run(workdir, ""))
    # members about nearly the same spin: the same path as the one model, to the map's accuracy
    np.testing.assert_allclose(d.cone_angle, fixed.diagnostics.cone_angle, rtol=0, atol=1e-6)


def test_family_needs_a_spinning_reference(workdir):  # noqa: F811
    text = run_toml().replace('formulation = "Q"', 'formulation = "Q"\npath_model = "spin-family"')
    (workdir / "bad.toml").write_text(text, encoding="utf-8")
    with pytest.raises(CaseError, match="path_model"):
        load_run_case(workdir / "bad.toml")
    _ = dataclasses  # (kept for symmetry with the other run tests)


def test_family_with_a_controlled_step(workdir):  # noqa: F811
    """A family with integration.step_tolerance: the members step at the controlled step (not
    the fixed dt), switch, and conserve |H| through the switches and E + E_d as the fixed step
    does."""
    _family_run(workdir, '\npath_model = "spin-family"\npath_switch = 1e-6')
    text = (workdir / "fam.toml").read_text(encoding="utf-8")
    (workdir / "fam.toml").write_text(text.replace("[integration]", "[integration]\nstep_tolerance = 1e-3"),
                                      encoding="utf-8")  # fmt: skip
    run = load_run_case(workdir / "fam.toml")
    result = sim.simulate(run, max_chunks=4)
    assert result.complete and len(result.family) >= 1
    assert result.solution.dt is None  # the controlled step's samples
    d = result.diagnostics
    assert np.all(np.diff(d.t) > 0)
    assert np.max(np.abs(d.H_norm - d.H_norm[0])) <= 1e-10 * d.H_norm[0]
    eb = d.E + d.E_d
    assert np.max(np.abs(eb - eb[0])) <= 1e-6 * abs(eb[0])
    for sw in result.family:
        assert sw.h_change <= 1e-12


def test_compare_refuses_a_family_path(tmp_path):
    """A results.nc of a spin-family run (samples in several members' charts) is not read as
    the path of one model (one line naming --results)."""
    import types

    import xarray as xr

    from quadmodes.analysis.path_point import results_point

    path = tmp_path / "results.nc"
    xr.Dataset({"quaternion": (("time", "quat"), np.zeros((2, 4)))},
               attrs={"reduced_model_key": "k", "dt": 5e-4,
                      "case_toml": '[reduced]\npath_model = "spin-family"\n'}).to_netcdf(path)  # fmt: skip
    model = types.SimpleNamespace(provenance={"content_key": "k"})
    run = types.SimpleNamespace(integration=types.SimpleNamespace(dt=5e-4))
    with pytest.raises(CaseError, match="--results.*spin-family"):
        results_point(path, run, None, model, "cone 10 deg")


def test_ctrl_c_gives_the_family_path_so_far(workdir, monkeypatch):  # noqa: F811
    """Ctrl-C in the second member's first chunk: Interrupted carrying the run result of the
    path so far (incomplete), both members' samples in it."""
    from quadmodes.runs.chunked import Interrupted

    stop_at_chunk(monkeypatch, 2, KeyboardInterrupt)
    run = _family_run(workdir, '\npath_model = "spin-family"\npath_switch = 1e-6', '"0.06 s"')
    with pytest.raises(Interrupted) as stop:
        sim.simulate(run)
    partial = stop.value.partial
    assert isinstance(partial, sim.RunResult) and not partial.complete
    assert len(partial.family) == 1 and partial.diagnostics.t[-1] > partial.family[0].time - 1e-12


def test_member_spins_are_a_grid_and_the_nearest_point_integrates():
    """Members at Ω₀(1 + spacing)^k: a spin maps to its nearest grid point (in ln Ω), the same
    one over ±half a spacing, and the grid is anchored on Ω₀ whatever the path."""
    w0, a = 2 * np.pi * 41.0, 0.0075
    for k in (-7, -1, 0, 3):
        centre = w0 * (1 + a) ** k
        for f in (1.001 / np.sqrt(1 + a), 1.0, 0.999 * np.sqrt(1 + a)):
            assert sf.grid_spin(centre * f, w0, a) == pytest.approx(centre, rel=2e-6)
    assert sf.grid_spin(w0, w0, a) == pytest.approx(w0, rel=1e-12)


@pytest.mark.parametrize(("stop_at", "controlled"), [(2, False), (3, False), (3, True)])
def test_interrupted_family_resumes_to_the_same_path(workdir, monkeypatch, tmp_path, stop_at,  # noqa: F811
                                                     controlled):  # fmt: skip
    """Ctrl-C at the ``stop_at``-th chunk (after a switch; fixed or controlled step), the
    checkpoint resumed: the same samples, switches and members as the uninterrupted run, bit
    for bit."""
    from quadmodes.runs.chunked import Interrupted
    from quadmodes.runs.run_checkpoint import RunCheckpoint

    run = _family_run(workdir, '\npath_model = "spin-family"\npath_switch = 1e-6', '"0.06 s"')
    if controlled:
        text = (workdir / "fam.toml").read_text(encoding="utf-8")
        (workdir / "fam.toml").write_text(text.replace("[integration]", "[integration]\nstep_tolerance = 1e-3"),
                                          encoding="utf-8")  # fmt: skip
        run = load_run_case(workdir / "fam.toml")
    whole = sim.simulate(run)
    setup = sim.prepare(run)
    path = tmp_path / "checkpoint.npz"
    with monkeypatch.context() as m:
        stop_at_chunk(m, stop_at, KeyboardInterrupt)
        with pytest.raises(Interrupted) as stop:
            sim.execute(setup, checkpoint=RunCheckpoint(path, setup, 0.0))
    assert stop.value.saved and len(stop.value.partial.family) >= 1
    start = RunCheckpoint(path, setup).load()
    resumed = sim.execute(setup, checkpoint=RunCheckpoint(path, setup, 0.0), resume=start)
    assert resumed.complete
    np.testing.assert_array_equal(resumed.solution.t, whole.solution.t)
    np.testing.assert_array_equal(resumed.solution.y, whole.solution.y)
    np.testing.assert_array_equal(resumed.diagnostics.E + resumed.diagnostics.E_d,
                                  whole.diagnostics.E + whole.diagnostics.E_d)  # fmt: skip
    assert resumed.family == whole.family


def test_measured_limit_from_neighbours():
    """The spin part's limit of a segment from its neighbours' measurements: the whole step x
    (δ = 1 − e^{−2x}) where both errors are within tolerance, else x scaled to where the worse
    reaches its tolerance (2 % coning rate, 1 % frequencies); None without a measurement."""
    w = 2 * np.pi * 40.0
    step = np.exp(-0.015)

    def switch(eps_c, eps_f):
        return sf.Switch(1.0, 1, w, w * step, 0.0, 0.0, 1.0, eps_c, eps_f)

    assert sf.measured_limit([switch(0.01, 1e-5)], 0)[0] == pytest.approx(-np.expm1(-0.03), rel=1e-12)
    assert sf.measured_limit([switch(0.04, 1e-5)], 0)[0] == pytest.approx(-np.expm1(-0.015), rel=1e-12)
    assert sf.measured_limit([switch(0.01, 0.04)], 1)[0] == pytest.approx(-np.expm1(-0.0075), rel=1e-12)
    assert sf.measured_limit([switch(np.nan, 0.0)], 0)[0] is None
    assert sf.measured_limit([], 0)[0] is None


def test_every_segment_is_checked_at_its_own_amplitude(workdir, monkeypatch):  # noqa: F811
    """The modal-amplitude check of a family path covers every member, not only the last: with
    the potential's error made proportional to ‖s‖ (failing above the median of the segments'
    largest ‖s‖), the path leaves in the earliest segment whose largest ‖s‖ fails, at or before
    its largest ‖s‖; the FE model is consulted once per segment plus the one-model check's
    bisections in the earliest failing one (its solve at the largest ‖s‖ the scan's): the
    verdict is the one-model check's on that segment, field for field. A segment of smaller
    largest ‖s‖ is not covered by one of larger that passed (the error depends on the member and
    the direction of s, measured on paper-41hz-coarse): a segment made to fail at 3 % while
    every other is at 1 % is where the path leaves."""
    from quadmodes.runs import family_validity as fv
    from quadmodes.runs import path_validity as pv

    run = _family_run(workdir, '\npath_model = "spin-family"\npath_switch = 1e-6', '"0.06 s"')
    setup = sim.prepare(run, check_deformation=True)
    assert setup.fe_checks
    seen, real_check = {}, fv.checked_amplitudes
    monkeypatch.setattr(fv, "checked_amplitudes", lambda parts: seen.setdefault("parts", parts) and real_check(parts))
    result = sim.execute(setup)
    parts = seen["parts"]
    assert len(result.family) >= 3 and len(parts) == len(result.family) + 1
    assert "modal amplitudes" in result.path.checked and not result.path.unchecked
    assert result.path.amplitude_error <= pv.DEFORMATION_ENERGY_TOLERANCE  # 10° cone, no bending

    def amplitudes(part):
        return np.linalg.norm(rsys.split_state(part[0].system, np.asarray(part[1].y))[2], axis=1)

    peaks = np.array([amplitudes(p).max() if len(p[1].t) else 0.0 for p in parts])
    level = float(np.median(peaks))  # the potential "fails" above it
    calls = []

    def error(setup_k, y, structure):
        a = float(np.linalg.norm(rsys.split_state(setup_k.system, np.asarray(y))[2]))
        calls.append(a)
        return pv.DEFORMATION_ENERGY_TOLERANCE * a / level, None

    monkeypatch.setattr(pv, "amplitude_error", error)
    monkeypatch.setattr("quadmodes.runs.deformation_check.deformation_structure", lambda s: None)
    paths = real_check(parts)
    failing = np.flatnonzero(peaks > level)
    first = int(failing.min())
    t = np.asarray(parts[first][1].t)
    assert paths[first].left_at is not None
    assert t[0] <= paths[first].left_at <= t[int(np.argmax(amplitudes(parts[first])))]
    assert all(paths[k].left_at is None for k in range(first))
    assert all(paths[k].amplitude_error > pv.DEFORMATION_ENERGY_TOLERANCE for k in failing)
    if len(failing) > 1:  # the later failing members, listed in one entry
        later = [r for _, r in paths[failing[1]].failures]
        assert len(later) == 1 and (f"{len(failing) - 1} later members" in later[0]
                                    or "of the member about" in later[0])  # fmt: skip
    assert all("modal amplitudes" in p.checked and not p.unchecked for p in paths)
    # every segment once; the earliest failing segment's solve at its largest ‖s‖ not repeated
    assert len(calls) <= np.count_nonzero(peaks) + pv.AMPLITUDE_BISECTIONS
    calls.clear()
    alone = pv.with_amplitude_check(parts[first][3], *parts[first][:3], None)
    assert alone == paths[first] and len(calls) == 1 + pv.AMPLITUDE_BISECTIONS  # the same verdict

    largest = int(np.argmax(peaks))
    weak = min((k for k in range(len(parts)) if peaks[k] > 0 and k != largest), key=lambda k: peaks[k])
    monkeypatch.setattr(pv, "amplitude_error", lambda setup_k, y, structure: (
        0.03 if setup_k is parts[weak][0] else 0.01, None))  # fmt: skip
    paths = real_check(parts)
    assert paths[largest].left_at is None and paths[largest].amplitude_error == 0.01
    assert paths[weak].left_at is not None and paths[weak].amplitude_error == 0.03
    assert all(paths[k].left_at is None for k in range(len(parts)) if k != weak)


def test_later_failing_members_are_one_entry():
    """The failing members after the earliest: how many, their errors' range and spins; those
    whose condensed energy did not converge (inf) counted, not printed as a number."""
    from types import SimpleNamespace

    from quadmodes.runs.family_validity import later_failures

    parts = [(SimpleNamespace(model=SimpleNamespace(reference_spin=2 * np.pi * f)),) for f in (30, 29, 28)]
    got = later_failures(parts, [(0, 0.03), (1, np.inf), (2, 0.05)])
    assert "3–5 %" in got and "3 later members (about 30 to 28 Hz)" in got and "of 1 of them" in got
    assert "inf" not in got
    assert "did not converge" in later_failures(parts, [(1, np.inf)])
    assert "2.5 % off" in later_failures(parts, [(1, 0.025)]) and "member about 29 Hz" in later_failures(parts, [(1, 0.025)])
