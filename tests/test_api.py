"""The public Python API (issue 13): cases from strings, pint quantities and SI floats,
validated changes, runs that record and replay their own model, CF results, the examples."""

from __future__ import annotations

import dataclasses
import importlib.util
import inspect
import math
import re
import sys
from pathlib import Path

import numpy as np
import pint_xarray  # noqa: F401  (registers the .pint accessor)
import pytest
import xarray as xr
from conftest import SMALL_CAPSULE, assert_cf_file

import quadmodes as qm
from quadmodes import api
from quadmodes.case import CaseError, case_from_toml, load_case, run_case_from_toml
from quadmodes.io.cf import unit_problems
from quadmodes.models import cache as model_cache
from quadmodes.rom import artifact

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def _example(name: str):
    """Import ``examples/<name>.py`` as a module."""
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def seeded_cache(tmp_path, monkeypatch, small_reduced_model):
    """A private model cache holding the small capsule's 5-mode reduced model."""
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    case = case_from_toml(SMALL_CAPSULE, source="small-capsule")
    seeded = dataclasses.replace(
        small_reduced_model,
        provenance={"case": case.name, "content_key": model_cache.reduced_key(case, 5)},
    )
    artifact.save_reduced_model(seeded, model_cache.cache_path(case, 5))
    return case


# ----------------------------------------------------------------------------- the names


def test_public_names_resolve_and_have_docstrings():
    assert "model_case" in qm.__all__ and "simulate" in qm.__all__ and "__version__" in qm.__all__
    for name in qm.__all__:
        value = getattr(qm, name)
        if callable(value):
            assert inspect.getdoc(value), name
    assert set(api.__all__) <= set(qm.__all__)
    with pytest.raises(AttributeError):
        qm.no_such_name  # noqa: B018


#: A docstring states units if it names one of these.
_UNITS = re.compile(r"\b(SI|Hz|rad/s|rad|kg|kg m\^2|Pa|deg|J|N/m)\b|\b(s|m)\)|1/s")


def test_every_public_function_states_units_of_dimensional_input():
    """Each API function says in which units it takes and returns quantities (the two that
    handle no quantities are named), and docs/api.md documents every public name."""
    unit_free = {"cases": "names and descriptions", "load": "reads a file as it is"}
    for name in api.__all__:
        doc = inspect.getdoc(getattr(api, name))
        assert doc and len(doc.splitlines()[0]) > 10, name
        if name not in unit_free:
            assert _UNITS.search(doc), f"{name}: docstring names no unit"
    reference = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    for name in qm.__all__:
        assert f"`{name}" in reference, f"docs/api.md does not document {name}"


# ----------------------------------------------------------------------------- cases


def test_model_case_takes_quantity_strings_pint_quantities_and_si_floats():
    base = load_case("paper-membrane-coarse")
    psi = 6894.757293168361  # Pa
    from_text = qm.model_case(base, pressure={"value": "0.4 psi"})
    from_pint = qm.model_case(base, pressure={"value": qm.ureg.Quantity(0.4, "psi")})
    from_si = qm.model_case(base, **{"pressure.value": 0.4 * psi})
    assert from_text.pressure.value == pytest.approx(0.4 * psi, rel=1e-15)
    assert from_pint == from_text
    assert from_si.pressure.value == pytest.approx(from_text.pressure.value, rel=1e-15)
    assert qm.changed(base, geometry={"length": 1.6}).geometry.length == 1.6  # m
    with pytest.raises(CaseError, match="pressure.value.*a mass, expected a pressure"):
        qm.model_case(base, pressure={"value": "0.4 kg"})
    with pytest.raises(CaseError, match="presure"):
        qm.model_case(base, presure={"value": "0.4 psi"})


def test_model_copy_validates_its_update():
    """pydantic's model_copy stored "0.4 psi" as a string in a float field; now the update is
    validated like a case file (issue 13)."""
    p = load_case("paper-membrane").pressure
    copy = p.model_copy(update={"value": "0.4 psi"})
    assert isinstance(copy.value, float) and copy.value == pytest.approx(2757.90291727, rel=1e-10)
    assert p.model_copy(update={"value": 2000.0}).value == 2000.0  # an SI float (Pa)
    with pytest.raises(CaseError, match="value.*must be positive"):
        p.model_copy(update={"value": "-1 psi"})
    integ = qm.load("paper-41hz").integration
    with pytest.raises(CaseError, match="dt"):
        integ.model_copy(update={"dt": 10 * integ.duration})  # longer than the run


