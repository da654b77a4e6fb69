"""A body a user would draw: a 2 m cylinder with flat end caps and a 1 kg tip mass at 0.2 psi.

A stress-free flat end disc has no stiffness out of its plane, so Newton from the drawn shape
fails; the inflation follows the pressure with pseudo-transient continuation and relaxes the
compressed rim of the ends by the tension-field law. Checked against the thin-wall closed form
away from the ends (hoop p r, axial p r / 2, with r the inflated radius), the equilibrium (no
compression left, wrinkles at the ends only) and the one-line advice when a field is wrong.
"""

import numpy as np
import pytest

from quadmodes.case import case_from_toml
from quadmodes.fe.membrane import MembraneSet
from quadmodes.structure import prestress
from quadmodes.structure.pipeline import build_modal_model, reference_state, structure_for_case

PSI = 6894.757293168361

FLAT_CYLINDER = """
name = "flat-cylinder-tip"
kind = "membrane"

[geometry]
shape = "flat-cylinder"
length = "2 m"
diameter = "0.5 m"

[mesh]
edge_length = "{edge}"

[material]
density = "0.0335 lb/in^3"
youngs_modulus = "0.05 Mpsi"
poisson_ratio = 0.3
thickness = "0.0045 in"
damping_ratio = "2 %"
wrinkling = "{wrinkling}"

[pressure]
value = "0.2 psi"

[[end_body]]
name = "tip"
pole = "rear"
mass = "1 kg"
radius = "5 cm"
height = "2 cm"
attach_radius = "5 cm"
offset = "1 cm"

[modes]
count = 6
"""


def _case(wrinkling="tension-field", edge="12 cm"):
    return case_from_toml(FLAT_CYLINDER.format(wrinkling=wrinkling, edge=edge))


@pytest.fixture(scope="module")
def inflated():
    case = _case()
    structure = structure_for_case(case)
    x, state = reference_state(case, structure)
    return case, structure, x, state


def _mid_length_errors(case, structure, x, state):
    """Relative errors of the mean hoop and axial resultants over the middle half of the
    cylinder against p r and p r / 2 (r the mean inflated radius of the nodes there)."""
    membrane = next(e for e in structure.elements if isinstance(e, MembraneSet))
    nodes = x[np.unique(membrane.conn)]
    centre = nodes.mean(axis=0)
    c = nodes - centre
    axis = np.linalg.eigh(c.T @ c)[1][:, -1]  # the long axis: largest second moment
    along = c @ axis
    quarter = 0.25 * case.geometry.length
    r = np.mean(np.linalg.norm(c - np.outer(along, axis), axis=1)[np.abs(along) < quarter])
    middle = np.abs((x[membrane.conn].mean(axis=1) - centre) @ axis) < quarter
    p = case.pressure.value
    axial, hoop = state.stress_resultants[middle].T
    return np.mean(hoop) / (p * r) - 1, np.mean(axial) / (p * r / 2) - 1


def test_flat_cylinder_mid_length_resultants_converge_to_thin_wall_closed_form(inflated):
    assert inflated[3].residual_norm < 1e-8
    hoop, axial = _mid_length_errors(*inflated)
    assert abs(hoop) < 0.03 and abs(axial) < 0.03  # 12 cm edges: -2.4 %, -1.7 %
    # a finer mesh: the faceting error falls as the edge length squared (12 cm -> 8 cm: / 2.25)
    case = _case(edge="8 cm")
    structure = structure_for_case(case)
    hoop_fine, axial_fine = _mid_length_errors(case, structure, *reference_state(case, structure))
    assert abs(hoop_fine) < abs(hoop) / 2.25 * 1.3
    assert abs(axial_fine) < abs(axial) / 2.25 * 1.3


def test_flat_ends_wrinkle_instead_of_carrying_compression(inflated):
    case, structure, x, state = inflated
    minor = state.stress_resultants[:, 0]
    largest = np.abs(state.stress_resultants).max()
    assert np.all(minor > -1e-9 * largest)  # no compression left
    wrinkled = state.wrinkle_state() == 1
    assert 0 < wrinkled.sum() < 0.3 * wrinkled.size
    assert state.volume_change > 0


def test_svk_flat_cylinder_is_refused_naming_the_wrinkling_field():
    case = _case("none")
    with pytest.raises(ValueError, match=r'wrinkling = "tension-field"'):
        reference_state(case, structure_for_case(case))


def test_inflation_failure_names_pressure_steps(monkeypatch):
    def never(*args, **kwargs):
        raise prestress.ConvergenceError("inflation: no convergence")

    monkeypatch.setattr(prestress, "equilibrium", never)
    case = _case()
    with pytest.raises(prestress.ConvergenceError, match=r"\[pressure\] steps \(now 1\)"):
        reference_state(case, structure_for_case(case))


def test_flat_cylinder_modes_include_the_bending_pair():
    model = build_modal_model(_case())
    labels = model.labels
    assert any(lab.startswith("bending") for lab in labels)
    assert np.all(model.modes.frequencies_hz > 1.0)  # no mechanism from the wrinkled rim


def test_equilibrium_does_not_depend_on_the_load_steps(inflated):
    """An elastic body's inflated state is path independent: four load steps (a quarter of the
    pressure first, grown on quick success) reach the one-step state, up to a rigid motion (the
    frame conditions hold per increment): the same stresses and volume."""
    case, structure, x, state = inflated
    stepped = case.model_copy(update={"pressure": case.pressure.model_copy(update={"steps": 4})})
    _, state4 = reference_state(stepped, structure_for_case(stepped))
    largest = np.abs(state.stress_resultants).max()
    assert np.abs(state4.stress_resultants - state.stress_resultants).max() < 1e-6 * largest
    assert state4.volume == pytest.approx(state.volume, rel=1e-9)
    assert state4.residual_norm < 1e-8


def test_newton_alone_fails_from_the_drawn_flat_ends_and_continuation_succeeds():
    """The negative control: from the stress-free drawn shape (8 cm edges) Newton at full
    pressure does not converge (the flat discs have no stiffness out of their plane); the
    pseudo-transient continuation from the same start does."""
    from quadmodes.fe.model import with_load_factor, with_tension_field

    case = _case(edge="8 cm")
    loaded = with_load_factor(with_tension_field(structure_for_case(case), False), 1.0)
    with pytest.raises(prestress.ConvergenceError):
        prestress.solve_static(loaded, loaded.reference)
    _, rel, _ = prestress.solve_pseudo_transient(loaded, loaded.reference)
    assert rel < 1e-8
