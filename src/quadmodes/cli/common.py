"""What every command shares: the two consoles, one-line errors, progress bars, staged output
folders and the reusable option declarations.

Errors a user can fix (bad case, bad units, failed convergence) print one line on stderr and exit
with status 2; results are written to a scratch folder and moved into place only when complete.
"""

from __future__ import annotations

import contextlib
import glob
import os
import shutil
import signal
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any, NoReturn

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

#: Progress on stderr (bars, warnings, errors); results on stdout.
err = Console(stderr=True)
out = Console()

DEFAULT_CASE = "paper-membrane"

#: The formulations a linearisation (campbell, rotating) accepts.
LINEAR_FORMULATIONS = ("Q", "P", "L", "Q4")

#: ``progress(stage, fraction)``: a stage name and its completed fraction in [0, 1].
ProgressCallback = Callable[[str, float], None]


class UserError(Exception):
    """An input or convergence problem the user can act on."""


def user_errors() -> tuple[type[BaseException], ...]:
    """The exception types that end a command with a one-line message (exit status 2)."""
    from quadmodes.case import CaseError, QuantityError
    from quadmodes.structure.calibrate import CalibrationError
    from quadmodes.structure.prestress import ConvergenceError

    return (UserError, CaseError, QuantityError, ConvergenceError, CalibrationError, ValueError)


def fail(exc: BaseException) -> NoReturn:
    """Print ``exc`` as one line ``error: ...`` on stderr and exit with status 2."""
    message = " ".join(str(exc).split())  # one line
    # escape: messages name TOML tables such as "[pressure]", which rich would take as markup
    err.print(
        f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True, emoji=False
    )
    raise typer.Exit(code=2)


@contextlib.contextmanager
def one_line_errors(*also: type[BaseException]) -> Iterator[None]:
    """Turn the user errors (and the exception types ``also``) raised inside into ``fail``.
    A deliberate ``typer.Exit`` (e.g. 130 after Ctrl-C) passes through: click's Exit is a
    RuntimeError, which ``also`` often names."""
    try:
        yield
    except typer.Exit:
        raise
    except (*user_errors(), *also) as exc:
        fail(exc)


