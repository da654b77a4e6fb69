"""The case-file reference and the JSON Schema for editors, generated from the case tables.

Every field of a model case (:class:`~quadmodes.case.model_case.Case`) and of a run case
(:class:`~quadmodes.case.run_case.RunCase`) with its meaning (:mod:`quadmodes.case.field_docs`),
dimension and units, default, allowed values and an example (the field's own
:class:`~quadmodes.case.meta.FieldMeta`). :func:`reference_markdown` is ``docs/case-reference.md``,
:func:`json_schema` ``docs/case-schema.json`` (draft-04, read by TOML language servers such as
taplo / Even Better TOML); ``tests/test_case_reference.py`` fails when the checked-in files
differ from what the code generates.

Regenerate both with ``python -m quadmodes.case.reference`` (from the repository root; ``--check``
only compares); ``quadmodes schema`` prints the schema (``--markdown``: the reference).
"""

from __future__ import annotations

import json
import sys
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel
from pydantic.fields import FieldInfo

from quadmodes.case.field_docs import FIELD_DOCS, TABLE_DOCS
from quadmodes.case.meta import field_meta, nested_model, toml_value
from quadmodes.case.model_case import Case
from quadmodes.case.run_case import RunCase
from quadmodes.case.units import DIMENSIONS, format_quantity, si_unit

#: The generated files, relative to the repository root.
MARKDOWN_PATH = Path("docs/case-reference.md")
SCHEMA_PATH = Path("docs/case-schema.json")


@dataclass(frozen=True)
class FieldRow:
    """One field as the reference shows it: TOML key, value type, unit, default, allowed values,
    example (TOML text) and meaning."""

    key: str
    kind: str
    unit: str
    default: str
    allowed: str
    example: str
    meaning: str


def tables(model: type[BaseModel], header: str = "") -> list[tuple[str, type[BaseModel]]]:
    """``(TOML header, table class)`` of ``model`` and every table below it, depth first: ``""``
    for the top level, ``[geometry]``, ``[[end_body]]`` (a list of tables) …"""
    out = [(header, model)]
    for name, info in model.model_fields.items():
        inner = nested_model(info.annotation)
        if inner is None or (model is RunCase and name == "model"):
            continue
        many = typing.get_origin(info.annotation) is tuple
        out += tables(inner, f"[[{name}]]" if many else f"[{name}]")
    return out


def _literal_options(annotation: Any) -> tuple[str, ...]:
    if typing.get_origin(annotation) is Literal:
        return typing.get_args(annotation)
    return tuple(o for arg in typing.get_args(annotation) for o in _literal_options(arg))


def _default(model: type[BaseModel], name: str, info: FieldInfo) -> str:
    if info.is_required():
        return "required"
    if info.default_factory is not None:
        return "(the table's defaults)"
    value = info.default
    if value is None or value == ():
        return "none (optional)"
    meta = field_meta(model, name)
    if meta.dimension is not None and meta.dimension != "dimensionless":
        return f'"{format_quantity(value, meta.display or si_unit(meta.dimension))}"'
    return toml_value(value)


#: Units a quantity of each dimension is commonly given in (any unit pint reads is accepted).
_COMMON_UNITS = {
    "length": "m, cm, mm, in, ft",
    "pressure": "Pa, kPa, psi, Mpsi, GPa",
    "density": "kg/m^3, g/cm^3, lb/in^3",
    "mass": "kg, g, lb",
    "inertia": "kg*m^2, g*cm^2",
    "angular_rate": "rad/s, Hz, rpm",
    "angle": "rad, deg",
    "time": "s, ms",
    "area": "m^2, mm^2, in^2",
    "second_moment": "m^4, mm^4, in^4",
}


def _unit(model: type[BaseModel], name: str) -> str:
    meta = field_meta(model, name)
    if meta.dimension is None:
        return ""
    if meta.dimension == "dimensionless":
        return "dimensionless (a number, or e.g. \"2 %\")"
    common = _COMMON_UNITS.get(meta.dimension, si_unit(meta.dimension))
    return f"{DIMENSIONS[meta.dimension].noun[2:].strip()} (SI {si_unit(meta.dimension)}; {common})"


