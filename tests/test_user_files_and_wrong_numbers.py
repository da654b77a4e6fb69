"""Issue 24, items 1, 2 and 5: quadmodes replaces or removes only the files it wrote, follows no
link it did not make and keeps its checkpoints inside ``-o``; a number that would be wrong (a
step longer than the spin period, a checkpoint or a model of another case, a damaged cache
entry) is refused or said; a full disk is one line and keeps the checkpoint."""

from __future__ import annotations

import dataclasses
import errno
from pathlib import Path

import numpy as np
import pytest
from test_run import workdir  # noqa: F401  (fixture)
from typer.testing import CliRunner

from quadmodes.analysis import comparison_run as runner
from quadmodes.case import CaseError, load_case, load_run_case
from quadmodes.cli.app import app
from quadmodes.io import outputs
from quadmodes.models import cache as model_cache
from quadmodes.rom import artifact
from quadmodes.runs import run_folder, simulate
from quadmodes.runs.run_checks import check_time_step

SHORT = ["--duration", "0.01 s"]


def _cli(*args: str):
    return CliRunner().invoke(app, list(args))


def _one_error_line(result) -> str:
    assert result.exit_code == 2, result.output
    lines = [s for s in result.stderr.strip().splitlines() if not s.endswith("%")]  # progress
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "Traceback" not in result.output
    return lines[0]


# ------------------------------------------------------------------------ 1. output folders


def test_rerun_removes_only_its_own_figures(workdir):  # noqa: F811
    case, out = str(workdir / "small-run.toml"), workdir / "out"
    first = _cli("run", case, "-o", str(out), *SHORT)
    assert first.exit_code == 0, first.output
    folder = out / "small-run"
    ours = sorted(p.name for p in folder.glob("*.png"))
    assert ours and set(ours) <= outputs.owned(folder)
    (folder / "my-sketch.png").write_bytes(b"the user's own picture")
    (folder / "notes.txt").write_text("mine")
    again = _cli("run", case, "-o", str(out), *SHORT, "--no-plots")
    assert again.exit_code == 0, again.output
    assert sorted(p.name for p in folder.glob("*.png")) == ["my-sketch.png"]
    assert (folder / "my-sketch.png").read_bytes() == b"the user's own picture"
    assert (folder / "notes.txt").read_text() == "mine"
    assert "notes.txt" in again.stderr and "my-sketch.png" in again.stderr  # listed, kept


def test_compare_into_the_current_folder_keeps_the_users_pictures(tmp_path, monkeypatch):
    """``compare -o .``: the checkpoint is inside ``.`` and a commit removes no PNG of the
    user's (the library path the command takes)."""
    monkeypatch.chdir(tmp_path)
    assert runner.checkpoint_beside(Path(".")).parent == tmp_path
    (tmp_path / "holiday.png").write_bytes(b"user")

    def data(scratch: Path):
        (scratch / "comparison.json").write_text("{}")
        return None, {}

    def draw(_, folder: Path):
        (folder / "overlay.png").write_bytes(b"figure")

    run_folder.commit(Path("."), data, draw, plots=True, what="comparison")
    run_folder.commit(Path("."), data, draw, plots=False, what="comparison")  # a rerun
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["holiday.png"]
    assert (tmp_path / "holiday.png").read_bytes() == b"user"
    assert not list(tmp_path.parent.glob(f".{tmp_path.name}.fullorder*"))


