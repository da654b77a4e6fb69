"""Command-line interface (typer)."""
import typer

app = typer.Typer(no_args_is_help=True, add_completion=False)


@app.command()
def version() -> None:
    """Print the package version."""
    from quadmodes import __version__

    print(__version__)
