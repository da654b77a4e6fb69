"""The ``quadmodes`` command line: listing and showing cases, the modes command (JSON, table and
output folder), and one-line user errors (exit status 2, nothing left behind).

Cheap cases only: the built-in ``kane-beam`` and a 10 in sphere meshed at 2 in (about 90 nodes)
with the paper-membrane material and pressure.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import tomllib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from quadmodes import __version__
from quadmodes.case import builtin_case_names, case_from_toml, load_case
from quadmodes.cli.app import app
from quadmodes.mesh.io import write_surface
from quadmodes.mesh.revolution import sphere_surface
from quadmodes.mesh.surface import TriangleSurface
from quadmodes.structure.prestress import ConvergenceError

BUILTINS = [
    "capsule", "heliogyro-blade", "hub-booms", "ikaros-sail", "kane-beam", "paper-membrane",
    "paper-membrane-coarse", "paper-membrane-rim", "sphere", "spinning-annulus", "spinning-disc",
    "string-blade-rotor", "two-blade-rotor",
]
PAPER_PRESSURE_PA = 2068.427187950509  # 0.3 psi


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def _paper_material_lines() -> list[str]:
    m = load_case("paper-membrane").material
    return [
        f'density = "{m.density!r} kg/m^3"',
        f'youngs_modulus = "{m.youngs_modulus!r} Pa"',
        f"poisson_ratio = {m.poisson_ratio!r}",
        f'thickness = "{m.thickness!r} m"',
        f"damping_ratio = {m.damping_ratio!r}",
    ]


def _sphere_toml(
    *,
    pressure: str | None = None,
    thickness: str | None = None,
    poisson_ratio: str | None = None,
    geometry: str = 'shape = "sphere"\ndiameter = "10 in"',
    count: int = 6,
) -> str:
    """A small sphere membrane (no end bodies) with the paper-membrane material and pressure;
    keyword arguments replace one TOML value (given as TOML source text)."""
    material = _paper_material_lines()
    if thickness is not None:
        material = [
            f"thickness = {thickness}" if s.startswith("thickness") else s for s in material
        ]
    if poisson_ratio is not None:
        material = [
            f"poisson_ratio = {poisson_ratio}" if s.startswith("poisson_ratio") else s
            for s in material
        ]
    paper_pressure = f'"{load_case("paper-membrane").pressure.value!r} Pa"'
    lines = [
        'name = "small-sphere"',
        'description = "10 in sphere, coarse mesh, for CLI tests"',
        'kind = "membrane"',
        "",
        "[geometry]",
        geometry,
        "",
        "[mesh]",
        'edge_length = "2 in"',
        "",
        "[material]",
        *material,
        "",
        "[pressure]",
        f"value = {pressure if pressure is not None else paper_pressure}",
        "gas_law_exponent = 0",
        "",
        "[modes]",
        f"count = {count}",
    ]
    return "\n".join(lines) + "\n"


def _write_case(tmp_path: Path, text: str, name: str = "case.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _assert_clean_failure(result, out_dir: Path | None, *needles: str) -> str:
    """Exit status 2, one ``error:`` line on stderr naming ``needles``, nothing on stdout, no
    traceback, and no output (nor scratch) folder. Returns the message."""
    assert result.exit_code == 2, (result.exit_code, result.stdout, result.stderr)
    assert isinstance(result.exception, SystemExit)  # not an escaped exception
    assert "Traceback" not in result.output
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    message = lines[0]
    assert message.startswith("error: ")
    for needle in needles:
        assert needle in message, message
    if out_dir is not None:
        assert not out_dir.exists()
        assert not list(out_dir.parent.glob(f".{out_dir.name}.partial*"))
    return message


# ----------------------------------------------------------------------------- cases / show-case


def test_version(runner):
    result = runner.invoke(app, ["version"])
    assert result.exit_code == 0
    assert result.stdout.strip() == __version__


def test_cases_lists_every_builtin(runner):
    assert builtin_case_names() == BUILTINS
    result = runner.invoke(app, ["cases"])
    assert result.exit_code == 0, result.output
    for name in BUILTINS:
        assert name in result.stdout
    assert "membrane" in result.stdout and "beam" in result.stdout


def test_show_case_round_trips(runner):
    result = runner.invoke(app, ["show-case", "paper-membrane"])
    assert result.exit_code == 0, result.output
    data = tomllib.loads(result.stdout)
    assert data["name"] == "paper-membrane"
    assert case_from_toml(result.stdout) == load_case("paper-membrane")


def test_show_case_of_a_file_prints_it_as_written_and_it_loads_back(runner, tmp_path):
    path = _write_case(tmp_path, _sphere_toml())
    result = runner.invoke(app, ["show-case", str(path)])
    assert result.exit_code == 0, result.output
    shown = case_from_toml(result.stdout)
    assert shown == load_case(path)
    assert math.isclose(shown.geometry.diameter, 0.254, rel_tol=1e-12)


def test_show_case_unknown_name(runner):
    result = runner.invoke(app, ["show-case", "paper-membrain"])
    message = _assert_clean_failure(result, None, 'did you mean "paper-membrane"')
    for name in BUILTINS:
        assert name in message


# ----------------------------------------------------------------------------- modes


def test_modes_kane_beam_json(runner):
    result = runner.invoke(app, ["modes", "kane-beam", "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)  # stdout is pure JSON (progress goes to stderr)
    freqs = summary["frequencies_hz"]
    assert len(freqs) >= 6
    assert freqs == sorted(freqs)
    assert len(summary["labels"]) == len(freqs)
    assert summary["rigid_frequencies_hz"] == []  # clamped: no rigid-body modes
    assert math.isclose(summary["mass_kg"], 12.0, rel_tol=1e-9)  # 1.2 kg/m x 10 m
    inertia = np.array(summary["inertia_kg_m2"])
    assert inertia.shape == (3, 3)
    np.testing.assert_allclose(inertia, inertia.T, atol=1e-9)
    # slender line along x about its centre: I_yy = I_zz = m L^2 / 12 = 100 kg m^2
    np.testing.assert_allclose(np.diag(inertia)[1:], 100.0, rtol=1e-9)
    assert summary["pressure_pa"] == 0.0
    # cantilever: omega_1 sqrt(rho A L^4 / EI) = 1.8751^2 = 3.5160
    length, ei, rho_a = 10.0, 1.4e4, 1.2
    coefficient = 2 * math.pi * freqs[0] * math.sqrt(rho_a * length**4 / ei)
    assert coefficient == pytest.approx(3.5160, rel=5e-3)
    assert freqs[1] == pytest.approx(freqs[0], rel=1e-6)  # the y/z bending pair


def test_modes_kane_beam_table(runner):
    result = runner.invoke(app, ["modes", "kane-beam"])
    assert result.exit_code == 0, result.output
    assert "kane-beam: elastic modes" in result.stdout
    assert "rigid-body frequencies (Hz): none (clamped)" in result.stdout
    assert "mass: 12 kg" in result.stdout


def test_modes_small_sphere_json(runner, tmp_path):
    path = _write_case(tmp_path, _sphere_toml())
    result = runner.invoke(app, ["modes", str(path), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    freqs = summary["frequencies_hz"]
    assert len(freqs) >= 6 and freqs == sorted(freqs) and freqs[0] > 0
    rigid = np.abs(summary["rigid_frequencies_hz"])
    assert rigid.shape == (6,)  # free-floating: three translations, three rotations
    assert np.all(rigid < 1e-3 * freqs[0])
    assert summary["pressure_pa"] == pytest.approx(2068.43, abs=0.01)  # 0.3 psi
    assert summary["prestress"]["elements_in_compression"] == 0
    assert summary["prestress"]["stress_resultant_min_n_per_m"] > 0
    # each mode slackens the membrane at some amplitude well below the sphere's size
    onsets = np.array(summary["slack_onset_m"], float)
    assert onsets.shape == (len(freqs),) and np.all((onsets > 1e-6) & (onsets < 0.05))


def test_modes_writes_output_folder(runner, tmp_path):
    path = _write_case(tmp_path, _sphere_toml(count=2))
    out_dir = tmp_path / "results"
    result = runner.invoke(app, ["modes", str(path), "-o", str(out_dir)])
    assert result.exit_code == 0, result.output
    assert "outputs written to" in result.stdout
    for name in ("mesh.vtu", "modes/modes.pvd", "modes.json", "mesh.png", "modes.png"):
        assert (out_dir / name).is_file(), name
        assert (out_dir / name).stat().st_size > 0, name
    summary = json.loads((out_dir / "modes.json").read_text())
    assert summary["case"] == "small-sphere"
    assert summary["pressure_pa"] == pytest.approx(PAPER_PRESSURE_PA)
    assert not [p.name for p in tmp_path.iterdir() if "partial" in p.name]


def test_modes_low_but_positive_pressure_tensions_the_sphere(runner, tmp_path):
    # Any positive pressure puts a closed convex membrane in biaxial tension (N = p R / 2).
    path = _write_case(tmp_path, _sphere_toml(pressure='"1e-3 psi"'))
    result = runner.invoke(app, ["modes", str(path), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["prestress"]["elements_in_compression"] == 0
    assert summary["prestress"]["stress_resultant_min_n_per_m"] > 0


# ----------------------------------------------------------------------------- user errors


@pytest.mark.parametrize(
    ("overrides", "needles"),
    [
        ({"pressure": '"0.3"'}, ["pressure.value", "no unit"]),
        ({"pressure": "0.3"}, ["pressure.value", "no unit"]),
        ({"pressure": '"3 in"'}, ["pressure", "length"]),
        ({"pressure": '"0 psi"'}, ["pressure.value", "positive"]),
        ({"pressure": '"-1 psi"'}, ["pressure.value", "positive"]),
        ({"thickness": '"0 in"'}, ["material.thickness", "positive"]),
        ({"thickness": '"-1 in"'}, ["material.thickness", "positive"]),
        ({"poisson_ratio": "0.5"}, ["material.poisson_ratio", "0.5"]),
    ],
    ids=[
        "pressure-bare-number-string",
        "pressure-bare-number",
        "pressure-length-unit",
        "pressure-zero",
        "pressure-negative",
        "thickness-zero",
        "thickness-negative",
        "poisson-half",
    ],
)
def test_bad_case_values(runner, tmp_path, overrides, needles):
    path = _write_case(tmp_path, _sphere_toml(**overrides))
    out_dir = tmp_path / "out"
    result = runner.invoke(app, ["modes", str(path), "-o", str(out_dir)])
    message = _assert_clean_failure(result, out_dir, *needles)
    assert "case.toml" in message  # names the source file too


def test_unknown_case_name(runner, tmp_path):
    out_dir = tmp_path / "out"
    result = runner.invoke(app, ["modes", "paper-membrain", "-o", str(out_dir)])
    message = _assert_clean_failure(result, out_dir, "built-in cases are")
    for name in BUILTINS:
        assert name in message


def test_missing_table_is_named_literally(runner, tmp_path):
    # the message contains "[pressure]": it must be printed as text, not taken as rich markup
    text = _sphere_toml().replace("[pressure]\n", "").replace("gas_law_exponent = 0\n", "")
    text = "\n".join(s for s in text.splitlines() if not s.startswith("value ="))
    path = _write_case(tmp_path, text)
    out_dir = tmp_path / "out"
    result = runner.invoke(app, ["modes", str(path), "-o", str(out_dir)])
    _assert_clean_failure(result, out_dir, "pressure: missing", "needs a [pressure] table")


def test_open_surface_file(runner, tmp_path):
    sphere = sphere_surface(0.127, 0.0508)
    open_surface = TriangleSurface(sphere.points, sphere.triangles[1:])  # drop one triangle
    write_surface(tmp_path / "open.vtu", open_surface)
    path = _write_case(tmp_path, _sphere_toml(geometry='shape = "file"\nfile = "open.vtu"'))
    out_dir = tmp_path / "out"
    result = runner.invoke(app, ["modes", str(path), "-o", str(out_dir)])
    _assert_clean_failure(result, out_dir, "mesh", "surface is open", "3 boundary edges")


def test_closed_surface_file_runs(runner, tmp_path):
    # the same surface without the hole: the file route itself works
    write_surface(tmp_path / "closed.vtu", sphere_surface(0.127, 0.0508))
    path = _write_case(tmp_path, _sphere_toml(geometry='shape = "file"\nfile = "closed.vtu"'))
    result = runner.invoke(app, ["modes", str(path), "--json"])
    assert result.exit_code == 0, result.output
    assert len(json.loads(result.stdout)["rigid_frequencies_hz"]) == 6


def test_vanishing_pressure(runner, tmp_path):
    # 1e-9 psi tensions a convex membrane only in exact arithmetic: the inflation strain
    # p R / (E t) ~ 1e-11 is below round-off in the Green strain, so the case is rejected before
    # inflation with a one-line error naming pressure.value and the smallest usable pressure.
    path = _write_case(tmp_path, _sphere_toml(pressure='"1e-9 psi"'))
    out_dir = tmp_path / "out"
    result = runner.invoke(app, ["modes", str(path), "--json", "-o", str(out_dir)])
    _assert_clean_failure(result, out_dir, "pressure.value", "too low to tension")


def test_newton_failure(runner, tmp_path, monkeypatch):
    def failing_inflate(*args, **kwargs):
        raise ConvergenceError(
            "inflation: Newton did not converge (relative residual 1.00e-03 after 40 "
            "iterations);\nraise [pressure] steps (now 1), use a finer mesh ([mesh] edge_length) or check "
            "the pressure"
        )

    monkeypatch.setattr("quadmodes.structure.pipeline.inflate", failing_inflate)
    path = _write_case(tmp_path, _sphere_toml())
    out_dir = tmp_path / "runs" / "first" / "out"  # parents do not exist yet
    result = runner.invoke(app, ["modes", str(path), "-o", str(out_dir)])
    _assert_clean_failure(result, out_dir, "inflation: Newton did not converge", "pressure")
    assert not (tmp_path / "runs").exists()  # no empty folders left behind either


def test_failed_run_keeps_existing_output_folder(runner, tmp_path, monkeypatch):
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    (out_dir / "modes.json").write_text("{}")

    def failing_inflate(*args, **kwargs):
        raise ConvergenceError("inflation: Newton did not converge")

    monkeypatch.setattr("quadmodes.structure.pipeline.inflate", failing_inflate)
    path = _write_case(tmp_path, _sphere_toml())
    result = runner.invoke(app, ["modes", str(path), "-o", str(out_dir)])
    assert result.exit_code == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "out"]
    assert [p.name for p in out_dir.iterdir()] == ["modes.json"]
    assert (out_dir / "modes.json").read_text() == "{}"


# ----------------------------------------------------------------------------- calibrate


def test_calibrate_help(runner):
    result = runner.invoke(app, ["calibrate", "--help"])
    assert result.exit_code == 0, result.output
    for option in ("--rocking", "--bending", "--axial", "--no-axial", "--output"):
        assert option in result.stdout


# ----------------------------------------------------------------------------- console script


def _console_script() -> str:
    exe = shutil.which("quadmodes")
    if exe is None:
        pytest.skip("the quadmodes console script is not on PATH")
    return exe


def test_console_script_cases():
    run = subprocess.run(
        [_console_script(), "cases"], capture_output=True, text=True, timeout=60, check=False
    )
    assert run.returncode == 0, run.stderr
    for name in BUILTINS:
        assert name in run.stdout


def test_console_script_error(tmp_path):
    out_dir = tmp_path / "out"
    path = _write_case(tmp_path, _sphere_toml(thickness='"0 in"'))
    run = subprocess.run(
        [_console_script(), "modes", str(path), "--json", "-o", str(out_dir)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert run.returncode == 2
    assert run.stdout == ""
    assert "Traceback" not in run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "material.thickness" in lines[0]
    assert not out_dir.exists()


def test_cache_key_follows_the_mesh_file_contents(tmp_path):
    """A mesh file changed under the same name (every coordinate doubled) must not reuse the
    reduced model, spectrum or damping modes built from the old file; the same bytes give the
    same key."""
    from quadmodes.case import load_case as load
    from quadmodes.fullorder.damping import damping_key
    from quadmodes.models import cache as model_cache

    surface = sphere_surface(0.127, 0.0508)
    write_surface(tmp_path / "body.vtu", surface)
    path = _write_case(tmp_path, _sphere_toml(geometry='shape = "file"\nfile = "body.vtu"'))
    case = load(str(path))
    keys = (model_cache.reduced_key(case, 5), damping_key(case, 100.0))
    assert model_cache.reduced_key(load(str(path)), 5) == keys[0]
    write_surface(tmp_path / "body.vtu", TriangleSurface(2.0 * surface.points, surface.triangles))
    changed = load(str(path))
    assert changed.to_toml() == case.to_toml()  # the case text alone cannot tell them apart
    assert model_cache.reduced_key(changed, 5) != keys[0]
    assert damping_key(changed, 100.0) != keys[1]
