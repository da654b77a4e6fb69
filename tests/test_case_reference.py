"""The case-file reference and JSON Schema: generated from the case tables, checked in, in step
with the code; every field documented; the schema accepts every built-in case and refuses what
the case loader refuses by type; show-case checks run-case files and keeps the user's text."""

import json
import re
import tomllib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from quadmodes.case import builtin_case_names, builtin_case_text, builtin_run_case_names
from quadmodes.case.field_docs import FIELD_DOCS, TABLE_DOCS
from quadmodes.case.model_case import Case
from quadmodes.case.reference import field_rows, generated_files, json_schema, main, tables
from quadmodes.case.run_case import RunCase
from quadmodes.cli.app import app

ROOT = Path(__file__).resolve().parents[1]
ALL_TABLES = {m for _, m in tables(Case) + tables(RunCase)}


def test_checked_in_reference_and_schema_match_the_code():
    for path, text in generated_files().items():
        current = (ROOT / path).read_text(encoding="utf-8")
        assert current == text, f"{path} is stale: run python -m quadmodes.case.reference"


def test_check_mode_names_a_stale_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["--check"]) == 1
    assert "docs/case-reference.md" in capsys.readouterr().out
    assert main([]) == 0 and main(["--check"]) == 0  # written, then up to date


def test_every_field_of_every_table_has_a_meaning_and_no_entry_is_stale():
    assert {m.__name__ for m in ALL_TABLES} == set(TABLE_DOCS) == set(FIELD_DOCS)
    for model in ALL_TABLES:
        assert set(FIELD_DOCS[model.__name__]) == set(model.model_fields), model.__name__
        for row in field_rows(model):
            assert row.meaning and row.default, (model.__name__, row.key)
            assert row.example or row.kind.startswith(("table", "list of tables")), row.key


def _valid(value, schema, definitions) -> bool:
    """A minimal draft-04 check of the keywords the case schema uses."""
    if "$ref" in schema:
        return _valid(value, definitions[schema["$ref"].rsplit("/", 1)[1]], definitions)
    if "anyOf" in schema:
        return any(_valid(value, s, definitions) for s in schema["anyOf"])
    if "enum" in schema and value not in schema["enum"]:
        return False
    kinds = schema.get("type")
    kinds = [kinds] if isinstance(kinds, str) else kinds or []
    python = {"string": str, "number": (int, float), "integer": int, "array": list, "object": dict}
    if kinds and not any(isinstance(value, python[k]) and not isinstance(value, bool) for k in kinds):
        return False
    if "minimum" in schema and value < schema["minimum"]:
        return False
    if isinstance(value, list) and "items" in schema:
        if not schema.get("minItems", 0) <= len(value) <= schema.get("maxItems", len(value)):
            return False
        return all(_valid(v, schema["items"], definitions) for v in value)
    if isinstance(value, dict) and "properties" in schema:
        if any(k not in schema["properties"] for k in value) or any(
            k not in value for k in schema.get("required", ())
        ):
            return False
        return all(_valid(v, schema["properties"][k], definitions) for k, v in value.items())
    return True


@pytest.mark.parametrize("name", builtin_case_names() + builtin_run_case_names(None))
def test_schema_accepts_every_builtin_case(name):
    schema = json_schema()
    keywords = set(re.findall(r'"(\$?[A-Za-z]+)":', json.dumps(schema)))
    later = {"const", "if", "then", "else", "contains", "propertyNames", "$id"}  # after draft-04
    assert not keywords & later
    assert _valid(tomllib.loads(builtin_case_text(name)), schema, schema["definitions"])


@pytest.mark.parametrize(
    ("edit", "why"),
    [
        (lambda d: d["geometry"].update(lenght="60 in"), "unknown key"),
        (lambda d: d["geometry"].update(shape="cube"), "not a shape"),
        (lambda d: d["modes"].update(count=2.5), "not a whole number"),
        (lambda d: d["modes"].update(count=0), "below the least"),
        (lambda d: d["material"].pop("thickness"), "required"),
        (lambda d: d.update(kind="run"), "a run case without a model"),
    ],
)
def test_schema_refuses_what_the_loader_refuses(edit, why):
    schema = json_schema()
    data = tomllib.loads(builtin_case_text("paper-membrane"))
    edit(data)
    assert not _valid(data, schema, schema["definitions"]), why


def test_schema_command_prints_the_checked_in_schema():
    result = CliRunner().invoke(app, ["schema"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout) == json.loads((ROOT / "docs/case-schema.json").read_text())
    markdown = CliRunner().invoke(app, ["schema", "--markdown"])
    assert markdown.stdout == (ROOT / "docs/case-reference.md").read_text(encoding="utf-8")


MODEL = """# my body: comments and units stay as written
name = "mine"
kind = "membrane"

[geometry]
shape = "sphere"
diameter = "10 in"   # the drawing's unit

[mesh]
edge_length = "2 in"

[material]
density = "0.0335 lb/in^3"
youngs_modulus = "0.05 Mpsi"
poisson_ratio = 0.3
thickness = "0.0045 in"

[pressure]
value = "0.3 psi"
"""

RUN = """name = "mine-1hz"
kind = "run"
model = "mine.toml"   # next to this file

[initial]
spin_rate = "1 Hz"

[integration]
dt = "1 ms"
duration = "1 s"
"""


def test_show_case_checks_run_case_files_and_prints_them_as_written(tmp_path):
    (tmp_path / "mine.toml").write_text(MODEL)
    (tmp_path / "run.toml").write_text(RUN)
    runner = CliRunner()
    for name, text in (("mine.toml", MODEL), ("run.toml", RUN)):
        result = runner.invoke(app, ["show-case", str(tmp_path / name)])
        assert result.exit_code == 0, result.output
        assert result.stdout == text  # units, comments and order kept
    (tmp_path / "mine.toml").write_text(MODEL.replace('"10 in"', '"10 kg"'))
    result = runner.invoke(app, ["show-case", str(tmp_path / "run.toml")])
    assert result.exit_code == 2 and "geometry.diameter" in result.output  # its model checked


def test_the_walk_through_cases_load_and_declare_the_schema():
    """docs/your-own-body.md's case files: written from the reference, valid, and pointing
    taplo at the schema with a header directive."""
    from quadmodes.case import load_case, load_run_case

    folder = ROOT / "docs" / "examples"
    run = load_run_case(folder / "flat-cylinder-5hz.toml")
    assert run.model_case() == load_case(folder / "flat-cylinder.toml")
    for path in folder.glob("*.toml"):
        assert path.read_text().startswith("#:schema ../case-schema.json\n")
