"""The library does what the command line does: ``qm.write_results`` writes the files of
``quadmodes run`` (and ``qm.simulate`` runs its deformation check, so the numbers agree), and
``qm.compare`` never scores an incomplete full order, says it is incomplete and resumes it.
Fast: the small capsule of conftest (``test_run.workdir``)."""

from __future__ import annotations

import json
import types

import numpy as np
import pytest
from test_interrupt import _assert_same_payload
from test_run import workdir  # noqa: F401  (fixture)
from typer.testing import CliRunner

import quadmodes as qm
from quadmodes.cli.app import app
from quadmodes.runs import results as res

#: Attributes of results.nc that say when and how fast it was written, not what.
VOLATILE = ("wall_s", "history", "date_created")


def _same(a, b) -> bool:
    """Equal attribute values (NaN equals NaN)."""
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    return np.array_equal(a, b, equal_nan=True)


def _files(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_write_results_writes_the_files_and_numbers_of_the_run_command(workdir):  # noqa: F811
    case = workdir / "small-run.toml"
    cli = CliRunner().invoke(app, ["run", str(case), "-o", str(workdir / "cli"), "--json"])
    assert cli.exit_code == 0, cli.output
    result = qm.simulate(case)
    summary = qm.write_results(result, workdir / "api")
    by_cli, by_api = workdir / "cli" / "small-run", workdir / "api"
    assert _files(by_api) == _files(by_cli)
    assert {"results.nc", "summary.json", "report.html"} <= set(_files(by_api))
    assert any(name.endswith(".png") for name in _files(by_api))
    # the deformation check ran in both (0.2 in of initial bending), with the same outcome
    a = json.loads((by_cli / "summary.json").read_text())
    b = json.loads((by_api / "summary.json").read_text())
    assert b == summary and a["validity"]["initial_deformation_energy_condensed_J"] > 0
    assert {k: v for k, v in a.items() if k != "wall_s"} == {
        k: v for k, v in b.items() if k != "wall_s"}  # fmt: skip
    ds_a, ds_b = res.load_results(by_cli / "results.nc"), res.load_results(by_api / "results.nc")
    assert set(ds_a.variables) == set(ds_b.variables)
    for name in ds_a.variables:
        floats = ds_a[name].dtype.kind == "f"  # NaN: a cone angle not reached
        assert np.array_equal(ds_a[name].values, ds_b[name].values, equal_nan=floats), name
        assert ds_a[name].attrs == ds_b[name].attrs, name
    differ = {k for k in ds_a.attrs if not _same(ds_a.attrs[k], ds_b.attrs.get(k))}
    assert set(ds_a.attrs) == set(ds_b.attrs) and differ <= set(VOLATILE), differ


def test_simulate_runs_the_deformation_check_unless_told_not_to(workdir):  # noqa: F811
    run = qm.load(workdir / "small-run.toml")
    short = qm.changed(run, integration={"duration": "2 ms"})
    checked = qm.simulate(short).validity
    assert checked.deformation_energy_condensed > 0 and checked.valid
    assert np.isnan(qm.simulate(short, check_deformation=False).validity.deformation_error)


COMPARE = dict(formulations=("rigid", "Q"), full_order_dt="0.2 ms", checkpoint_every=20)


def test_compare_reports_an_interrupted_full_order_incomplete_and_resumes_it(workdir):  # noqa: F811
    """Ctrl-C in the full order (a progress callback raising KeyboardInterrupt after its first
    checkpoint): nothing is scored, the error says it is incomplete and names the checkpoint;
    resuming from it gives the uninterrupted comparison (60 steps) and its files."""
    run = qm.load(workdir / "small-run.toml")
    checkpoint = workdir / "full-order.npz"

    def interrupt_after_a_checkpoint(stage: str, fraction: float) -> None:
        if stage == "full order" and checkpoint.is_file():
            raise KeyboardInterrupt

    with pytest.raises(qm.FullOrderIncomplete) as stopped:
        qm.compare(run, "0.012 s", checkpoint=checkpoint, progress=interrupt_after_a_checkpoint,
                   **COMPARE)  # fmt: skip
    assert stopped.value.interrupted and stopped.value.checkpoint == checkpoint
    assert "stopped early (interrupted at t = 0.004 s)" in str(stopped.value)
    assert "nothing is scored" in str(stopped.value) and checkpoint.is_file()
    out = workdir / "cmp"
    resumed = qm.compare(run, "0.012 s", checkpoint=checkpoint, resume=True, output_dir=out,
                         **COMPARE)  # fmt: skip
    assert resumed.full.complete and resumed.full.stats["n_steps"] == 60
    assert not checkpoint.exists()  # removed once the comparison's files are written
    assert {"comparison.nc", "comparison.json", "comparison.csv", "report.html"} <= set(_files(out))
    # the factorisation is renewed after every checkpoint: the same checkpoints, the same numbers
    whole = qm.compare(run, "0.012 s", checkpoint=workdir / "whole.npz", **COMPARE)
    assert not (workdir / "whole.npz").exists()
    _assert_same_payload(resumed.as_json(), whole.as_json())
    assert json.loads((out / "comparison.json").read_text()) == resumed.as_json()


def test_compare_never_scores_a_full_order_that_stopped_early(monkeypatch):
    from quadmodes.analysis import full_order_runs as fullorder

    stopped = types.SimpleNamespace(status=1, message="diverged at t = 0.1 s")
    monkeypatch.setattr(fullorder, "setup_for_run", lambda run, **k: types.SimpleNamespace(notes=()))
    monkeypatch.setattr(fullorder, "full_order_for_run", lambda r, dt, **k: stopped)
    with pytest.raises(qm.FullOrderIncomplete, match="nothing is scored") as info:
        qm.compare("paper-41hz-coarse", "0.2 s", formulations=("rigid",))
    assert not info.value.interrupted and info.value.reason == "diverged at t = 0.1 s"


def test_compare_resume_needs_a_checkpoint(tmp_path):
    with pytest.raises(ValueError) as info:  # one line, as every user error
        qm.compare("paper-41hz-coarse", "0.2 s", checkpoint=tmp_path / "none.npz", resume=True)
    assert "no checkpoint" in str(info.value)


def test_modal_model_writes_the_files_of_the_modes_command(workdir):  # noqa: F811
    case = workdir / "small.toml"
    cli = CliRunner().invoke(app, ["modes", str(case), "-o", str(workdir / "cli"), "--json"])
    assert cli.exit_code == 0, cli.output
    model = qm.modal_model(case, output_dir=workdir / "api")
    assert _files(workdir / "api") == _files(workdir / "cli")
    assert {"mesh.vtu", "modes", "modes.json", "modes.png"} <= set(_files(workdir / "api"))
    summary = json.loads((workdir / "api" / "modes.json").read_text())
    assert summary == json.loads(cli.stdout) == json.loads(json.dumps(qm.modes_summary(model)))


def test_a_compare_resolves_auto_modes_once(tmp_path, monkeypatch):
    """``reduced.modes = "auto"`` (paper-41hz-coarse) is resolved from the spectrum once per
    comparison: for the reduced runs and the full order alike (full order faked by the Q run)."""
    from test_compare import _reduced_as_reference

    from quadmodes.analysis import full_order_runs as fullorder
    from quadmodes.runs import mode_choice, simulate

    calls = []
    real = mode_choice.covering_spectrum

    def counted(*args, **kwargs):
        calls.append(args)
        return real(*args, **kwargs)

    def setup_for_run(run, **kwargs):  # the real one prepares the reduced run first
        simulate.prepare(run)
        return types.SimpleNamespace(notes=())

    monkeypatch.setattr(mode_choice, "covering_spectrum", counted)
    monkeypatch.setattr(fullorder, "setup_for_run", setup_for_run)
    monkeypatch.setattr(fullorder, "estimate_for_run", lambda *a, **k: {"estimate_s": 1.0})
    monkeypatch.setattr(fullorder, "full_order_for_run", lambda r, dt, **k: _reduced_as_reference(r, dt))
    args = ["compare", "paper-41hz-coarse", "--window", "0.05 s", "--formulations", "rigid,Q",
            "--no-plots", "--json", "-o", str(tmp_path / "cmp")]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert len(calls) == 1
    assert isinstance(json.loads(result.stdout)["reduced_model"]["modes"], int)
    calls.clear()
    qm.compare("paper-41hz-coarse", "0.05 s", formulations=("Q",))
    assert len(calls) == 1


def test_simulate_checkpoints_and_resumes_bit_for_bit(workdir):  # noqa: F811
    """As ``run --resume``: Ctrl-C (a progress callback raising KeyboardInterrupt after the
    first checkpoint) stops with the partial result; resuming gives the uninterrupted numbers."""
    from quadmodes.runs.chunked import Interrupted

    run = qm.load(workdir / "small-run.toml")
    checkpoint = workdir / "run.npz"

    def interrupt_after_a_checkpoint(stage: str, fraction: float) -> None:
        if stage == run.name and checkpoint.is_file():
            raise KeyboardInterrupt

    with pytest.raises(Interrupted) as stopped:
        qm.simulate(run, checkpoint=checkpoint, checkpoint_every=0,
                    progress=interrupt_after_a_checkpoint)  # fmt: skip
    assert stopped.value.saved and not stopped.value.partial.complete and checkpoint.is_file()
    resumed = qm.simulate(run, checkpoint=checkpoint, resume=True, checkpoint_every=0)
    assert resumed.complete and not checkpoint.exists()
    whole = qm.simulate(run)
    assert np.array_equal(resumed.solution.t, whole.solution.t)
    assert np.array_equal(resumed.solution.y, whole.solution.y)
    assert np.array_equal(resumed.diagnostics.E_d, whole.diagnostics.E_d)
