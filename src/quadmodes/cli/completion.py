"""Shell completion of the command line (``quadmodes --install-completion``): case names (the
built-in cases of the right kind, and TOML files and folders from the path typed so far) and
the choices of the options that have a fixed set of values (a comma-separated list completes
its last item).

Each function here is a typer ``autocompletion`` callback: the text typed so far in, the
candidates out (fast: no case is loaded)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

#: The formulations of a linearisation (campbell, rotating) and of a time run. A linearisation
#: of "QM" about a steady spin is Q4's (the same numbers: runs.manifold_system.linear_formulation),
#: offered so that a QM run's formulation is accepted as it is.
LINEAR_FORMULATIONS = ("Q", "P", "L", "Q4", "QM")
RUN_FORMULATIONS = ("Q", "P", "L", "rigid", "Q4", "QM")
#: Named spin axes (three numbers such as 0,0,1 are also accepted).
AXES = ("x", "y", "z", "minor", "intermediate", "major")
#: Units of frequencies and spin rates shown in tables and figures.
UNITS = ("Hz", "rpm", "rad/s")
#: Integration methods of a run.
METHODS = ("midpoint", "backward-euler", "adaptive")


def _toml_paths(incomplete: str) -> list[str]:
    """TOML files and folders whose path starts with ``incomplete`` (relative paths as typed)."""
    folder, _, stem = incomplete.rpartition("/")
    base = Path(folder or ".").expanduser()
    if not base.is_dir():
        return []
    found = []
    try:
        entries = sorted(base.iterdir())
    except OSError:
        return []
    for entry in entries:
        if not entry.name.startswith(stem) or entry.name.startswith("."):
            continue
        typed = f"{folder}/{entry.name}" if folder else entry.name
        if entry.is_dir():
            found.append(typed + "/")
        elif entry.suffix == ".toml":
            found.append(typed)
    return found


def _cases(names: list[str], incomplete: str) -> list[str]:
    return [n for n in names if n.startswith(incomplete)] + _toml_paths(incomplete)


def complete_model_case(incomplete: str) -> list[str]:
    """Built-in model cases (and TOML files) starting with ``incomplete``."""
    from quadmodes.case import builtin_case_names

    return _cases(builtin_case_names(), incomplete)


def complete_run_case(incomplete: str) -> list[str]:
    """Built-in run cases (and TOML files) starting with ``incomplete``."""
    from quadmodes.case import builtin_run_case_names

    return _cases(builtin_run_case_names(spinup=None), incomplete)


def complete_any_case(incomplete: str) -> list[str]:
    """Built-in model and run cases (and TOML files) starting with ``incomplete``."""
    from quadmodes.case import builtin_case_names, builtin_run_case_names

    return _cases(builtin_case_names() + builtin_run_case_names(spinup=None), incomplete)


def choices(*values: str, listed: bool = False) -> Callable[[str], list[str]]:
    """The completion of an option with the fixed ``values``; ``listed``: the option takes a
    comma-separated list (its last item is completed, the items before it kept)."""

    def complete(incomplete: str) -> list[str]:
        head, comma, last = incomplete.rpartition(",") if listed else ("", "", incomplete)
        prefix = head + comma
        done = set(head.split(",")) if listed else set()
        return [prefix + v for v in values if v.lower().startswith(last.strip().lower())
                and v not in done]  # fmt: skip

    return complete