def test_output_into_the_current_folder_stages_inside_it(tmp_path, monkeypatch):
    """``-o .``: the scratch folder is inside ``.``, never in its parent (not named by the user:
    its entries and time stamp stay as they were), whether the command succeeds or fails; a
    new folder that fails is removed again. Through the CLI too (``campbell -o .``)."""
    from quadmodes.io.staging import staged_output

    here = tmp_path / "here"
    here.mkdir()
    (here / "mine.txt").write_text("mine")
    monkeypatch.chdir(here)
    before = (sorted(p.name for p in tmp_path.iterdir()), tmp_path.stat().st_mtime_ns)

    def parent_untouched():
        assert (sorted(p.name for p in tmp_path.iterdir()), tmp_path.stat().st_mtime_ns) == before

    with staged_output(Path(".")) as scratch:
        assert scratch.parent == here and scratch.name.startswith(".here.partial-")
        parent_untouched()
        (scratch / "campbell.nc").write_text("data")
    parent_untouched()
    assert sorted(p.name for p in here.iterdir()) == sorted(["mine.txt", "campbell.nc",
                                                             outputs.MANIFEST])  # fmt: skip
    with pytest.raises(RuntimeError):
        with staged_output(Path(".")) as scratch:
            (scratch / "campbell.png").write_text("half")
            raise RuntimeError("failed mid-way")
    parent_untouched()
    assert "campbell.png" not in {p.name for p in here.iterdir()}
    with pytest.raises(RuntimeError):
        with staged_output(Path("new")):
            raise RuntimeError("failed mid-way")
    assert not (here / "new").exists()
    cli = _cli("campbell", "kane-beam", "--spin-max", "1 rad/s", "--points", "2", "-o", ".")
    assert cli.exit_code == 0, cli.output
    parent_untouched()
    assert (here / "campbell.nc").is_file() and (here / "mine.txt").read_text() == "mine"
    assert not [p for p in here.iterdir() if ".partial-" in p.name]


def test_staging_never_writes_through_a_link_nor_over_a_users_file(tmp_path):
    from quadmodes.io.staging import staged_output

    real = tmp_path / "real"
    real.mkdir()
    (real / "a.png").write_bytes(b"user")
    link = tmp_path / "link"
    link.symlink_to(real, target_is_directory=True)
    with pytest.raises(outputs.OutputPathError, match="symbolic link"):
        with staged_output(link):
            pass
    with pytest.raises(outputs.OutputPathError, match="did not write"):
        with staged_output(real) as scratch:
            (scratch / "a.png").write_bytes(b"new")
    assert (real / "a.png").read_bytes() == b"user"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]  # no staging left


def test_a_users_partial_folder_is_not_removed(tmp_path):
    folders = run_folder.run_folders(tmp_path, "case")
    folders.partial.mkdir()
    (folders.partial / "thesis.tex").write_text("mine")
    with pytest.raises(outputs.OutputPathError, match="did not write"):
        run_folder.check_folders([folders], resume=False, restart=False)
    assert (folders.partial / "thesis.tex").read_text() == "mine"


def test_output_path_checks(tmp_path, monkeypatch):
    long = tmp_path / ("n" * 240)  # fits alone, not with the staging suffix
    with pytest.raises(outputs.OutputPathError, match="too long"):
        outputs.check_output_path(long)
    outputs.check_output_path(tmp_path / "fine", partial=True)
    monkeypatch.setattr(outputs.shutil, "disk_usage", lambda p: type("U", (), {"free": 1e6})())
    with pytest.raises(outputs.OutputPathError, match="MB free"):
        outputs.check_output_path(tmp_path / "fine", estimate_bytes=5e9)
    assert list(tmp_path.iterdir()) == []  # the checks write nothing


def test_run_refuses_an_output_larger_than_the_free_space(workdir, monkeypatch):  # noqa: F811
    monkeypatch.setattr(outputs.shutil, "disk_usage", lambda p: type("U", (), {"free": 10})())
    line = _one_error_line(_cli("run", str(workdir / "small-run.toml"), "-o",
                                str(workdir / "out"), *SHORT))  # fmt: skip
    assert "-o" in line and "MB free" in line
    assert not (workdir / "out").exists()


# ------------------------------------------------------------- 2. numbers that are wrong say so


def test_time_step_against_spin_and_modes():
    spin = 2 * np.pi * 41.0
    assert check_time_step(0.5e-3, spin, [125.0]) is None  # paper-41hz-coarse: 16 steps a period
    note = check_time_step(1e-3, spin, [164.9])  # 6 steps a period: said
    assert note and "integration.dt" in note and "highest retained mode" in note
    with pytest.raises(CaseError) as exc:
        check_time_step(0.2, spin)  # 8 spin turns a step
    assert exc.value.field == "integration.dt" and "--yes" in str(exc.value)
    assert "spin" in check_time_step(0.2, spin, allow_coarse=True)


