"""The full order of a membrane on a hub in time (issue 26; docs/sails.md, "Full-order
comparisons in time"): its Newton failure at a large nutation is the membrane's loss of tension,
and says so; a nutation small enough for the membrane to stay taut integrates and conserves."""

import numpy as np
import pytest

from quadmodes.case import case_from_toml, load_case
from quadmodes.case.editing import edit
from quadmodes.fe.build import MembraneSpec
from quadmodes.fe.hub import HubSpec
from quadmodes.fe.hub_membrane import build_hub_membrane_structure
from quadmodes.fullorder import integrate_full_order
from quadmodes.fullorder.newton import FullOrderNewtonError
from quadmodes.fullorder.options import FullOrderOptions
from quadmodes.mesh.hub_flat import annulus_surface, hub_ring_nodes
from quadmodes.structure import pipeline
from quadmodes.structure.membrane_tension import loss_of_tension, tension_state

E, NU, T = 3e9, 0.3, 7.5e-6


def test_tension_state_of_a_uniform_stretch():
    """Hub and membrane scaled by λ about the hub's centre: a uniform equibiaxial Green strain
    e = (λ² − 1)/2, so every principal resultant is E t e/(1 − ν) — taut for λ > 1, compressed
    everywhere for λ < 1."""
    s = annulus_surface(1.0, 0.3, 0.15)
    st = build_hub_membrane_structure(s.points, s.triangles, MembraneSpec(T, E, NU, 1420.0, 0.0),
                                      HubSpec(10.0, (1.0, 1.0, 1.5)),
                                      hub_ring_nodes(s.points, 0.3))  # fmt: skip
    for lam in (1.0 + 1e-4, 1.0 - 1e-4):
        ts = tension_state(st, lam * st.reference)  # the axes rows scaled too: the images
        expected = E * T * 0.5 * (lam**2 - 1.0) / (1.0 - NU)
        assert np.isclose(ts.least_resultant, expected, rtol=1e-6)
        assert ts.not_taut_fraction == (0.0 if lam > 1 else 1.0)
    assert loss_of_tension(st, (1 + 1e-4) * st.reference, st.reference) == ""
    cause = loss_of_tension(st, (1 - 1e-4) * st.reference, (1 + 1e-4) * st.reference)
    assert "lost its tension: not taut on 100 %" in cause


@pytest.fixture(scope="module")
def coarse_annulus():
    """spinning-annulus on a 1.5 m mesh (51 DOFs) at its 1 rad/s relative equilibrium."""
    case = edit(load_case("spinning-annulus"), {"mesh.edge_length": "1.5 m"}, "test")
    st = pipeline.structure_for_case(case)
    x_ref, _ = pipeline.reference_state(case, st)
    return st, x_ref


def _coning(st, x_ref, cone_deg: float) -> np.ndarray:
    """The rigid velocity (n,3) of the torque-free body with |H| = I_z × 1 rad/s at
    ``cone_deg`` from the normal z (body axes principal by symmetry): ω = (H sin θ / I_x, 0,
    H cos θ / I_z); the hub's axis rows turn as directions (ω × a)."""
    tr = st.translational.astype(float)
    ms = st.mass_scalar
    r = x_ref - np.outer(tr, (tr @ ms @ x_ref) / (tr @ ms @ tr))
    j = r.T @ (ms @ r)  # the position field is linear in the vector DOFs
    inertia = np.trace(j) * np.eye(3) - j
    th = np.radians(cone_deg)
    h = inertia[2, 2]
    omega = np.array([h * np.sin(th) / inertia[0, 0], 0.0, h * np.cos(th) / inertia[2, 2]])
    return np.cross(omega, r)


def _run(st, x_ref, cone_deg: float, duration: float):
    opts = FullOrderOptions(damping=False, spin_axis=np.array([0.0, 0.0, 1.0]))
    return integrate_full_order(st, x_ref, x_ref, _coning(st, x_ref, cone_deg), (0.0, duration),
                                0.1, opts)  # fmt: skip


