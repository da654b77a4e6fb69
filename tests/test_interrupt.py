"""Runs that survive: ``run`` and ``compare`` killed (SIGKILL), interrupted (SIGINT, SIGTERM)
and resumed, reruns into a used folder, stale figures and left-over staging folders.

The interrupted commands run in a subprocess through a small driver that makes them wait at a
chosen point (a chunk starting at or after ``QM_BLOCK_AT`` s, the figures, the data files, or
right after the first full-order checkpoint) until the test signals them; the test waits for
the checkpoint or a marker file to appear (generous timeout), never for a fixed time, so no
outcome depends on the speed of the machine. Fast: the small capsule of conftest, 0.1 s runs.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
import types
from pathlib import Path

import numpy as np
import pytest
from test_run import workdir  # noqa: F401  (fixture)
from typer.testing import CliRunner

import quadmodes
from quadmodes.cli.app import app
from quadmodes.runs import results as res

DRIVER = r'''
import os, signal, sys, time
from pathlib import Path

signal.signal(signal.SIGINT, signal.default_int_handler)  # even if started with SIGINT ignored

def wait(marker):
    if marker:
        Path(marker).write_text("waiting")
    while True:
        time.sleep(0.05)

marker = os.environ.get("QM_MARKER", "")
block_at = float(os.environ.get("QM_BLOCK_AT", "inf"))
from quadmodes.rom import integrators
real_integrate = integrators.integrate

def integrate(system, y0, t_span, *args, **kwargs):
    if t_span[0] >= block_at:
        wait(marker)
    return real_integrate(system, y0, t_span, *args, **kwargs)

integrators.integrate = integrate
if os.environ.get("QM_BLOCK_PLOTS"):
    import quadmodes.io.plots as plots
    plots.write_plots = lambda ds, directory: wait(marker)
if os.environ.get("QM_BLOCK_DATA"):
    import quadmodes.runs.results as results
    real_write = results.write_dataset
    def write_dataset(ds, path):
        real_write(ds, path)
        wait(marker)
    results.write_dataset = write_dataset
if os.environ.get("QM_FULL_ORDER_EVERY"):
    import quadmodes.cli.compare_command as cc
    cc.FULL_ORDER_CHECKPOINT_EVERY = int(os.environ["QM_FULL_ORDER_EVERY"])
if os.environ.get("QM_BLOCK_FULL_ORDER"):
    import quadmodes.fullorder.integrator as fi
    real_checkpoint = fi.write_checkpoint
    def write_checkpoint(path, data):
        real_checkpoint(path, data)
        wait(marker)
    fi.write_checkpoint = write_checkpoint
from quadmodes.cli.app import app
sys.argv = ["quadmodes", *sys.argv[1:]]
app()
'''

TIMEOUT_S = 300.0  # generous: only reached if something is broken
RUN = ["--duration", "0.1 s", "--no-plots", "--checkpoint-every", "0"]


def _start(tmp: Path, args: list[str], **env: str) -> subprocess.Popen:
    """The driver running ``quadmodes <args>`` in ``tmp`` (stdout/stderr to files)."""
    driver = tmp / "driver.py"
    driver.write_text(DRIVER, encoding="utf-8")
    src = str(Path(quadmodes.__file__).resolve().parents[1])
    full_env = {**os.environ, "PYTHONPATH": src, "MPLBACKEND": "Agg", "COLUMNS": "200", **env}
    return subprocess.Popen(
        [sys.executable, str(driver), *args], cwd=tmp, env=full_env,
        stdout=open(tmp / "stdout.txt", "w"), stderr=open(tmp / "stderr.txt", "w"),
    )  # fmt: skip


def _wait_for(path: Path, proc: subprocess.Popen) -> None:
    """Poll until ``path`` exists (the process must still be running)."""
    deadline = time.monotonic() + TIMEOUT_S
    while not path.exists():
        assert proc.poll() is None, (path, (path.parent.parent / "stderr.txt").read_text())
        assert time.monotonic() < deadline, f"{path} did not appear"
        time.sleep(0.05)


def _finish(proc: subprocess.Popen, sig: int) -> int:
    proc.send_signal(sig)
    return proc.wait(timeout=TIMEOUT_S)


def _cli(*args: str):
    return CliRunner().invoke(app, list(args))


def _same_numbers(path_a: Path, path_b: Path) -> None:
    """Every data variable and coordinate of two results.nc files bit for bit, and the step
    counters."""
    a, b = res.load_results(path_a), res.load_results(path_b)
    assert set(a.data_vars) == set(b.data_vars)
    for name in [*a.data_vars, "time"]:
        assert np.array_equal(a[name].values, b[name].values, equal_nan=True), name  # NaN: not reached
    for key in ("n_steps", "n_rhs", "n_newton", "n_jac", "complete", "status"):
        assert a.attrs[key] == b.attrs[key], key


@pytest.fixture
def reference(workdir):  # noqa: F811
    """An uninterrupted run of the small case (0.1 s) in ``ref/``."""
    result = _cli("run", str(workdir / "small-run.toml"), "-o", str(workdir / "ref"), *RUN)
    assert result.exit_code == 0, result.output
    return workdir / "ref" / "small-run" / "results.nc"


def test_killed_run_resumes_to_the_uninterrupted_numbers(workdir, reference):  # noqa: F811
    case = str(workdir / "small-run.toml")
    partial = workdir / "out" / "small-run.partial"
    proc = _start(workdir, ["run", case, "-o", "out", *RUN], QM_BLOCK_AT="0.04")
    _wait_for(partial / "checkpoint.npz", proc)
    assert _finish(proc, signal.SIGKILL) == -signal.SIGKILL
    assert not (workdir / "out" / "small-run").exists()
    # a rerun without --resume does not discard the checkpoint
    refused = _cli("run", case, "-o", str(workdir / "out"), *RUN)
    assert refused.exit_code == 2
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "--resume" in lines[0] and "--restart" in lines[0]
    assert (partial / "checkpoint.npz").is_file()
    resumed = _cli("run", case, "-o", str(workdir / "out"), *RUN, "--resume")
    assert resumed.exit_code == 0, resumed.output
    assert "resuming from" in resumed.stderr
    _same_numbers(workdir / "out" / "small-run" / "results.nc", reference)
    assert not partial.exists()


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupted_rerun_keeps_the_complete_result(workdir, reference, sig, code):  # noqa: F811
    case = str(workdir / "small-run.toml")
    out = workdir / "out"
    first = _cli("run", case, "-o", str(out), "--duration", "0.02 s", "--no-plots")
    assert first.exit_code == 0, first.output
    complete = (out / "small-run" / "results.nc").read_bytes()
    proc = _start(workdir, ["run", case, "-o", "out", *RUN], QM_BLOCK_AT="0.04")
    partial = out / "small-run.partial"
    _wait_for(partial / "checkpoint.npz", proc)
    assert _finish(proc, sig) == code
    stderr = (workdir / "stderr.txt").read_text()
    assert "stopped" in stderr and "--resume" in stderr and "Traceback" not in stderr
    assert (out / "small-run" / "results.nc").read_bytes() == complete  # never replaced
    ds = res.load_results(partial / "results.nc")
    assert ds.attrs["complete"] == 0 and "interrupted" in ds.attrs["incomplete_reason"]
    assert 0 < ds["time"].values[-1] < 0.1
    assert json.loads((partial / "summary.json").read_text())["status"] == "incomplete"
    # resuming with other settings is refused in one line naming them
    other = _cli("run", case, "-o", str(out), *RUN, "--dt", "0.1 ms", "--resume")
    assert other.exit_code == 2
    lines = other.stderr.strip().splitlines()
    assert len(lines) == 1 and "integration.dt" in lines[0] and "--restart" in lines[0]
    resumed = _cli("run", case, "-o", str(out), *RUN, "--resume")
    assert resumed.exit_code == 0, resumed.output
    _same_numbers(out / "small-run" / "results.nc", reference)
    assert not partial.exists()


def test_interrupt_while_drawing_keeps_the_data(workdir):  # noqa: F811
    marker = workdir / "plotting"
    args = ["run", str(workdir / "small-run.toml"), "-o", "out", "--duration", "0.02 s"]
    proc = _start(workdir, args, QM_BLOCK_PLOTS="1", QM_MARKER=str(marker))
    _wait_for(marker, proc)
    assert _finish(proc, signal.SIGINT) == 130
    stderr = (workdir / "stderr.txt").read_text()
    assert "the data are saved" in stderr and "Traceback" not in stderr
    folder = workdir / "out" / "small-run"
    assert res.load_results(folder / "results.nc").attrs["complete"] == 1
    assert json.loads((folder / "summary.json").read_text())["status"] == "complete"
    assert not (workdir / "out" / "small-run.partial").exists()


def test_killed_while_writing_leaves_the_old_result_and_no_staging(workdir):  # noqa: F811
    case = str(workdir / "small-run.toml")
    out = workdir / "out"
    first = _cli("run", case, "-o", str(out), "--duration", "0.02 s", "--no-plots")
    assert first.exit_code == 0, first.output
    complete = (out / "small-run" / "results.nc").read_bytes()
    marker = workdir / "writing"
    proc = _start(workdir, ["run", case, "-o", "out", *RUN], QM_BLOCK_DATA="1",
                  QM_MARKER=str(marker))  # fmt: skip
    _wait_for(marker, proc)
    assert _finish(proc, signal.SIGKILL) == -signal.SIGKILL
    staging = list(out.glob(".small-run.partial-*"))
    assert staging and (out / "small-run" / "results.nc").read_bytes() == complete
    # the killed run's integration had ended: its final checkpoint is resumed, not repeated
    resumed = _cli("run", case, "-o", str(out), *RUN, "--resume")
    assert resumed.exit_code == 0, resumed.output
    assert "left-over staging folder" in resumed.stderr
    assert not list(out.glob(".small-run.partial*")) and not (out / "small-run.partial").exists()
    ds = res.load_results(out / "small-run" / "results.nc")
    assert ds.attrs["complete"] == 1 and ds["time"].values[-1] == pytest.approx(0.1)


def test_no_plots_rerun_removes_the_old_figures_and_lists_other_files(workdir):  # noqa: F811
    case = str(workdir / "small-run.toml")
    out = workdir / "out"
    assert _cli("run", case, "-o", str(out), "--duration", "0.02 s").exit_code == 0
    folder = out / "small-run"
    figures = sorted(p.name for p in folder.glob("*.png"))
    assert figures
    (folder / "notes.txt").write_text("mine")
    again = _cli("run", case, "-o", str(out), "--duration", "0.03 s", "--no-plots")
    assert again.exit_code == 0, again.output
    assert not list(folder.glob("*.png"))
    assert "removed" in again.stderr and figures[0] in again.stderr
    assert "notes.txt" in again.stderr and (folder / "notes.txt").read_text() == "mine"
    ds = res.load_results(folder / "results.nc")
    assert ds["time"].values[-1] == pytest.approx(0.03)


def test_damaged_checkpoint_is_one_line(workdir):  # noqa: F811
    partial = workdir / "out" / "small-run.partial"
    partial.mkdir(parents=True)
    (partial / "checkpoint.npz").write_bytes(b"not a checkpoint")
    result = _cli("run", str(workdir / "small-run.toml"), "-o", str(workdir / "out"), "--resume")
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "damaged" in lines[0] and "--restart" in lines[0]
    restarted = _cli("run", str(workdir / "small-run.toml"), "-o", str(workdir / "out"),
                     "--restart", *RUN)  # fmt: skip
    assert restarted.exit_code == 0, restarted.output
    assert "discarded" in restarted.stderr and not partial.exists()


# ----------------------------------------------------------------------------- compare


COMPARE = ["--window", "0.012 s", "--full-dt", "0.2 ms", "--formulations", "rigid,Q",
           "--no-plots", "--json"]  # fmt: skip
NOT_COMPARED = ("wall", "speedup", "steps_per_s")


def _assert_same_payload(a, b, path: str = "") -> None:
    """Two comparison payloads equal (floats to 1e-9 relative), wall times aside."""
    if isinstance(a, dict):
        assert set(a) == set(b), path
        for key in a:
            if not any(word in key for word in NOT_COMPARED):
                _assert_same_payload(a[key], b[key], f"{path}.{key}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_same_payload(x, y, f"{path}[{i}]")
    elif isinstance(a, float) and isinstance(b, float):
        assert math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-300), path
    else:
        assert a == b, path


def test_compare_interrupted_resumes_to_the_uninterrupted_numbers(workdir, monkeypatch):  # noqa: F811
    import quadmodes.cli.compare_command as cc

    case = str(workdir / "small-run.toml")
    checkpoint = workdir / "cmp" / ".fullorder-checkpoint.npz"  # inside -o
    marker = workdir / "checkpointed"
    proc = _start(workdir, ["compare", case, "-o", "cmp", *COMPARE], QM_FULL_ORDER_EVERY="20",
                  QM_BLOCK_FULL_ORDER="1", QM_MARKER=str(marker))  # fmt: skip
    _wait_for(marker, proc)
    assert _finish(proc, signal.SIGINT) == 130
    stderr = (workdir / "stderr.txt").read_text()
    assert "--resume" in stderr and str(checkpoint) in stderr and "Traceback" not in stderr
    assert checkpoint.is_file() and [p.name for p in (workdir / "cmp").iterdir()] == [checkpoint.name]
    monkeypatch.setattr(cc, "FULL_ORDER_CHECKPOINT_EVERY", 20)
    refused = _cli("compare", case, "-o", str(workdir / "cmp"), *COMPARE)
    assert refused.exit_code == 2 and checkpoint.is_file()
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "--restart" in lines[0]
    resumed = _cli("compare", case, "-o", str(workdir / "cmp"), *COMPARE, "--resume")
    assert resumed.exit_code == 0, resumed.output
    assert not checkpoint.exists()
    whole = _cli("compare", case, "-o", str(workdir / "whole"), *COMPARE)
    assert whole.exit_code == 0, whole.output
    a, b = json.loads(resumed.stdout), json.loads(whole.stdout)
    assert a["full_order"]["complete"] and a["full_order"]["steps"] == 60
    _assert_same_payload(a, b)


def _fake_full_order(monkeypatch, solution) -> None:
    from quadmodes.analysis import full_order_runs

    monkeypatch.setattr(full_order_runs, "setup_for_run", lambda run, **k: types.SimpleNamespace(notes=()))
    monkeypatch.setattr(full_order_runs, "estimate_for_run", lambda *a, **k: {"estimate_s": 1.0})
    monkeypatch.setattr(full_order_runs, "full_order_for_run", lambda r, dt, **k: solution)


@pytest.mark.parametrize(
    ("message", "code", "needle"),
    [("interrupted at t = 0.1 s", 130, "nothing to resume"),
     ("diverged at t = 0.1 s", 2, "nothing is scored")],
)  # fmt: skip
def test_compare_never_scores_an_incomplete_reference(tmp_path, monkeypatch, message, code,
                                                      needle):  # fmt: skip
    _fake_full_order(monkeypatch, types.SimpleNamespace(status=1, message=message))
    out = tmp_path / "cmp"
    result = _cli("compare", "paper-41hz-coarse", "--window", "0.2 s", "--formulations", "rigid", "--no-plots",
                  "-o", str(out))  # fmt: skip
    assert result.exit_code == code, result.output
    assert needle in result.stderr and not out.exists()


def test_compare_restart_discards_the_checkpoint(tmp_path, monkeypatch):
    _fake_full_order(monkeypatch, types.SimpleNamespace(status=1, message="interrupted at t = 0"))
    checkpoint = tmp_path / "cmp" / ".fullorder-checkpoint.npz"  # inside -o
    checkpoint.parent.mkdir()
    checkpoint.write_bytes(b"old")
    args = ["compare", "paper-41hz-coarse", "--window", "0.2 s", "--formulations", "rigid", "--no-plots",
            "-o", str(tmp_path / "cmp")]  # fmt: skip
    both = _cli(*args, "--resume", "--restart")
    assert both.exit_code == 2 and checkpoint.read_bytes() == b"old"
    damaged = _cli(*args, "--resume")
    assert damaged.exit_code == 2 and checkpoint.read_bytes() == b"old"
    lines = damaged.stderr.strip().splitlines()
    assert len(lines) == 1 and "damaged" in lines[0] and "--restart" in lines[0]
    restarted = _cli(*args, "--restart")  # then "interrupted" before any new checkpoint
    assert restarted.exit_code == 130 and "discarded" in restarted.stderr
    assert not checkpoint.exists()


def test_compare_draws_after_the_data_and_a_no_plots_rerun_removes_figures(tmp_path, monkeypatch):
    from test_compare import _reduced_as_reference

    from quadmodes.analysis import full_order_runs

    monkeypatch.setattr(full_order_runs, "setup_for_run", lambda run, **k: types.SimpleNamespace(notes=()))
    monkeypatch.setattr(full_order_runs, "estimate_for_run", lambda *a, **k: {"estimate_s": 1.0})
    monkeypatch.setattr(full_order_runs, "full_order_for_run", lambda r, dt, **k: _reduced_as_reference(r, dt))
    out = tmp_path / "cmp"
    args = ["compare", "paper-41hz-coarse", "--window", "0.05 s", "--formulations", "Q", "-o", str(out)]
    assert _cli(*args).exit_code == 0
    figures = sorted(p.name for p in out.glob("*.png"))
    assert figures and (out / "comparison.json").is_file()
    again = _cli(*args, "--no-plots")
    assert again.exit_code == 0, again.output
    assert not list(out.glob("*.png")) and figures[0] in again.stderr
    assert (out / "comparison.nc").is_file()
    # Ctrl-C while drawing: exit 130, the data are kept
    from quadmodes.analysis import compare as cm

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(cm, "plot_comparison", interrupted)
    stopped = _cli(*args)
    assert stopped.exit_code == 130 and "the data are saved" in stopped.stderr
    assert json.loads((out / "comparison.json").read_text())["full_order"]["complete"]
