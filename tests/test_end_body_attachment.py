"""End-body attachments (issue 14): the bonded flange of ``attachment = "flange"`` (a doubler
annulus around the rigid patch) and the unchanged ``"rim"``; their case fields, the flange's
thickness and mass, and the convergence of the flange model's frequencies with refinement."""

from __future__ import annotations

import numpy as np
import pytest

from quadmodes.case import CaseError, load_case
from quadmodes.case.model_loading import case_from_toml
from quadmodes.fe.build import element_thickness
from quadmodes.fe.membrane import MembraneSet
from quadmodes.fe.model import total_mass
from quadmodes.structure.pipeline import build_modal_model, structure_for_case, surface_for_case

IN = 0.0254
OBJECTIVE = "paper-membrane"


def _membrane(structure) -> MembraneSet:
    return next(e for e in structure.elements if isinstance(e, MembraneSet))


def _coarse(case, edge_in: float, per_attach: float | None):
    mesh = case.mesh.model_copy(
        update={"edge_length": edge_in * IN, "elements_per_attach_radius": per_attach}
    )
    return case.model_copy(update={"mesh": mesh})


def _family(model, label: str, count: int) -> float:
    """Mean frequency (Hz) of the first ``count`` modes labelled ``label``."""
    freqs = [f for f, lab in zip(model.modes.frequencies_hz, model.labels, strict=True)
             if lab == label]  # fmt: skip
    assert len(freqs) >= count, (label, model.labels)
    return float(np.mean(freqs[:count]))


def _bad(old: str, new: str) -> str:
    text = load_case(OBJECTIVE).to_toml()
    assert old in text
    with pytest.raises(CaseError) as info:
        case_from_toml(text.replace(old, new, 1), source="bad.toml")
    message = str(info.value)
    assert "\n" not in message.strip()
    return message


def test_flange_fields_are_checked():
    message = _bad('flange_radius = "0.0508 m"  # 2 in\n', "")
    assert "end_body[0].flange_radius" in message and "missing" in message
    message = _bad('attachment = "flange"\n', 'attachment = "rim"\n')
    assert "flange_radius" in message and 'attachment = "flange"' in message
    message = _bad('flange_radius = "0.0508 m"', 'flange_radius = "0.5 in"')
    assert "flange_radius" in message and "attach_radius" in message
    message = _bad('flange_radius = "0.0508 m"', 'flange_radius = "2.5 in"')
    assert "end_body[0].flange_radius" in message and "cap radius" in message
    message = _bad("flange_thickness_factor = 2.0", "flange_thickness_factor = 0.5")
    assert "flange_thickness_factor" in message


def test_rim_attachment_is_the_default_and_unchanged():
    case = load_case("paper-membrane-coarse")
    assert all(b.attachment == "rim" and b.flange_radius is None for b in case.end_body)
    model = build_modal_model(case)
    assert np.ndim(_membrane(model.structure).thickness) == 0
    # calibrated (before attachments existed) to the seed's 31.2 / 38.0 Hz and their mean
    assert _family(model, "rocking (rear mass)", 2) == pytest.approx(31.2, rel=1e-4)
    assert _family(model, "bending", 2) == pytest.approx(38.0, rel=1e-4)
    assert _family(model, "axial (rear mass)", 1) == pytest.approx(np.sqrt(31.2 * 38.0), rel=1e-4)


def test_flange_doubles_the_membrane_on_its_annulus():
    case = _coarse(load_case(OBJECTIVE), 2.0, 4)
    structure = structure_for_case(case)
    membrane = _membrane(structure)
    t0 = case.material.thickness
    thickness = np.asarray(membrane.thickness)
    assert set(np.unique(thickness / t0).round(12)) == {1.0, 2.0}
    # the extra ply's mass: (k - 1) ρ t over the spherical zone within each flange radius
    extra = 0.0
    for body in case.end_body:
        k, r = body.flange_thickness_factor, body.flange_radius
        cap = case.geometry.cap_radius(body.pole)
        zone = 2.0 * np.pi * cap * (cap - np.sqrt(cap * cap - r * r))
        extra += (k - 1.0) * case.material.density * t0 * zone
    bare = structure_for_case(
        case.model_copy(
            update={"end_body": tuple(
                b.model_copy(update={"attachment": "rim", "flange_radius": None,
                                     "flange_thickness_factor": None})
                for b in case.end_body
            )}
        )
    )  # fmt: skip
    assert total_mass(structure) - total_mass(bare) == pytest.approx(extra, rel=0.02)
    # no flange: the scalar thickness, as before
    points = structure.reference[: len(structure.groups["membrane"])]
    assert element_thickness(points, membrane.conn, t0, ()) == t0


def test_flange_frequencies_converge_with_refinement():
    """Refining edge length and rim grading together by √2 twice: the changes of the rocking and
    bending pairs shrink by a factor (they converge); the bare rigid rim's bending pair, refined
    uniformly, keeps changing by about as much per step (first order at a singular rim)."""
    objective = load_case(OBJECTIVE)
    rim = load_case("paper-membrane-rim")
    steps = (2.0, 2.0 / np.sqrt(2.0), 1.0)
    flange = [build_modal_model(_coarse(objective, e, 8.0 * 2.0 / e)) for e in steps]
    for label in ("rocking (rear mass)", "bending"):
        f = [_family(m, label, 2) for m in flange]
        assert abs(f[2] - f[1]) < 0.6 * abs(f[1] - f[0]), (label, f)
        assert abs(f[2] / f[1] - 1.0) < 0.006, (label, f)
    bare = [build_modal_model(_coarse(rim, e, None)) for e in steps]
    b = [_family(m, "bending", 2) for m in bare]
    assert abs(b[2] - b[1]) > 0.6 * abs(b[1] - b[0]), b


def test_flange_mesh_has_rings_at_both_radii_graded_toward_them():
    case = _coarse(load_case(OBJECTIVE), 2.0, 8)
    points = surface_for_case(case).points
    radial = np.hypot(points[:, 0], points[:, 1])
    for body in case.end_body:
        side = points[:, 2] < 0.3 if body.pole == "front" else points[:, 2] > 1.2
        for radius in (body.attach_radius, body.flange_radius):
            ring = side & np.isclose(radial, radius, rtol=1e-9, atol=0.0)
            # a full ring with edges of about attach_radius / 8 around it
            spacing = 2.0 * np.pi * radius / ring.sum()
            assert spacing == pytest.approx(body.attach_radius / 8, rel=0.1), (body.name, radius)
