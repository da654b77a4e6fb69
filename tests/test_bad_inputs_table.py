"""Bad inputs, one table: every row is a command line a user might type that cannot work.

Each must end with exit status 2, exactly one line on stderr starting with ``error:`` that names
the field or option to change, nothing on stdout, no traceback, and no file left behind (the
whole test folder, the model cache in it included, is unchanged). Every row fails before any
finite-element model is built: the inputs are tiny or refused up front, so the table is fast.
"""

from __future__ import annotations

import os
from pathlib import Path

import meshio
import numpy as np
import pytest
from typer.testing import CliRunner

from quadmodes.case import load_case
from quadmodes.cli.app import app
from quadmodes.mesh.io import write_surface
from quadmodes.mesh.revolution import sphere_surface
from quadmodes.mesh.surface import TriangleSurface


def _material() -> str:
    m = load_case("paper-membrane").material
    return "\n".join([
        f'density = "{m.density!r} kg/m^3"', f'youngs_modulus = "{m.youngs_modulus!r} Pa"',
        f"poisson_ratio = {m.poisson_ratio!r}", f'thickness = "{m.thickness!r} m"',
    ])  # fmt: skip


def sphere_case(
    *, pressure: str = '"0.3 psi"', edge: str = '"2 in"', geometry: str | None = None,
    material: dict[str, str] | None = None,
) -> str:
    """A 10 in sphere membrane (about 90 nodes at 2 in); keyword arguments replace values
    (given as TOML source)."""
    lines = _material().splitlines()
    for key, value in (material or {}).items():
        lines = [f"{key} = {value}" if s.startswith(f"{key} ") else s for s in lines]
    geometry = geometry or 'shape = "sphere"\ndiameter = "10 in"'
    return (
        f'name = "small-sphere"\nkind = "membrane"\n\n[geometry]\n{geometry}\n\n[mesh]\n'
        f"edge_length = {edge}\n\n[material]\n" + "\n".join(lines)
        + f"\n\n[pressure]\nvalue = {pressure}\n\n[modes]\ncount = 6\n"
    )


def _file_case(file: str, extra: str = "") -> str:
    return sphere_case(geometry=f'shape = "file"\nfile = "{file}"\n{extra}')


def beam_case(*, support: str = "clamped", elements: int = 20) -> str:
    text = load_case("kane-beam").to_toml()
    text = text.replace('support = "clamped"', f'support = "{support}"')
    return text.replace("elements = 20", f"elements = {elements}").replace(
        'name = "kane-beam"', 'name = "my-beam"'
    )


def run_case(model: Path, modes: int = 4) -> str:
    return (
        f'name = "my-run"\nkind = "run"\nmodel = "{model}"\n\n[reduced]\nmodes = {modes}\n\n'
        '[initial]\nspin_rate = "0.5 Hz"\ncone_angle = "6 deg"\n\n[integration]\n'
        'method = "midpoint"\ndt = "0.5 ms"\nduration = "0.01 s"\n'
    )


def _write(folder: Path, name: str, text: str) -> None:
    (folder / name).write_text(text, encoding="utf-8")