def _kind(model: type[BaseModel], name: str, info: FieldInfo) -> str:
    inner = nested_model(info.annotation)
    if inner is not None and not (model is RunCase and name == "model"):
        many = typing.get_origin(info.annotation) is tuple
        return f"list of tables [[{name}]]" if many else f"table [{name}]"
    meta = field_meta(model, name)
    if _literal_options(info.annotation):
        return "whole number or text" if meta.minimum is None and name == "modes" else "text"
    if meta.dimension == "dimensionless":
        return "number"
    if meta.dimension is not None:
        return "quantity (text: number and unit)"
    if meta.minimum is not None:
        return "whole number"
    return {"spin_axis": "text or 3 numbers", "model": "text or table [model]"}.get(name, "text")


def field_rows(model: type[BaseModel]) -> list[FieldRow]:
    """The rows of table ``model``, in field order."""
    rows = []
    for name, info in model.model_fields.items():
        meta = field_meta(model, name)
        rows.append(FieldRow(
            key=name,
            kind=_kind(model, name, info),
            unit=_unit(model, name),
            default=_default(model, name, info),
            allowed=meta.allowed or "",
            example=meta.example if nested_model(info.annotation) is None or name == "model" else "",
            meaning=FIELD_DOCS.get(model.__name__, {}).get(name, ""),
        ))  # fmt: skip
    return rows


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _table_markdown(header: str, model: type[BaseModel]) -> list[str]:
    title = header or "top level"
    lines = [f"### `{title}`" if header else "### top level", "", TABLE_DOCS[model.__name__], ""]
    lines += ["| key | meaning | type | unit | default | allowed | example |",
              "|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in field_rows(model):
        example = f"`{r.key} = {r.example}`" if r.example else ""
        cells = (f"`{r.key}`", r.meaning, r.kind, r.unit, r.default, r.allowed, example)
        lines.append("| " + " | ".join(_cell(c) for c in cells) + " |")
    return lines + [""]


_INTRO = """# Case-file reference

<!-- Generated by `python -m quadmodes.case.reference` from the case tables
(src/quadmodes/case/); do not edit by hand: tests/test_case_reference.py fails on a difference. -->

Every field of a **model case** (the structure: `kind = "membrane"`, `"beam"` or `"spacecraft"`)
and of a **run case** (`kind = "run"`: a model, its reduced model, initial state and time
integration). A case file is TOML. Quantities are text with a unit, e.g. `"0.3 psi"`, `"60 in"`,
`"5 Hz"`, `"2 %"` (any unit pint reads; a bare number is refused where a unit is needed);
dimensionless numbers may be bare. An unknown key is refused with the closest known one.
`quadmodes show-case NAME` prints a built-in case to start from; `quadmodes show-case FILE`
checks a file and prints it back as written. Editors: see "Editor support" at the end
(`docs/case-schema.json`). A walk-through from a drawing to the answers: docs/your-own-body.md.

Which tables a model case has: a membrane has `[geometry]`, `[mesh]`, `[material]` and
`[pressure]` (a `disc` has `[spin]` instead of `[pressure]`), any `[[end_body]]` tables, and
`[modes]`; a beam has `[beam]` and `[modes]`; a spacecraft has `[hub]`, `[[boom]]` and `[modes]`.
Which fields a shape needs (`geometry.shape`): sphere-cone: `length`, `front_cap_diameter`,
`rear_cap_diameter`; sphere: `diameter`; capsule and flat-cylinder: `length`, `diameter`; disc:
`diameter`; file: `file` (and `file_unit`). An end body gives its inertia either as
`inertia_axial` and `inertia_transverse` or as `radius` and `height`.
"""

_EDITORS = """## Editor support (JSON Schema)

`docs/case-schema.json` (also printed by `quadmodes schema`) describes both kinds of case file
for editors that read a JSON Schema for TOML: completion of keys, the allowed values, the
meaning on hover, and unknown keys flagged.

* **taplo** (CLI and language server) and **Even Better TOML** (VS Code, which runs taplo): put
  a schema directive on the first line of a case file,
  `#:schema ./case-schema.json` (a path relative to the file, or a `file://` / `https://` URL),
  or associate the schema with your case files once in a `.taplo.toml` at the project root:

  ```toml
  [[rule]]
  include = ["cases/**/*.toml"]
  schema = { path = "docs/case-schema.json" }
  ```

  In VS Code the setting `"evenBetterToml.schema.associations"` does the same
  (`{".*/cases/.*\\\\.toml": "file:///path/to/case-schema.json"}`). Check a file from the shell
  with `taplo lint --schema file://$PWD/docs/case-schema.json my-case.toml`.
* The schema checks types, allowed choices and whole numbers; the rules that involve several
  fields (which fields a shape needs, an end body smaller than its cap, units of quantities)
  are checked by quadmodes itself: `quadmodes show-case my-case.toml` validates a file and
  names the field and the fix on a problem.
"""


def reference_markdown() -> str:
    """The text of ``docs/case-reference.md``."""
    lines = [_INTRO, "## Model case", ""]
    for header, model in tables(Case):
        lines += _table_markdown(header, model)
    lines += ["## Run case", "",
              "`model` may also be the model case itself: a `[model]` table with the model "
              "case's fields and its tables below it (`[model.geometry]`, "
              "`[[model.end_body]]` …), as the run's own output folder records it.", ""]  # fmt: skip
    for header, model in tables(RunCase):
        lines += _table_markdown(header, model)
    return "\n".join(lines) + "\n" + _EDITORS


def _field_schema(model: type[BaseModel], name: str, info: FieldInfo) -> dict[str, Any]:
    meta = field_meta(model, name)
    inner = nested_model(info.annotation)
    if model is RunCase and name == "model":
        body: dict[str, Any] = {"anyOf": [{"type": "string"}, {"$ref": "#/definitions/Case"}]}
    elif inner is not None:
        ref = {"$ref": f"#/definitions/{inner.__name__}"}
        body = {"type": "array", "items": ref} if typing.get_origin(info.annotation) is tuple else ref
    elif options := _literal_options(info.annotation):
        body = {"enum": list(options)}
        if name == "modes":
            body = {"anyOf": [{"type": "integer", "minimum": 1}, body]}
    elif meta.dimension == "dimensionless":
        body = {"type": ["number", "string"]}
    elif meta.dimension is not None:
        body = {"type": "string"}
    elif meta.minimum is not None:
        body = {"type": "integer", "minimum": meta.minimum}
    elif name == "spin_axis":
        three = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}
        body = {"anyOf": [{"type": "string"}, three]}
    else:
        body = {"type": "string"}
    row = next(r for r in field_rows(model) if r.key == name)
    notes = [row.meaning] + [f"{k}: {v}" for k, v in (("unit", row.unit), ("default", row.default),
                                                        ("allowed", row.allowed)) if v]  # fmt: skip
    body["description"] = ". ".join(n for n in notes if n)
    if meta.example and inner is None:
        body["examples"] = [json.loads(meta.example) if meta.example[0] in '"-0123456789'
                            else meta.example]  # fmt: skip
    return body


