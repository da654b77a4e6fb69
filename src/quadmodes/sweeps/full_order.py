"""Full-order linearisation markers of a sweep (``quadmodes sweep --full-order "20 Hz, 41 Hz"``).

At each asked spin the point case of the sweep's first line (the other swept parameters at
their first values, as the Campbell figure shows them) is set to that spin; its reduced model is
the one the sweep uses there (:func:`quadmodes.sweeps.points.model_for_group`, through the shared
cache) and the full-order model is linearised about its own spinning equilibrium about the same
axis (:func:`quadmodes.analysis.full_order_markers.full_order_markers`). One dask task per spin;
each finished spin is kept in ``DIR/points/full-order-<spin>-<hash>.json`` so that a rerun skips
it like the points.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from pathlib import Path

from quadmodes.analysis import full_order_markers as fom
from quadmodes.io.atomic import write_text
from quadmodes.sweeps.engine import SweepPlan, point_code_fingerprint
from quadmodes.sweeps.overrides import PointCase, apply_values
from quadmodes.sweeps.params import SweepError, resolve_path
from quadmodes.sweeps.points import model_for_group, spin_axis_request

FORMAT = "quadmodes-sweep-full-order"


def full_order_cases(plan: SweepPlan, spins: Sequence[float]) -> list[PointCase]:
    """The point case at every spin (rad/s) of ``spins``: the first point's values, the spin
    set (validated; :class:`SweepError` for a value the case rejects or a clamped body)."""
    mc = plan.model_case
    if mc.kind == "beam" and mc.beam.support == "clamped":
        raise SweepError("--full-order: the full-order rotating-frame analysis is for free "
                         "bodies; this beam is clamped to a hub (drop --full-order)")  # fmt: skip
    base = plan.points[0].case if plan.points else PointCase(plan.run, plan.model_case)
    path = resolve_path("initial.spin_rate", mc, "--full-order")
    return [apply_values(base.run, base.model_case, [(path, float(s))],
                         f"--full-order {s / (2 * math.pi):.6g} Hz") for s in spins]  # fmt: skip


def full_order_task(case: PointCase) -> dict:
    """The markers (:func:`quadmodes.analysis.full_order_markers.to_record`) at the spin of
    ``case`` on the reduced model the sweep uses there (runs on a worker)."""
    model, counts = model_for_group([case])
    model = model.select(list(range(counts[0]))) if counts[0] < model.n_modes else model
    run = case.run
    markers = fom.full_order_markers(case.model_case, model, [float(run.initial.spin_rate)],
                                     spin_axis_request(run), run.reduced.formulation,
                                     axis_option="initial.spin_axis")  # fmt: skip
    return fom.to_record(markers)


def _key(case: PointCase) -> str:
    text = "\n".join([FORMAT, case.run.to_toml(), case.model_case.to_toml(),
                      point_code_fingerprint()])  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def record_path(directory: Path, case: PointCase) -> Path:
    spin_hz = float(case.run.initial.spin_rate) / (2 * math.pi)
    return Path(directory) / "points" / f"full-order-{spin_hz:.6g}Hz-{_key(case)}.json"


def _load(path: Path) -> dict | None:
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record.get("markers") if record.get("format") == FORMAT else None


def run_full_order(cases: list[PointCase], directory: Path, client, progress=None
                   ) -> tuple[fom.FullOrderMarkers | None, dict[str, str]]:  # fmt: skip
    """The markers at every case of :func:`full_order_cases` (saved ones loaded, the others
    run on ``client``, saved as they finish) and the failures by spin text. ``progress(done,
    total)`` after each spin."""
    from distributed import as_completed

    records: list[dict | None] = [None] * len(cases)
    futures = {}
    for i, case in enumerate(cases):
        path = record_path(directory, case)
        records[i] = _load(path) if path.is_file() else None
        if records[i] is None:
            futures[client.submit(full_order_task, case, pure=False, retries=1)] = i
    failures: dict[str, str] = {}
    done = len(cases) - len(futures)
    if progress:
        progress(done, len(cases))
    for fut in as_completed(list(futures), loop=client.loop):
        i = futures[fut]
        spin = f"{float(cases[i].run.initial.spin_rate) / (2 * math.pi):.6g} Hz"
        if fut.status == "finished":
            records[i] = fut.result()
            path = record_path(directory, cases[i])
            path.parent.mkdir(parents=True, exist_ok=True)
            write_text(path, json.dumps({"format": FORMAT, "markers": records[i]}) + "\n")
        else:
            exc = fut.exception()
            failures[spin] = " ".join(f"{type(exc).__name__}: {exc}".split())[:400]
        done += 1
        if progress:
            progress(done, len(cases))
    parts = [fom.from_record(r) for r in records if r is not None]
    return (fom.combine(parts) if parts else None), failures
