"""Heliogyro blades (issue 26): radial membrane strips clamped at their roots to a free rigid
hub, held taut by their spin alone: flap and twist frequencies against the string with
centrifugal tension (tests/reference/spinning_strip.py, no quadmodes code)."""

import numpy as np
import pytest
from reference.spinning_strip import flap_ratios, twist_ratios

from quadmodes.case import CaseError, case_from_toml, load_case
from quadmodes.case.editing import edit
from quadmodes.structure.pipeline import build_modal_model

PATTERN = np.array([1.0, -1.0, 1.0, -1.0])  # four blades alternating: no net load on the hub


def blade_modes(model, blades: int = 4) -> list[tuple[float, str, float]]:
    """``(ω/Ω, "flap" or "twist", share of the alternating pattern)`` per mode: each blade's
    deflection split into its mean (flap) and its first moment across the width (twist)."""
    st = model.structure
    idx = st.groups["membrane"]
    p = st.reference[idx, :2]
    phi = 2 * np.pi * np.arange(blades) / blades
    axes = np.column_stack([np.cos(phi), np.sin(phi)])
    k = np.argmax(p @ axes.T, axis=1)
    y = p[:, 0] * -axes[k, 1] + p[:, 1] * axes[k, 0]
    width = model.case.geometry.width
    out = []
    for f, shape in zip(model.modes.frequencies_hz, model.modes.shapes, strict=True):
        w = shape[idx, 2]
        flap = np.array([w[k == j].sum() for j in range(blades)])
        twist = np.array([(w * y)[k == j].sum() for j in range(blades)]) * 12 / width**2
        kind, v = ("flap", flap) if np.linalg.norm(flap) > np.linalg.norm(twist) else ("twist", twist)
        share = abs(v @ PATTERN) / (2 * np.linalg.norm(v) + 1e-300)
        out.append((2 * np.pi * f / model.spinning.spin, kind, share))
    return out


def _model(edge: float, spin: float = 1.0, count: int = 12):
    changes = {"mesh.edge_length": f"{edge} m", "spin.rate": f"{spin} rad/s", "modes.count": count}
    return build_modal_model(edit(load_case("heliogyro-blade"), changes, "test"))


def test_flap_against_the_string():
    """The alternating flap pattern (no net force or moment on the hub) within 0.05 % of the
    string with centrifugal tension, first and second flap, on the 0.25 m mesh; ω/Ω the same at
    1 and 3 rad/s."""
    g = load_case("heliogyro-blade").geometry
    ref = flap_ratios(0.5 * g.inner_diameter, g.length, 2)
    for spin in (1.0, 3.0):
        model = _model(0.25, spin, 16)
        modes = blade_modes(model)
        alt = sorted(r for r, kind, share in modes if kind == "flap" and share > 0.99)
        assert len(alt) == 2
        names = [lab for lab, (_, kind, share) in zip(model.labels, modes, strict=True)
                 if kind == "flap" and share > 0.99]  # fmt: skip
        assert names == ["blade flap (n=2, s=0)", "blade flap (n=2, s=1)"]
        np.testing.assert_allclose(alt, ref, rtol=5e-4)  # 1e-6 and 3e-4


def test_twist_converges_to_the_propeller_moment():
    """Twist: the string's tension plus the membrane's propeller moment, ω² = ω²_flap + Ω²;
    resolved only across the width, 12.3 % (2 elements), 3.2 % (4), 0.8 % (8, docs)."""
    g = load_case("heliogyro-blade").geometry
    ref = twist_ratios(0.5 * g.inner_diameter, g.length, 1)[0]
    errors = []
    for edge in (0.25, 0.125):
        twist = min(r for r, kind, _ in blade_modes(_model(edge)) if kind == "twist")
        errors.append(twist / ref - 1)
    assert 0 < errors[1] < 0.04 and errors[0] > 3 * errors[1]


def test_case_rules():
    blade = load_case("heliogyro-blade")
    assert case_from_toml(blade.to_toml()) == blade
    with pytest.raises(CaseError, match="their roots would overlap"):
        edit(blade, {"geometry.width": "1.2 m"}, "test")
    with pytest.raises(CaseError, match="width"):
        edit(blade, {"geometry.width": None}, "test")
    with pytest.raises(CaseError, match=r"needs a \[hub\] table"):
        edit(blade, {"hub": None}, "test")
