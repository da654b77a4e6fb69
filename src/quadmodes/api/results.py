"""Results back in Python: :func:`open_results` reads what a command wrote (``results.nc`` of
``run``, ``comparison.nc`` of ``compare``, ``campbell.nc`` of ``campbell``, ``sweep.nc`` or
``sweep.zarr`` of ``sweep``, or the folder holding one) into a :class:`Results`: the dataset
(xarray, SI with units in attributes), the summary the command wrote beside it, and
:meth:`Results.plot`, which draws a figure with the very function the command used, so a
figure redrawn from the file is the PNG the command wrote (docs/api.md, "Results back in
Python")."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from quadmodes.errors import InputError

__all__ = ["Results", "open_results"]

#: File names each command writes, in the order a folder is searched.
_FILES = ("results.nc", "comparison.nc", "campbell.nc", "sweep.zarr", "sweep.nc")
#: The JSON summary beside each kind's dataset.
_SUMMARY = {"run": "summary.json", "spin-up": "summary.json", "comparison": "comparison.json",
            "sweep": "sweep.json"}  # fmt: skip


def _kind(ds: xr.Dataset) -> str | None:
    """The kind of results in ``ds`` by its ``format`` attribute (Campbell files: by their
    variables), None if it is none of quadmodes's."""
    fmt = str(ds.attrs.get("format", ""))
    kinds = {"quadmodes-run-results": "run", "quadmodes-spinup-results": "spin-up",
             "quadmodes-comparison": "comparison", "quadmodes-sweep": "sweep"}  # fmt: skip
    if fmt in kinds:
        return kinds[fmt]
    if {"branch_label", "frequency", "divergence_spin"} <= set(ds.variables):
        return "campbell"
    return None


def _locate(path: Path) -> Path:
    if not path.exists():
        raise InputError(f"open_results: {path} does not exist; give a results file (results.nc, "
                         "comparison.nc, campbell.nc, sweep.nc) or the folder a command wrote")  # fmt: skip
    if path.is_dir() and path.suffix != ".zarr":
        found = [path / n for n in _FILES if (path / n).exists()]
        if not found:
            raise InputError(f"open_results: {path} holds no {', '.join(_FILES)}; give the folder "
                             "a command wrote (e.g. OUT/<case> of quadmodes run -o OUT)")  # fmt: skip
        return found[0]
    return path


def _load(path: Path) -> xr.Dataset:
    """The dataset at ``path``, loaded into memory (the file is closed)."""
    try:
        if path.suffix == ".zarr":
            from quadmodes.sweeps.store import open_sweep

            return open_sweep(path)
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            return ds.load()
    except (OSError, ValueError) as exc:
        raise InputError(f"open_results: {path} is not a NetCDF file quadmodes can read ({exc})") from exc


def _run_summary(ds: xr.Dataset) -> dict:
    from quadmodes.runs.results import spinup_summary, summary

    return spinup_summary(ds) if ds.attrs.get("format") == "quadmodes-spinup-results" else summary(ds)


def _campbell_summary(ds: xr.Dataset) -> dict:
    spin = np.asarray(ds["spin"].values, float) / (2 * math.pi)
    return {"formulation": str(ds.attrs.get("formulation", "")), "body": str(ds.attrs.get("body", "")),
            "spin_min_hz": float(spin.min()) if spin.size else None,
            "spin_max_hz": float(spin.max()) if spin.size else None, "points": int(spin.size),
            "branches": [str(v) for v in ds["branch_label"].values],
            "divergence_hz": [float(w) / (2 * math.pi) for w in ds["divergence_spin"].values]}  # fmt: skip


