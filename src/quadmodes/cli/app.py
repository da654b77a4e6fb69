"""Command-line interface: ``quadmodes cases | show-case | modes | calibrate | reduce | run |
campbell | compare | rotating | cache``.

Errors a user can fix (bad case, bad units, failed convergence) print one line on stderr and exit
with status 2; results are written to a scratch folder and moved into place only when complete.

This module holds the typer ``app`` and registers the commands, in the order ``--help`` lists
them; the commands live in ``model_commands``, ``validate_command``, ``run_commands``,
``analysis_commands``, ``compare_command`` and ``cache_commands``, what they share in ``common``.
"""

from __future__ import annotations

from typing import Annotated

import typer

from quadmodes._version import __version__
from quadmodes.cli import verbosity
from quadmodes.cli.analysis_commands import campbell, rotating_command
from quadmodes.cli.cache_commands import cache_app
from quadmodes.cli.common import out
from quadmodes.cli.compare_command import compare_command
from quadmodes.cli.model_commands import calibrate, cases, modes, reduce_command, schema, show_case
from quadmodes.cli.run_commands import run_command
from quadmodes.cli.shape import QuadmodesCommand
from quadmodes.cli.sweep_command import sweep_command
from quadmodes.cli.usage import OneLineUsageGroup
from quadmodes.cli.validate_command import validate

app = typer.Typer(
    cls=OneLineUsageGroup,  # QuadmodesGroup with usage errors in one line, exit 2
    no_args_is_help=True,
    add_completion=True,  # --install-completion, --show-completion (bash, zsh, fish, PowerShell)
)


def _print_version(value: bool) -> None:
    if value:
        out.print(f"quadmodes {__version__}", highlight=False)
        raise typer.Exit()


@app.callback()
def global_options(
    version: Annotated[
        bool,
        typer.Option("--version", callback=_print_version, is_eager=True,
                     help="print the version and exit"),
    ] = False,
    quiet: Annotated[
        bool, typer.Option("--quiet", "-q", help="errors and warnings only: no progress, no notes")
    ] = False,
    verbose: Annotated[
        bool, typer.Option("--verbose", "-v", help="also log cache hits and stage timings")
    ] = False,
) -> None:
    """Spinning flexible bodies by the method of quadratic modes.

    -o/--output DIR is the folder a command writes into (run: DIR/<case>/).
    Dimensional options take quantities with units ("0.25 ms", "41 Hz").
    Results go to stdout (--json: one JSON object), progress and notes to stderr.
    """
    verbosity.configure(quiet=quiet, verbose=verbose)


@app.command(cls=QuadmodesCommand)
def version() -> None:
    """Print the package version."""
    out.print(__version__)


app.command(cls=QuadmodesCommand)(cases)
app.command("show-case", cls=QuadmodesCommand)(show_case)
app.command(cls=QuadmodesCommand)(schema)
app.command(cls=QuadmodesCommand)(modes)
app.command(cls=QuadmodesCommand)(calibrate)
app.command(cls=QuadmodesCommand)(validate)
app.command("reduce", cls=QuadmodesCommand)(reduce_command)
app.command("run", cls=QuadmodesCommand)(run_command)
app.command(cls=QuadmodesCommand)(campbell)
app.command("compare", cls=QuadmodesCommand)(compare_command)
app.command("rotating", cls=QuadmodesCommand)(rotating_command)
app.add_typer(cache_app, name="cache")
app.command("sweep", cls=QuadmodesCommand)(sweep_command)


def main() -> None:  # pragma: no cover - console entry point
    app()
