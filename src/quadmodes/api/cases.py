"""Cases from Python: a model case or a run case from a built-in name, a TOML file, a dict or
keyword arguments, with quantities given as strings ("0.3 psi"), pint quantities or SI floats;
validated changes of a case; saving a case as TOML.

Every function validates like a case file (:mod:`quadmodes.case`; the changes go through
:mod:`quadmodes.case.editing`, as the command line's and the sweeps' do) and raises
:class:`~quadmodes.case.CaseError` (one line naming the field and the fix).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from quadmodes.case import Case, CaseError, RunCase, load_case, load_run_case
from quadmodes.case.editing import case_table, merge, nested, validated
from quadmodes.case.fields import input_table
from quadmodes.errors import InputError
from quadmodes.io.atomic import write_text

CaseSource = str | os.PathLike[str] | Mapping[str, Any] | Case | None
RunSource = str | os.PathLike[str] | Mapping[str, Any] | RunCase | None


def _name_or_path(value: Any, what: str, also: str = "") -> str | os.PathLike[str]:
    """``value`` if it is a name or path, else an :class:`InputError` saying what is taken."""
    if isinstance(value, (str, os.PathLike)):
        return value
    raise InputError(f"{what}: got {type(value).__name__} {value!r:.40}; give a built-in case "
                     f"name (quadmodes cases), a .toml path{also}")  # fmt: skip


def _table(source: Any, kind: type) -> dict[str, Any]:
    """The TOML table of ``source`` (a case of ``kind``, a mapping, or a name or path)."""
    if source is None:
        return {}
    if isinstance(source, Mapping):
        return nested(source)
    if not isinstance(source, kind):
        what = "run_case" if kind is RunCase else "model_case"
        source = _name_or_path(source, what, f", a dict or a {kind.__name__}")
        source = load_run_case(source) if kind is RunCase else load_case(source)
    return case_table(source)


def model_case(source: CaseSource = None, /, **tables: Any) -> Case:
    """A validated model case (membrane or beam).

    Parameters
    ----------
    source
        Built-in case name (``"paper-membrane"``), path of a ``.toml`` case file, a dict shaped
        like the TOML file, an existing :class:`~quadmodes.case.Case`, or None (all from
        ``tables``).
    **tables
        Tables or keys to set on top of ``source``: ``pressure={"value": "0.4 psi"}`` changes
        one key of ``[pressure]``; dotted keys need a dict, e.g.
        ``model_case("paper-membrane", **{"pressure.value": 2757.9})``.

    Quantities may be quantity strings (``"60 in"``), pint quantities (``1.524 * ureg.m``) or
    bare floats in SI units (m, kg, Pa, kg/m^3, kg m^2, s, rad, rad/s; Hz for frequencies).

    Returns
    -------
    Case
        Frozen, SI floats inside; ``case.to_toml()`` is its TOML text.
    """
    data = merge(_table(source, Case), tables)
    return validated(Case, input_table(Case, data), "model_case")


def run_case(source: RunSource = None, /, *, model: CaseSource = None, **tables: Any) -> RunCase:
    """A validated run case.

    Parameters
    ----------
    source
        Built-in run case name (``"paper-41hz"``), ``.toml`` path, dict, :class:`RunCase` or None.
    model
        The model it runs: a :class:`~quadmodes.case.Case` (embedded in the run case, so that
        the run's TOML replays that very model), a built-in name or a case file path.
    **tables
        Tables or keys set on top of ``source``, e.g. ``initial={"spin_rate": "10 Hz"}``,
        ``integration={"duration": 0.5}`` (0.5 s: bare floats are SI: s, rad, rad/s).

    Returns
    -------
    RunCase
        Frozen, SI floats inside; ``run.to_toml()`` is its TOML text.
    """
    data = merge(_table(source, RunCase), tables)
    if model is not None:
        path_or_name = isinstance(model, (str, os.PathLike))
        data["model"] = os.fspath(model) if path_or_name else model_case(model)
    data.setdefault("kind", "run")
    return validated(RunCase, input_table(RunCase, data), "run_case")


def changed(case: Case | RunCase, /, **tables: Any) -> Case | RunCase:
    """``case`` with ``tables`` changed and validated (see :func:`model_case`; quantities as
    strings, pint quantities or SI floats), e.g. ``changed(run, integration={"dt": "0.25 ms"})``.
    """
    if isinstance(case, RunCase):
        return run_case(case, **tables)
    if isinstance(case, Case):
        return model_case(case, **tables)
    raise CaseError(f"changed: {type(case).__name__} is not a Case or RunCase")


def save_case(case: Case | RunCase, path: str | os.PathLike[str]) -> Path:
    """Write ``case`` as TOML (SI units; :func:`load` reads it back to an equal case) to
    ``path`` atomically; returns the path."""
    path = Path(path)
    write_text(path, case.to_toml())
    return path


def load(name_or_path: str | os.PathLike[str]) -> Case | RunCase:
    """A model or run case from a built-in name or a ``.toml`` file (a file with
    ``kind = "run"`` or a built-in run name gives a :class:`RunCase`)."""
    from quadmodes.runs.simulate import is_run_case

    text = os.fspath(_name_or_path(name_or_path, "load"))
    return load_run_case(name_or_path) if is_run_case(text) else load_case(name_or_path)


def cases() -> list[dict[str, str]]:
    """The built-in cases as ``quadmodes cases --json`` lists them: ``name``, ``kind``
    ("membrane", "beam" or "run") and ``description``; no quantities, so no units."""
    from quadmodes.case import builtin_case_names, builtin_run_case_names

    found = [load_case(n) for n in builtin_case_names()]
    found += [load_run_case(n) for n in builtin_run_case_names(None)]
    return [{"name": c.name, "kind": c.kind, "description": c.description} for c in found]
