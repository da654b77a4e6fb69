"""The ``validate`` command: run the validation checks and print (or write) their tables."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from quadmodes.cli.common import (
    JsonFlag,
    ProgressCallback,
    UserError,
    check_output_file,
    err,
    fail,
    flag,
    one_line_errors,
    output_file_in,
    output_path,
    progress_bars,
    user_errors,
    write_file_in,
)
from quadmodes.cli.completion import choices
from quadmodes.io.atomic import write_text

VALIDATION_SUITES = ("fe", "reduced", "full-order")

#: Section titles of the suites after the finite-element tables.
_TITLES = {"reduced": "Reduced dynamics", "full-order": "Full-order reference"}


def _checks_to_run(chosen: list[str], quick: bool) -> list[tuple[str, str, Callable[[], list]]]:
    """(suite, check name, check) of the chosen suites; with ``quick`` only the fast checks
    of the dynamics suites (all of the finite-element suite)."""
    from quadmodes.validation import dynamics_checks as vdyn
    from quadmodes.validation import fe_checks as validation

    checks: dict[str, dict] = {
        "fe": validation.FE_CHECKS,
        "reduced": vdyn.ROM_CHECKS,
        "full-order": vdyn.FULL_ORDER_CHECKS,
    }
    return [
        (k, name, fn)
        for k in chosen
        for name, fn in checks[k].items()
        if not quick or name in vdyn.FAST or k == "fe"
    ]


def _run_checks(
    todo: list[tuple[str, str, Callable[[], list]]],
    results: dict[str, list],
    progress: ProgressCallback,
) -> None:
    """Run each check, appending its rows to ``results[suite]``; a check that raises counts as
    one failed row "<name>: ran to completion" carrying the error."""
    from quadmodes.validation.report import Row

    for i, (k, name, fn) in enumerate(todo):
        progress("validation", i / max(len(todo), 1))
        err.print(f"running {k}/{name} ...")
        try:
            results[k] += fn()
        except (*user_errors(), ImportError, RuntimeError) as exc:
            err.print(f"[bold red]check {escape(name)} failed to run:[/] {escape(str(exc))}")
            results[k].append(
                Row(f"{name}: ran to completion", 0.0, 1.0, 0.0, absolute=True,
                               source=" ".join(str(exc).split())[:200])
            )  # fmt: skip
    progress("validation", 1.0)


ValidateWrite = Annotated[
    Path | None, typer.Option("--write", help="write the tables to this Markdown file")
]
ValidateOutput = output_path("folder to write the tables in (validation.md)")
SuiteOption = Annotated[
    list[str] | None,
    typer.Option(
        "--suite", help="fe | reduced | full-order (repeat to combine; default: all three)",
        autocompletion=choices("fe", "reduced", "full-order"),
    ),
]
ConvergenceFlag = flag("--convergence/--no-convergence", "paper-model mesh convergence")
QuickFlag = flag("--quick", "only the fast checks (the subset the tests run)")


def _row_json(r) -> dict:
    """One validation row as JSON (floats; the error relative unless ``absolute``)."""
    def num(x):
        return float(x) if math.isfinite(float(x)) else None

    return {"check": r.check, "measured": num(r.measured), "reference": num(r.reference),
            "unit": r.unit, "error": num(r.error), "absolute": r.absolute,
            "tolerance": num(r.tolerance), "report_only": r.report_only,
            "passed": r.passed, "source": r.source}  # fmt: skip


def validate(
    write: ValidateWrite = None,
    suite: SuiteOption = None,
    convergence: ConvergenceFlag = True,
    quick: QuickFlag = False,
    output_dir: ValidateOutput = None,
    as_json: JsonFlag = False,
) -> None:
    """Run the validation suite and print (or write) the measured tables with pass/fail.

    The whole suite (finite elements, reduced dynamics, full order) takes tens of minutes on two
    cores; --quick runs the subset the tests also run."""
    from quadmodes.validation import fe_checks as validation
    from quadmodes.validation.report import validation_markdown

    chosen = list(suite or VALIDATION_SUITES)
    bad = [s for s in chosen if s not in VALIDATION_SUITES]
    if bad:
        fail(UserError(f"--suite: unknown {', '.join(bad)}; choose from fe, reduced, full-order"))
    with one_line_errors():
        check_output_file(write, "--write")  # before tens of minutes of checks
        if output_dir is not None and write is not None:
            raise UserError("-o: give either -o DIR (writes DIR/validation.md) or --write FILE")
        write = output_file_in(output_dir, "validation.md") or write
    todo = _checks_to_run(chosen, quick)
    results: dict[str, list] = {k: [] for k in chosen}
    with progress_bars() as progress:
        _run_checks(todo, results, progress)
        conv = validation.mesh_convergence() if convergence and "fe" in chosen and not quick else []
    sections = {_TITLES[k]: results[k] for k in chosen if k != "fe"}
    text = validation_markdown(results.get("fe", []), conv, sections)
    if as_json:  # {suite: [row, ...]} with every row's measured and reference in its unit
        sys.stdout.write(json.dumps({k: [_row_json(r) for r in rows] for k, rows in
                                     results.items()}, indent=2) + "\n")  # fmt: skip
    elif write is None:
        sys.stdout.write(text)
    else:
        write_file_in(write, lambda path: write_text(path, text))
        err.print(f"written {write}")
    failed = [r.check for rows in results.values() for r in rows if not r.passed]
    if failed:
        err.print(f"[bold red]{len(failed)} checks failed:[/] {', '.join(failed)}")
        raise typer.Exit(code=1)