def _table_schema(model: type[BaseModel]) -> dict[str, Any]:
    fields = model.model_fields
    schema = {
        "type": "object",
        "description": TABLE_DOCS[model.__name__],
        "properties": {name: _field_schema(model, name, info) for name, info in fields.items()},
        "required": [name for name, info in fields.items() if info.is_required()],
        "additionalProperties": False,
    }
    if not schema["required"]:  # draft-04 wants a non-empty list, or none
        del schema["required"]
    return schema


def json_schema() -> dict[str, Any]:
    """The JSON Schema of a case file, a model case or a run case (their ``kind`` tells them
    apart). Draft-04 keywords only (``examples`` aside, which older readers ignore): taplo's
    validator is documented to read draft 4."""
    definitions = {m.__name__: _table_schema(m) for _, m in tables(Case) + tables(RunCase)}
    return {
        "$schema": "http://json-schema.org/draft-04/schema#",
        "title": "quadmodes case file",
        "description": "A quadmodes model case (kind = membrane, beam, spacecraft) or run case "
        "(kind = run); docs/case-reference.md",
        "type": "object",
        "anyOf": [{"$ref": "#/definitions/Case"}, {"$ref": "#/definitions/RunCase"}],
        "definitions": definitions,
    }


def schema_text() -> str:
    """The text of ``docs/case-schema.json``."""
    return json.dumps(json_schema(), indent=2, ensure_ascii=False) + "\n"


def generated_files() -> dict[Path, str]:
    """``{path relative to the repository root: text}`` of the generated files."""
    return {MARKDOWN_PATH: reference_markdown(), SCHEMA_PATH: schema_text()}


def main(argv: list[str] | None = None) -> int:
    """Write the generated files under the current folder (``--check``: compare only; exit 1
    and name the stale files when they differ)."""
    args = sys.argv[1:] if argv is None else argv
    stale = []
    for path, text in generated_files().items():
        current = path.read_text(encoding="utf-8") if path.is_file() else None
        if current == text:
            continue
        stale.append(str(path))
        if "--check" not in args:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
    if "--check" in args and stale:
        print(f"out of date: {', '.join(stale)}; run python -m quadmodes.case.reference")
        return 1
    print("up to date" if not stale else f"wrote {', '.join(stale)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