def test_coarse_step_is_noted_in_the_results(workdir, small_reduced_model):  # noqa: F811
    run = simulate.apply_overrides(load_run_case(workdir / "small-run.toml"), dt="1 ms",
                                   duration="0.01 s")  # fmt: skip
    result = simulate.simulate(run, _own_model(workdir, small_reduced_model))
    assert any(n.startswith("integration.dt") for n in result.notes)


def _own_model(folder: Path, model):
    case = load_case(folder / "small.toml")
    return dataclasses.replace(model, provenance={"case": case.name, "case_toml": case.to_toml()})


def test_simulate_refuses_another_cases_model(workdir, small_reduced_model):  # noqa: F811
    run = simulate.apply_overrides(load_run_case(workdir / "small-run.toml"), duration="0.002 s")
    other = load_case("sphere")
    foreign = dataclasses.replace(
        small_reduced_model, provenance={"case": other.name, "case_toml": other.to_toml()})
    with pytest.raises(CaseError) as exc:
        simulate.prepare(run, foreign)
    assert exc.value.field == "model" and "sphere" in str(exc.value)
    simulate.prepare(run, _own_model(workdir, small_reduced_model))  # its own: accepted
    import quadmodes as qm

    with pytest.raises(CaseError, match="model"):
        qm.simulate(run, model=foreign)


def test_full_order_resume_is_keyed_by_case_and_model(small_modal_model, small_reduced_model,
                                                      tmp_path):  # fmt: skip
    from test_fullorder import _full_state, _reduced_state

    from quadmodes.fullorder import FullOrderOptions, integrate_full_order

    _, y0 = _reduced_state(small_reduced_model, 10.0, 5.0, amplitude=1e-3)
    x0, v0 = _full_state(small_modal_model, small_reduced_model, y0)
    m, h, path = small_modal_model, 2.5e-4, tmp_path / "ck.npz"

    def run(n_steps, key, **kw):
        return integrate_full_order(m.structure, m.x, x0, v0, (0.0, n_steps * h), h,
                                    FullOrderOptions(model=small_reduced_model, checkpoint=path,
                                                     checkpoint_every=10, checkpoint_key=key, **kw))  # fmt: skip

    run(15, "case A")
    with pytest.raises(ValueError, match="another run case or model"):
        run(20, "case A, edited", resume=True)
    assert run(20, "case A", resume=True).stats["n_steps"] == 20


def test_compare_resume_after_the_case_was_edited_is_refused(tmp_path):
    from types import SimpleNamespace

    from quadmodes.analysis.full_order_runs import checkpoint_key
    from quadmodes.case.editing import edit

    run = load_run_case("paper-41hz-coarse")
    model = SimpleNamespace(provenance={"content_key": "0123"})
    setup = SimpleNamespace(run=run, model=model)
    path = tmp_path / ".fullorder-checkpoint.npz"
    np.savez(path, version=1, step=3, key=checkpoint_key(setup))
    runner.check_checkpoint_key(path, setup)
    longer = SimpleNamespace(run=edit(run, {"integration.duration": "5 s"}, "test"), model=model)
    runner.check_checkpoint_key(path, longer)  # a longer window continues the same run
    edited = SimpleNamespace(run=edit(run, {"initial.cone_angle": "20 deg"}, "test"), model=model)
    with pytest.raises(runner.CheckpointError, match="edited"):
        runner.check_checkpoint_key(path, edited)


