"""The shape every command shares (issue 25 item 7): the typer command and group classes of the
``quadmodes`` app.

* ``--quiet``/``-q`` and ``--verbose``/``-v`` are accepted after the subcommand as well as
  before it (a "Global options" panel in each command's help);
* old option spellings keep working as hidden, deprecated aliases (:data:`DEPRECATED_ALIASES`,
  with a note on stderr), so a script written for an older release does not break;
* flags show no ``<bool>`` type in the help (a flag takes no value);
* docstrings are reflowed (one line per paragraph) so that the help wraps at the terminal's
  width, never at the line breaks of the source.
"""

from __future__ import annotations

import functools
from typing import Annotated

import typer
from rich.markup import escape
from typer.core import TyperCommand, TyperGroup

from quadmodes.cli import verbosity
from quadmodes.cli.consoles import err

#: Old option spelling -> the one spelling of its concept. An alias applies to a command that
#: has the new option and not the old one.
DEPRECATED_ALIASES = {
    "--formulations": "--formulation",
    "--spins": "--spin-rate",
}

#: The help panel of the options every command accepts.
GLOBAL_PANEL = "Global options"


def reflow(text: str | None) -> str | None:
    """``text`` with the single line breaks inside each paragraph replaced by spaces
    (paragraphs, lists whose lines start with "* " or "- ", and click's ``\\b`` blocks kept)."""
    if not text:
        return text
    paragraphs = []
    for block in text.strip().split("\n\n"):
        lines = [line.strip() for line in block.strip().splitlines()]
        if block.lstrip().startswith("\b") or any(line[:2] in ("* ", "- ") for line in lines):
            paragraphs.append(block)
            continue
        paragraphs.append(" ".join(line for line in lines if line))
    return "\n\n".join(paragraphs)


def _set_quiet(value: bool) -> None:
    if value:
        verbosity.configure(quiet=True)


def _set_verbose(value: bool) -> None:
    if value:
        verbosity.configure(verbose=True)


@functools.cache
def _global_parameters() -> tuple:
    """The ``--quiet`` and ``--verbose`` parameters of every command (click parameters built by
    typer from a declaration, not exposed to the command's function)."""
    probe = typer.Typer(add_completion=False)

    @probe.command()
    def globals_probe(
        quiet: Annotated[bool, typer.Option(
            "--quiet", "-q", callback=_set_quiet, expose_value=False, rich_help_panel=GLOBAL_PANEL,
            help="errors and warnings only: no progress, no notes (also before the command)")] = False,
        verbose: Annotated[bool, typer.Option(
            "--verbose", "-v", callback=_set_verbose, expose_value=False,
            rich_help_panel=GLOBAL_PANEL,
            help="also log cache hits and stage timings (also before the command)")] = False,
    ) -> None:  # fmt: skip
        """Never run: its parameters are taken."""

    return tuple(typer.main.get_command(probe).params)


def _no_bool_metavar(params) -> list:
    """``params`` with the flags' type label removed (``metavar`` ""); returns them."""
    for param in params:
        if getattr(param, "is_flag", False) and param.metavar is None:
            param.metavar = ""
    return params


def option_names(command) -> set[str]:
    """Every spelling of every option of ``command`` (e.g. ``{"--json", "-o", "--output"}``)."""
    return {name for p in command.params for name in (*p.opts, *p.secondary_opts)}


def renamed(args: list[str], names: set[str]) -> tuple[list[str], list[tuple[str, str]]]:
    """``args`` with every deprecated alias of :data:`DEPRECATED_ALIASES` (``--old VALUE`` or
    ``--old=VALUE``) spelled the new way where the command's option ``names`` have the new and
    not the old spelling; also the (old, new) pairs replaced. Nothing after ``--`` changes."""
    out: list[str] = []
    used: list[tuple[str, str]] = []
    for i, arg in enumerate(args):
        if arg == "--":
            out += args[i:]
            break
        name, eq, value = arg.partition("=")
        new = DEPRECATED_ALIASES.get(name)
        if new is not None and new in names and name not in names:
            used.append((name, new))
            arg = new + eq + value
        out.append(arg)
    return out, used


class QuadmodesCommand(TyperCommand):
    """A ``quadmodes`` command: reflowed help, the global options, deprecated aliases, flags
    without a type label."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs["help"] = reflow(kwargs.get("help"))
        super().__init__(*args, **kwargs)
        self.params.extend(_global_parameters())
        _no_bool_metavar(self.params)

    def get_params(self, ctx):
        return _no_bool_metavar(super().get_params(ctx))  # --help is added here

    def parse_args(self, ctx, args: list[str]) -> list[str]:
        args, used = renamed(list(args), option_names(self))
        if used and not verbosity.quiet() and not {"-q", "--quiet"} & set(args):
            for old, new in used:
                err.print(f"note: {escape(old)} is deprecated; use {escape(new)} (same values)",
                          highlight=False, soft_wrap=True)  # fmt: skip
        return super().parse_args(ctx, args)


class QuadmodesGroup(TyperGroup):
    """The ``quadmodes`` group (and ``cache``): reflowed help, flags without a type label."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs["help"] = reflow(kwargs.get("help"))
        super().__init__(*args, **kwargs)
        _no_bool_metavar(self.params)

    def get_params(self, ctx):
        return _no_bool_metavar(super().get_params(ctx))