def test_run_case_embeds_its_model_and_replays_exactly(tmp_path):
    body = qm.model_case("paper-membrane-coarse", pressure={"value": "0.35 psi"})
    run = qm.run_case("paper-41hz-coarse", model=body, integration={"duration": "0.2 s"})
    assert run.model == body and run.model_case() == body and run.model_name == body.name
    assert run.integration.duration == 0.2
    again = run_case_from_toml(run.to_toml())
    assert again == run and again.model_case() == body
    path = qm.save_case(run, tmp_path / "run.toml")
    assert qm.load(path) == run
    assert run.model_copy(update={"reduced": {"modes": 6}}).model == body  # still embedded
    builtin = qm.load("paper-41hz")
    assert builtin.with_model(builtin.model_case()) is builtin  # same model: unchanged
    with pytest.raises(CaseError, match=r"pressure\.value.*a length"):
        qm.run_case("paper-41hz", model={**body.model_dump(), "pressure": {"value": "1 m"}})
    bad = run.to_toml().replace(f'value = "{body.pressure.value!r} Pa"', 'value = "1 m"')
    assert bad != run.to_toml()
    with pytest.raises(CaseError, match=r"model\.pressure\.value: .*a length"):
        run_case_from_toml(bad)


# ----------------------------------------------------------------------------- a run


def test_run_with_a_custom_model_records_it_and_writes_cf_results(seeded_cache, tmp_path):
    """A run given a model built in Python records that model (not the placeholder it names)
    in results.nc's case_toml, and every variable and coordinate carries long_name and units
    that pint parses."""
    run = qm.run_case(
        name="custom", model="paper-membrane",  # a placeholder: the run is given its model
        reduced={"modes": 5},
        initial={"spin_rate": "20 Hz", "cone_angle": "2 deg"},
        integration={"dt": "0.5 ms", "duration": 0.02, "save_every": 2},
    )  # fmt: skip
    result = qm.simulate(run, model_case=seeded_cache)
    assert result.complete and result.run.model == seeded_cache
    summary = qm.write_results(result, tmp_path / "out", plots=False)
    assert summary["H_relative_drift"] < 1e-12  # the midpoint rule conserves H
    with xr.open_dataset(tmp_path / "out" / "results.nc", engine="h5netcdf") as ds:
        assert ds.attrs["Conventions"] == "CF-1.10"
        assert ds.attrs["quadmodes_version"] == qm.__version__
        assert ds.attrs["model_hash"] == ds.attrs["reduced_model_key"] != ""
        assert unit_problems(ds) == []
        assert set(ds.coords) >= {"time", "mode", "xyz_label", "quat_label"}
        assert ds["modal_coordinates"].attrs["units"] == "m"  # modes normalised to 1 kg (io.cf)
        assert ds["angular_momentum"].attrs["units"] == "kg m^2/s"
        # pint-xarray turns every variable into a quantity with the unit its attribute names
        quantified = ds.pint.quantify()
        h = quantified["angular_momentum"].pint.to("N m s")
        assert float(abs(h.pint.magnitude).max()) == pytest.approx(
            float(abs(ds["angular_momentum"]).max()))
        assert all(str(quantified[v].pint.units) != "None" for v in ds.data_vars
                   if ds[v].dtype.kind == "f")  # fmt: skip
        replay = run_case_from_toml(ds.attrs["case_toml"])
    assert replay.model_case() == seeded_cache and replay == result.run
    assert_cf_file(tmp_path / "out" / "results.nc")


# ----------------------------------------------------------------------------- examples


def test_example_custom_body_from_a_mesh_file(tmp_path):
    ex = _example("custom_body_from_mesh")
    s = ex.main(tmp_path, subdivisions=2)
    body = s["case"]
    m = body.material
    assert s["mass_kg"] == pytest.approx(m.density * m.thickness * s["area_m2"], rel=1e-9)
    inertia = np.array(s["inertia_kg_m2"])
    shell = 2.0 / 3.0 * s["mass_kg"] * 0.25**2  # thin spherical shell, R = 0.25 m
    assert np.allclose(np.diag(inertia), shell, rtol=0.03)
    assert np.allclose(inertia - np.diag(np.diag(inertia)), 0.0, atol=1e-12)
    f = np.array(s["frequencies_hz"][:5])  # the l = 2 family: icosahedral symmetry keeps it whole
    assert np.ptp(f) < 1e-6 * f[0] and f[0] > 0
    assert qm.load(tmp_path / "icosphere.toml") == body


