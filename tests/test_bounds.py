"""Bounded work and checked mesh files (issue 24, items 3 and 4; docs/reliability.md): quantity
strings read by a strict grammar (no arithmetic), the limits of quadmodes.limits, and the
checks of mesh files (regular file, size, unit, one closed body, duplicate nodes, plausible
strain and mass)."""

from __future__ import annotations

import pytest

from quadmodes.case import QuantityError, parse_quantity

# ----------------------------------------------------------------------------- quantity grammar


@pytest.mark.parametrize(
    ("text", "dimension", "si"),
    [
        ("0.3 psi", "pressure", 2068.427187950509),
        ("60 in", "length", 1.524),
        ("5in", "length", 0.127),
        ("2 %", "dimensionless", 0.02),
        ("0.02", "dimensionless", 0.02),
        ("1e-5 kg m^2", "inertia", 1e-5),
        ("1e-5 kg*m^2", "inertia", 1e-5),
        ("1e-05 kilogram * meter ** 2", "inertia", 1e-5),  # pint's own spelling (API inputs)
        ("0.0335 lb/in^3", "density", 0.0335 * 0.45359237 / 0.0254**3),
        ("2.0 1 / second", "frequency", 2.0),
        ("+6 deg", "angle", 6 * 3.141592653589793 / 180),
        ("-1 psi", "pressure", -6894.757293168361),
        ("0.05 Mpsi", "pressure", 0.05e6 * 6894.757293168361),
    ],
)
def test_quantities_of_the_project_still_read(text, dimension, si):
    assert parse_quantity(text, dimension, "f") == pytest.approx(si, rel=1e-12)


@pytest.mark.parametrize(
    "text", ["10**10**10 psi", "2*3 m", "1 m**2**2**2", "(1+1) m", "1/2 m", "3 (m)", "1 m 2"]
)
def test_arithmetic_is_refused_at_once(text, monkeypatch):
    """Refused by the grammar before pint evaluates anything (pint is never called)."""
    from quadmodes.case import units

    def evaluated(*args, **kwargs):
        raise AssertionError(f"pint evaluated {args!r}")

    monkeypatch.setattr(units.ureg, "parse_units", evaluated)
    monkeypatch.setattr(units.ureg, "parse_expression", evaluated)
    with pytest.raises(QuantityError) as exc:
        parse_quantity(text, "length", "geometry.length")
    assert str(exc.value).startswith("geometry.length: ")
    assert "\n" not in str(exc.value)


def test_overlong_quantity_is_refused():
    with pytest.raises(QuantityError, match="too long"):
        parse_quantity("1" + " m" * 500, "length", "f")


# ----------------------------------------------------------------------------- limits


def test_every_limit_has_a_variable_and_a_positive_default():
    from quadmodes.limits import LIMITS

    assert len({lim.env for lim in LIMITS}) == len(LIMITS)
    for lim in LIMITS:
        assert lim.env.startswith("QUADMODES_") and lim.default > 0 and lim.value() == lim.default


def test_a_variable_raises_a_limit_and_a_bad_one_is_named(monkeypatch):
    from quadmodes.case import load_run_case
    from quadmodes.limits import LimitError
    from quadmodes.sweeps.params import SweepError, grid, parse_param

    run = load_run_case("paper-0.5hz")
    params = [parse_param("initial.spin_rate=1 Hz:45 Hz:200", run.model_case()),
              parse_param("pressure.value=0.2 psi:0.4 psi:100", run.model_case())]  # fmt: skip
    with pytest.raises(SweepError, match="200 × 100.*QUADMODES_MAX_SWEEP_POINTS=20000"):
        grid(params)
    monkeypatch.setenv("QUADMODES_MAX_SWEEP_POINTS", "2e4")
    assert len(grid(params)) == 20_000
    monkeypatch.setenv("QUADMODES_MAX_SWEEP_POINTS", "many")
    with pytest.raises(SweepError, match="QUADMODES_MAX_SWEEP_POINTS='many': must be a positive"):
        grid(params)
    from quadmodes.limits import SWEEP_POINTS

    with pytest.raises(LimitError):
        SWEEP_POINTS.value()


