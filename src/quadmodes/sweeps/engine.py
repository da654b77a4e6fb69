"""Running a sweep on dask.distributed: the plan, the client, per-point files and resume.

Stages::

    RunCase + [SweepParameter] ──plan_sweep──▶ SweepPlan (every point validated before any work)
    SweepPlan + Client ──execute──▶ SweepOutcome (point results, failures, critical speeds)

The same code runs on a :class:`distributed.LocalCluster` (default: one worker process per
core, one thread each, BLAS threads limited to one) and on an existing cluster
(``--scheduler ADDRESS``). One task builds the reduced model of each structural key
(:func:`quadmodes.sweeps.points.structural_key`); the point tasks take its future, so the model
is built once and shipped to the workers by dask. A task that raises is retried once; a worker
that dies costs only the points it was running (the scheduler gives each task one more try,
``allowed-failures`` = 1 on the local cluster); either failure is then reported for that point
alone (at most one point per worker thread is in flight, so a dying worker was running only
its own point). Each finished point is written at once, atomically, to ``DIR/points/<point>.json``
(named by the point's index and a hash of its run and model case and of the code that computes
it), so a sweep that stops and is run again skips the points already done.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from quadmodes._version import __version__
from quadmodes.case import Case, RunCase
from quadmodes.io.atomic import write_text
from quadmodes.models.cache import fingerprint_files
from quadmodes.sweeps import critical as crit
from quadmodes.sweeps.cluster import lost_workers
from quadmodes.sweeps.overrides import PointCase, apply_values
from quadmodes.sweeps.params import SweepError, SweepParameter, grid
from quadmodes.sweeps.points import model_for_group, run_point, structural_key

FORMAT = "quadmodes-sweep-point"
FORMAT_VERSION = 1


@dataclass(frozen=True, eq=False)
class PlannedPoint:
    """One point: ``index`` (position in the plan), ``where`` (index per swept parameter),
    ``values`` (name → SI value of each swept parameter), its :class:`PointCase` and file key."""

    index: int
    where: tuple[int, ...]
    values: dict
    case: PointCase
    key: str

    @property
    def label(self) -> str:
        return ", ".join(f"{k} = {v:.6g}" if isinstance(v, float) else f"{k} = {v}"
                         for k, v in self.values.items()) or "the point"  # fmt: skip


@dataclass(frozen=True, eq=False)
class SweepPlan:
    """The sweep: base run and model case, parameters (fixed and swept), zipped or product,
    whether each point has a time run, and the points."""

    run: RunCase
    model_case: Case
    params: tuple[SweepParameter, ...]
    zipped: bool
    time_run: bool
    points: tuple[PlannedPoint, ...]

    @property
    def swept(self) -> tuple[SweepParameter, ...]:
        return tuple(p for p in self.params if p.swept)


#: Source folders and files whose code computes a point: a change in any of them re-runs every point (the
#: reduced models themselves stay cached by their own key).
POINT_CODE = ("fe", "structure", "mesh", "linalg", "rom", "models", "runs", "analysis", "signals.py",
              "sweeps/points.py", "sweeps/overrides.py",
              "sweeps/full_order.py")


@functools.cache
def point_code_fingerprint() -> str:
    """:func:`quadmodes.models.cache.fingerprint_files` of :data:`POINT_CODE`."""
    return fingerprint_files(Path(__file__).resolve().parents[1], POINT_CODE)


def _point_key(case: PointCase, time_run: bool) -> str:
    text = "\n".join([case.run.to_toml(), case.model_case.to_toml(), f"time_run={time_run}",
                      __version__, point_code_fingerprint(), f"format={FORMAT_VERSION}"])  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def plan_sweep(run: RunCase, params: list[SweepParameter], zipped: bool = False,
               time_run: bool = True) -> SweepPlan:  # fmt: skip
    """Every point of the sweep, validated (raises :class:`SweepError` before any work)."""
    if run.spinup is not None:
        raise SweepError("RUN_CASE: a [spinup] run cannot be swept; give a free-body run case")
    model_case = run.model_case()
    fixed = [(p.path, p.values[0]) for p in params if not p.swept]
    base = apply_values(run, model_case, fixed, "fixed values") if fixed else PointCase(run, model_case)
    swept = [p for p in params if p.swept]
    points = []
    for i, where in enumerate(grid(params, zipped)):
        values = {p.name: p.values[k] for p, k in zip(swept, where, strict=True)}
        pairs = [(p.path, p.values[k]) for p, k in zip(swept, where, strict=True)]
        label = ", ".join(f"{n} = {v}" for n, v in values.items())
        case = apply_values(base.run, base.model_case, pairs, label) if pairs else base
        points.append(PlannedPoint(i, tuple(where), values, case, _point_key(case, time_run)))
    return SweepPlan(base.run, base.model_case, tuple(params), zipped, time_run, tuple(points))


# ---------------------------------------------------------------------------------------------
# per-point files
# ---------------------------------------------------------------------------------------------


def point_path(directory: Path, point: PlannedPoint) -> Path:
    return Path(directory) / "points" / f"point-{point.index:05d}-{point.key}.json"


def save_point(directory: Path, point: PlannedPoint, result: dict) -> Path:
    """Write one finished point atomically (:func:`quadmodes.io.atomic.write_text`); files of
    the same point index with another key (an earlier case or code) are removed."""
    path = point_path(directory, point)
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {"format": FORMAT, "format_version": FORMAT_VERSION, "key": point.key,
              "index": point.index, "values": point.values, "result": result}  # fmt: skip
    write_text(path, json.dumps(record, indent=1) + "\n")
    for stale in path.parent.glob(f"point-{point.index:05d}-*.json"):
        if stale != path:  # the same point from an earlier case or code: replaced
            stale.unlink(missing_ok=True)
    return path


def load_done(directory: Path, plan: SweepPlan) -> dict[int, dict]:
    """Results of the points already saved in ``directory`` with matching keys."""
    done = {}
    for point in plan.points:
        path = point_path(directory, point)
        if not path.is_file():
            continue
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue  # unreadable: the point is run again
        if record.get("key") == point.key and isinstance(record.get("result"), dict):
            done[point.index] = record["result"]
    return done


# ---------------------------------------------------------------------------------------------
# the client
# ---------------------------------------------------------------------------------------------


@contextlib.contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None) -> Iterator:
    """A :class:`distributed.Client` on ``scheduler`` (an address; :class:`SweepError` if it
    cannot be reached within 5 s or its workers run another version) or on a new private
    LocalCluster with ``workers`` processes (default one per core): :mod:`quadmodes.sweeps.
    cluster`."""
    from quadmodes.sweeps import cluster

    with (cluster.external_client(scheduler) if scheduler else cluster.local_client(workers)) as c:
        yield c


# ---------------------------------------------------------------------------------------------
# execution
# ---------------------------------------------------------------------------------------------


def _group_task(points: list[PointCase]):
    return model_for_group(points)


def _point_task(point: PointCase, group, position: int, time_run: bool) -> dict:
    model, counts = group
    return run_point(point, model, counts[position], time_run)


def _refine_task(group, bracket: crit.Bracket, formulation: str, axis=None) -> dict | None:
    if bracket.reason == "extend":
        found = crit.extend(group[0], bracket, formulation, axis)
        return None if found is None else crit.critical_speed_record(found)
    return crit.critical_speed_record(crit.refine(group[0], bracket, formulation, axis))


@dataclass(eq=False)
class SweepOutcome:
    """Results per point (None: failed), failure messages by point index, the critical speeds
    (records of :func:`quadmodes.sweeps.critical.critical_speed_record`), how many points were
    taken from earlier files, and the wall time of the execution (s); with ``--full-order`` the
    full-order markers (:class:`quadmodes.analysis.full_order_markers.FullOrderMarkers`) and the
    failures of their spins; the workers that left the cluster during the sweep (their points
    were rerun elsewhere)."""

    results: list[dict | None]
    failures: dict[int, str] = field(default_factory=dict)
    critical: list[dict] = field(default_factory=list)
    resumed: int = 0
    wall_s: float = 0.0
    full_order: object | None = None
    full_order_failures: dict[str, str] = field(default_factory=dict)
    lost_workers: list[str] = field(default_factory=list)


def _message(future) -> str:
    exc = future.exception()
    return " ".join(f"{type(exc).__name__}: {exc}".split())[:400]


class _Groups:
    """Model futures by structural key, submitted when first needed."""

    def __init__(self, client, plan: SweepPlan):
        self.client, self.futures = client, {}
        self.members: dict[str, list[int]] = {}
        for p in plan.points:
            self.members.setdefault(structural_key(p.case), []).append(p.index)
        self.plan = plan

    def future(self, index: int):
        """(model-group future, position of point ``index`` in its group)."""
        key = structural_key(self.plan.points[index].case)
        if key not in self.futures:
            cases = [self.plan.points[i].case for i in self.members[key]]
            self.futures[key] = self.client.submit(_group_task, cases, pure=False, retries=1)
        return self.futures[key], self.members[key].index(index)


def _free_workers(client, busy: list[str]) -> list[str]:
    """One address per free worker thread of the cluster, given the workers of the points in
    flight (``busy``); least loaded first."""
    try:
        threads = client.nthreads()
    except (OSError, TimeoutError):
        return []
    free = []
    for address, n in sorted(threads.items()):
        free.extend([address] * max(0, int(n) - busy.count(address)))
    # a point whose worker died is still in flight elsewhere: it holds a thread too
    return free[: max(0, sum(int(n) for n in threads.values()) - len(busy))]


def execute(plan: SweepPlan, directory: Path, client,
            progress: Callable[[int, int], None] | None = None,
            point_task: Callable | None = None) -> SweepOutcome:  # fmt: skip
    """Run the points of ``plan`` not yet saved in ``directory`` on ``client``, saving each as
    it finishes; then refine the critical speeds. ``progress(done, total)`` after each point.
    ``point_task(case, group, position, time_run)`` replaces the task of a point (default:
    :func:`quadmodes.sweeps.points.run_point` on the group's model).

    At most one point per worker thread is in flight, sent to a free worker (a loose
    restriction: it moves if that worker goes away); the next is submitted when one finishes. So
    a worker that dies was running only its own point, and the scheduler's count of suspicious
    tasks blames that point alone."""
    import time

    from distributed import as_completed

    start = time.perf_counter()
    directory = Path(directory)
    done = load_done(directory, plan)
    results: list[dict | None] = [done.get(p.index) for p in plan.points]
    outcome = SweepOutcome(results, resumed=len(done))
    groups = _Groups(client, plan)
    todo = [p for p in plan.points if p.index not in done]
    futures: dict = {}
    pending = as_completed([], loop=client.loop)

    where: dict = {}  # future -> worker it was sent to

    def submit_more() -> None:
        busy = [w for f, w in where.items() if not f.done()]
        free = _free_workers(client, busy)
        if not busy and not free:
            free = [None]  # no worker yet (a new external cluster): the scheduler waits
        for worker in free:
            if not todo:
                break
            p = todo.pop(0)
            group, position = groups.future(p.index)
            placement = {} if worker is None else {"workers": [worker], "allow_other_workers": True}
            fut = client.submit(point_task or _point_task, p.case, group, position,
                                plan.time_run, pure=False, retries=1, **placement)  # fmt: skip
            futures[fut] = p
            where[fut] = worker
            pending.add(fut)

    total = len(plan.points)
    if progress:
        progress(len(done), total)
    workers_at_start = set(client.nthreads())
    submit_more()
    for fut in pending:
        p = futures[fut]
        if fut.status == "finished":
            results[p.index] = fut.result()
            save_point(directory, p, results[p.index])
        else:
            outcome.failures[p.index] = f"{p.label}: {_message(fut)}"
        submit_more()
        if progress:
            progress(sum(r is not None for r in results) + len(outcome.failures), total)
    outcome.lost_workers = lost_workers(workers_at_start, client)
    outcome.critical = _critical_speeds(plan, results, groups, client)
    outcome.wall_s = time.perf_counter() - start
    return outcome


def spin_lines(plan: SweepPlan) -> list[list[int]]:
    """Point indices along the swept ``initial.spin_rate`` (ascending spin), one list per
    combination of the other swept parameters ([] if the spin is not swept; zipped sweeps:
    one line)."""
    swept = plan.swept
    spin_pos = [i for i, p in enumerate(swept) if p.path.keys == ("initial", "spin_rate")]
    if not spin_pos:
        return []
    k = spin_pos[0]
    lines: dict[tuple, list[int]] = {}
    for p in plan.points:
        other = () if plan.zipped else tuple(w for i, w in enumerate(p.where) if i != k)
        lines.setdefault(other, []).append(p.index)
    name = swept[k].name
    return [sorted(line, key=lambda i: plan.points[i].values[name]) for line in lines.values()]


def _critical_speeds(plan: SweepPlan, results, groups: _Groups, client) -> list[dict]:
    """Brackets along every spin line, refined on the workers."""
    name = next((p.name for p in plan.swept if p.path.keys == ("initial", "spin_rate")), None)
    todo = []
    for line in spin_lines(plan):
        spins = [plan.points[i].values[name] for i in line]
        for b in crit.brackets(spins, [results[i] for i in line], line):
            group, _ = groups.future(b.lo)
            form = plan.points[b.lo].case.run.reduced.formulation
            axis = plan.points[b.lo].case.run.initial.spin_axis
            todo.append((b, client.submit(_refine_task, group, b, form, axis, pure=False,
                                          retries=1)))  # fmt: skip
    records = []
    for b, fut in todo:
        try:
            record = fut.result()
            if record is not None:
                records.append(record)
        except Exception as exc:  # a failed refinement keeps the bracket, reported as such
            records.append({**crit.critical_speed_record(crit.CriticalSpeed(
                0.5 * (b.spin_lo + b.spin_hi), "unrefined", "", "", False, b)),
                "error": " ".join(str(exc).split())[:200]})  # fmt: skip
    for r in records:
        r["values"] = {k: v for k, v in plan.points[r["lo"]].values.items() if k != name}
    return sorted(records, key=lambda r: (str(r["values"]), r["spin"]))


def finite_or_none(x):
    """``x`` if a finite float, else None (for JSON summaries)."""
    return float(x) if isinstance(x, int | float) and math.isfinite(x) else None
