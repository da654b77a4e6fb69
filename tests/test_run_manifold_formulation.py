"""A run case with ``reduced.formulation = "QM"`` (runs.manifold_system): the run builds the QM
system from the case's structure, integrates it by the QM midpoint, and its summary's |H| and
energy balance are QM's (conserved to round-off and to the midpoint's energy error)."""

import tomllib

import numpy as np
from test_run import run_toml, workdir  # noqa: F401  (fixture)

from quadmodes.case import load_run_case, run_case_from_dict
from quadmodes.rom import manifold_kinetics as mk
from quadmodes.rom.integrators import integrate
from quadmodes.runs import simulate


def short_run(formulation: str):
    """paper-0.5hz on the coarse mesh (5 modes about rest), 0.2 s."""
    data = tomllib.loads(load_run_case("paper-0.5hz").to_toml())
    data["model"] = "paper-membrane-coarse"
    data["reduced"]["formulation"] = formulation
    data["integration"].update({"duration": "0.2 s", "save_every": 10})
    data["integration"].pop("until", None)
    return run_case_from_dict(data, source="test")


def test_qm_run_conserves_h_and_energy():
    setup = simulate.prepare(short_run("QM"))
    sys = setup.system
    assert sys.formulation == "QM" and isinstance(sys.manifold, mk.ManifoldArrays)
    n = sys.n_modes
    assert np.allclose(sys.manifold.gram, np.eye(n), atol=1e-9)  # ΦᵀMΦ = I
    res = simulate.execute(setup)
    assert res.complete
    dt = float(res.solution.t[1] - res.solution.t[0]) / 10  # save_every = 10
    direct = integrate(sys, setup.initial.y0, (0.0, 0.2), dt=dt, save_every=10)
    scale = np.max(np.abs(direct.y), axis=0)
    assert np.max(np.abs(res.solution.y[-1] - direct.y[-1]) / scale) < 1e-9  # QM's own step
    h = np.linalg.norm(res.diagnostics.H, axis=1)
    assert np.max(np.abs(h - h[0])) <= 1e-12 * h[0]
    e = res.diagnostics.E + res.solution.dissipated
    assert np.max(np.abs(e - e[0])) <= 1e-8 * abs(e[0])
    q = simulate.execute(simulate.prepare(short_run("Q")))  # the same case by Q differs more
    assert np.max(np.abs(q.solution.y[-1] - direct.y[-1]) / scale) > 1e-6


def test_qm_family_conserves_h_and_energy_through_switches(workdir):  # noqa: F811
    """The spin family of test_spin_family with formulation QM (a switch at every chunk): the
    members' QM systems from the one structure, the switches' map with QM's momenta: |H| and
    E + E_d as constant as Q's family keeps them; the neighbours' errors measured at each switch."""
    text = run_toml(spin='"300 rad/s"', cone='"10 deg"', amplitude='"0 in"', duration='"0.04 s"',
                    dt='"0.2 ms"', save_every="50")  # fmt: skip
    text = text.replace('formulation = "Q"', 'formulation = "QM"\nreference = "spinning"\n'
                        'path_model = "spin-family"\npath_switch = 1e-6')  # fmt: skip
    (workdir / "fam.toml").write_text(text, encoding="utf-8")
    result = simulate.simulate(load_run_case(workdir / "fam.toml"))
    assert result.complete and len(result.family) >= 1
    assert result.system.formulation == "QM"
    d = result.diagnostics
    assert np.max(np.abs(d.H_norm - d.H_norm[0])) <= 1e-10 * d.H_norm[0]
    eb = d.E + d.E_d
    assert np.max(np.abs(eb - eb[0])) <= 1e-6 * abs(eb[0])
    for sw in result.family:
        assert sw.h_change <= 1e-12
        # the members' coning-rate error is measured (by their quadratic view): a QM family's
        # adaptive spacing follows it as Q's does (before: NaN, the first departure for good)
        assert np.isfinite(sw.sink_error) and np.isfinite(sw.frequency_error)


def test_linearised_analyses_use_q4_and_hub_runs_refuse_qm():
    """QM's kinetic energy to second order is Q's and its potential Q4's: the spin check's
    linearised analyses use Q4; a spin-up (a beam on a hub) refuses QM with one line."""
    import pytest

    from quadmodes.case import CaseError
    from quadmodes.runs.manifold_system import linear_formulation

    assert linear_formulation("QM") == "Q4" and linear_formulation("Q") == "Q"
    data = tomllib.loads(load_run_case("kane-spinup").to_toml())
    data["reduced"]["formulation"] = "QM"
    with pytest.raises(CaseError, match="QM"):
        simulate.simulate_spinup(run_case_from_dict(data, source="test"))


def test_a_path_left_by_its_amplitudes_points_to_qm():
    """The run's warning names formulation QM when the path leaves by the amplitude check under
    another formulation of a model with the manifold potential; not for other reasons, not for
    QM itself, not for a model without V3/V4."""
    from types import SimpleNamespace

    from quadmodes.cli.run_commands import path_hint
    from quadmodes.runs.path_validity import PathValidity

    def path(err):
        return PathValidity(reference_spin=257.6, centrifugal_max=0.03, centrifugal_limit=0.02,
                            spin_range=(255.0, 260.0), min_stiffness=1e3, amplitude_peak=5e-4,
                            amplitude_peak_time=1.0, left_at=1.0, amplitude_error=err)  # fmt: skip

    amp = path(0.023)  # the potential 2.3 % off the condensed energy: left by the amplitudes
    spin = path(0.004)  # left by the spin (the centrifugal load); the amplitudes pass
    model, old = SimpleNamespace(manifold_potential=True), SimpleNamespace(manifold_potential=False)
    assert 'reduced.formulation = "QM"' in path_hint(amp, "Q", model)
    assert path_hint(amp, "QM", model) == "" and path_hint(amp, "Q", old) == ""
    assert path_hint(spin, "Q", model) == ""
