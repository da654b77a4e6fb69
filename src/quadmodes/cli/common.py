"""What every command shares: the two consoles, one-line errors, progress bars, staged output
folders and the reusable option declarations.

Errors a user can fix (bad case, bad units, failed convergence) print one line on stderr and exit
with status 2; results are written to a scratch folder and moved into place only when complete.
"""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any, NoReturn

import typer
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from quadmodes.cli import completion, verbosity
from quadmodes.cli.completion import LINEAR_FORMULATIONS  # noqa: F401 (re-exported)
from quadmodes.cli.consoles import err, out  # noqa: F401 (out: re-exported to the commands)
from quadmodes.io import staging

DEFAULT_CASE = "paper-membrane"

#: ``progress(stage, fraction)``: a stage name and its completed fraction in [0, 1].
ProgressCallback = Callable[[str, float], None]


class UserError(Exception):
    """An input or convergence problem the user can act on."""


def user_errors() -> tuple[type[BaseException], ...]:
    """The exception types that end a command with a one-line message (exit status 2)."""
    from quadmodes.errors import QuadmodesError

    # ValueError: a value a stage cannot use, met below the case validation (as the API's
    # boundary turns it into an InputError, api/boundary.py)
    return (UserError, QuadmodesError, ValueError)


def print_error(message: str) -> None:
    """Print ``message`` as one line ``error: ...`` on stderr."""
    message = " ".join(message.split())  # one line
    # escape: messages name TOML tables such as "[pressure]", which rich would take as markup
    err.print(
        f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True, emoji=False
    )


def fail(exc: BaseException) -> NoReturn:
    """Print ``exc`` as one line ``error: ...`` on stderr and exit with status 2."""
    print_error(str(exc))
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


def _text_progress() -> ProgressCallback:
    """Progress for a stderr that is not a terminal (a log file, a pipe, a batch job): one
    time-stamped line per stage and 10 % step, e.g. ``12:04:31 paper-membrane N=16 about 41 Hz:
    inflation: 40 %``. A stage that starts again (its fraction falls) is shown again from its
    start, so a second model build of one command is never silent."""
    shown: dict[str, int] = {}

    def progress(stage: str, fraction: float) -> None:
        tenth = int(10 * fraction + 1e-9)
        if tenth < shown.get(stage, -1):  # the stage runs again (another model, another pass)
            del shown[stage]
        if shown.get(stage, -1) < tenth:
            shown[stage] = tenth
            stamp = time.strftime("%H:%M:%S")
            err.print(f"{stamp} {escape(stage)}: {10 * tenth} %", highlight=False, soft_wrap=True)

    return progress


@contextlib.contextmanager
def progress_bars(enabled: bool = True) -> Iterator[ProgressCallback]:
    """A ``progress(stage, fraction)`` callback drawing rich bars on stderr, or printing a line
    per 10 % when stderr is not a terminal; nothing when not ``enabled`` or after ``--quiet``."""
    enabled = enabled and not verbosity.quiet()
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
    lines = _text_progress() if enabled and not err.is_terminal else None

    def update(stage: str, fraction: float) -> None:
        if stage not in tasks:
            tasks[stage] = bars.add_task(stage, total=1.0)
        bars.update(tasks[stage], completed=fraction)
        if lines is not None:
            lines(stage, fraction)

    with bars:
        yield update


def note(text: str) -> None:
    """One line on stderr (markup escaped): the ``note`` callback of the library's file
    writers."""
    err.print(escape(text), highlight=False, soft_wrap=True)


def clean_stale_staging(directory: Path) -> list[Path]:
    """:func:`quadmodes.io.staging.clean_stale_staging`, its notes on stderr."""
    return staging.clean_stale_staging(directory, note)


def staged_output(directory: Path | None):
    """:func:`quadmodes.io.staging.staged_output` (all-or-nothing output folder), its notes on
    stderr."""
    return staging.staged_output(directory, note)


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
#: Room the staging folder ``.<name>.partial-XXXXXXXX`` needs beyond the folder's own name.
_STAGING_EXTRA = 24


def _nearest_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path(path.anchor or ".")


def _check_name_lengths(path: Path, option: str, extra: int) -> None:
    """Raise UserError if a component of ``path`` (its last one plus ``extra`` characters of
    staging or temporary suffix) or the whole path is longer than the file system allows."""
    base = _nearest_existing(path.parent)
    try:
        name_max = os.pathconf(base, "PC_NAME_MAX")
        path_max = os.pathconf(base, "PC_PATH_MAX")
    except (OSError, ValueError, AttributeError):
        name_max, path_max = 255, 4096
    longest = max((len(os.fsencode(p)) for p in path.parts), default=0)
    if longest + extra > name_max or len(os.fsencode(str(path))) + extra >= path_max:
        raise UserError(
            f"{option}: {path} is too long for the file system (names up to about "
            f"{name_max - extra} characters, paths up to {path_max - extra}); use a shorter path"
        )