def test_large_nutation_fails_naming_the_loss_of_tension(coarse_annulus):
    """5°: the hub's nutation drives the membrane relative to it far beyond what its
    centrifugal tension carries; the SVK membrane goes into compression over most of its area
    and the step's Newton fails — the error names that cause, not the tolerance."""
    with pytest.raises(FullOrderNewtonError) as err:
        _run(*coarse_annulus, 5.0, 4.0)
    assert "the membrane has lost its tension: not taut on" in str(err.value)
    assert "(0 % in the reference state)" in err.value.cause


def test_small_nutation_integrates_and_conserves(coarse_annulus):
    """0.05°: the membrane stays taut; undamped, |H| and the energy are kept to round-off."""
    sol = _run(*coarse_annulus, 0.05, 3.0)
    assert sol.status == 0 and np.isclose(np.degrees(sol.cone_angle[0]), 0.05, rtol=1e-6)
    assert np.ptp(sol.H_norm) < 1e-9 * sol.H_norm[0]
    assert np.ptp(sol.E) < 1e-8 * np.abs(sol.E).max()


def test_taut_nutation_decay_reduced_against_the_full_order(tmp_path):
    """The coarse annulus (1.5 m mesh) from 0.1°, 60 s, 2 % membrane damping: the reduced run
    (every mode up to the rule's margin) against the full order with its independent damping —
    the envelope, the cone and the dissipated power agree (measured 2.6 %, 1.5 %, × 1.025; the
    built-in sail and annulus over 600 s: docs/sails.md)."""
    import json
    import sys
    from pathlib import Path

    import quadmodes as qm

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from benchmarks.studies.bench_sail_fullorder import write_cases

    run = write_cases(tmp_path, "spinning-annulus-nutation", 0.1, 1.5, 60.0)
    qm.compare(str(run), "60 s", formulations=("Q",), output_dir=tmp_path / "out", plots=False)
    summary = json.loads((tmp_path / "out" / "comparison.json").read_text())
    q, full = summary["formulations"]["Q"], summary["full_order"]
    assert full["complete"] and full["H_relative_drift"] < 1e-8
    assert full["cone_angle_end_deg"] < 0.095  # it decays (0.0865° measured)
    assert q["envelope_error"] < 0.04 and q["cone_angle_error"] < 0.03
    assert abs(q["dissipated_power_ratio"] - 1.0) < 0.05


def test_spin_stiffened_rotor_starts_without_the_coning_stretch(tmp_path):
    """A string-blade rotor with a tall hub (a major-axis spinner whose blades have EI ≈ 0)
    about its spinning state, from 0.5°: the quasi-static centrifugal stretch of the coning ω is
    not added (it swung the strings into compression at t = 0 and the first step failed); the
    blades start as taut as the reference state and the full order integrates."""
    from quadmodes.analysis.full_order_runs import full_order_for_run, setup_for_run

    rotor = load_case("string-blade-rotor").to_toml()
    rotor = rotor.replace('name = "string-blade-rotor"', 'name = "tall-hub-rotor"')
    rotor = rotor.replace("elements = 40", "elements = 10")  # coarse: seconds
    model = edit(case_from_toml(rotor), {"hub.inertia_x": "0.9 kg*m^2", "hub.inertia_y":
                                         "0.9 kg*m^2", "hub.damping_ratio": 0.02}, "test")  # fmt: skip
    (tmp_path / "tall-hub-rotor.toml").write_text(model.to_toml(), encoding="utf-8")
    run = tmp_path / "tall.toml"
    run.write_text(
        'name = "tall"\nkind = "run"\nmodel = "tall-hub-rotor.toml"\n[reduced]\nmodes = 4\n'
        'formulation = "Q"\nreference = "spinning"\n[initial]\nspin_rate = "1 rad/s"\n'
        'cone_angle = "0.5 deg"\nspin_axis = "major"\n[integration]\ndt = "0.05 s"\n'
        'duration = "1 s"\n', encoding="utf-8")  # fmt: skip
    st = setup_for_run(str(run), damping="none")
    assert any("spin-stiffened body about its spinning state" in n for n in st.notes)
    axial = [e for e in st.structure.elements[1:] if e.offsets.shape[-1] == 4]  # beam strains
    for x in (st.x_ref, st.x0):
        assert min(float(e.strains(x)[:, :, 0].min()) for e in axial) > 0.0
    sol = full_order_for_run(st.run, setup=st, damping="none")
    assert sol.status == 0 and np.isclose(sol.t[-1], 1.0)