def test_compare_resumes_from_a_checkpoint_of_the_earlier_layout(tmp_path, monkeypatch):
    """An old-style ``.OUT.fullorder-checkpoint.npz`` beside OUT is moved into OUT (one note)
    and resumed as any checkpoint: its own key still checks it; without --resume it is not
    silently dropped; where both exist the one inside is used and the old one named."""
    from types import SimpleNamespace

    from quadmodes.analysis.full_order_runs import checkpoint_key

    setup = SimpleNamespace(run=load_run_case("paper-41hz-coarse"),
                            model=SimpleNamespace(provenance={"content_key": "0123"}))  # fmt: skip
    out = tmp_path / "cmp"
    old = tmp_path / ".cmp.fullorder-checkpoint.npz"
    np.savez(old, version=1, step=7, key=checkpoint_key(setup))
    saved = old.read_bytes()
    notes: list[str] = []
    monkeypatch.chdir(tmp_path)
    path = runner.check_checkpoint(runner.checkpoint_beside(Path("cmp")), resume=True,
                                   restart=False, note=notes.append)  # fmt: skip
    assert path == out / ".fullorder-checkpoint.npz" and path.read_bytes() == saved
    assert not old.exists() and len(notes) == 1 and "moved" in notes[0] and str(old) in notes[0]
    runner.check_checkpoint_key(path, setup)  # the same comparison: resumed
    path.unlink()
    np.savez(old, version=1, step=7, key=checkpoint_key(setup))
    monkeypatch.chdir(out)  # compare -o . inside the folder: the old file is in its parent
    with pytest.raises(runner.CheckpointError, match="--resume"):
        runner.check_checkpoint(runner.checkpoint_beside(Path(".")), resume=False, restart=False,
                                note=notes.append)  # fmt: skip
    np.savez(old, version=1, step=9, key=checkpoint_key(setup))  # both exist now
    runner.check_checkpoint(runner.checkpoint_beside(Path(".")), resume=True, restart=False,
                            note=notes.append)  # fmt: skip
    assert "ignored" in notes[-1] and old.is_file()
    assert int(np.load(out / ".fullorder-checkpoint.npz")["step"]) == 7


def _seeded(folder: Path, model) -> tuple:
    case = load_case(folder / "small.toml")
    path = model_cache.cache_path(case, 5)
    return case, path


def test_cache_entry_with_flipped_bits_is_rebuilt(workdir, small_reduced_model):  # noqa: F811
    case, path = _seeded(workdir, small_reduced_model)
    assert model_cache.find_model(case, 5, path)[1] == "hit"
    raw = bytearray(path.read_bytes())
    block = np.ascontiguousarray(small_reduced_model.J0).tobytes()
    at = bytes(raw).find(block)
    assert at >= 0  # the arrays are stored uncompressed
    raw[at + 3] ^= 0x10  # one flipped bit in J0
    path.write_bytes(bytes(raw))
    assert model_cache.find_model(case, 5, path) == (None, "rebuilt")


def test_foreign_cache_entry_is_rebuilt(workdir, small_reduced_model):  # noqa: F811
    case, path = _seeded(workdir, small_reduced_model)
    other = load_case("sphere")
    foreign = dataclasses.replace(small_reduced_model, provenance={
        "case": other.name, "case_toml": other.to_toml(),
        "content_key": model_cache.reduced_key(case, 5)})  # fmt: skip
    artifact.save_reduced_model(foreign, path)  # valid-looking, right key, another body
    assert model_cache.find_model(case, 5, path) == (None, "rebuilt")
    ds = artifact.to_dataset(small_reduced_model)  # a key edited into a file: checksum fails
    ds.attrs["provenance_content_key"] = model_cache.reduced_key(case, 5)
    ds.to_netcdf(path, engine="h5netcdf")
    with pytest.raises(artifact.ArtifactError, match="checksum"):
        artifact.load_reduced_model(path)
    assert model_cache.find_model(case, 5, path) == (None, "rebuilt")


# ------------------------------------------------------------------------------ 5. disk full


