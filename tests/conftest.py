"""Shared fixtures: small finite-element models reduced to a handful of modes (fast)."""

import os

import pytest

from quadmodes.case import case_from_toml
from quadmodes.rom.reduced import reduce
from quadmodes.structure.pipeline import build_modal_model

SMALL_CAPSULE = """
name = "small-capsule"
description = "prolate inflated capsule with a rear end body: a fast minor-axis spinner"
kind = "membrane"
[geometry]
shape = "capsule"
length = "30 in"
diameter = "8 in"
[mesh]
edge_length = "1.5 in"
[material]
density = "0.0335 lb/in^3"
youngs_modulus = "0.05 Mpsi"
poisson_ratio = 0.3
thickness = "0.0045 in"
damping_ratio = 0.02
[pressure]
value = "0.3 psi"
[modes]
count = 5
[[end_body]]
name = "rear"
pole = "rear"
mass = "0.05 kg"
radius = "1.5 in"
height = "0.5 in"
attach_radius = "1.5 in"
offset = "0.25 in"
"""


@pytest.fixture(scope="session", autouse=True)
def _private_model_cache(tmp_path_factory):
    """Keep the suite out of the per-user model cache.

    A test that does not choose a cache folder would otherwise read and write the user's own cache,
    where a concurrent run (or a stale artifact from another version) can change what it sees.
    """
    before = os.environ.get("QUADMODES_CACHE")
    os.environ["QUADMODES_CACHE"] = str(tmp_path_factory.mktemp("model-cache"))
    yield
    if before is None:
        os.environ.pop("QUADMODES_CACHE", None)
    else:
        os.environ["QUADMODES_CACHE"] = before


@pytest.fixture(scope="session")
def small_modal_model():
    """Inflated small capsule (≈400 nodes) with its first 5 elastic modes."""
    return build_modal_model(case_from_toml(SMALL_CAPSULE, source="small-capsule"))


@pytest.fixture(scope="session")
def small_reduced_model(small_modal_model):
    """:class:`quadmodes.rom.reduced.ReducedModel` of the small capsule, N = 5, ζ = 2 %."""
    m = small_modal_model
    return reduce(m.structure, m.x, m.modes.frequencies_hz, m.modes.shapes, m.labels, 0.02)
