"""The model cache is safe to share: parallel cold builds build once and both use the result,
the key follows the package version and the model-building code, ``--no-cache`` leaves the
cache alone, and ``quadmodes cache list | clear`` show and remove only cache entries.

The case is the built-in kane-beam (21 nodes) with 2 modes: a cold build takes well under a
second. No test waits for a time: the lock test reads the waiting process's own report.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from quadmodes.case import load_case
from quadmodes.cli.app import app
from quadmodes.io.locking import file_lock, lock_path
from quadmodes.models import build as model_build
from quadmodes.models import cache as model_cache
from quadmodes.models.cache_entries import cache_entries
from quadmodes.rom import artifact

CASE, N_MODES = "kane-beam", 2
SRC = Path(__file__).resolve().parents[1] / "src"


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("QUADMODES_CACHE", str(folder))
    return folder


def _env(cache: Path) -> dict:
    python_path = os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])
    return {**os.environ, "QUADMODES_CACHE": str(cache), "PYTHONPATH": python_path,
            "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1"}  # fmt: skip


def _reduce_cmd() -> list[str]:
    launcher = "from quadmodes.cli import app; app(prog_name='quadmodes')"
    return [sys.executable, "-c", launcher, "reduce", CASE, "--modes", str(N_MODES), "--json"]


def _model_files(cache: Path) -> list[Path]:
    return sorted(cache.glob("*.nc"))


def _assert_one_valid_entry(cache: Path) -> Path:
    """Exactly one reduced-model file, readable, with the current key; no temporary files."""
    files = _model_files(cache)
    assert len(files) == 1, files
    case = load_case(CASE)
    assert files[0] == model_cache.cache_path(case, N_MODES)
    model = artifact.load_reduced_model(files[0])
    assert model.n_modes == N_MODES
    assert model.provenance["content_key"] == model_cache.reduced_key(case, N_MODES)
    assert not [p for p in cache.iterdir() if ".partial" in p.name]
    return files[0]


def test_two_parallel_cold_builds_build_once_and_both_succeed(cache):
    procs = [
        subprocess.Popen(_reduce_cmd(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=_env(cache))  # fmt: skip
        for _ in range(2)
    ]
    outputs = [p.communicate(timeout=300) for p in procs]
    for proc, (_, stderr) in zip(procs, outputs, strict=True):
        assert proc.returncode == 0, stderr
    summaries = [json.loads(stdout) for stdout, _ in outputs]
    # one process built and saved the model; the other found it (before or after the lock)
    assert sorted(s["cache"] for s in summaries) == ["hit", "miss"]
    path = _assert_one_valid_entry(cache)
    assert all(s["cache_path"] == str(path) for s in summaries)
    assert summaries[0]["frequencies_hz"] == summaries[1]["frequencies_hz"]


_WAITER = textwrap.dedent(
    """
    import json, sys
    from quadmodes.case import load_case
    from quadmodes.models import build as model_build

    def progress(stage, fraction):
        print(stage, flush=True)

    info = {}
    model_build.reduced_model_for(load_case("kane-beam"), 2, progress, info=info)
    print(json.dumps(info), flush=True)
    """
)


def test_a_process_waiting_for_the_lock_uses_the_model_built_meanwhile(cache):
    """While this test holds the lock of the cache entry, a second process reports that it
    waits; the model saved meanwhile is what it uses (no second build)."""
    case = load_case(CASE)
    path = model_cache.cache_path(case, N_MODES)
    model = model_build.build_reduced_model(case, N_MODES)
    with file_lock(path) as locked:
        assert locked
        proc = subprocess.Popen([sys.executable, "-c", _WAITER], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=_env(cache))  # fmt: skip
        assert proc.stdout.readline().strip() == "cache lock"  # blocked on our lock
        artifact.save_reduced_model(model, path)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    info = json.loads(stdout.strip().splitlines()[-1])
    assert info["cache"] == "hit" and info["waited"] is True
    assert "modes" not in stdout.split()  # it built no modal model
    _assert_one_valid_entry(cache)


def test_a_changed_code_hash_or_version_rebuilds(cache, monkeypatch):
    case = load_case(CASE)
    states = []
    for _ in range(2):
        info: dict = {}
        model_build.reduced_model_for(case, N_MODES, info=info)
        states.append(info["cache"])
    assert states == ["miss", "hit"]
    first = model_cache.cache_path(case, N_MODES)

    monkeypatch.setattr(model_cache, "code_fingerprint", lambda: "0" * 64)
    info = {}
    model_build.reduced_model_for(case, N_MODES, info=info)
    assert info["cache"] == "miss" and Path(info["path"]) != first
    monkeypatch.setattr(model_cache, "__version__", "99.0.0")
    info = {}
    model_build.reduced_model_for(case, N_MODES, info=info)
    assert info["cache"] == "miss"
    assert len({first, *(_model_files(cache))}) == 3  # three keys, three files


def test_the_code_fingerprint_follows_every_byte_of_the_model_code(tmp_path):
    (tmp_path / "fe").mkdir()
    (tmp_path / "fe" / "a.py").write_text("x = 1\n")
    (tmp_path / "reduced.py").write_text("y = 2\n")
    entries = ("fe", "reduced.py")
    before = model_cache.fingerprint_files(tmp_path, entries)
    assert model_cache.fingerprint_files(tmp_path, entries) == before
    (tmp_path / "fe" / "a.py").write_text("x = 2\n")
    assert model_cache.fingerprint_files(tmp_path, entries) != before
    # the package's own fingerprint covers the model code and is computed once
    assert len(model_cache.code_fingerprint()) == 64
    assert model_cache.code_fingerprint() is model_cache.code_fingerprint()


def test_no_cache_neither_reads_nor_writes(cache):
    runner = CliRunner()
    result = runner.invoke(app, ["reduce", CASE, "--modes", str(N_MODES), "--json", "--no-cache"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["cache"] == "off"
    assert not cache.exists() or not list(cache.iterdir())
    with model_cache.caching_disabled():
        assert not model_cache.caching_enabled()
    assert model_cache.caching_enabled()  # restored after the block


def test_cache_folder_is_per_user_unless_overridden(tmp_path, monkeypatch):
    monkeypatch.delenv("QUADMODES_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    pytest.importorskip("platformdirs")
    if sys.platform.startswith("linux"):
        assert model_cache.cache_dir() == tmp_path / "xdg" / "quadmodes"
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "mine"))
    assert model_cache.cache_dir() == tmp_path / "mine"


def test_lock_degrades_where_the_lock_file_cannot_be_made(tmp_path):
    target = tmp_path / "no-such-parent-file"
    target.write_text("")  # a file where the lock's folder would be
    with file_lock(target / "entry.nc") as locked:
        assert locked is False  # the block still runs
    assert lock_path(tmp_path / "a.nc") == tmp_path / "a.nc.lock"


def test_cache_list_and_clear(cache):
    runner = CliRunner()
    model_build.reduced_model_for(load_case(CASE), N_MODES)
    (cache / "notes.txt").write_text("mine")  # not a cache entry: never listed nor removed

    listed = runner.invoke(app, ["cache", "list", "--json"])
    assert listed.exit_code == 0, listed.output
    data = json.loads(listed.stdout)
    assert data["cache_dir"] == str(cache)
    assert [(e["case"], e["kind"], e["modes"]) for e in data["entries"]] == [(CASE, "reduced", "2")]
    assert data["entries"][0]["size_bytes"] > 0 and data["entries"][0]["age_s"] >= 0
    table = runner.invoke(app, ["cache", "list"])
    assert table.exit_code == 0 and CASE in table.stdout and "1 entries" in table.stdout

    refused = runner.invoke(app, ["cache", "clear"])  # not a terminal and no --yes
    assert refused.exit_code == 2
    assert refused.stderr.strip().startswith("error:") and "--yes" in refused.stderr
    assert len(cache_entries(cache)) == 1

    cleared = runner.invoke(app, ["cache", "clear", "--yes"])
    assert cleared.exit_code == 0, cleared.output
    assert sorted(p.name for p in cache.iterdir()) == ["notes.txt"]  # entry and lock removed
    assert "empty" in runner.invoke(app, ["cache", "clear", "--yes"]).stdout


def test_cache_entries_are_recognised_by_name(tmp_path):
    names = {
        "paper-membrane-N5-0123456789abcdef.nc": ("reduced", "paper-membrane", "5"),
        "kane-beam-spectrum12-0123456789abcdef.json": ("spectrum", "kane-beam", "12"),
        "paper-41hz-coarse-damping-150Hz-0123456789abcdef.nc": ("damping", "paper-41hz-coarse", "150 Hz"),
        ".kane-beam-N2-0123456789abcdef.nc.k3j2h1.partial.nc": ("partial", "kane-beam", "2"),
    }
    for name in [*names, "results.nc", "notes.txt", "kane-beam-N2-0123456789abcdef.nc.lock"]:
        (tmp_path / name).write_bytes(b"12345")
    found = {e.path.name: (e.kind, e.case, e.modes) for e in cache_entries(tmp_path)}
    assert found == names  # other files and (by default) lock files are not listed
    with_locks = cache_entries(tmp_path, locks=True)
    assert [e.kind for e in with_locks].count("lock") == 1


@pytest.mark.parametrize("command", ["run", "reduce", "compare", "rotating"])
def test_model_building_commands_take_no_cache(command):
    result = CliRunner().invoke(app, [command, "--help"], terminal_width=200)
    assert result.exit_code == 0 and "--no-cache" in result.stdout


@pytest.mark.parametrize(
    ("kind", "size", "spin_hz", "modes", "spin"),
    [
        ("reduced", 16, 41.0, "16", "41 Hz"),
        ("reduced", 5, 0.0, "5", ""),
        ("spectrum", 20, 41.5, "20", "41.5 Hz"),
        ("spectrum", 10, 0.0, "10", ""),
        ("damping", 382.417, 0.0, "382.417 Hz", ""),
    ],
)
def test_every_name_the_cache_writes_is_listed(tmp_path, kind, size, spin_hz, modes, spin):
    """One naming scheme for the writers and the listing: a name made by ``entry_name`` (as
    ``cache_path``, ``spectrum_path`` and the damping cache make theirs) parses back."""
    from quadmodes.models.cache_entries import entry_name

    name = entry_name(kind, "paper-membrane-coarse", size, "0123456789abcdef", spin_hz)
    (tmp_path / name).write_bytes(b"x")
    (tmp_path / f"{name}.lock").write_bytes(b"")
    (found,) = cache_entries(tmp_path)
    assert (found.kind, found.case, found.modes, found.spin) == (kind, "paper-membrane-coarse", modes, spin)
    assert len(cache_entries(tmp_path, locks=True)) == 2


def test_spinning_models_are_listed_and_cleared(tmp_path, monkeypatch):
    """The default models are about a spinning state: their files (model, spectrum, locks) are
    listed by ``cache list`` and removed by ``cache clear --yes``."""
    from quadmodes.fullorder.damping import damping_cache_path

    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path))
    case = load_case("paper-membrane-coarse")
    spin = 2 * np.pi * 41.0
    written = [model_cache.cache_path(case, 16, spin), model_cache.spectrum_path(case, 20, spin),
               model_cache.cache_path(case, 5), damping_cache_path(case, 382.417)]  # fmt: skip
    for path in written:
        path.write_bytes(b"x")
        path.with_name(path.name + ".lock").write_bytes(b"")
    (tmp_path / "notes.txt").write_text("mine")
    assert {e.path for e in cache_entries(tmp_path)} == set(written)
    listed = CliRunner().invoke(app, ["cache", "list", "--json"])
    assert listed.exit_code == 0, listed.output
    rows = json.loads(listed.stdout)["entries"]
    assert sorted((r["kind"], r["modes"], r["spin"]) for r in rows) == [
        ("damping", "382.417 Hz", ""), ("reduced", "16", "41 Hz"), ("reduced", "5", ""),
        ("spectrum", "20", "41 Hz")]  # fmt: skip
    assert CliRunner().invoke(app, ["cache", "clear", "--yes"]).exit_code == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]
