"""Usage errors in one line: ``error: No such option: --bogus (quadmodes run --help lists the
options)`` and exit status 2, as every other error a user can fix; click's default is a usage
line, a hint and a boxed message (three to six lines on stderr)."""

from __future__ import annotations

import sys
from typing import Any

import typer

from quadmodes.cli.common import print_error
from quadmodes.cli.shape import QuadmodesGroup


def _click_class(name: str) -> type[Exception]:
    """A click exception class by name, from typer's public ``BadParameter`` (typer ≥ 0.22
    carries its own copy of click, older typers use click: both derive BadParameter from
    UsageError from ClickException)."""
    return next(c for c in typer.BadParameter.__mro__ if c.__name__ == name)


USAGE_ERROR = _click_class("UsageError")
CLICK_EXCEPTION = _click_class("ClickException")


def _where(exc: Exception) -> str:
    ctx = getattr(exc, "ctx", None)
    return f"{ctx.command_path} --help" if ctx is not None else "quadmodes --help"


class OneLineUsageGroup(QuadmodesGroup):
    """The command group of ``quadmodes`` (:class:`~quadmodes.cli.shape.QuadmodesGroup`) with
    click's own main, but a usage error (an unknown
    option or command, a value that is not a number) printed as one line naming where the
    options are listed; bare ``quadmodes`` still prints the help."""

    def main(self, args: Any = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:  # fmt: skip
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        try:
            code = super().main(args, prog_name, complete_var, False, **extra)
        except CLICK_EXCEPTION as exc:
            if type(exc).__name__ == "NoArgsIsHelpError":  # bare `quadmodes`: the help
                exc.show()
            elif isinstance(exc, USAGE_ERROR):
                listed = "commands" if "command" in exc.format_message() else "options"
                print_error(f"{exc.format_message()} ({_where(exc)} lists the {listed})")
            else:  # e.g. a file option that cannot be opened
                print_error(exc.format_message())
            sys.exit(2 if isinstance(exc, USAGE_ERROR) else exc.exit_code)
        except typer.Abort:
            sys.exit(130)
        sys.exit(code if isinstance(code, int) else 0)