def _check_writable_folder(folder: Path, option: str, path: Path) -> None:
    """Raise UserError unless a file can be created in ``folder`` (an existing folder): a
    temporary file is created and removed (permission bits alone do not tell, e.g. for root or
    a read-only mount)."""
    if not folder.is_dir():
        raise UserError(f"{option}: {folder} is a file, not a folder; choose another path for {path}")
    try:
        fd, probe = tempfile.mkstemp(prefix=".quadmodes-write-check-", dir=folder)
    except OSError as exc:
        reasons = {errno.EROFS: "read-only file system", errno.EACCES: "permission denied",
                   errno.EPERM: "permission denied", errno.ENOSPC: "no space left"}  # fmt: skip
        raise UserError(
            f"{option}: cannot write in {folder} ({reasons.get(exc.errno, 'not writable')}); "
            "choose a folder you can write to"
        ) from None
    os.close(fd)
    os.unlink(probe)


def check_output_folder(directory: Path | None, option: str = "-o", *,
                        replaces: tuple[str, ...] = ()) -> None:  # fmt: skip
    """Before any long work: raise UserError (naming ``option``) unless ``directory`` can be
    created or written as an output folder (not a file nor a symbolic link, writable parent,
    short enough: :func:`quadmodes.io.outputs.check_output_path`), and none of the names it
    ``replaces`` is a user's file (:func:`quadmodes.io.outputs.check_replaceable`)."""
    from quadmodes.io.outputs import check_output_path, check_replaceable

    if directory is None:
        return
    directory = Path(directory).expanduser().absolute()
    check_output_path(directory, option)
    check_replaceable(directory, replaces, option)
    if directory.exists() and not directory.is_dir():
        raise UserError(f"{option}: {directory} is a file, not a folder; give a folder name")
    _check_name_lengths(directory, option, _STAGING_EXTRA)
    # an existing folder is written (and staged) inside only: its parent is not probed
    where = directory if directory.is_dir() else _nearest_existing(directory.parent)
    _check_writable_folder(where, option, directory)


def check_output_file(path: Path | None, option: str = "-o") -> None:
    """Before any long work: raise UserError (naming ``option``) unless the file ``path`` can be
    written (not a folder, writable existing parent, short enough)."""
    if path is None:
        return
    path = Path(path).expanduser().absolute()
    if path.is_dir():
        raise UserError(f"{option}: {path} is a folder; give a file name, e.g. {path / 'out'}")
    _check_name_lengths(path, option, _STAGING_EXTRA)
    _check_writable_folder(_nearest_existing(path.parent), option, path)


def guard_model_size(case, allow_large: bool) -> None:
    """Refuse (CaseError naming the field) a model case estimated above the node limit of
    :mod:`quadmodes.runs.resources` (unless ``allow_large``, ``--yes``) or with a pressure too
    low to inflate it."""
    from quadmodes.runs.resources import check_model_size

    check_model_size(case, allow_large=allow_large)


def guard_reduced_model(
    case, n_modes, allow_large: bool, *, spins: bool = False, from_option: bool = False
) -> None:
    """Refuse a reduced model of ``n_modes`` modes (an int; "auto" is checked when resolved)
    that the model cannot have or that is too large (unless ``allow_large``), and, if it
    ``spins``, a free beam. ``from_option``: the count came from ``--modes`` (named first)."""
    from quadmodes.case import CaseError
    from quadmodes.runs.resources import check_can_spin, check_reduced_size

    if spins:
        check_can_spin(case)
    if not isinstance(n_modes, int):
        return
    if from_option and n_modes < 1:
        raise UserError(f"--modes {n_modes}: must be at least 1; use e.g. 5")
    try:
        check_reduced_size(case, n_modes, allow_large=allow_large)
    except CaseError as exc:
        if not from_option:
            raise
        raise UserError(f"--modes {n_modes}: {exc.detail.split(': ', 1)[-1]}") from None


def load_model_case(case: str):
    """The model case named ``case`` (built-in name or TOML file)."""
    from quadmodes.case import load_case

    return load_case(case)


def parse_formulations(
    text: str, allowed: tuple[str, ...], *, use: str, none: str = "(none)",
    option: str = "--formulation",
) -> tuple[str, ...]:  # fmt: skip
    """The comma-separated formulation names of ``--formulation`` (formerly
    ``--formulations``), each one of ``allowed``.

    ``use`` is the list the error message suggests, ``none`` what it says when none is given."""
    names = tuple(f.strip() for f in text.split(",") if f.strip())
    bad = [f for f in names if f not in allowed]
    if bad or not names:
        raise UserError(f"{option}: unknown {', '.join(bad) or none}; use {use}")
    return names


# ------------------------------------------------------------------------- option declarations


def flag(declaration: str, help: str) -> Any:
    """A boolean option, e.g. ``flag("--json", "print JSON on stdout")`` or ``"--a/--no-a"``."""
    return Annotated[bool, typer.Option(declaration, help=help)]


def output_path(help: str, *, optional: bool = True) -> Any:
    """The ``-o/--output`` option: a file or folder to write."""
    return Annotated[Path | None if optional else Path, typer.Option("-o", "--output", help=help)]


#: Completion of a CASE argument by the kind of case it takes.
_CASE_COMPLETION = {"model": completion.complete_model_case, "run": completion.complete_run_case,
                    "any": completion.complete_any_case}  # fmt: skip


