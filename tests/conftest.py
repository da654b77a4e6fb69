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


@pytest.fixture(scope="session")
def capsule_energy_context(small_modal_model, small_reduced_model):
    """``(energy context, reduced model, modal scale (N,) m)`` of the small capsule, N = 5, for
    the condensed-energy tests (rom.manifold_energy) and the candidate potentials
    (experimental). Its near-degenerate pairs can come out of the eigensolver in a different
    orientation from one process to the next (observed: the same sample gave a different W_red
    alone and in the full suite), so the tests keep their amplitudes where every orientation
    tried converges."""
    import numpy as np

    from quadmodes.rom import manifold_energy as me

    m, model = small_modal_model, small_reduced_model
    ctx = me.energy_context(m.structure, m.x, model)
    t = np.asarray(model.translational, bool)
    scale = np.array([np.max(np.linalg.norm(p[t], axis=1)) for p in model.Phi])
    return ctx, model, scale


def udunits_reads_as_pint(units: str) -> bool:
    """UDUNITS-2 (cf_units) reads ``units`` as pint does: the same SI base unit and factor.
    Needs cf_units (the [test] extra; it bundles the UDUNITS-2 library)."""
    import cf_units
    import numpy as np

    from quadmodes.case.units import ureg

    try:
        q = ureg.Quantity(1.0, units).to_base_units()
    except Exception:  # pint refuses it: nothing to agree with
        return False
    powers = dict(q.unit_items())
    if any(float(p) != int(p) for p in powers.values()):
        return False  # a fractional power: no UDUNITS-2 unit has it
    base = " ".join(f"{ureg.get_symbol(n)}^{int(p)}" for n, p in powers.items()) or "1"
    try:
        read = cf_units.Unit(units)
    except ValueError:
        return False
    return read.is_convertible(base) and bool(
        np.isclose(read.convert(1.0, cf_units.Unit(base)), q.magnitude, rtol=1e-12))


def assert_cf_file(path) -> None:
    """The NetCDF file ``path`` passes :func:`quadmodes.io.cf.file_problems` (Conventions, long
    names, units pint parses and UDUNITS-2 reads alike in the one spelling, no _FillValue on
    coordinates, no string dimension coordinate) and, where cf_units is installed, UDUNITS-2
    itself reads every unit as pint does."""
    import importlib.util

    import xarray as xr

    from quadmodes.io.cf import file_problems

    problems = file_problems(path)
    assert problems == [], f"{path}:\n" + "\n".join(problems)
    if importlib.util.find_spec("cf_units") is None:
        return
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        bad = [f"{n}: {ds[n].attrs['units']!r}" for n in [*ds.coords, *ds.data_vars]
               if not udunits_reads_as_pint(ds[n].attrs["units"])]  # fmt: skip
    assert bad == [], f"{path}: UDUNITS-2 reads otherwise:\n" + "\n".join(bad)
