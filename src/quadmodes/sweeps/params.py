"""Sweep parameters: ``PATH=VALUES`` strings to validated, SI-valued parameters and the grid of
points they span.

``PATH`` is a TOML path of the run case (``initial.spin_rate``, ``integration.duration``,
``reduced.modes``) or of its model case (``pressure.value``, ``material.damping_ratio``,
``end_body[1].mass`` or ``end_body.rear.mass`` by the end body's name; an explicit ``model.``
prefix is accepted). ``VALUES`` is one quantity (the field is only overridden), a comma list
(``"10 Hz, 20 Hz"``) or a range ``start:stop:count`` whose ends carry units
(``"1 Hz:45 Hz:45"``: 45 evenly spaced values, both ends included), or a comma list of both
(``"0.5 Hz, 5 Hz:40 Hz:8, 41 Hz"``). Quantities are parsed by
:func:`quadmodes.case.units.parse_quantity` with the dimension of the field, so the values are
SI floats (rad/s, Pa, kg, s, rad, ...). Fields that are not quantities (``reduced.modes``,
``reduced.formulation``, ``reduced.reference``) take plain comma lists.

Every problem raises :class:`SweepError`: one line naming the ``--param`` and the fix.
"""

from __future__ import annotations

import difflib
import itertools
import math
import re
import typing
from dataclasses import dataclass

from pydantic import BaseModel

from quadmodes.case import Case, QuantityError, RunCase, parse_quantity, si_unit
from quadmodes.case.fields import field_meta
from quadmodes.case.meta import nested_model
from quadmodes.errors import QuadmodesError
from quadmodes.limits import REDUCED_MODES, SWEEP_POINTS, LimitError


class SweepError(QuadmodesError, ValueError):
    """A bad sweep input: ``str(exc)`` is one line naming the option and the fix."""


#: Tables of a run case a path may start with; the other first keys address the model case.
RUN_TABLES = ("reduced", "initial", "integration")
MODEL_TABLES = ("geometry", "mesh", "material", "pressure", "spin", "end_body", "beam", "modes")


@dataclass(frozen=True)
class FieldPath:
    """A resolved field path: ``target`` "run" or "model", ``keys`` (str table/field names and
    int indices of arrays of tables), the field's unit ``dimension`` (None: not a quantity) and
    its SI ``unit`` ("" dimensionless or not a quantity)."""

    text: str
    target: str
    keys: tuple[str | int, ...]
    dimension: str | None

    @property
    def field(self) -> str:
        """The last key (the name of the sweep dimension)."""
        return str(self.keys[-1])

    @property
    def unit(self) -> str:
        return si_unit(self.dimension) if self.dimension else ""


@dataclass(frozen=True)
class SweepParameter:
    """One ``--param``: its :class:`FieldPath`, the dimension ``name`` in the dataset and its
    ``values`` (SI floats for quantities, else ints or strings), in the order given."""

    path: FieldPath
    name: str
    values: tuple

    @property
    def swept(self) -> bool:
        """True for more than one value (a dimension); one value only overrides the field."""
        return len(self.values) > 1


def _leaf_paths(model: type[BaseModel], prefix: str, depth: int = 0) -> list[str]:
    """Every leaf field path below ``model`` (arrays of tables written with ``[0]``)."""
    paths = []
    for name, info in model.model_fields.items():
        sub = nested_model(info.annotation)
        is_array = typing.get_origin(info.annotation) is tuple
        head = f"{prefix}{name}{'[0]' if is_array else ''}"
        if sub is not None and depth < 3:
            paths.extend(_leaf_paths(sub, head + ".", depth + 1))
        elif sub is None:
            paths.append(head)
    return paths


def known_paths() -> list[str]:
    """All field paths a ``--param`` may name (run-case tables first, then the model case)."""
    run = [p for p in _leaf_paths(RunCase, "") if p.split(".")[0] in RUN_TABLES]
    model = [p for p in _leaf_paths(Case, "") if p.split(".")[0] in MODEL_TABLES]
    return run + model


def _unknown(text: str, option: str) -> SweepError:
    """The error for an unknown path, with the closest known path."""
    candidates = known_paths()
    plain = re.sub(r"\[\d+\]", "[0]", text)
    close = difflib.get_close_matches(plain, candidates, n=1, cutoff=0.5)
    hint = f'did you mean "{close[0]}"? ' if close else ""
    return SweepError(f'{option}: unknown field path "{text}"; {hint}give a TOML path such as '
                      '"initial.spin_rate", "pressure.value" or "end_body[1].mass"')  # fmt: skip