def make_inputs(d: Path) -> None:
    """Every input file a row uses, in the test folder ``d``."""
    cases = {
        "sphere.toml": sphere_case(),
        "p-bare-string.toml": sphere_case(pressure='"0.3"'),
        "p-bare-number.toml": sphere_case(pressure="0.3"),
        "p-length.toml": sphere_case(pressure='"3 in"'),
        "p-zero.toml": sphere_case(pressure='"0 psi"'),
        "p-negative.toml": sphere_case(pressure='"-1 psi"'),
        "p-1e-6.toml": sphere_case(pressure='"1e-6 psi"'),
        "p-1e-9.toml": sphere_case(pressure='"1e-9 psi"'),
        "t-zero.toml": sphere_case(material={"thickness": '"0 in"'}),
        "t-negative.toml": sphere_case(material={"thickness": '"-1 in"'}),
        "poisson-half.toml": sphere_case(material={"poisson_ratio": "0.5"}),
        "edge-long.toml": sphere_case(edge='"50 in"'),
        "edge-tiny.toml": sphere_case(edge='"0.01 in"'),
        "edge-zero.toml": sphere_case(edge='"0 in"'),
        "empty-mesh.toml": sphere_case(geometry='shape = "file"\nfile = "empty.vtu"'),
        "zero-byte-mesh.toml": sphere_case(geometry='shape = "file"\nfile = "zero.vtu"'),
        "inward-mesh.toml": sphere_case(geometry='shape = "file"\nfile = "inward.vtu"'),
        "open-mesh.toml": sphere_case(geometry='shape = "file"\nfile = "open.vtu"'),
        "missing-mesh.toml": sphere_case(geometry='shape = "file"\nfile = "nowhere.vtu"'),
        "no-pressure.toml": sphere_case().split("[pressure]")[0] + "[modes]\ncount = 6\n",
        "free-beam.toml": beam_case(support="free"),
        "huge-beam.toml": beam_case(elements=100_000),
        "bad-syntax.toml": 'name = "x"\nkind = \n',
        # ---- issue 24: bounded work, mesh files checked
        "p-arithmetic.toml": sphere_case(pressure='"10**10**10 psi"'),
        "count-huge.toml": sphere_case().replace("count = 6", "count = 1000000000"),
        "t-1e-300.toml": sphere_case(material={"thickness": '"1e-300 m"'}),
        "e-1e-30.toml": sphere_case(material={"youngs_modulus": '"1e-30 Pa"'}),
        "rho-huge.toml": sphere_case(material={"density": '"1e12 kg/m^3"'}),
        "fifo-mesh.toml": _file_case("fifo.vtu"),
        "dev-zero-mesh.toml": _file_case("zero-link.vtu"),
        "folder-mesh.toml": _file_case("afolder"),
        "huge-mesh.toml": _file_case("huge.vtu"),
        "stl-nodes-mesh.toml": _file_case("many.stl"),
        "two-bodies-mesh.toml": _file_case("two.vtu"),
        "mm-mesh.toml": _file_case("mm.stl"),
        "unit-kg-mesh.toml": _file_case("mm.stl", 'file_unit = "kg"'),
        "unit-not-file.toml": sphere_case(geometry='shape = "sphere"\ndiameter = "10 in"\n'
                                                   'file_unit = "mm"'),
    }
    for name, text in cases.items():
        _write(d, name, text)
    _write(d, "free-beam-run.toml", run_case(d / "free-beam.toml"))
    _write(d, "bad-axis-run.toml", run_case(d / "sphere.toml").replace(
        'cone_angle = "6 deg"', 'cone_angle = "6 deg"\nspin_axis = "sideways"'))  # fmt: skip
    sphere = sphere_surface(0.127, 0.0508)
    write_surface(d / "inward.vtu", TriangleSurface(sphere.points, sphere.triangles[:, ::-1].copy()))
    write_surface(d / "open.vtu", TriangleSurface(sphere.points, sphere.triangles[1:]))
    meshio.write(d / "empty.vtu", meshio.Mesh(np.zeros((0, 3)), []))
    two = (sphere.points, sphere.points + [1.0, 0.0, 0.0])
    write_surface(d / "two.vtu", TriangleSurface(np.vstack(two), np.vstack(
        [sphere.triangles, sphere.triangles + len(sphere.points)])))  # fmt: skip
    write_surface(d / "mm.stl", TriangleSurface(1000.0 * sphere.points, sphere.triangles))
    if hasattr(os, "mkfifo"):
        os.mkfifo(d / "fifo.vtu")
    (d / "zero-link.vtu").symlink_to("/dev/zero")
    with open(d / "huge.vtu", "wb") as f:  # sparse: 300 MB on paper, nothing on disk
        f.truncate(300_000_000)
    with open(d / "many.stl", "wb") as f:  # a binary STL header: a million triangles
        f.write(b"binary".ljust(80, b"\0") + (1_000_000).to_bytes(4, "little"))
        f.truncate(84 + 50 * 1_000_000)
    (d / "zero.vtu").write_bytes(b"")
    (d / "afile").write_text("not a folder")
    (d / "afolder").mkdir()
    # compare's checkpoint sits inside its output folder: <folder>/.fullorder-checkpoint.npz
    (d / "garbage").mkdir()
    (d / "garbage" / ".fullorder-checkpoint.npz").write_bytes(b"this is not a zip archive\n")
    np.savez(d / "whole.npz", version=1, step=3, x=np.zeros(2000))
    truncated = (d / "whole.npz").read_bytes()[:400]
    (d / "truncated").mkdir()
    (d / "truncated" / ".fullorder-checkpoint.npz").write_bytes(truncated)
    (d / "whole.npz").unlink()
    # ---- issue 24 items 1-2 (output folders, wrong numbers): the user's own files and links
    (d / "proj" / "modes").mkdir(parents=True)
    (d / "proj" / "modes" / "mine.txt").write_text("the user's notes")
    (d / "theirs" / "paper-0.5hz").mkdir(parents=True)
    (d / "theirs" / "paper-0.5hz" / "results.nc").write_bytes(b"the user's own results")
    (d / "links").mkdir()
    (d / "links" / "paper-0.5hz").symlink_to(d / "afolder", target_is_directory=True)
    (d / "dangling").symlink_to(d / "nowhere-folder")
    _write(d, "long-name-run.toml", run_case(d / "sphere.toml").replace(
        'name = "my-run"', f'name = "{"r" * 250}"'))  # fmt: skip