def test_mode_count_bound_is_a_case_error(monkeypatch):
    from quadmodes.case import CaseError, case_from_toml, load_case

    text = load_case("sphere").to_toml().replace("count = 10", "count = 600")
    with pytest.raises(CaseError) as exc:
        case_from_toml(text)
    assert exc.value.field == "modes.count" and "QUADMODES_MAX_MODES" in str(exc.value)
    monkeypatch.setenv("QUADMODES_MAX_MODES", "1000")
    assert case_from_toml(text).modes.count == 600


def test_reduced_modes_bound_holds_in_the_library():
    from quadmodes.case import load_case
    from quadmodes.limits import LimitError
    from quadmodes.models.build import reduced_model_for

    with pytest.raises(LimitError, match="QUADMODES_MAX_REDUCED_MODES"):
        reduced_model_for(load_case("kane-beam"), 10**9)


def test_campbell_points_bound_before_the_model(monkeypatch):
    from quadmodes.analysis import campbell_output
    from quadmodes.limits import LimitError

    def no_model(*args, **kwargs):
        raise AssertionError("the model must not be built")

    monkeypatch.setattr(campbell_output, "model_for_case", no_model)
    with pytest.raises(LimitError, match="--points"):
        campbell_output.campbell_with_full_order("kane-beam", 0.0, 10.0, 10**9)


def test_output_estimate_matches_the_results_file(tmp_path, small_reduced_model):
    """The estimate of results.nc (8 bytes × (2N + 17) a sample) is within 10 % of the data
    the file holds, and a run beyond the bound is refused with a save_every that fits."""
    from quadmodes.case import CaseError, run_case_from_toml
    from quadmodes.runs import results, simulate
    from quadmodes.runs.resources import check_output_size, output_bytes

    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    run = run_case_from_toml(run_toml(), base_dir=tmp_path)
    result = simulate.simulate(run, small_reduced_model)
    results.write_outputs(result, tmp_path / "out", plots=False)
    ds = results.load_results(tmp_path / "out" / "results.nc")
    data = sum(v.nbytes for v in ds.data_vars.values() if "time" in v.dims) + ds["time"].nbytes
    assert output_bytes(run) == pytest.approx(data, rel=0.1)
    big = run.model_copy(update={"integration": run.integration.model_copy(
        update={"duration": "2e5 s"})})  # fmt: skip
    with pytest.raises(CaseError) as exc:
        check_output_size(big)
    assert exc.value.field == "integration.save_every"
    every = int(str(exc.value).split("save_every = ")[2].split()[0])
    fits = big.integration.model_copy(update={"save_every": every})
    check_output_size(big.model_copy(update={"integration": fits}))


# ----------------------------------------------------------------------------- mesh files


def _sphere():
    from quadmodes.mesh.revolution import sphere_surface

    return sphere_surface(0.127, 0.0508)


def test_duplicate_nodes_are_merged(tmp_path):
    """A file writing each triangle's own corners (as STL does) reads as the closed surface."""
    import meshio
    import numpy as np

    from quadmodes.mesh.io import read_surface
    from quadmodes.mesh.surface import check_closed_surface

    s = _sphere()
    corners = s.points[s.triangles].reshape(-1, 3)
    meshio.write(tmp_path / "dup.vtu",
                 meshio.Mesh(corners, [("triangle", np.arange(len(corners)).reshape(-1, 3))]))  # fmt: skip
    read = read_surface(tmp_path / "dup.vtu")
    assert read.n_points == s.n_points and read.n_triangles == s.n_triangles
    check_closed_surface(read)
    assert np.array_equal(np.sort(read.points, axis=0), np.sort(s.points, axis=0))


def test_a_surface_without_duplicates_is_read_unchanged(tmp_path):
    import numpy as np

    from quadmodes.mesh.io import read_surface, write_surface

    s = _sphere()
    write_surface(tmp_path / "s.vtu", s)
    read = read_surface(tmp_path / "s.vtu")
    assert np.array_equal(read.points, s.points) and np.array_equal(read.triangles, s.triangles)


