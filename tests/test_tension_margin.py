"""First loss of tension along a deformation (structure.tension_margin): the analytic onset of
a uniformly contracted inflated sphere, rigid motions that never slacken it, and the onset
amplitude's independence of the size of the direction given."""

import numpy as np
import pytest
from scipy.optimize import brentq

from quadmodes.fe.build import MembraneSpec, build_membrane_structure
from quadmodes.fe.membrane import MembraneSet
from quadmodes.mesh.revolution import sphere_surface
from quadmodes.structure.prestress import inflate
from quadmodes.structure.tension_margin import element_slack_onset, slack_onset

E, NU, T, RHO, P = 344.7379e6, 0.3, 1.143e-4, 927.28, 2068.43  # the seed's membrane, 0.3 psi
RADIUS = 0.127


@pytest.fixture(scope="module")
def sphere():
    surface = sphere_surface(RADIUS, RADIUS / 10)
    structure = build_membrane_structure(surface.points, surface.triangles,
                                         MembraneSpec(T, E, NU, RHO, P))  # fmt: skip
    x0 = inflate(structure).x
    return structure, x0, next(e for e in structure.elements if isinstance(e, MembraneSet))


def test_contracted_sphere_slackens_where_the_linearised_stress_says(sphere):
    """x0 − a (x0 − c): F = (1 − a) F0, so the linearised S vanishes at a = (λ² − 1)/(2λ²),
    λ the exact SVK sphere stretch (t E/(1 − ν)(λ² − 1) = p R λ)."""
    structure, x0, membrane = sphere
    stretch = brentq(lambda s: T * E / (1 - NU) * (s * s - 1) - P * RADIUS * s, 1.0, 1.5)
    expected = (stretch**2 - 1) / (2 * stretch**2)
    u = -(x0 - x0.mean(axis=0))
    onset = element_slack_onset(membrane, x0, u)
    assert np.median(onset) == pytest.approx(expected, rel=0.03)
    first = slack_onset(structure, x0, u)
    assert first.fraction == pytest.approx(onset.min())
    assert first.slack_at_rest == 0 and first.slack_at_unit == 1.0  # a = 1: collapsed to c


def test_rigid_motions_never_slacken(sphere):
    structure, x0, membrane = sphere
    translation = np.broadcast_to([1e-3, -2e-3, 5e-4], x0.shape)
    rotation = np.cross([0.3, -0.2, 0.9], x0)  # infinitesimal rotation: E1 = 0 exactly
    for u in (translation, rotation):
        onset = element_slack_onset(membrane, x0, np.asarray(u))
        assert np.all(onset > 1e6)


def test_onset_amplitude_does_not_depend_on_the_size_of_the_direction(sphere):
    structure, x0, _ = sphere
    rng = np.random.default_rng(3)
    u = rng.standard_normal(x0.shape) * 1e-3
    a, b = slack_onset(structure, x0, u), slack_onset(structure, x0, 7.0 * u)
    assert a.fraction == pytest.approx(7.0 * b.fraction, rel=1e-12)
    assert a.element == b.element