@contextlib.contextmanager
def progress_bars(enabled: bool = True) -> Iterator[ProgressCallback]:
    """A ``progress(stage, fraction)`` callback drawing rich bars on stderr."""
    bars = Progress(
        TextColumn("{task.description:<12}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(),
        console=err,
        transient=False,
        disable=not enabled or not err.is_terminal,
    )
    tasks: dict[str, int] = {}

    def update(stage: str, fraction: float) -> None:
        if stage not in tasks:
            tasks[stage] = bars.add_task(stage, total=1.0)
        bars.update(tasks[stage], completed=fraction)

    with bars:
        yield update


def _staging_owner(folder: Path, prefix: str) -> int | None:
    """The process id in the name of staging folder ``folder`` (``<prefix><pid>-<random>``)."""
    head = folder.name[len(prefix):].partition("-")[0]
    return int(head) if head.isdigit() else None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. another user's process
        return True
    return True


def clean_stale_staging(directory: Path) -> list[Path]:
    """Remove the hidden staging folders ``.<name>.partial-<pid>-…/`` beside ``directory`` left
    by a process that no longer runs (e.g. killed while writing); returns those removed (a note
    on stderr names each)."""
    directory = Path(directory).resolve()
    prefix = f".{directory.name}.partial-"
    removed = []
    if not directory.parent.is_dir():
        return removed
    for folder in sorted(directory.parent.glob(f"{glob.escape(prefix)}*")):
        pid = _staging_owner(folder, prefix)
        if not folder.is_dir() or (pid is not None and pid != os.getpid() and _alive(pid)):
            continue
        shutil.rmtree(folder, ignore_errors=True)
        removed.append(folder)
        err.print(f"note: removed the left-over staging folder {escape(str(folder))} (an "
                  "earlier run stopped while writing)", highlight=False, soft_wrap=True)  # fmt: skip
    return removed


@contextlib.contextmanager
def staged_output(directory: Path | None) -> Iterator[Path | None]:
    """Write into a hidden scratch folder ``.<name>.partial-<pid>-…/`` beside ``directory``; move
    the files in only on success. Left-over scratch folders of dead processes are removed
    first (:func:`clean_stale_staging`)."""
    if directory is None:
        yield None
        return
    directory = directory.resolve()
    created = [p for p in directory.parents if not p.exists()]  # deepest first
    directory.parent.mkdir(parents=True, exist_ok=True)
    clean_stale_staging(directory)
    prefix = f".{directory.name}.partial-{os.getpid()}-"
    scratch = Path(tempfile.mkdtemp(prefix=prefix, dir=directory.parent))
    done = False
    try:
        yield scratch
        with deferred_interrupts():  # never half the new files beside half the old ones
            directory.mkdir(exist_ok=True)
            for item in scratch.iterdir():
                target = directory / item.name
                if target.is_dir():
                    shutil.rmtree(target)
                item.replace(target)
            done = True
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
        if not done:  # a failed run leaves no folders behind: remove the parents it made
            for folder in created:
                with contextlib.suppress(OSError):
                    folder.rmdir()


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Inside, Ctrl-C and SIGTERM are held and delivered at the end (a few renames that must not
    be cut in half). Outside the main thread nothing is held."""
    held: list[int] = []

    def hold(signum, frame):
        held.append(signum)

    try:
        previous = {s: signal.signal(s, hold) for s in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if held:
            signal.raise_signal(held[0])


#: Exit status after Ctrl-C (128 + SIGINT) and after SIGTERM (128 + SIGTERM).
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[dict]:
    """Inside, SIGTERM raises KeyboardInterrupt like Ctrl-C (so a run saves its checkpoint);
    yields a dict whose ``"exit"`` is the exit status to use after an interrupt (130, or 143
    after SIGTERM). Outside the main thread nothing is installed."""
    state = {"exit": EXIT_INTERRUPTED}

    def handler(signum, frame):
        state["exit"] = EXIT_TERMINATED
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        yield state
        return
    try:
        yield state
    finally:
        signal.signal(signal.SIGTERM, previous)


def load_model_case(case: str):
    """The model case named ``case`` (built-in name or TOML file)."""
    from quadmodes.case import load_case

    return load_case(case)


def parse_formulations(
    text: str, allowed: tuple[str, ...], *, use: str, none: str = "(none)"
) -> tuple[str, ...]:
    """The comma-separated formulation names of ``--formulations``, each one of ``allowed``.

    ``use`` is the list the error message suggests, ``none`` what it says when none is given."""
    names = tuple(f.strip() for f in text.split(",") if f.strip())
    bad = [f for f in names if f not in allowed]
    if bad or not names:
        raise UserError(f"--formulations: unknown {', '.join(bad) or none}; use {use}")
    return names


# ------------------------------------------------------------------------- option declarations


def flag(declaration: str, help: str) -> Any:
    """A boolean option, e.g. ``flag("--json", "print JSON on stdout")`` or ``"--a/--no-a"``."""
    return Annotated[bool, typer.Option(declaration, help=help)]


def output_path(help: str, *, optional: bool = True) -> Any:
    """The ``-o/--output`` option: a file or folder to write."""
    return Annotated[Path | None if optional else Path, typer.Option("-o", "--output", help=help)]


def case_argument(help: str) -> Any:
    """The CASE argument: a built-in case name or a TOML file."""
    return Annotated[str, typer.Argument(help=help)]


#: A model case: built-in name or TOML file.
ModelCase = case_argument("built-in case name or TOML file")
#: ``--json`` of the commands that print their summary as JSON.
JsonFlag = flag("--json", "print JSON on stdout")