def _disk_full(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_disk_full_writing_the_results_keeps_the_checkpoint(workdir, monkeypatch):  # noqa: F811
    from quadmodes.runs import results

    case, out = str(workdir / "small-run.toml"), workdir / "out"
    with monkeypatch.context() as patched:  # (the fixture's own patches stay)
        patched.setattr(results, "write_netcdf", _disk_full)
        line = _one_error_line(_cli("run", case, "-o", str(out), *SHORT))
    assert "disk full" in line and "checkpoint is kept" in line and "--resume" in line
    assert (out / "small-run.partial" / "checkpoint.npz").is_file()
    assert not (out / "small-run").exists()
    assert not [p for p in out.iterdir() if ".partial-" in p.name]  # no staging left
    resumed = _cli("run", case, "-o", str(out), *SHORT, "--resume", "--no-plots")
    assert resumed.exit_code == 0, resumed.output
    assert (out / "small-run" / "results.nc").is_file()


def test_disk_full_writing_a_checkpoint_is_one_line(workdir, monkeypatch):  # noqa: F811
    from quadmodes.runs import run_checkpoint

    monkeypatch.setattr(run_checkpoint, "atomic_path", _disk_full)
    line = _one_error_line(_cli("run", str(workdir / "small-run.toml"), "-o",
                                str(workdir / "out"), *SHORT))  # fmt: skip
    assert "disk full" in line and "checkpoint" in line


def test_netcdf_written_in_one_plain_write(tmp_path, monkeypatch):
    """NetCDF files are serialised in memory, so a full disk fails in Python's own write (a
    clean ENOSPC, temporary file removed), never inside the HDF5 library."""
    import builtins

    import xarray as xr

    ds = xr.Dataset({"a": ("x", np.arange(4.0))})
    outputs.write_netcdf(ds, tmp_path / "ok.nc")
    assert xr.load_dataset(tmp_path / "ok.nc", engine="h5netcdf")["a"].values.tolist() == [0, 1, 2, 3]
    real_open = builtins.open

    class Full:
        def __init__(self, fh):
            self.fh = fh

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(builtins, "open", lambda p, m="r", *a, **k: Full(real_open(p, m, *a, **k))
                        if "w" in m else real_open(p, m, *a, **k))  # fmt: skip
    with pytest.raises(OSError) as exc:
        outputs.write_netcdf(ds, tmp_path / "full.nc")
    monkeypatch.undo()
    assert outputs.is_disk_full(exc.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ok.nc"]


def test_disk_full_storing_a_cache_entry_is_not_an_error(tmp_path, monkeypatch, small_reduced_model):
    """The cache entry cannot be written: the model is returned, the entry is "not saved" and no
    file (temporary or partial) is left."""
    monkeypatch.setattr(artifact, "write_netcdf", _disk_full)
    info: dict = {}
    path = tmp_path / "entry.nc"
    model = model_cache.find_or_build(path, lambda p: (None, "miss"), lambda: small_reduced_model,
                                      model_cache.store_model, info=info)  # fmt: skip
    assert model is small_reduced_model
    assert info["cache"].startswith("not saved") and "No space" in info["cache"]
    assert [p.name for p in tmp_path.iterdir() if not p.name.endswith(".lock")] == []


def test_compare_refuses_a_folder_without_room(tmp_path, monkeypatch):
    """The comparison's output (checkpoint, data, figures) is estimated from the full order's
    set-up and checked against the free space before the runs."""
    from types import SimpleNamespace

    from quadmodes.analysis import full_order_runs

    setup = SimpleNamespace(notes=(), sample_interval=1e-3, structure=SimpleNamespace(n=400))
    assert 5e6 < runner.comparison_output_bytes(setup, 1.0) < 50e6
    monkeypatch.setattr(full_order_runs, "setup_for_run", lambda run, **k: setup)
    monkeypatch.setattr(full_order_runs, "full_order_for_run", lambda *a, **k: pytest.fail("ran"))
    monkeypatch.setattr(outputs.shutil, "disk_usage", lambda p: type("U", (), {"free": 1e5})())
    out = tmp_path / "cmp"
    line = _one_error_line(_cli("compare", "paper-41hz-coarse", "--window", "0.2 s",
                                "--formulation", "rigid", "--no-plots", "-o", str(out)))  # fmt: skip
    assert "-o" in line and "MB free" in line and not out.exists()


def test_api_write_results_has_the_same_guards(workdir, small_reduced_model, tmp_path):  # noqa: F811
    import quadmodes as qm

    run = simulate.apply_overrides(load_run_case(workdir / "small-run.toml"), duration="0.002 s")
    result = qm.simulate(run, model=_own_model(workdir, small_reduced_model),
                         check_deformation=False)  # fmt: skip
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "summary.json").write_text("{}")
    with pytest.raises(outputs.OutputPathError, match="summary.json"):
        qm.write_results(result, theirs, plots=False)
    assert sorted(p.name for p in theirs.iterdir()) == ["summary.json"]
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "elsewhere")
    with pytest.raises(outputs.OutputPathError, match="dangling"):
        qm.write_results(result, link, plots=False)
    qm.write_results(result, tmp_path / "mine", plots=False)
    qm.write_results(result, tmp_path / "mine", plots=False)  # its own files: replaced
    assert {"results.nc", "summary.json"} <= outputs.owned(tmp_path / "mine")