def case_argument(help: str, kind: str = "model") -> Any:
    """The CASE argument: a built-in case name or a TOML file; the shell completes the built-in
    cases of ``kind`` ("model", "run" or "any") and TOML files."""
    return Annotated[str, typer.Argument(help=help, autocompletion=_CASE_COMPLETION[kind])]


def units_option(what: str) -> Any:
    """The ``--units`` option: the unit of the frequencies and spin rates of ``what``."""
    return Annotated[str, typer.Option(
        "--units", help=f"unit of {what}: Hz, rpm or rad/s",
        autocompletion=completion.choices(*completion.UNITS))]  # fmt: skip


def parse_units(text: str):
    """The :class:`~quadmodes.io.display_units.FrequencyUnit` of ``--units`` (UserError
    otherwise)."""
    from quadmodes.io.display_units import frequency_unit

    try:
        return frequency_unit(text, "--units")
    except ValueError as exc:
        raise UserError(str(exc)) from None


def formulation_option(help: str, choices: tuple[str, ...], *, listed: bool = False) -> Any:
    """The ``--formulation`` option (one name, or with ``listed`` a comma-separated list; the old
    spelling ``--formulations`` still works, :mod:`quadmodes.cli.shape`)."""
    return Annotated[str | None, typer.Option(
        "--formulation", help=help, autocompletion=completion.choices(*choices, listed=listed))]


def axis_option(help: str) -> Any:
    """The ``--axis`` option (a name or three numbers; the shell completes the names)."""
    return Annotated[str | None, typer.Option(
        "--axis", help=help, autocompletion=completion.choices(*completion.AXES))]


#: A model case: built-in name or TOML file.
ModelCase = case_argument("built-in case name or TOML file")
#: A model or run case (show-case).
AnyCase = case_argument("built-in case name or TOML file (model or run case)", "any")
#: ``--json`` of the commands that print their summary as JSON.
JsonFlag = flag("--json", "print JSON on stdout")
#: ``--no-cache`` of the commands that build reduced models.
NoCacheFlag = flag("--no-cache", "build the reduced model; do not read or save the model cache")
#: ``--yes`` of the commands that build a finite-element model: lifts the size limit.
LargeModelFlag = flag(
    "--yes", "build above the size limits (50,000 nodes, 60 modes, 4 GB of reduced arrays)"
)


# ------------------------------------------------------------------------- quantities


def deprecated_bare_number(option: str, text: str, unit: str) -> None:
    """The note for a bare number given to a dimensional option (still read in ``unit``)."""
    if not verbosity.quiet():
        err.print(f"note: {option} {escape(text)}: a bare number is read in {unit} (deprecated); "
                  f'give the unit, e.g. "{escape(text)} {unit}"', highlight=False, soft_wrap=True)  # fmt: skip


def frequency_option(text: str, option: str) -> float:
    """The frequency (Hz) of option ``option``: a quantity ("31.2 Hz", "196 rad/s") or, as
    before, a bare number of Hz (with a deprecation note)."""
    from quadmodes.case import parse_quantity

    try:
        value = float(text)
    except ValueError:
        return parse_quantity(text, "frequency", option)
    deprecated_bare_number(option, text, "Hz")
    return value


def output_file_in(output: Path | None, name: str, option: str = "-o") -> Path | None:
    """The file a command writes for ``-o DIR``: ``DIR/name`` (``-o`` is always the output
    folder). An ``-o`` ending in the suffix of ``name`` that is not a folder is, as before, the
    file itself (with a deprecation note). Checked before any long work (UserError)."""
    if output is None:
        return None
    output = Path(output)
    if output.suffix == Path(name).suffix and not output.is_dir():
        check_output_file(output, option)
        if not verbosity.quiet():
            err.print(f"note: {option} {escape(str(output))}: a file name is deprecated; -o takes "
                      f"the output folder (writes DIR/{name})", highlight=False, soft_wrap=True)  # fmt: skip
        return output
    check_output_folder(output, option)
    return output / name


def write_file_in(path: Path, write: Callable[[Path], Any]) -> None:
    """``write(path)`` after creating the folder of ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    write(path)


#: ``run``'s CASE argument (optional: both paper cases).
RunCaseArgument = Annotated[str | None, typer.Argument(
    help="run case (built-in name or TOML file); default: both paper cases",
    autocompletion=completion.complete_run_case)]
#: ``run --axis``: sets ``initial.spin_axis``.
RunAxis = axis_option("body-frame spin axis (sets initial.spin_axis): x, y, z, minor, "
                      "intermediate, major or three numbers such as 0,0,1; default: the run "
                      "case's (the minor axis)")  # fmt: skip
#: ``run --method`` and ``run --formulation`` (overrides of the run case).
RunMethod = Annotated[str | None, typer.Option(
    help="midpoint | backward-euler | adaptive", autocompletion=completion.choices(*completion.METHODS))]
RunFormulation = Annotated[str | None, typer.Option(
    help="Q | P | L | rigid | Q4 | QM", autocompletion=completion.choices(*completion.RUN_FORMULATIONS))]
