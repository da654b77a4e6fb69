"""A whole sweep from its parameter texts to its files, for the command line and the Python
API alike: plan (every point validated first), execute on a dask client (per-point files,
resume), the full-order markers where asked, then ``sweep.nc`` (or ``sweep.zarr``),
``sweep.json``, the figures and ``report.html`` in one folder."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

from quadmodes.case import RunCase
from quadmodes.io.atomic import write_text
from quadmodes.sweeps.engine import SweepOutcome, SweepPlan, dask_client, execute, plan_sweep
from quadmodes.sweeps.overrides import apply_values
from quadmodes.sweeps.params import SweepError, parse_param, resolve_path, unique_names
from quadmodes.sweeps.store import choose_format, write_dataset


def plan_from_texts(run: RunCase, texts: Sequence[str], zipped: bool = False,
                    time_run: bool = True, axis: str | None = None) -> SweepPlan:  # fmt: skip
    """The plan of ``run`` swept over ``texts`` (``PATH=VALUES`` each, as ``--param``), its
    ``initial.spin_axis`` set to ``axis`` if given (``--axis``: a name or "a,b,c"); raises
    :class:`SweepError` (one line) for bad input."""
    if not texts:
        raise SweepError('--param: give at least one, e.g. --param "initial.spin_rate=1 Hz:45 Hz:45"')
    model_case = run.model_case()
    if axis is not None:
        path = resolve_path("initial.spin_axis", model_case, "--axis")
        run = apply_values(run, model_case, [(path, axis)], "--axis").run
    params = unique_names([parse_param(t, model_case) for t in texts])
    return plan_sweep(run, params, zipped, time_run)


def write_sweep_files(plan: SweepPlan, outcome: SweepOutcome, directory: Path, command: str,
                      plots: bool = True, fmt: str | None = None, unit="Hz"):  # fmt: skip
    """``sweep.nc`` (or ``sweep.zarr``: ``fmt``, :func:`quadmodes.sweeps.store.choose_format`;
    SI), ``sweep.json``, the figures (``plots``) and ``report.html`` in ``directory``, spin
    rates and frequencies of the figures and the report's tables in ``unit`` ("Hz", "rpm" or
    "rad/s"); returns ``(dataset, summary dict)``."""
    from quadmodes.sweeps.dataset import summary, sweep_dataset
    from quadmodes.sweeps.plots import sweep_figures
    from quadmodes.sweeps.report import write_sweep_report

    ds = sweep_dataset(plan, outcome, command)
    path = write_dataset(ds, directory, choose_format(fmt, int(ds.nbytes)))
    info = summary(ds, outcome)
    info["dataset"] = path.name
    info["figures"] = [p.name for p in sweep_figures(ds, directory, unit)] if plots else []
    write_text(directory / "sweep.json", json.dumps(info, indent=2) + "\n")
    write_sweep_report(directory, ds, info, command, unit)
    return ds, info


def run_sweep(plan: SweepPlan, directory: Path, *, workers: int | None = None,
              scheduler: str | None = None, command: str = "", plots: bool = True,
              progress: Callable[[int, int], None] | None = None,
              full_order: Sequence[float] = (), fmt: str | None = None):  # fmt: skip
    """Execute ``plan`` on a LocalCluster of ``workers`` (default one per core) or on the
    scheduler at ``scheduler``, writing into ``directory``; at the spins ``full_order`` (rad/s)
    also the full-order markers (:mod:`quadmodes.sweeps.full_order`); ``fmt`` as in
    :func:`write_sweep_files`. Returns ``(dataset, summary, outcome)``. ``progress(done,
    total)`` after every point."""
    from quadmodes.sweeps.full_order import full_order_cases, run_full_order

    directory = Path(directory)
    cases = full_order_cases(plan, full_order) if full_order else []
    with dask_client(workers, scheduler) as client:
        directory.mkdir(parents=True, exist_ok=True)
        outcome = execute(plan, directory, client, progress or (lambda done, total: None))
        if cases:
            outcome.full_order, outcome.full_order_failures = run_full_order(
                cases, directory, client)
    ds, info = write_sweep_files(plan, outcome, directory, command, plots, fmt)
    return ds, info, outcome
