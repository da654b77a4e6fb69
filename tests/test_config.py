"""Units parsing and validated case files."""

import math

import pytest

from quadmodes.case import (
    Case,
    CaseError,
    QuantityError,
    builtin_case_names,
    builtin_case_text,
    case_from_toml,
    case_to_toml,
    format_quantity,
    load_case,
    parse_quantity,
)

BUILTINS = [
    "capsule", "heliogyro-blade", "hub-booms", "ikaros-sail", "kane-beam", "paper-membrane",
    "paper-membrane-coarse", "paper-membrane-rim", "sphere", "spinning-annulus", "spinning-disc",
    "string-blade-rotor", "two-blade-rotor",
]


def _one_line(message: str) -> None:
    assert message and "\n" not in message and "\r" not in message


# ------------------------------------------------------------------------------- units


@pytest.mark.parametrize(
    ("text", "dimension", "si"),
    [
        ("0.3 psi", "pressure", 2068.43),
        ("0.0335 lb/in^3", "density", 927.28),
        ("0.05 Mpsi", "pressure", 344.74e6),
        ("60 in", "length", 1.524),
        ("41 Hz", "frequency", 41.0),
        ("6 deg", "angle", math.radians(6)),
        ("2 %", "dimensionless", 0.02),
        ("1e-5 kg m^2", "inertia", 1e-5),
        ("60 rpm", "angular_rate", 2 * math.pi),
        ("1 Hz", "angular_rate", 2 * math.pi),
        ("2 rad/s", "angular_rate", 2.0),
        ("6.283185307179586 rad/s", "frequency", 1.0),
        ("4e-4 m^2", "area", 4e-4),
        ("2e-7 m^4", "second_moment", 2e-7),
        ("3 kN", "force", 3000.0),
        ("2.8e7 N", "stiffness_EA", 2.8e7),
        ("1.4e4 N m^2", "stiffness_EI", 1.4e4),
        ("1.2 kg/m", "linear_density", 1.2),
        ("250 ms", "time", 0.25),
        ("0.1 kg", "mass", 0.1),
    ],
)
def test_parse_quantity_si(text, dimension, si):
    assert parse_quantity(text, dimension, "f") == pytest.approx(si, rel=1e-4)


def test_dimensionless_accepts_plain_numbers():
    assert parse_quantity(0.3, "dimensionless", "f") == 0.3
    assert parse_quantity("0.3", "dimensionless", "f") == 0.3


@pytest.mark.parametrize(
    ("value", "dimension", "expected"),
    [
        ("0.3", "pressure", 'pressure.value: "0.3" has no unit; give a pressure'),
        (0.3, "pressure", "pressure.value: 0.3 has no unit"),
        ("3 in", "pressure", 'pressure.value: "3 in" is a length, expected a pressure'),
        ("0.3 psi", "length", 'pressure.value: "0.3 psi" is a pressure, expected a length'),
        ("sixty in", "length", "pressure.value:"),
        ("3 furlongz", "length", "pressure.value:"),
        ("6 deg", "dimensionless", "is an angle"),
        (True, "length", "pressure.value:"),
    ],
)
def test_parse_quantity_errors(value, dimension, expected):
    with pytest.raises(QuantityError) as info:
        parse_quantity(value, dimension, "pressure.value")
    _one_line(str(info.value))
    assert expected in str(info.value)


def test_format_quantity():
    assert format_quantity(2068.427187950509, "psi") == "0.3 psi"
    assert format_quantity(1.524, "in") == "60 in"
    assert format_quantity(0.02, "%") == "2 %"


# ------------------------------------------------------------------------------- cases


def test_builtin_names():
    assert builtin_case_names() == BUILTINS


@pytest.mark.parametrize("name", BUILTINS)
def test_builtin_case_loads_and_round_trips(name):
    case = load_case(name)
    assert isinstance(case, Case) and case.name == name
    text = case_to_toml(case)
    assert case_from_toml(text) == case
    assert case_to_toml(case_from_toml(text)) == text


def test_paper_membrane_si_values():
    case = load_case("paper-membrane")
    assert case.kind == "membrane" and case.beam is None
    assert case.pressure.value == pytest.approx(2068.43, rel=1e-4)
    assert case.pressure.gas_law_exponent == 0
    assert case.material.density == pytest.approx(927.28, rel=1e-4)
    assert case.material.youngs_modulus == pytest.approx(344.74e6, rel=1e-4)
    assert case.material.thickness == pytest.approx(0.0045 * 0.0254)
    assert case.material.poisson_ratio == 0.3
    assert case.material.damping_ratio == pytest.approx(0.02)
    assert case.geometry.shape == "sphere-cone"
    assert case.geometry.length == pytest.approx(1.524, rel=1e-4)
    assert case.geometry.front_cap_diameter == pytest.approx(0.127)
    assert case.geometry.rear_cap_diameter == pytest.approx(0.508)
    assert case.mesh.edge_length == pytest.approx(0.0254)
    assert case.mesh.mass_matrix == "consistent"
    assert case.modes.count == 10
    front, rear = case.end_body
    assert (front.name, front.pole, rear.name, rear.pole) == ("front", "front", "rear", "rear")
    assert front.mass > 0 and rear.mass > 0  # calibrated values, checked in test_prestress_modes
    assert rear.attach_radius == pytest.approx(0.0508)
    assert "quadmodes calibrate" in builtin_case_text("paper-membrane")