LONG = "x" * 250
# (id, command line with {d} = the test folder, text the error line must contain)
ROWS: list[tuple[str, str, tuple[str, ...]]] = [
    # ---- case values (the existing checks, kept)
    ("pressure-bare-string", "modes {d}/p-bare-string.toml -o {d}/out", ("pressure.value", "no unit")),
    ("pressure-bare-number", "modes {d}/p-bare-number.toml -o {d}/out", ("pressure.value", "no unit")),
    ("pressure-length-unit", "modes {d}/p-length.toml -o {d}/out", ("pressure", "length")),
    ("pressure-zero", "modes {d}/p-zero.toml -o {d}/out", ("pressure.value", "positive")),
    ("pressure-negative", "modes {d}/p-negative.toml -o {d}/out", ("pressure.value", "positive")),
    ("pressure-1e-9-psi", "modes {d}/p-1e-9.toml -o {d}/out", ("pressure.value", "too low to tension")),
    ("thickness-zero", "modes {d}/t-zero.toml -o {d}/out", ("material.thickness", "positive")),
    ("thickness-negative", "modes {d}/t-negative.toml", ("material.thickness", "positive")),
    ("poisson-half", "modes {d}/poisson-half.toml", ("material.poisson_ratio", "0.5")),
    ("edge-zero", "modes {d}/edge-zero.toml", ("mesh.edge_length", "positive")),
    ("missing-table", "modes {d}/no-pressure.toml -o {d}/out", ("pressure: missing", "[pressure]")),
    ("toml-syntax", "modes {d}/bad-syntax.toml", ("line 2", "invalid TOML")),
    ("unknown-case", "modes paper-membrain -o {d}/out", ("built-in cases are",)),
    ("missing-case-file", "modes {d}/nowhere.toml", ("case file not found",)),
    ("run-case-to-modes", "modes paper-0.5hz", ("run case", "quadmodes run")),
    ("model-case-to-run", "run paper-membrane -o {d}/out", ("not a run case", "model =")),
    ("open-mesh", "modes {d}/open-mesh.toml -o {d}/out", ("surface is open", "3 boundary edges")),
    ("missing-mesh-file", "modes {d}/missing-mesh.toml", ("geometry.file",)),
    # ---- the bad inputs of issue 11
    ("folder-as-case", "modes {d}/afolder -o {d}/out", ("is a folder, not a case file",)),
    ("folder-as-run-case", "run {d}/afolder -o {d}/out", ("is a folder", "run case file")),
    ("pressure-1e-6-psi", "modes {d}/p-1e-6.toml -o {d}/out", ("pressure.value", "at least")),
    ("pressure-1e-6-psi-reduce", "reduce {d}/p-1e-6.toml", ("pressure.value", "psi")),
    ("edge-longer-than-body", "modes {d}/edge-long.toml -o {d}/out", ("mesh.edge_length", "too long")),
    ("edge-longer-than-body-reduce", "reduce {d}/edge-long.toml", ("mesh.edge_length",)),
    ("modes-500-reduce", "reduce paper-membrane-coarse --modes 500", ("--modes 500", "GB")),
    ("modes-500-run", "run paper-0.5hz --modes 500 -o {d}/out", ("--modes 500",)),
    ("modes-500-compare", "compare paper-41hz-coarse --modes 500 -o {d}/out", ("--modes",)),
    ("modes-500-rotating", "rotating --modes 500", ("--modes 500",)),
    ("modes-beyond-dofs", "reduce kane-beam --modes 200", ("--modes 200", "elastic modes")),
    ("modes-120-reduce", "reduce kane-beam --modes 120", ("--modes 120", "--yes")),
    ("modes-zero-reduce", "reduce kane-beam --modes 0", ("--modes 0", "at least 1")),
    ("empty-vtu", "modes {d}/empty-mesh.toml -o {d}/out", ("geometry.file", "empty.vtu")),
    ("zero-byte-vtu", "modes {d}/zero-byte-mesh.toml -o {d}/out", ("geometry.file", "empty")),
    ("inward-mesh", "modes {d}/inward-mesh.toml -o {d}/out", ("geometry.file", "flip the normals")),
    # a free *cable* beam (kane-beam's element) cannot spin; the 3-D beam can
    ("free-beam-run", "run {d}/free-beam-run.toml -o {d}/out", ("beam.element", "beam3d")),
    ("free-beam-campbell", "campbell {d}/free-beam.toml", ("beam.element",)),
    ("free-beam-compare", "compare {d}/free-beam-run.toml -o {d}/out", ("beam.element",)),
    ("free-beam-rotating", "rotating {d}/free-beam.toml", ("beam.element",)),
    ("garbage-checkpoint", "compare paper-41hz-coarse -o {d}/garbage --resume", ("--resume", "damaged", "--restart")),
    ("truncated-checkpoint", "compare paper-41hz-coarse -o {d}/truncated --resume", ("--resume", "truncated")),
    ("no-checkpoint", "compare paper-41hz-coarse -o {d}/out --resume", ("--resume", "no checkpoint")),
    # ---- resource guards
    ("edge-0.01in-modes", "modes {d}/edge-tiny.toml -o {d}/out", ("mesh.edge_length", "nodes", "--yes")),
    ("edge-0.01in-reduce", "reduce {d}/edge-tiny.toml", ("mesh.edge_length", "GB")),
    ("edge-0.01in-campbell", "campbell {d}/edge-tiny.toml", ("mesh.edge_length",)),
    ("beam-elements-huge", "modes {d}/huge-beam.toml", ("beam.elements", "--yes")),
    ("run-duration-huge", "run paper-0.5hz --duration '1e6 s' -o {d}/out", ("integration.duration", "--yes")),
    ("run-dt-tiny", "run paper-0.5hz --dt '1e-9 s' -o {d}/out", ("--dt", "steps")),
    # ---- output paths, checked before any work
    ("modes-o-is-file", "modes {d}/sphere.toml -o {d}/afile", ("-o", "is a file")),
    ("run-o-is-file", "run paper-0.5hz -o {d}/afile", ("-o", "is a file")),
    ("run-o-under-file", "run paper-0.5hz -o {d}/afile/sub", ("-o", "is a file")),
    ("run-o-too-long", f"run paper-0.5hz -o {{d}}/{LONG}", ("-o", "too long")),
    ("modes-o-read-only", "modes {d}/sphere.toml -o /proc/quadmodes-out", ("-o", "cannot write")),
    ("reduce-o-read-only", "reduce kane-beam -o /proc/model.nc", ("-o", "cannot write")),
    # -o is the output folder for every command (issue 13); a file name with the file's suffix
    # is still read as the file (deprecated)
    ("reduce-o-is-file", "reduce kane-beam -o {d}/afile", ("-o", "is a file")),
    ("calibrate-o-is-file", "calibrate paper-membrane -o {d}/afile", ("-o", "is a file")),
    ("rotating-o-is-file", "rotating -o {d}/afile", ("-o", "is a file")),
    ("campbell-o-is-file", "campbell kane-beam -o {d}/afile", ("-o", "is a file")),
    ("compare-o-is-file", "compare paper-41hz-coarse -o {d}/afile", ("-o", "is a file")),
    # ---- options
    ("run-dt-not-a-number", "run paper-0.5hz --dt abc -o {d}/out", ("integration.dt", "number")),
    ("run-method", "run paper-0.5hz --method bogus -o {d}/out", ("integration.method",)),
    ("run-formulation", "run paper-0.5hz --formulation X -o {d}/out", ("reduced.formulation",)),
    ("run-spin-rate-unit", "run paper-0.5hz --spin-rate '10 m' -o {d}/out", ("initial.spin_rate", "length")),
    ("run-duration-negative", "run paper-0.5hz --duration '-1 s' -o {d}/out", ("integration.duration",)),
    ("run-dt-convergence-spinup", "run kane-spinup --dt-convergence -o {d}/out", ("--dt-convergence",)),
    ("campbell-spin-unit", "campbell --spin-min '1 m'", ("--spin-min", "length")),
    ("campbell-formulation", "campbell --formulation X", ("--formulation",)),
    ("campbell-no-points", "campbell --points 0", ("--points",)),
    ("campbell-spin-range-reversed", "campbell --spin-min '10 rad/s' --spin-max '1 rad/s'", ("--spin-max",)),
    ("rotating-spins", "rotating --spin-rate a,b", ("--spin-rate",)),
    ("campbell-axis-word", "campbell --axis diagonal", ("--axis", "diagonal", "minor")),
    ("campbell-axis-two-numbers", "campbell --axis 1,2", ("--axis", "three numbers")),
    ("rotating-axis-zero", "rotating --axis 0,0,0", ("--axis", "not all zero")),
    ("run-spin-axis", "run {d}/bad-axis-run.toml -o {d}/out", ("initial.spin_axis", "sideways")),
    ("compare-window-zero", "compare --window '0 s' -o {d}/out", ("--window", "positive")),
    ("compare-formulations", "compare --formulation bogus -o {d}/out", ("--formulation",)),
    ("compare-full-dt", "compare --full-dt '2 s' -o {d}/out", ("--full-dt",)),
    ("show-case-unknown", "show-case nope", ("unknown case",)),
    ("cache-clear-without-yes", "cache clear", ("--yes",)),
    ("validate-write-is-folder", "validate --quick --write {d}/afolder", ("--write", "is a folder")),
    # ---- issue 24 item 3: bounded work (docs/reliability.md)
    ("quantity-arithmetic", "modes {d}/p-arithmetic.toml -o {d}/out", ("pressure.value", "no arithmetic")),
    ("quantity-arithmetic-option", "run paper-0.5hz --dt '10**10**10 s' -o {d}/out", ("integration.dt", "no arithmetic")),
    ("modes-count-huge", "modes {d}/count-huge.toml -o {d}/out", ("modes.count", "QUADMODES_MAX_MODES")),
    ("modes-500-yes", "reduce paper-membrane-coarse --modes 500 --yes", ("--modes 500", "QUADMODES_MAX_REDUCED_MODES")),
    ("sweep-range-huge", "sweep paper-0.5hz --param 'initial.spin_rate=1 Hz:45 Hz:100000000' -o {d}/out", ("--param", "QUADMODES_MAX_SWEEP_POINTS")),
    ("sweep-grid-huge", "sweep paper-0.5hz --param 'initial.spin_rate=1 Hz:45 Hz:1000' --param 'pressure.value=0.2 psi:0.4 psi:1000' -o {d}/out", ("--param", "1000 × 1000", "QUADMODES_MAX_SWEEP_POINTS")),
    ("sweep-modes-huge", "sweep paper-0.5hz --param 'reduced.modes=5,1000' -o {d}/out", ("--param", "reduced.modes = 1000", "QUADMODES_MAX_REDUCED_MODES")),
    ("campbell-points-huge", "campbell kane-beam --points 1000000000", ("--points", "QUADMODES_MAX_CAMPBELL_POINTS")),
    ("mesh-fifo", "modes {d}/fifo-mesh.toml -o {d}/out", ("geometry.file", "not a regular file")),
    ("mesh-dev-zero-link", "modes {d}/dev-zero-mesh.toml -o {d}/out", ("geometry.file", "not a regular file")),
    ("mesh-folder", "modes {d}/folder-mesh.toml -o {d}/out", ("geometry.file", "is a folder")),
    ("mesh-file-huge", "modes {d}/huge-mesh.toml -o {d}/out", ("geometry.file", "QUADMODES_MAX_MESH_BYTES")),
    ("mesh-file-huge-reduce", "reduce {d}/huge-mesh.toml", ("geometry.file", "QUADMODES_MAX_MESH_BYTES")),
    ("mesh-fifo-reduce", "reduce {d}/fifo-mesh.toml", ("geometry.file", "not a regular file")),
    ("mesh-stl-nodes", "modes {d}/stl-nodes-mesh.toml -o {d}/out", ("geometry.file", "500,002 nodes", "QUADMODES_MAX_MESH_NODES")),
    ("run-output-huge", "run paper-0.5hz --duration '20000 s' --yes -o {d}/out", ("integration.save_every", "save_every = 13", "QUADMODES_MAX_OUTPUT_BYTES")),
    # ---- issue 24 item 4: mesh files checked, plausible values
    ("mesh-two-bodies", "modes {d}/two-bodies-mesh.toml -o {d}/out", ("geometry.file", "2 separate closed parts")),
    ("mesh-in-millimetres", "modes {d}/mm-mesh.toml -o {d}/out", ("geometry.file_unit", '"mm"')),
    ("mesh-unit-not-length", "modes {d}/unit-kg-mesh.toml -o {d}/out", ("geometry.file_unit", "length unit")),
    ("mesh-unit-without-file", "modes {d}/unit-not-file.toml -o {d}/out", ("geometry.file_unit", "only used")),
    ("thickness-1e-300", "modes {d}/t-1e-300.toml -o {d}/out", ("material.thickness", "strain scale")),
    ("thickness-1e-300-reduce", "reduce {d}/t-1e-300.toml", ("material.thickness", "strain scale")),
    ("youngs-modulus-1e-30", "modes {d}/e-1e-30.toml -o {d}/out", ("material.youngs_modulus", "strain scale")),
    ("density-huge", "modes {d}/rho-huge.toml -o {d}/out", ("material.density", "mass")),
    # ---- issue 24 items 1-2: nothing a user owns is touched, no wrong number is silent
    ("modes-o-user-modes-folder", "modes kane-beam -o {d}/proj", ("-o", "proj/modes", "did not write")),
    ("run-user-results-file", "run paper-0.5hz -o {d}/theirs", ("-o", "results.nc", "did not write")),
    ("run-case-folder-is-symlink", "run paper-0.5hz -o {d}/links", ("-o", "symbolic link")),
    ("run-o-dangling-symlink", "run paper-0.5hz -o {d}/dangling", ("-o", "dangling")),
    ("compare-o-dangling-symlink", "compare paper-41hz-coarse -o {d}/dangling", ("-o", "dangling")),
    ("run-name-250-chars", "run {d}/long-name-run.toml -o {d}/out", ("-o", "too long")),
    ("run-dt-8-turns-a-step", "run paper-41hz-coarse --dt '0.2 s' -o {d}/out", ("integration.dt", "spin", "--yes")),
    # ---- issue 24 item 7: the weak cases made clean (usage errors were boxed, 3-6 lines)
    ("usage-unknown-option", "run paper-41hz-coarse --bogus", ("--bogus", "run --help lists the options")),
    ("usage-unknown-command", "nonsense", ("nonsense", "--help lists the commands")),
    ("usage-points-not-a-number", "campbell paper-membrane-coarse --points abc", ("--points", "integer")),
    ("run-modes-fraction", "run paper-41hz-coarse --modes 7.5 -o {d}/out", ("reduced.modes", "whole number")),
]