def _summary(kind: str, ds: xr.Dataset, path: Path) -> dict:
    """The summary the command wrote beside the dataset, else one made from the dataset."""
    beside = path.parent / _SUMMARY[kind] if kind in _SUMMARY else None
    if beside is not None and beside.is_file():
        try:
            return json.loads(beside.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            pass  # unreadable: made from the dataset below
    if kind in ("run", "spin-up"):
        return _run_summary(ds)
    if kind == "campbell":
        return _campbell_summary(ds)
    return {"dimensions": {str(k): int(v) for k, v in ds.sizes.items()},
            "attributes": {k: v for k, v in ds.attrs.items() if isinstance(v, str | int | float)}}


def _figures(kind: str, ds: xr.Dataset) -> dict[str, Callable]:
    """name -> draw(unit) -> Figure of the figures this kind of results has."""
    if kind == "run":
        from quadmodes.io.plots import RUN_FIGURES, run_figure

        return {n: (lambda unit, n=n: run_figure(ds, n)) for n in RUN_FIGURES}
    if kind == "spin-up":
        from quadmodes.io.plots import tip_deflection_figure

        return {"tip_deflection": lambda unit: tip_deflection_figure(ds)}
    if kind == "comparison":
        from quadmodes.analysis.comparison_figures import COMPARISON_FIGURES, comparison_figure

        return {n: (lambda unit, n=n: comparison_figure(ds, n)) for n in COMPARISON_FIGURES}
    if kind == "campbell":
        return {"campbell": lambda unit: _campbell_figure(ds, unit)}
    from quadmodes.sweeps.plots import SWEEP_FIGURES, figure_names

    return {n: (lambda unit, n=n: SWEEP_FIGURES[n](ds, None, unit)) for n in figure_names(ds)}


def _campbell_figure(ds: xr.Dataset, unit: str):
    from quadmodes.analysis.campbell_figure import plot_campbell
    from quadmodes.analysis.campbell_output import from_dataset
    from quadmodes.io.figures import plain_numbers

    result, markers = from_dataset(ds)
    return plain_numbers(plot_campbell(result, markers=markers, unit=unit))


@dataclass(frozen=True)
class Results:
    """What a command wrote, read back (:func:`open_results`).

    ``kind``: "run", "spin-up", "comparison", "campbell" or "sweep". ``path``: the file read.
    ``data``: its xarray Dataset (SI; every variable with ``units`` and ``long_name``).
    ``summary``: the command's summary dict (``summary.json``, ``comparison.json``,
    ``sweep.json`` beside the file; made from the dataset when absent). ``figure_names``: the
    figures :meth:`plot` draws, named as the PNG files of the command without ``.png``
    (comparisons: without ``compare_``).
    """

    kind: str
    path: Path
    data: xr.Dataset = field(repr=False)
    summary: dict = field(repr=False)
    _draw: dict = field(repr=False, compare=False)

    @property
    def figure_names(self) -> tuple[str, ...]:
        return tuple(self._draw)

    def plot(self, name: str | None = None, unit: str = "Hz"):
        """The figure ``name`` (default the first of :attr:`figure_names`: a run's cone angle,
        a comparison's modal amplitude, the Campbell diagram) as a matplotlib Figure (on its
        own Agg canvas: ``fig.savefig(...)``, or display it in a notebook), drawn by the
        command's own function; ``unit`` ("Hz", "rpm", "rad/s") the frequency unit of Campbell
        and sweep figures (the CLI's ``--units``; other figures keep their file's units)."""
        from quadmodes.io.display_units import frequency_unit

        try:
            frequency_unit(unit, "plot(unit=)")  # a bad unit: one line naming the choices
        except ValueError as exc:
            raise InputError(str(exc)) from None
        if not self._draw:
            raise InputError(f"plot: {self.path} has no figures (a sweep without a swept spin rate)")
        name = next(iter(self._draw)) if name is None else name
        if name not in self._draw:
            raise InputError(f"plot: no figure {name!r} in these {self.kind} results; use one of "
                             f"{', '.join(self._draw)}")  # fmt: skip
        return self._draw[name](unit)

    def plots(self, unit: str = "Hz") -> dict:
        """Every figure, name -> matplotlib Figure (:meth:`plot`)."""
        return {name: self.plot(name, unit) for name in self._draw}


def open_results(path: str | os.PathLike[str]) -> Results:
    """Read back what ``run``, ``compare``, ``campbell`` or ``sweep`` wrote: ``path`` is the
    file (``results.nc``, ``comparison.nc``, ``campbell.nc``, ``sweep.nc``/``sweep.zarr``) or
    the folder holding one (a run's ``OUT/<case>``), recognised by its contents. Returns a
    :class:`Results`: ``data`` (xarray, SI: s, rad, rad/s, J, kg m^2/s, with ``units``
    attributes), ``summary`` (keys carry their units: ``_hz``, ``_deg``, ``_s``),
    ``plot(name, unit="Hz")`` (a matplotlib Figure)."""
    found = _locate(Path(path))
    ds = _load(found)
    kind = _kind(ds)
    if kind is None:
        raise InputError(f"open_results: {found} is not a results file of quadmodes (no run, "
                         "comparison, Campbell or sweep data in it)")  # fmt: skip
    return Results(kind, found, ds, _summary(kind, ds, found), _figures(kind, ds))
