"""The CF side of the files quadmodes writes: units that UDUNITS-2 (cf_units, Iris, CDO,
Panoply) reads as pint does, the rule check :func:`quadmodes.io.cf.udunits_problem` against the
real UDUNITS-2 library, and the reduced-model artifact. results.nc, comparison.nc, campbell.nc
and sweep.nc are checked where their tests write them (``conftest.assert_cf_file``)."""

import importlib.util

import pytest
from conftest import assert_cf_file, udunits_reads_as_pint

from quadmodes.analysis import compare
from quadmodes.io import cf
from quadmodes.rom import artifact
from quadmodes.runs import secular
from quadmodes.sweeps import dataset as sweep_dataset

HAVE_CF_UNITS = importlib.util.find_spec("cf_units") is not None

#: What UDUNITS-2 misreads (kg^0.5 m is 5 m to it) or does not know.
MISREAD = ["kg^0.5 m", "kg**0.5*m", "kg0.5 m", "kg^-0.5", "J kg^-1.5 m^-3", "kg^(1/2) m",
           "deg/s", "dimensionless"]  # fmt: skip


def _code_units() -> set[str]:
    """Every unit string of the code's variable tables."""
    units = {u for _, u, _, _ in artifact._VARIABLES.values()}
    units |= {u for _, u, _ in sweep_dataset.SCALARS + sweep_dataset.BRANCHES}
    units |= {u for _, u, _ in compare._SERIES_VARS.values()}
    units |= {q[3] for q in secular.QUANTITIES}
    return units


@pytest.mark.parametrize("units", MISREAD)
def test_the_rule_refuses_what_udunits_misreads(units):
    assert cf.udunits_problem(units)


def test_the_code_writes_units_the_rule_accepts_in_one_spelling():
    for units in _code_units():
        assert cf.udunits_problem(units) == "", units
        assert cf.spelling(units) == units and "^-" not in units, units
    assert cf.spelling("kg*m^2") == "kg m^2" and cf.spelling("") == "1"


@pytest.mark.skipif(not HAVE_CF_UNITS, reason="cf_units (UDUNITS-2) not installed")
def test_the_rule_agrees_with_udunits():
    """UDUNITS-2 itself: every unit the rule accepts reads as in pint; the misread ones do not
    (kg^0.5 m is 5 m to UDUNITS), which is why the files state modal quantities at 1 kg."""
    import cf_units

    assert cf_units.Unit("kg^0.5 m").convert(1.0, cf_units.Unit("m")) == pytest.approx(5.0)
    for units in _code_units() | {"kg m^2/s", "rad/s", "1/s^2", "degree", "Hz", "1", "1/(kg m)"}:
        assert udunits_reads_as_pint(units), units
    for units in MISREAD:
        assert not udunits_reads_as_pint(units), units


def test_reduced_model_file_is_cf(small_reduced_model, tmp_path):
    """reduced_model.nc: modal quantities at a modal mass of 1 kg (the same numbers), each with
    its mass-normalised unit; it loads back unchanged."""
    path = artifact.save_reduced_model(small_reduced_model, tmp_path / "reduced_model.nc")
    assert_cf_file(path)
    back = artifact.load_reduced_model(path)
    assert (back.Phi == small_reduced_model.Phi).all() and (back.Lam == small_reduced_model.Lam).all()
    ds = artifact.to_dataset(small_reduced_model)
    assert ds["Phi"].attrs["units"] == "1" and ds["Phi"].attrs["mass_normalised_units"] == "kg^-0.5"
    assert ds.attrs["Conventions"] == cf.CONVENTIONS and "1 kg" in ds.attrs["modal_normalisation"]