def test_kane_beam_values():
    case = load_case("kane-beam")
    assert case.kind == "beam" and case.geometry is None and case.end_body == ()
    beam = case.beam
    assert (beam.length, beam.area, beam.second_moment) == (10.0, 4e-4, 2e-7)
    assert (beam.youngs_modulus, beam.density) == (7e10, 3000.0)
    assert beam.support == "clamped" and beam.elements == 20
    assert case.modes.count == 6


def test_other_membranes():
    sphere = load_case("sphere")
    assert sphere.geometry.diameter == pytest.approx(0.508) and sphere.end_body == ()
    capsule = load_case("capsule")
    assert capsule.geometry.diameter == pytest.approx(0.508)
    assert capsule.geometry.length == pytest.approx(1.524)


def test_load_case_from_path(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(builtin_case_text("sphere").replace('"sphere"\n', '"mine"\n', 1))
    case = load_case(str(path))
    assert case.name == "mine" and case.geometry.shape == "sphere"


def test_case_is_frozen():
    case = load_case("sphere")
    with pytest.raises(ValueError):
        case.name = "other"


# ------------------------------------------------------------------------------- bad input

# A hand-written case in inch-pound units (the built-in paper case is stored in SI after
# calibration); the bad-input tests edit this text.
PAPER = """
name = "paper-membrane"
kind = "membrane"

[geometry]
shape = "sphere-cone"
length = "60 in"
front_cap_diameter = "5 in"
rear_cap_diameter = "20 in"

[mesh]
edge_length = "1 in"
mass_matrix = "consistent"

[material]
density = "0.0335 lb/in^3"
youngs_modulus = "0.05 Mpsi"
poisson_ratio = 0.3
thickness = "0.0045 in"
damping_ratio = "2 %"

[pressure]
value = "0.3 psi"
gas_law_exponent = 0

[modes]
count = 10

[[end_body]]
name = "front"
pole = "front"
mass = "0.05 kg"
inertia_axial = "2e-6 kg m^2"
inertia_transverse = "2e-6 kg m^2"
attach_radius = "1 in"
offset = "0.25 in"
arm = "0.75 in"

[[end_body]]
name = "rear"
pole = "rear"
mass = "0.2 kg"
inertia_axial = "1e-4 kg m^2"
inertia_transverse = "1e-4 kg m^2"
attach_radius = "2 in"
offset = "0.5 in"
arm = "1.5 in"
"""


def _bad(old: str, new: str, text: str = PAPER) -> str:
    assert old in text
    with pytest.raises(CaseError) as info:
        case_from_toml(text.replace(old, new, 1), source="bad.toml")
    message = str(info.value)
    _one_line(message)
    return message


def test_bare_number_for_quantity():
    message = _bad('value = "0.3 psi"', 'value = "0.3"')
    assert "pressure.value" in message and "has no unit" in message and "psi" in message
    assert "pressure.value" in _bad('value = "0.3 psi"', "value = 0.3")


def test_wrong_kind_of_unit():
    message = _bad('value = "0.3 psi"', 'value = "3 in"')
    assert "pressure.value" in message and "is a length" in message
    message = _bad('thickness = "0.0045 in"', 'thickness = "0.3 psi"')
    assert 'material.thickness: "0.3 psi" is a pressure, expected a length' in message


@pytest.mark.parametrize("thickness", ['"0 in"', '"-0.0045 in"'])
def test_non_positive_thickness(thickness):
    message = _bad('thickness = "0.0045 in"', f"thickness = {thickness}")
    assert "material.thickness" in message and "positive" in message


def test_poisson_ratio_half():
    message = _bad("poisson_ratio = 0.3", "poisson_ratio = 0.5")
    assert "material.poisson_ratio = 0.5: must be below 0.5" in message


def test_unknown_case_name():
    with pytest.raises(CaseError) as info:
        load_case("paper-membran")
    message = str(info.value)
    _one_line(message)
    assert '"paper-membran"' in message
    assert all(name in message for name in BUILTINS)


def test_misspelt_key():
    message = _bad('thickness = "0.0045 in"', 'thicknes = "0.0045 in"')
    assert "material.thicknes" in message and "unknown key" in message
    assert '"thickness"' in message


def test_negative_mass():
    message = _bad('mass = "0.2 kg"', 'mass = "-0.2 kg"')
    assert "end_body[1].mass" in message and "positive" in message


def test_missing_section_and_field():
    assert "mesh.edge_length: missing" in _bad('edge_length = "1 in"', "")
    assert "pressure: missing" in _bad('[pressure]\nvalue = "0.3 psi"\ngas_law_exponent = 0', "")


def test_section_not_for_kind():
    beam = builtin_case_text("kane-beam")
    message = _bad("[modes]", '[pressure]\nvalue = "1 psi"\n[modes]', beam)
    assert "pressure: not used" in message


def test_shape_fields():
    assert "geometry.length: not used" in _bad('shape = "sphere-cone"', 'shape = "sphere"')
    assert "geometry.length" in _bad('length = "60 in"', 'length = "10 in"')


def test_toml_syntax_error_names_file_and_line():
    message = _bad("[mesh]", "[mesh")
    line = PAPER.splitlines().index("[mesh]") + 1
    assert message.startswith("bad.toml") and f"line {line}," in message