def _split_keys(text: str, end_bodies: tuple[str, ...], option: str) -> list[str | int]:
    """``"end_body[1].mass"`` / ``"end_body.rear.mass"`` → ``["end_body", 1, "mass"]``."""
    keys: list[str | int] = []
    for part in text.split("."):
        m = re.fullmatch(r"([A-Za-z_]\w*)((?:\[\d+\])*)", part.strip())
        if not m:
            raise _unknown(text, option)
        keys.append(m.group(1))
        keys.extend(int(i) for i in re.findall(r"\[(\d+)\]", m.group(2)))
    if keys and keys[0] == "model":
        keys = keys[1:]
    if len(keys) >= 3 and keys[0] == "end_body" and isinstance(keys[1], str):
        if keys[1] not in end_bodies:
            names = ", ".join(end_bodies) or "none"
            raise SweepError(f'{option}: no end body named "{keys[1]}" (end bodies: {names}); '
                             'use e.g. "end_body[0].mass"')  # fmt: skip
        keys[1] = end_bodies.index(keys[1])
    return keys


def resolve_path(text: str, model_case: Case | None = None, option: str = "--param") -> FieldPath:
    """The :class:`FieldPath` of ``text``; raises :class:`SweepError` (with "did you mean") for
    a path that names no field, or names a table instead of a field."""
    bodies = tuple(b.name for b in model_case.end_body) if model_case is not None else ()
    keys = _split_keys(text.strip(), bodies, option)
    if not keys or not isinstance(keys[0], str):
        raise _unknown(text, option)
    target = "run" if keys[0] in RUN_TABLES else "model" if keys[0] in MODEL_TABLES else None
    if target is None:
        raise _unknown(text, option)
    model: type[BaseModel] | None = RunCase if target == "run" else Case
    for i, key in enumerate(keys):
        if isinstance(key, int):
            if i == 0 or keys[i - 1] != "end_body":
                raise _unknown(text, option)
            if model_case is not None and key >= len(model_case.end_body):
                raise SweepError(f"{option}: {text}: the model has {len(model_case.end_body)} "
                                 "end bodies (indices from 0)")  # fmt: skip
            continue
        if model is None or key not in model.model_fields:
            raise _unknown(text, option)
        if i == len(keys) - 1:
            if nested_model(model.model_fields[key].annotation) is not None:
                raise SweepError(f'{option}: "{text}" is a table, not a field; name one of its '
                                 f"fields, e.g. {known_paths_below(text)}")  # fmt: skip
            return FieldPath(text.strip(), target, tuple(keys), field_meta(model, key).dimension)
        model = nested_model(model.model_fields[key].annotation)
        if keys[0] == "end_body" and i == 0 and (len(keys) < 2 or not isinstance(keys[1], int)):
            raise SweepError(f'{option}: "{text}": name the end body, e.g. "end_body[0].mass" '
                             'or "end_body.rear.mass"')  # fmt: skip
    raise _unknown(text, option)


def known_paths_below(text: str) -> str:
    """Up to three known paths that start with ``text`` (for messages)."""
    plain = re.sub(r"\[\d+\]", "[0]", text.strip())
    below = [p for p in known_paths() if p.startswith(plain)]
    return ", ".join(f'"{p}"' for p in below[:3]) or '"initial.spin_rate"'


def _quantity(text: str, path: FieldPath, option: str) -> float:
    try:
        return parse_quantity(text.strip(), path.dimension, path.text)
    except QuantityError as exc:
        raise SweepError(f"{option}: {exc}") from None


def _plain(text: str):
    """A non-quantity value: a whole number if it reads as one, else the stripped string."""
    text = text.strip().strip('"')
    return int(text) if re.fullmatch(r"[+-]?\d+", text) else text


def _range(text: str, path: FieldPath, option: str) -> tuple[float, ...]:
    """``start:stop:count`` → count evenly spaced SI values, ends included."""
    start, stop, count = (p.strip() for p in text.split(":"))
    if not re.fullmatch(r"\d+", count):
        raise SweepError(f'{option}: {path.text}: range "{text}" needs a whole number of '
                         'values last, e.g. "1 Hz:45 Hz:45"')  # fmt: skip
    n = int(count)
    if n < 1:
        raise SweepError(f'{option}: {path.text}: range "{text}" is empty (count {n}); give '
                         'at least one value, e.g. "1 Hz:45 Hz:45"')  # fmt: skip
    _check_points(n, f'{option}: {path.text}: range "{text}"')
    a, b = _quantity(start, path, option), _quantity(stop, path, option)
    if n == 1 and a != b:
        raise SweepError(f'{option}: {path.text}: range "{text}" has one value but two ends; '
                         "use a count of at least 2")  # fmt: skip
    return tuple(a + (b - a) * k / (n - 1) for k in range(n)) if n > 1 else (a,)


def _check_points(count: int, what: str) -> None:
    """Raise :class:`SweepError` (``what`` names the option) when ``count`` points exceed the
    bound :data:`quadmodes.limits.SWEEP_POINTS`."""
    try:
        bound = SWEEP_POINTS.value()
    except LimitError as exc:
        raise SweepError(str(exc)) from None
    if count > bound:
        raise SweepError(f"{what}: {count:,} points, more than the limit of {bound:,.0f}; "
                         f"use fewer values, {SWEEP_POINTS.raise_hint(count)}")  # fmt: skip


