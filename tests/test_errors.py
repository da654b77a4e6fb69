"""One exception type for every problem a user can fix (issue 24 item 7): the API raises a
``QuadmodesError`` with the message the CLI prints after ``error:``; usage errors are one line;
numpy integers are whole numbers; a cache entry that cannot be written is said, not hidden."""

from __future__ import annotations

import errno
import logging
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import quadmodes as qm
from quadmodes.cli.app import app
from quadmodes.models import cache

ERROR_TYPES = [
    "quadmodes.case.errors.CaseError",
    "quadmodes.case.units.QuantityError",
    "quadmodes.limits.LimitError",
    "quadmodes.io.outputs.OutputPathError",
    "quadmodes.io.outputs.DiskFullError",
    "quadmodes.structure.prestress.ConvergenceError",
    "quadmodes.structure.calibrate.CalibrationError",
    "quadmodes.rom.artifact.ArtifactError",
    "quadmodes.sweeps.params.SweepError",
    "quadmodes.runs.run_folder.FolderError",
    "quadmodes.runs.run_checkpoint.CheckpointError",
    "quadmodes.analysis.comparison_run.CheckpointError",
    "quadmodes.fullorder.newton.FullOrderNewtonError",
]


@pytest.mark.parametrize("dotted", ERROR_TYPES)
def test_every_user_error_is_a_quadmodes_error(dotted):
    import importlib

    module, name = dotted.rsplit(".", 1)
    cls = getattr(importlib.import_module(module), name)
    assert issubclass(cls, qm.QuadmodesError)


@pytest.fixture()
def runner():
    return CliRunner()


def _cli_error(runner, args) -> str:
    result = runner.invoke(app, args, prog_name="quadmodes")
    assert result.exit_code == 2, (result.exit_code, result.output)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ")
    return lines[0].removeprefix("error: ")


BAD_FIELDS = {
    "a pressure in metres": ("[pressure]", 'value = "3 m"'),
    "a negative thickness": ("[material]", 'thickness = "-5 mil"'),
    "a misspelt key": ("[pressure]", 'valeu = "0.3 psi"'),
}


@pytest.mark.parametrize("label", list(BAD_FIELDS))
def test_the_api_raises_the_clis_message(runner, tmp_path, label):
    """The same bad case file: the CLI's one line equals ``str`` of the API's exception."""
    table, line = BAD_FIELDS[label]
    text = qm.load("paper-membrane-coarse").to_toml()
    assert table in text
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(f"{table}\n", f"{table}\n{line}\n", 1), encoding="utf-8")
    shown = _cli_error(runner, ["show-case", str(path)])
    with pytest.raises(qm.QuadmodesError) as raised:
        qm.load(path)
    assert " ".join(str(raised.value).split()) == shown


def test_arguments_that_do_not_fit_are_input_errors():
    with pytest.raises(qm.InputError, match=r"got int 5; give a built-in case name"):
        qm.model_case(5)
    with pytest.raises(qm.InputError, match=r"simulate\(\).*'foo'.*its parameters are: run,"):
        qm.simulate("paper-41hz-coarse", foo=1)
    with pytest.raises(qm.InputError, match="load: got NoneType"):
        qm.load(None)
    assert issubclass(qm.InputError, ValueError)  # older `except ValueError` code still works


def test_numpy_whole_numbers_are_whole_numbers_and_fractions_are_refused():
    run = qm.run_case("paper-41hz-coarse", reduced={"modes": np.int64(7)})
    assert run.reduced.modes == 7 and type(run.reduced.modes) is int
    body = qm.model_case("paper-membrane-coarse", modes={"count": np.int32(12)},
                         pressure={"value": np.float32(2000.0)})  # fmt: skip
    assert body.modes.count == 12 and body.pressure.value == pytest.approx(2000.0)
    for bad in (7.5, np.float64(7.5), True, "7"):
        with pytest.raises(qm.CaseError, match="reduced.modes.*whole number"):
            qm.run_case("paper-41hz-coarse", reduced={"modes": bad})


@pytest.mark.parametrize(("args", "listed"), [
    (["run", "--bogus"], "quadmodes run --help lists the options"),
    (["campbell", "--points", "abc"], "quadmodes campbell --help lists the options"),
    (["no-such-command"], "quadmodes --help lists the commands"),
])  # fmt: skip
def test_usage_errors_are_one_line(runner, args, listed):
    assert _cli_error(runner, args).endswith(f"({listed})")


def test_bare_quadmodes_still_prints_the_help(runner):
    result = runner.invoke(app, [])
    assert "Usage" in result.output and "run" in result.output


def test_a_cache_entry_that_cannot_be_written_is_said(tmp_path, caplog):
    """A read-only cache does not stop the run, but the user is told the model will be built
    again (a warning, shown without --verbose), and no "saved" line claims otherwise."""

    def store(value, path: Path) -> None:
        raise OSError(errno.EROFS, "Read-only file system")

    info: dict = {}
    with caplog.at_level(logging.INFO, logger="quadmodes"):
        value = cache.find_or_build(tmp_path / "entry.nc", lambda p: (None, "miss"), lambda: 42,
                                    store, info=info, what="reduced model of x")  # fmt: skip
    assert value == 42 and info["cache"] == "not saved (Read-only file system)"
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "QUADMODES_CACHE" in warnings[0].getMessage()
    assert not any("built in" in r.getMessage() for r in caplog.records)  # no "saved" claim


def test_a_rerun_that_replaces_an_earlier_result_says_so(tmp_path):
    """quadmodes replaces its own earlier files (listed in the folder's manifest), with a note."""
    from quadmodes.io.staging import staged_output

    notes: list[str] = []
    for text in ("first", "second"):
        with staged_output(tmp_path / "out", notes.append) as scratch:
            (scratch / "results.nc").write_text(text)
    assert (tmp_path / "out" / "results.nc").read_text() == "second"
    assert [n for n in notes if "replaced" in n] == [
        f"note: replaced the earlier results.nc in {tmp_path / 'out'}"
    ]
