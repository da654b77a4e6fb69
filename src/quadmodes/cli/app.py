"""Command-line interface: ``quadmodes cases | show-case | modes | calibrate | reduce | run |
campbell | compare | rotating | cache``.

Errors a user can fix (bad case, bad units, failed convergence) print one line on stderr and exit
with status 2; results are written to a scratch folder and moved into place only when complete.

This module holds the typer ``app`` and registers the commands, in the order ``--help`` lists
them; the commands live in ``model_commands``, ``validate_command``, ``run_commands``,
``analysis_commands``, ``compare_command`` and ``cache_commands``, what they share in ``common``.
"""

from __future__ import annotations

import typer

from quadmodes import __version__
from quadmodes.cli.analysis_commands import campbell, rotating_command
from quadmodes.cli.cache_commands import cache_app
from quadmodes.cli.common import out
from quadmodes.cli.compare_command import compare_command
from quadmodes.cli.model_commands import calibrate, cases, modes, reduce_command, show_case
from quadmodes.cli.run_commands import run_command
from quadmodes.cli.sweep_command import sweep_command
from quadmodes.cli.validate_command import validate

app = typer.Typer(
    no_args_is_help=True,
    add_completion=False,
    help="Spinning flexible bodies by the method of quadratic modes.",
)


@app.command()
def version() -> None:
    """Print the package version."""
    out.print(__version__)


app.command()(cases)
app.command("show-case")(show_case)
app.command()(modes)
app.command()(calibrate)
app.command()(validate)
app.command("reduce")(reduce_command)
app.command("run")(run_command)
app.command()(campbell)
app.command("compare")(compare_command)
app.command("rotating")(rotating_command)
app.add_typer(cache_app, name="cache")
app.command("sweep")(sweep_command)


def main() -> None:  # pragma: no cover - console entry point
    app()
