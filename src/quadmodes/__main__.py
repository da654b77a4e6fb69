"""``python -m quadmodes``: the command line (same as the ``quadmodes`` script)."""

from quadmodes.cli.app import app

if __name__ == "__main__":  # pragma: no cover - entry point
    app(prog_name="quadmodes")
