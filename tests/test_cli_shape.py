"""One command line (issue 25 item 7): one option name per concept (old spellings still work,
with a note), global options after the subcommand, no ``<bool>`` metavar, help reflowed,
``run --axis``, ``campbell --modes/--no-cache``, progress on stderr with ``--json``, shell
completion of case names and choices, ``compare``'s tables whole in 80 columns."""

from __future__ import annotations

import io
import json

import pytest
import typer
from rich.console import Console
from typer.testing import CliRunner

from quadmodes.case import builtin_case_names, builtin_run_case_names, load_run_case
from quadmodes.case.errors import CaseError
from quadmodes.cli.app import app
from quadmodes.cli.shape import reflow, renamed


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))


def _commands() -> dict:
    """Every command of the app by its path ("run", "cache list", ...)."""
    group = typer.main.get_command(app)
    found = {}
    for name, command in group.commands.items():
        if hasattr(command, "commands"):
            found.update({f"{name} {n}": c for n, c in command.commands.items()})
        else:
            found[name] = command
    return found


def _options(command) -> set[str]:
    return {o for p in command.params for o in (*p.opts, *p.secondary_opts)}


def test_one_option_name_per_concept():
    commands = _commands()
    for name, command in commands.items():
        names = _options(command)
        assert not names & {"--formulations", "--spins"}, name
        assert {"--quiet", "-q", "--verbose", "-v"} <= names, name  # global options anywhere
    for name in ("run", "campbell", "compare", "rotating"):
        assert "--formulation" in _options(commands[name]), name
    for name in ("run", "compare", "rotating"):
        assert "--spin-rate" in _options(commands[name]), name
    for name in ("run", "campbell", "rotating", "sweep"):
        assert "--axis" in _options(commands[name]), name
    for name in ("campbell", "rotating", "reduce", "run", "compare"):
        assert {"--modes", "--no-cache"} <= _options(commands[name]), name
    for name in ("campbell", "rotating", "sweep"):
        assert "--units" in _options(commands[name]), name


def test_old_spellings_are_renamed_before_parsing():
    names = {"--formulation", "--spin-rate", "-o"}
    args, used = renamed(["--spins", "0 Hz", "--formulations=Q,L", "-o", "x", "--", "--spins"],
                         names)  # fmt: skip
    assert args == ["--spin-rate", "0 Hz", "--formulation=Q,L", "-o", "x", "--", "--spins"]
    assert used == [("--spins", "--spin-rate"), ("--formulations", "--formulation")]
    # a command that has the old spelling as an option of its own keeps it
    assert renamed(["--spins", "1"], {"--spins", "--spin-rate"})[1] == []


def test_deprecated_aliases_still_work_with_a_note(runner, tmp_path):
    result = runner.invoke(app, ["compare", "paper-41hz-coarse", "--formulations", "bogus",
                                 "-o", str(tmp_path / "c")])  # fmt: skip
    assert result.exit_code == 2
    assert "--formulations is deprecated; use --formulation" in result.stderr
    assert "--formulation: unknown bogus" in result.stderr
    result = runner.invoke(app, ["rotating", "--spins=a,b"])
    assert result.exit_code == 2 and "--spin-rate" in result.stderr
    assert "--spins is deprecated" in result.stderr
    quiet = runner.invoke(app, ["rotating", "--spins=a,b", "--quiet"])
    assert "deprecated" not in quiet.stderr


def test_global_options_after_the_subcommand(runner):
    args = ["reduce", "kane-beam", "--modes", "4", "--json"]
    built = runner.invoke(app, [*args, "--quiet"])
    assert built.exit_code == 0 and built.stderr == ""  # no progress after --quiet
    assert json.loads(built.stdout)["n_modes"] == 4
    again = runner.invoke(app, [*args, "-v"])
    assert again.exit_code == 0 and "cache hit" in again.stderr
    before = runner.invoke(app, ["-q", *args])  # before the subcommand as always
    assert before.exit_code == 0 and before.stderr == ""


def test_flags_show_no_bool_metavar_and_help_is_reflowed(runner):
    for path, command in _commands().items():
        help_text = runner.invoke(app, [*path.split(), "--help"], env={"COLUMNS": "200"}).stdout
        assert "<bool>" not in help_text, path
        # one line per paragraph: the help wraps at the terminal's width, not at source lines
        assert all("\n" not in p for p in (command.help or "").split("\n\n")), path
    top = runner.invoke(app, ["--help"], env={"COLUMNS": "80"}).stdout
    assert "<bool>" not in top
    assert reflow("one\n two\n\n* a\n* b") == "one two\n\n* a\n* b"


