"""How much the command line says: ``--quiet`` (errors and warnings only: no progress, no
notes), the default, ``--verbose`` (also the ``quadmodes`` library's INFO log lines: cache
hits, stage timings). Log lines go to stderr through rich, results stay on stdout."""

from __future__ import annotations

import logging
import sys

from rich.logging import RichHandler

from quadmodes.cli.consoles import err

#: The chosen level: -1 quiet, 0 normal, 1 verbose.
_LEVEL = {"value": 0}
_HANDLER: dict[str, logging.Handler] = {}


class _CurrentStderr(logging.StreamHandler):
    """Plain log lines to whatever ``sys.stderr`` is when a line is written (a handler bound
    to the stream of configure time writes into a closed file once a caller, e.g. a test
    runner capturing output, has swapped and closed it: "--- Logging error ---")."""

    @property
    def stream(self):  # noqa: D102 (the logging.StreamHandler attribute)
        return sys.stderr

    @stream.setter
    def stream(self, _value) -> None:
        pass


def configure(quiet: bool = False, verbose: bool = False) -> None:
    """Set the verbosity and configure the ``quadmodes`` logger (WARNING by default, INFO with
    ``verbose``, ERROR with ``quiet``; one handler on stderr: rich on a terminal, plain lines
    otherwise)."""
    _LEVEL["value"] = -1 if quiet else (1 if verbose else 0)
    logger = logging.getLogger("quadmodes")
    old = _HANDLER.pop("handler", None)
    if old is not None:
        logger.removeHandler(old)
    if err.is_terminal:
        handler: logging.Handler = RichHandler(console=err, show_path=False, markup=False)
        handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    else:  # a log file or pipe: plain lines, whole
        handler = _CurrentStderr()
        handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    logger.addHandler(handler)
    _HANDLER["handler"] = handler
    logger.setLevel(logging.ERROR if quiet else (logging.INFO if verbose else logging.WARNING))


def quiet() -> bool:
    """True after ``--quiet``: no progress, no notes."""
    return _LEVEL["value"] < 0


def verbose() -> bool:
    """True after ``--verbose``."""
    return _LEVEL["value"] > 0
