"""``quadmodes sweep``: a run case swept over case fields on dask.distributed (docs/sweeps.md).

Everything is validated before any work (every point's case, the output folder, the scheduler),
so bad input prints one ``error:`` line, exits with status 2 and writes nothing. Finished points
are kept in ``DIR/points/`` as they come (a rerun skips them); ``sweep.nc``, ``sweep.json`` and
the figures are written at the end, each atomically.
"""

from __future__ import annotations

import json
import shlex
import sys
import tomllib
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from quadmodes.case import load_run_case, run_case_from_dict
from quadmodes.cli.analysis_commands import FULL_ORDER_HELP, parse_full_order
from quadmodes.cli.common import (
    axis_option,
    case_argument,
    check_output_folder,
    err,
    one_line_errors,
    out,
    parse_units,
    progress_bars,
    units_option,
)
from quadmodes.cli.completion import choices
from quadmodes.sweeps.params import SweepError


def load_sweep_case(name_or_path: str):
    """(run case, ``[sweep]`` parameter strings, zip flag): a run-case file may carry a
    ``[sweep]`` table (``param = ["initial.spin_rate=1 Hz:45 Hz:45"]``, ``zip = false``)."""
    path = Path(name_or_path).expanduser()
    if path.suffix != ".toml" or not path.is_file():
        return load_run_case(name_or_path), [], False
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return load_run_case(name_or_path), [], False  # the loader reports it
    table = data.pop("sweep", None)
    if table is None:
        return load_run_case(name_or_path), [], False
    params = table.get("param", [])
    if isinstance(params, str):
        params = [params]
    unknown = set(table) - {"param", "zip"}
    if unknown or not all(isinstance(p, str) for p in params):
        raise SweepError(f"{path}: [sweep]: keys are param (a list of \"PATH=VALUES\" strings) "
                         "and zip (true/false)")  # fmt: skip
    run = run_case_from_dict(data, source=str(path), base_dir=path.resolve().parent)
    return run, list(params), bool(table.get("zip", False))


def _plan(case: str, param: list[str], zipped: bool, time_run: bool, axis: str | None = None):
    from quadmodes.sweeps.run import plan_from_texts

    run, from_file, zip_file = load_sweep_case(case)
    return plan_from_texts(run, from_file + list(param or []), zipped or zip_file, time_run, axis)


def _write(plan, outcome, directory: Path, plots: bool = True, fmt: str | None = None,
           unit="Hz") -> dict:  # fmt: skip
    from quadmodes.sweeps.run import write_sweep_files

    command = shlex.join(["quadmodes", *sys.argv[1:]])
    return write_sweep_files(plan, outcome, directory, command, plots, fmt, unit)[1]


def _full_order(cases, directory: Path, client):
    """The full-order markers at ``cases`` (:mod:`quadmodes.sweeps.full_order`), with
    progress."""
    from quadmodes.sweeps.full_order import run_full_order

    with progress_bars(True) as bars:
        return run_full_order(cases, directory, client,
                              lambda done, total: bars("full-order linearisations",
                                                       done / max(total, 1)))  # fmt: skip


def _report(info: dict, directory: Path, unit) -> None:
    """The summary lines: counts, critical speeds and full-order spins in ``unit``, failures."""
    u = unit.name
    out.print(f"sweep: {info['points']} points ({info['resumed']} from earlier files, "
              f"{info['failed']} failed) in {info['wall_s']:.1f} s -> "
              f"{escape(str(directory))}/{info.get('dataset', 'sweep.nc')}",
              highlight=False)  # fmt: skip
    for c in info["critical_speeds"]:
        partner = f" + {c['partner']}" if c["partner"] else ""
        out.print(f"  critical speed {unit.from_hz(c['spin_hz']):.4g} {u}: {c['kind']} of "
                  f"{escape(c['branch'])}"
                  f"{escape(partner)}", highlight=False)  # fmt: skip
    for spin in info.get("full_order", []):
        worst = max((abs(r["relative_error"]) for r in spin["roots"]
                     if r["relative_error"] is not None), default=float("nan"))  # fmt: skip
        out.print(f"  full order at {unit.from_hz(spin['spin_hz']):.4g} {u}: {len(spin['roots'])} roots, "
                  f"matched branches within {100 * worst:.3g} %", highlight=False)  # fmt: skip
    for message in info["failures"].values():
        err.print(f"warning: point failed: {escape(message)}", highlight=False, soft_wrap=True)
    for worker in info.get("lost_workers", []):
        err.print(f"note: worker {escape(worker)} left the cluster during the sweep; its points "
                  "were rerun on the others", highlight=False, soft_wrap=True)  # fmt: skip
    for spin, message in info.get("full_order_failures", {}).items():
        err.print(f"warning: full order at {escape(spin)} failed: {escape(message)}",
                  highlight=False, soft_wrap=True)  # fmt: skip