def test_example_spinning_beam_matches_euler_bernoulli_and_southwell():
    r = _example("spinning_beam").main(spin_max="4 rad/s", spinup_duration="2 s")
    assert r["omega0"] == pytest.approx(r["omega0_analytic"], rel=1e-3)
    assert r["out_of_plane"] == pytest.approx(r["out_of_plane_analytic"], rel=0.01)
    assert r["in_plane"] == pytest.approx(r["in_plane_analytic"], rel=0.015)
    assert r["spinup"]["complete"] and math.isfinite(r["spinup"]["peak_tip_deflection_m"])


def test_example_spin_loop_conserves_and_replays(seeded_cache, tmp_path):
    ex = _example("spin_loop")
    assert qm.model_case(ex.CAPSULE) == seeded_cache  # the test cache holds its model
    out, folder = ex.main(spins=("2 Hz", "4 Hz"), duration="0.02 s", folder=tmp_path)
    for spin, s in out.items():
        assert s["complete"] and s["H_relative_drift"] < 1e-12
        assert s["energy_balance_relative_error"] < 1e-9
        assert s["spin_rate_end_hz"] == pytest.approx(float(spin.split()[0]), rel=0.01)
    with xr.open_dataset(folder / "spin-4Hz" / "results.nc", engine="h5netcdf") as ds:
        assert run_case_from_toml(ds.attrs["case_toml"]).model_case() == seeded_cache


def test_campbell_and_spinup_files_are_cf_too(tmp_path):
    """campbell.nc and a spin-up's results.nc: long_name and pint-parsable units everywhere."""
    qm.campbell("kane-beam", "0 Hz", "0.5 Hz", points=3, output_dir=tmp_path / "campbell")
    run = qm.run_case("kane-spinup", reduced={"modes": 2},
                      spinup={"duration": "1 s", "ramp_time": "0.5 s", "samples": 51})  # fmt: skip
    qm.write_results(qm.simulate(run), tmp_path / "spinup", plots=False)
    for path in (tmp_path / "campbell" / "campbell.nc", tmp_path / "spinup" / "results.nc"):
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            assert ds.attrs["Conventions"] == "CF-1.10" and ds.attrs["source"].startswith("quadmodes")
            assert unit_problems(ds) == [], path.name
        assert_cf_file(path)
    with xr.open_dataset(tmp_path / "spinup" / "results.nc", engine="h5netcdf") as ds:
        assert run_case_from_toml(ds.attrs["case_toml"]) == run
        assert ds["hub_rate"].attrs["units"] == "rad/s"


def test_api_convergence_and_cases(seeded_cache):
    run = qm.run_case(name="conv", model=seeded_cache, reduced={"modes": 5},
                      initial={"spin_rate": "20 Hz", "cone_angle": "2 deg"},
                      integration={"dt": "1 ms", "duration": "0.01 s"})  # fmt: skip
    conv = qm.dt_convergence(run)
    rows = conv["rows"]
    assert "cone_growth_rate_deg_per_s" in conv["judged"] or "cone_angle_deg" in conv["judged"]
    assert [r["dt_s"] for r in rows] == pytest.approx([1e-3, 5e-4, 2.5e-4])
    for key in ("rel_change_spin_rate_hz", "rel_change_cone_angle_deg"):  # converging in dt
        assert rows[2][key] < rows[1][key] < 1e-4
    names = [c["name"] for c in qm.cases()]
    assert "paper-membrane" in names and "paper-41hz" in names


def test_kernel_compile_is_a_stage_of_its_own():
    """The compiled kernel's first call (seconds) is done once, as stage "compile", before a
    run's timed integration; later runs and runs that do not use it skip it."""
    from quadmodes.runs import simulate as sim

    run = qm.load("paper-41hz")
    stages = []
    first = sim.warm_up_kernel(run, lambda stage, f: stages.append((stage, f)))
    assert first is None or stages == [("compile", 0.0), ("compile", 1.0)]
    assert sim.warm_up_kernel(run, lambda stage, f: stages.append(stage)) is None
    adaptive = qm.changed(run, integration={"method": "adaptive"})
    assert sim.warm_up_kernel(adaptive) is None


def test_example_spin_sweep(tmp_path):
    """Minor-axis spinner: the energy-sink estimate grows with spin, positive everywhere."""
    pytest.importorskip("distributed")
    ds = _example("spin_sweep").main(tmp_path, spins="2 Hz:6 Hz:3")
    growth = ds["energy_sink_growth_rate"].values
    assert ds.sizes["spin_rate"] == 3 and np.all(growth > 0) and np.all(np.diff(growth) > 0)
    assert (tmp_path / "sweep.nc").is_file() and (tmp_path / "report.html").is_file()