def test_run_axis_sets_the_spin_axis_and_is_refused_for_a_spinup():
    from quadmodes.runs.simulate import apply_overrides

    assert apply_overrides(load_run_case("paper-41hz-coarse"), axis="major").initial.spin_axis == "major"
    with pytest.raises(CaseError, match="--axis"):
        apply_overrides(load_run_case("kane-spinup"), axis="z")


def test_campbell_modes_sets_the_model_size(runner):
    """kane-beam computes 6 modes (3 planes × 2); --modes 4 keeps 4, so 4 branches."""
    args = ["campbell", "kane-beam", "--spin-max", "6 rad/s", "--points", "3", "--json"]
    result = runner.invoke(app, [*args, "--modes", "4", "--no-cache"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert len(payload["branches"]) == 4
    assert "100 %" in result.stderr  # progress on stderr with --json
    bad = runner.invoke(app, [*args, "--modes", "0"])
    assert bad.exit_code == 2 and "--modes" in bad.stderr


def test_progress_on_stderr_with_json(runner, tmp_path):
    """Every long command shows its stages on stderr whatever stdout carries."""
    for args in (["modes", "kane-beam", "--json"], ["reduce", "kane-beam", "--modes", "4", "--json"],
                 ["rotating", "paper-membrane-coarse", "--spin-rate", "0 Hz", "--modes", "3",
                  "--formulation", "Q", "--json"]):  # fmt: skip
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        json.loads(result.stdout)
        assert "100 %" in result.stderr, args


def _complete(runner, words: str) -> list[str]:
    env = {"_QUADMODES_COMPLETE": "complete_bash", "COMP_WORDS": words,
           "COMP_CWORD": str(len(words.split()) - (0 if words.endswith(" ") else 1))}  # fmt: skip
    result = runner.invoke(app, [], env=env, prog_name="quadmodes")
    assert result.exit_code == 0, result.output
    return result.stdout.split()


def test_completion_offers_case_names_and_choices(runner, tmp_path, monkeypatch):
    assert set(_complete(runner, "quadmodes campbell ")) >= set(builtin_case_names())
    assert set(_complete(runner, "quadmodes run ")) >= set(builtin_run_case_names(spinup=None))
    assert _complete(runner, "quadmodes run paper-0.5") == ["paper-0.5hz", "paper-0.5hz-large"]
    assert _complete(runner, "quadmodes campbell --units r") == ["rpm", "rad/s"]
    assert _complete(runner, "quadmodes run --axis m") == ["minor", "major"]
    assert "rigid" in _complete(runner, "quadmodes run --formulation ")
    assert _complete(runner, "quadmodes validate --suite f") == ["fe", "full-order"]
    assert _complete(runner, "quadmodes run paper-0.5hz --animate-frame ") == ["inertial", "body"]
    assert "paper-41hz" in _complete(runner, "quadmodes show-case paper-41")  # run cases too
    listed = _complete(runner, "quadmodes compare paper-41hz --formulation Q,")
    assert "Q,L" in listed and "Q,Q" not in listed
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my-body.toml").write_text("")
    (tmp_path / "notes.txt").write_text("")
    assert _complete(runner, "quadmodes modes my") == ["my-body.toml"]


def test_compare_tables_keep_their_numbers_in_80_columns(monkeypatch):
    from quadmodes.cli import compare_command as cc

    row = {"envelope_error": 1.234e-3, "cone_angle_error": 2.345e-4,
           "cone_angle_change_error": 3.456e-2, "spin_rate_error": 4.567e-7,
           "cone_growth_ratio": 0.987654, "dissipated_power_ratio": 1.0123,
           "spin_rate_change_ratio": 0.912, "wall_s": 12.34, "speedup": 456.7}  # fmt: skip
    payload = {"full_order": {"wall_s": 5634.5},
               "formulations": {name: row for name in ("rigid", "L", "P", "Q", "Q4")}}  # fmt: skip

    class Plan:
        window_s = 1.0

        class run:  # noqa: N801
            name = "paper-41hz-coarse"

    buffer = io.StringIO()
    console = Console(file=buffer, width=80, force_terminal=False, color_system=None)
    for table in cc._comparison_tables(payload, Plan):
        console.print(table)
    text = buffer.getvalue()
    assert "…" not in text and max(len(line) for line in text.splitlines()) <= 80
    for cell in ("1.23e-03", "2.35e-04", "3.46e-02", "4.57e-07", "×0.988", "×1.01", "×0.912",
                 "12.3", "457", "5.63e+03"):  # fmt: skip
        assert cell in text, cell
