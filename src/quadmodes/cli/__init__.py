"""The ``quadmodes`` command line."""

from quadmodes.cli.app import app

__all__ = ["app"]