SweepCase = case_argument("run case (built-in name or TOML file)", "run")
SweepAxis = axis_option("body-frame spin axis of every point (sets initial.spin_axis): x, y, z, "
                        "minor, intermediate, major or three numbers such as 0,0,1; default: "
                        "the run case's initial.spin_axis")  # fmt: skip
SweepUnits = units_option("the printed critical speeds and the figures (sweep.nc stays SI)")


def sweep_command(
    case: SweepCase,
    param: Annotated[list[str], typer.Option(
        "--param", help='PATH=VALUES, e.g. "initial.spin_rate=1 Hz:45 Hz:45" or '
        '"pressure.value=0.2 psi, 0.3 psi"; one value only overrides the field')] = None,
    zipped: Annotated[bool, typer.Option("--zip", help="zip the lists instead of the "
                                         "cartesian product")] = False,
    workers: Annotated[int | None, typer.Option(help="local worker processes (default: one "
                                                "per core)", min=1)] = None,
    scheduler: Annotated[str | None, typer.Option(help="address of an existing dask "
                                                  "scheduler, e.g. tcp://host:8786")] = None,
    output_dir: Annotated[Path, typer.Option("-o", "--output", help="output folder")] = Path(
        "sweep-out"),
    no_time_run: Annotated[bool, typer.Option("--no-time-run", help="linearisation and "
                                              "energy-sink estimate only")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="print the summary as JSON")] = False,
    plots: Annotated[bool, typer.Option("--plots/--no-plots", help="write the PNG figures")] = True,
    axis: SweepAxis = None,
    full_order: Annotated[str | None, typer.Option("--full-order", help=FULL_ORDER_HELP.replace(
        "campbell", "sweep").replace("sweep.png", "the Campbell diagram"))] = None,
    fmt: Annotated[str | None, typer.Option("--format", autocompletion=choices("netcdf", "zarr"),
                                            help="netcdf (sweep.nc) or zarr "
                                            "(sweep.zarr, the zarr extra); default netcdf, "
                                            "zarr above 256 MiB when installed")] = None,
    units: SweepUnits = "Hz",
) -> None:
    """Sweep a run case over case fields: stability map, critical speeds, coning time constants.

    Writes DIR/sweep.nc (one dimension per swept parameter; or sweep.zarr; SI), sweep.json,
    campbell.png, stability.png and energy_sink.png (spin rates and frequencies in --units, Hz by
    default); finished points stay in DIR/points/ so that
    the same command run again skips them."""
    from quadmodes.sweeps.engine import dask_client, execute
    from quadmodes.sweeps.full_order import full_order_cases
    from quadmodes.sweeps.store import check_format

    if workers is not None and scheduler:
        with one_line_errors():
            raise SweepError("--workers: not used with --scheduler (the cluster has its own "
                             "workers); give one of them")  # fmt: skip
    with one_line_errors():
        fmt = check_format(fmt)
        unit = parse_units(units)
        full_spins = parse_full_order(full_order)
        plan = _plan(case, param, zipped, not no_time_run, axis)
        cases = full_order_cases(plan, full_spins) if full_spins else []
        check_output_folder(output_dir, "-o")
    # progress on stderr whatever stdout carries (--json): bars on a terminal, time-stamped
    # lines per 10 % otherwise
    with one_line_errors(), dask_client(workers, scheduler) as client:
        output_dir.mkdir(parents=True, exist_ok=True)
        try:
            with progress_bars(True) as bars:
                outcome = execute(plan, output_dir, client,
                                  lambda done, total: bars("sweep points", done / max(total, 1)))  # fmt: skip
            if cases:
                outcome.full_order, outcome.full_order_failures = _full_order(
                    cases, output_dir, client)
        except KeyboardInterrupt:
            err.print(f"interrupted: the finished points are in {escape(str(output_dir))}/points; "
                      "run the same command again to go on", highlight=False)  # fmt: skip
            raise typer.Exit(code=130) from None
    info = _write(plan, outcome, output_dir, plots, fmt, unit)
    if as_json:
        out.print_json(json.dumps(info))
    else:
        _report(info, output_dir, unit)
    if outcome.failures or outcome.full_order_failures:
        raise typer.Exit(code=1)
