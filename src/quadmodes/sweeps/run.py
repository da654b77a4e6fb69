"""A whole sweep from its parameter texts to its files, for the command line and the Python
API alike: plan (every point validated first), execute on a dask client (per-point files,
resume), then ``sweep.nc``, ``sweep.json``, the figures and ``report.html`` in one folder."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

from quadmodes.case import RunCase
from quadmodes.io.atomic import atomic_path, write_text
from quadmodes.sweeps.engine import SweepOutcome, SweepPlan, dask_client, execute, plan_sweep
from quadmodes.sweeps.params import SweepError, parse_param, unique_names


def plan_from_texts(run: RunCase, texts: Sequence[str], zipped: bool = False,
                    time_run: bool = True) -> SweepPlan:  # fmt: skip
    """The plan of ``run`` swept over ``texts`` (``PATH=VALUES`` each, as ``--param``);
    raises :class:`SweepError` (one line) for bad input."""
    if not texts:
        raise SweepError('--param: give at least one, e.g. --param "initial.spin_rate=1 Hz:45 Hz:45"')
    model_case = run.model_case()
    params = unique_names([parse_param(t, model_case) for t in texts])
    return plan_sweep(run, params, zipped, time_run)


def write_sweep_files(plan: SweepPlan, outcome: SweepOutcome, directory: Path, command: str,
                      plots: bool = True):  # fmt: skip
    """``sweep.nc``, ``sweep.json``, the figures (``plots``) and ``report.html`` in
    ``directory``; returns ``(dataset, summary dict)``."""
    from quadmodes.sweeps.dataset import summary, sweep_dataset
    from quadmodes.sweeps.plots import sweep_figures
    from quadmodes.sweeps.report import write_sweep_report

    ds = sweep_dataset(plan, outcome, command)
    with atomic_path(directory / "sweep.nc") as tmp:
        ds.to_netcdf(tmp, engine="h5netcdf")
    info = summary(ds, outcome)
    info["figures"] = [p.name for p in sweep_figures(ds, directory)] if plots else []
    write_text(directory / "sweep.json", json.dumps(info, indent=2) + "\n")
    write_sweep_report(directory, ds, info, command)
    return ds, info


def run_sweep(plan: SweepPlan, directory: Path, *, workers: int | None = None,
              scheduler: str | None = None, command: str = "", plots: bool = True,
              progress: Callable[[int, int], None] | None = None):  # fmt: skip
    """Execute ``plan`` on a LocalCluster of ``workers`` (default one per core) or on the
    scheduler at ``scheduler``, writing into ``directory``; returns ``(dataset, summary,
    outcome)``. ``progress(done, total)`` after every point."""
    directory = Path(directory)
    with dask_client(workers, scheduler) as client:
        directory.mkdir(parents=True, exist_ok=True)
        outcome = execute(plan, directory, client, progress or (lambda done, total: None))
    ds, info = write_sweep_files(plan, outcome, directory, command, plots)
    return ds, info, outcome
