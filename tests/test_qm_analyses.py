"""Formulation "QM" in the analyses that linearise about a steady spin (Campbell, critical speeds,
the energy-sink estimate, a sweep) and in ``quadmodes campbell`` / ``sweep`` / ``run``.

Why QM's linearisation is Q4's. About a relative equilibrium (s*, ṡ = 0, ω0) the linearised
equations read the Lagrangian L = T − V and the dissipation to second order in (δs, δṡ, δω).
With T = ½ωᵀJ(s)ω + ωᵀA(s)ᵀṡ + ½ṡᵀμ(s)ṡ that is, at s* = 0, J to second order in s, A to
first and μ to zeroth (every term of T of total degree two in the perturbations). The exact
kinetic energy of the quadratic manifold x(s) = X + Φs + Σ g^{mn}s_m s_n (QM's) and Q's agree in
exactly those orders (:func:`test_qm_kinetics_are_qs_to_the_orders_a_linearisation_reads`: the
differences of the J, A and μ blocks are O(|s|³), O(|s|²), O(|s|)); QM's potential is Q4's
(the same arrays) and its damping at s = 0 is the model's C. So at s* = 0 — a model expanded
about the spinning state, at its reference spin — the linearisation of QM *is* Q4's, and the
analyses use Q4's arrays for it (``runs.manifold_system.linear_formulation``); elsewhere (s* ≠ 0)
QM's own linearisation would differ from Q4's by terms relatively O(|s*|), those Q's kinetic
energy leaves out everywhere, and the analyses give Q4's numbers there too (docs/
manifold-formulation.md). The tests below then check that the analyses give Q4's numbers to the
last bit for QM, and that the command line takes QM (a QM run case included) without failing.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from test_sweep import RUN, folder, runner  # noqa: F401  (fixture)

from quadmodes.analysis.campbell import campbell
from quadmodes.cli.app import app
from quadmodes.rom import dynamics as dy
from quadmodes.rom import manifold_kinetics as mk
from quadmodes.rom import system as rsys
from quadmodes.rom.energy_sink import energy_sink
from quadmodes.sweeps import critical as crit

#: Spin rates (Hz) between which the small capsule's rotating stiffness Λ − ωᵀJ2ω (Q4, about
#: its minor axis) loses positive definiteness: a divergence.
DIVERGENCE_BRACKET_HZ = (180.0, 200.0)


@pytest.fixture(scope="module")
def capsule(small_modal_model, small_reduced_model):
    model = small_reduced_model
    arrays = mk.manifold_arrays(model, small_modal_model.structure.mass_scalar,
                                mk.retained_damping(model))  # fmt: skip
    return model, mk.manifold_system(model, arrays), rsys.reduced_system(model, "Q4")


def test_qm_kinetics_are_qs_to_the_orders_a_linearisation_reads(capsule):
    """𝕄_QM(s) − 𝕄_Q(s) along s = ε d: the J block O(ε³), the coupling O(ε²), μ O(ε) (halving ε
    divides them by 8, 4, 2), and zero at s = 0: J, its gradient and Hessian, A and its gradient,
    and μ at s = 0 are the same (module docstring)."""
    model, qm, q4 = capsule
    n = model.n_modes
    d = np.random.default_rng(3).standard_normal(n)
    t = np.asarray(model.translational, bool)
    d *= 1e-3 / np.max(np.linalg.norm(np.tensordot(d, model.Phi, 1)[t], axis=1))  # 1 mm

    def blocks(eps):
        diff = dy.mass_matrix(qm, eps * d) - dy.mass_matrix(q4, eps * d)
        return [np.max(np.abs(b)) for b in (diff[:3, :3], diff[:3, 3:], diff[3:, 3:])]

    m0 = dy.mass_matrix(q4, np.zeros(n))
    assert np.max(np.abs(dy.mass_matrix(qm, np.zeros(n)) - m0)) <= 1e-12 * np.max(np.abs(m0))
    big, small = blocks(1.0), blocks(0.5)
    for ratio, order in zip(np.array(big) / np.array(small), (3, 2, 1), strict=True):
        assert ratio == pytest.approx(2.0**order, rel=0.05)
    assert np.array_equal(qm.Lam, q4.Lam) and np.array_equal(qm.V4, q4.V4)  # Q4's potential
    assert np.allclose(mk.damping_matrix(qm.manifold, np.zeros(n)), model.C, rtol=0,
                       atol=1e-9 * np.max(np.abs(model.C)))  # fmt: skip


def _refined(model, lo_hz, hi_hz, formulation):
    """The refined critical speed of a stiffness bracket (spin, kind, branch), or the error."""
    bracket = crit.Bracket(0, 1, 2 * np.pi * lo_hz, 2 * np.pi * hi_hz, "stiffness")
    try:
        c = crit.refine(model, bracket, formulation, "minor")
    except ValueError as exc:
        return str(exc)
    return c.spin, c.kind, c.branch, c.partner, c.entering


def test_campbell_critical_speed_and_energy_sink_of_qm_are_q4s(capsule):
    model, qm, q4 = capsule
    spins = 2 * np.pi * np.linspace(0.0, 60.0, 7)
    a, b = (campbell(model, spins, "minor", formulation=f, damped=True) for f in ("QM", "Q4"))
    assert a.formulation == "QM" and a.labels == b.labels
    for name in ("frequency", "growth", "min_stiffness", "s_eq"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    # refinement: a bracket without a crossing (it ends at its top), and the divergence, where
    # Q4's relative equilibrium is a fold of the quartic statics (its Newton may not converge)
    for lo, hi in ((20.0, 40.0), DIVERGENCE_BRACKET_HZ):
        assert _refined(model, lo, hi, "QM") == _refined(model, lo, hi, "Q4")
    assert _refined(model, 20.0, 40.0, "QM")[0] == pytest.approx(2 * np.pi * 40.0, rel=1e-6)
    i = 3  # 30 Hz: the energy-sink estimate of the QM system is the Q4 system's
    w0 = a.spin_axis[i] * spins[i]
    sq, s4 = (energy_sink(sys, a.s_eq[i], w0, math.radians(6)) for sys in (qm, q4))
    assert sq == s4 and sq.power > 0


def _qm_run(folder, name="qm-run.toml"):  # noqa: F811
    text = RUN.replace("modes = 5", 'modes = 5\nformulation = "QM"')
    (folder / name).write_text(text, encoding="utf-8")
    return name


def test_campbell_command_takes_qm_and_prints_q4s_numbers(folder):  # noqa: F811
    out = {}
    for f in ("QM", "Q4"):
        res = runner.invoke(app, ["campbell", "small.toml", "--formulation", f, "--points", "3",
                                  "--spin-max", "40 Hz", "--modes", "5", "--json"])  # fmt: skip
        assert res.exit_code == 0, res.output
        out[f] = json.loads(res.stdout)
    assert out["QM"].pop("formulation") == "QM" and out["Q4"].pop("formulation") == "Q4"
    assert out["QM"] == out["Q4"]


def test_sweep_of_a_qm_run_case_gives_q4s_numbers(folder):  # noqa: F811
    """A run case with formulation QM through ``quadmodes sweep`` beside Q4 (linearisation,
    energy sink, the critical speeds of each spin line refined on a worker): no point fails,
    the same numbers."""
    name = _qm_run(folder)
    lo, hi = DIVERGENCE_BRACKET_HZ
    res = runner.invoke(app, ["sweep", name, "--param", "reduced.formulation=QM,Q4", "--param",
                              f"initial.spin_rate={lo} Hz, {hi} Hz", "--axis", "minor",
                              "--no-time-run", "--workers", "1", "-o", "out", "--json",
                              "--no-plots"])  # fmt: skip
    assert res.exit_code == 0, res.output
    info = json.loads(res.stdout)
    assert info["points"] == 4 and info["failed"] == 0
    ds = xr.open_dataset(folder / "out" / "sweep.nc")
    for var in ("energy_sink_growth_rate", "branch_frequency", "min_rotating_stiffness"):
        qm, q4 = (ds[var].sel(formulation=f).values for f in ("QM", "Q4"))
        np.testing.assert_array_equal(qm, q4, err_msg=var)
    speeds = info["critical_speeds"]
    assert len(speeds) == 2  # one per formulation's spin line, the same
    strip = [{k: v for k, v in s.items() if k not in ("values", "lo", "hi", "formulation")} for s in speeds]
    assert strip[0] == strip[1]


def test_run_of_a_qm_case_has_q4s_linear_answer_and_campbell(folder):  # noqa: F811
    """``quadmodes run`` of a QM case: its energy-sink estimate and stability verdict (Q4's) and
    its model's Campbell diagram (a model about rest) beside its figures, no note of a failure."""
    name = _qm_run(folder)
    text = (folder / name).read_text().replace('"QM"', '"Q4"')
    (folder / "q4.toml").write_text(text, encoding="utf-8")
    summaries = {}
    for f, case, plots in (("QM", name, "--plots"), ("Q4", "q4.toml", "--no-plots")):
        res = runner.invoke(app, ["run", case, "-o", f"out-{f}", "--json", plots])
        assert res.exit_code == 0, res.output
        summaries[f] = json.loads(next((folder / f"out-{f}").glob("*/summary.json")).read_text())
    qm, q4 = summaries["QM"], summaries["Q4"]
    assert qm["formulation"] == "QM"
    assert qm["coning_time_constant_s"] == q4["coning_time_constant_s"]
    assert math.isfinite(qm["coning_time_constant_s"])
    assert qm["spin_stability"] == q4["spin_stability"] == "unstable"  # a minor-axis spinner
    assert next((folder / "out-QM").glob("*/campbell.png")).stat().st_size > 0
    assert not any("no Campbell" in n or "no energy-sink" in n for n in qm.get("notes", []))