def _snapshot(folder: Path) -> dict[str, int]:
    """Every path under ``folder`` with its size (files) or -1 (folders)."""
    return {str(p.relative_to(folder)): (p.stat().st_size if p.is_file() else -1)
            for p in folder.rglob("*")}  # fmt: skip


def _split(command: str, d: Path) -> list[str]:
    import shlex

    return shlex.split(command.replace("{d}", str(d)))


@pytest.fixture
def inputs(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    make_inputs(tmp_path)
    (tmp_path / "cache").mkdir()
    # a cache entry, so that `cache clear` has something it would remove
    (tmp_path / "cache" / "x-N5-0123456789abcdef.nc").write_bytes(b"\0" * 16)
    return tmp_path


def test_the_table_has_at_least_40_rows():
    assert len(ROWS) >= 40
    assert len({row[0] for row in ROWS}) == len(ROWS)  # ids are unique


@pytest.mark.parametrize(("command", "needles"), [r[1:] for r in ROWS], ids=[r[0] for r in ROWS])
def test_bad_input(inputs: Path, command: str, needles: tuple[str, ...]):
    if "/proc/" in command and not Path("/proc").is_dir():
        pytest.skip("needs a /proc file system (a folder nobody can write in)")
    before = _snapshot(inputs)
    result = CliRunner().invoke(app, _split(command, inputs))
    assert result.exit_code == 2, (result.exit_code, result.stdout, result.stderr)
    assert isinstance(result.exception, SystemExit), result.exception  # not an escaped error
    assert "Traceback" not in result.output
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ")
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert _snapshot(inputs) == before  # nothing written, nothing removed


def test_yes_lifts_the_size_limit():
    """``--yes`` is what the size message offers: with it the estimate is returned, not
    refused (checked without building the model)."""
    from quadmodes.case import case_from_toml
    from quadmodes.case.errors import CaseError
    from quadmodes.runs.resources import MAX_NODES, check_model_size

    case = case_from_toml(sphere_case(edge='"0.01 in"'))
    with pytest.raises(CaseError) as exc:
        check_model_size(case)
    assert exc.value.field == "mesh.edge_length"
    size = check_model_size(case, allow_large=True)
    assert size.nodes > MAX_NODES


def test_node_estimate_is_the_mesh_node_count():
    """The estimate places the mesher's rings without meshing: it equals the node count."""
    from quadmodes.runs.resources import estimate_size
    from quadmodes.structure.pipeline import surface_for_case

    for name in ("paper-membrane-coarse", "sphere"):
        case = load_case(name)
        assert estimate_size(case).nodes == len(surface_for_case(case).points)


def test_output_checks_accept_good_paths(tmp_path):
    from quadmodes.cli.common import check_output_file, check_output_folder

    check_output_folder(tmp_path / "new" / "deeper")  # parents need not exist
    check_output_folder(tmp_path)  # an existing folder
    check_output_file(tmp_path / "model.nc")
    assert sorted(os.listdir(tmp_path)) == []  # the checks leave nothing behind



@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root may write anywhere")
def test_read_only_output_folder_is_named(tmp_path):
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        result = CliRunner().invoke(app, ["modes", "kane-beam", "-o", str(folder / "out")])
    finally:
        folder.chmod(0o755)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: -o: cannot write in")
    assert list(folder.iterdir()) == []