def _check_modes(values: tuple, option: str) -> None:
    """Raise :class:`SweepError` for a mode count above :data:`quadmodes.limits.REDUCED_MODES`
    (refused here, before any point runs)."""
    try:
        bound = REDUCED_MODES.value()
    except LimitError as exc:
        raise SweepError(str(exc)) from None
    for n in values:
        if isinstance(n, int) and n > bound:
            raise SweepError(f"{option}: reduced.modes = {n}: more than the limit of {bound:,.0f} "
                             f"{REDUCED_MODES.what}; use fewer modes (the paper cases use 5), "
                             f"{REDUCED_MODES.raise_hint(n)}")  # fmt: skip


def parse_values(text: str, path: FieldPath, option: str = "--param") -> tuple:
    """The values of ``VALUES`` for ``path`` (module docstring); raises :class:`SweepError`."""
    text = text.strip()
    if not text:
        raise SweepError(f'{option}: {path.text}: no values; give e.g. '
                         f'"{path.text}={_example(path)}"')  # fmt: skip
    if path.dimension is None:
        if ":" in text:
            raise SweepError(f"{option}: {path.text} is not a quantity: give a comma list, "
                             'not a range (e.g. "reduced.formulation=Q,L")')  # fmt: skip
        values = tuple(_plain(v) for v in text.split(",") if v.strip())
        if path.keys == ("reduced", "modes"):
            _check_modes(values, option)
        return values
    parts = text.split(",")
    if any(not v.strip() for v in parts):
        raise SweepError(f'{option}: {path.text}: empty item in the list "{text}"; e.g. '
                         '"10 Hz, 20 Hz"')  # fmt: skip
    values: list[float] = []
    for item in parts:
        if item.count(":") == 2:
            values.extend(_range(item, path, option))
            _check_points(len(values), f"{option}: {path.text}")
        elif ":" in item:
            raise SweepError(f'{option}: {path.text}: "{item.strip()}" is neither a quantity nor '
                             'a range start:stop:count; e.g. "1 Hz:45 Hz:45"')  # fmt: skip
        else:
            values.append(_quantity(item, path, option))
    return tuple(values)


def _example(path: FieldPath) -> str:
    return {"angular_rate": "1 Hz:45 Hz:45", "pressure": "0.2 psi, 0.3 psi",
            "time": "2 s"}.get(path.dimension or "", "...")  # fmt: skip


def parse_param(text: str, model_case: Case | None = None, option: str = "--param"
                ) -> SweepParameter:  # fmt: skip
    """One ``PATH=VALUES`` string → :class:`SweepParameter` (name: the path's last key)."""
    path_text, sep, values = text.partition("=")
    if not sep or not path_text.strip():
        raise SweepError(f'{option} "{text}": write PATH=VALUES, e.g. '
                         '"initial.spin_rate=1 Hz:45 Hz:45"')  # fmt: skip
    shown = f'{option} "{text}"'
    path = resolve_path(path_text, model_case, shown)
    return SweepParameter(path, path.field, parse_values(values, path, shown))


def unique_names(params: list[SweepParameter]) -> list[SweepParameter]:
    """``params`` with distinct dimension names: a repeated last key is prefixed by the keys
    before it (``end_body_1_mass``); a path given twice raises :class:`SweepError`."""
    texts = [p.path.keys for p in params]
    if len(set(texts)) < len(texts):
        raise SweepError("--param: the same field is given twice; give each path once")
    names = [p.name for p in params]
    out = []
    for p in params:
        name = p.name
        if names.count(name) > 1:
            name = "_".join(str(k) for k in p.path.keys)
        out.append(SweepParameter(p.path, name, p.values))
    return out


def grid(params: list[SweepParameter], zipped: bool = False) -> list[tuple[int, ...]]:
    """Index tuples (one per point) over the swept parameters: the cartesian product (last
    parameter fastest) or, ``zipped``, the k-th value of each (all lists equally long)."""
    swept = [p for p in params if p.swept]
    if not swept:
        return [()]
    if zipped:
        lengths = {len(p.values) for p in swept}
        if len(lengths) > 1:
            detail = ", ".join(f"{p.name}: {len(p.values)}" for p in swept)
            raise SweepError(f"--zip: the swept lists differ in length ({detail}); give each "
                             "the same number of values")  # fmt: skip
        return [(k,) * len(swept) for k in range(lengths.pop())]
    sizes = [len(p.values) for p in swept]
    _check_points(math.prod(sizes), "--param: the grid " + " × ".join(map(str, sizes)))
    return list(itertools.product(*(range(n) for n in sizes)))