def test_file_unit_scales_the_coordinates(tmp_path):
    import numpy as np

    from quadmodes.case import case_from_toml
    from quadmodes.mesh.io import write_surface
    from quadmodes.mesh.surface import TriangleSurface
    from quadmodes.structure.pipeline import surface_for_case

    s = _sphere()
    write_surface(tmp_path / "mm.vtu", TriangleSurface(1000.0 * s.points, s.triangles))
    text = _sphere_case('shape = "file"\nfile = "mm.vtu"\nfile_unit = "mm"')
    case = case_from_toml(text, base_dir=tmp_path)
    assert case.geometry.file_scale() == 1e-3
    assert np.allclose(surface_for_case(case).points, s.points, rtol=1e-12, atol=1e-15)
    assert case_from_toml(case.to_toml(), base_dir=tmp_path) == case  # round trip
    assert 'file_unit = "mm"' in case.to_toml()


def test_a_millimetre_file_with_its_unit_has_the_metre_file_modes(tmp_path):
    """Physics: the same body written in mm (file_unit = "mm") and in m has the same modes."""
    import numpy as np

    from quadmodes.case import case_from_toml
    from quadmodes.mesh.io import write_surface
    from quadmodes.mesh.surface import TriangleSurface
    from quadmodes.structure.pipeline import build_modal_model

    s = _sphere()
    write_surface(tmp_path / "m.vtu", s)
    write_surface(tmp_path / "mm.vtu", TriangleSurface(1000.0 * s.points, s.triangles))
    freqs = []
    for geometry in ('file = "m.vtu"', 'file = "mm.vtu"\nfile_unit = "mm"'):
        case = case_from_toml(_sphere_case(f'shape = "file"\n{geometry}'), base_dir=tmp_path)
        freqs.append(build_modal_model(case).modes.frequencies_hz)
    assert np.allclose(freqs[0], freqs[1], rtol=1e-8)


def test_modes_command_warns_of_a_large_volume_change(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from quadmodes.cli.app import app

    (tmp_path / "sphere.toml").write_text(_sphere_case(), encoding="utf-8")
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("QUADMODES_MAX_VOLUME_CHANGE", "0.001")
    result = CliRunner().invoke(app, ["modes", str(tmp_path / "sphere.toml")])
    assert result.exit_code == 0, result.output
    warning = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1 and "enclosed volume" in warning[0], result.stderr


def test_two_bodies_are_named(tmp_path):
    import numpy as np

    from quadmodes.mesh.surface import TriangleSurface, check_closed_surface, connected_parts

    s = _sphere()
    two = TriangleSurface(np.vstack([s.points, s.points + 1.0]),
                          np.vstack([s.triangles, s.triangles + s.n_points]))  # fmt: skip
    assert sorted(np.bincount(connected_parts(two.triangles))) == [s.n_triangles] * 2
    with pytest.raises(ValueError, match="2 separate closed parts"):
        check_closed_surface(two)


def test_plausibility_names_the_field():
    from quadmodes.case import CaseError, case_from_toml, load_case
    from quadmodes.runs.resources import check_pressure

    for field, text in [
        ("material.thickness", _sphere_case(material={"thickness": '"1e-300 m"'})),
        ("material.youngs_modulus", _sphere_case(material={"youngs_modulus": '"1 Pa"'})),
        ("pressure.value", _sphere_case(pressure='"1e6 psi"')),
    ]:
        with pytest.raises(CaseError) as exc:
            check_pressure(case_from_toml(text))
        assert exc.value.field == field, str(exc.value)
    beam = load_case("kane-beam").to_toml().replace('density = "3000.0 kg/m^3"',
                                                    'density = "1e-9 kg/m^3"')  # fmt: skip
    with pytest.raises(CaseError) as exc:
        check_pressure(case_from_toml(beam))
    assert exc.value.field == "beam.density" and "light" in str(exc.value)


def test_volume_change_warning(monkeypatch):
    from quadmodes.case.plausibility import volume_change_warning

    assert volume_change_warning(0.03) is None
    assert "geometry.file_unit" in volume_change_warning(105.77)
    monkeypatch.setenv("QUADMODES_MAX_VOLUME_CHANGE", "0.01")
    assert volume_change_warning(0.03) is not None


def _sphere_case(geometry: str | None = None, **kwargs) -> str:
    from test_bad_inputs_table import sphere_case

    return sphere_case(geometry=geometry, **kwargs)


from conftest import SMALL_CAPSULE  # noqa: E402
from test_run import run_toml  # noqa: E402
