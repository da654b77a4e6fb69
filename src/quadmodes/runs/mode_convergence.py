"""Convergence in the number of modes: rerun a prepared run with the next pair-whole mode counts
above its own and compare the headline numbers (``quadmodes run --mode-convergence``).

Stages::

    RunSetup (N modes) + its RunResult ──mode_convergence──▶ {rows: N, N₁, N₂; verdict}

N₁ < N₂ are the next counts above N that keep every degenerate pair whole
(:func:`quadmodes.runs.mode_choice.next_counts`). Each reduced model comes from the cache
(:func:`quadmodes.models.build.reduced_model_for`); a new one reuses the modal model of the
process (inflated state and modes) and pays only the reduction (``reduce_s`` of its row).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from quadmodes.case import CaseError
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import system as rsys
from quadmodes.runs.mode_choice import next_counts, with_modes

Progress = Callable[[str, float], None]

#: Refinements of :func:`mode_convergence`: N → N₁ → N₂.
MODE_STEPS = 2
#: Verdict: converged if every judged headline changes by at most this (relative) from one
#: mode count to the next.
MODE_TOLERANCE = 0.01

#: (key, label, unit, judged) of the headline numbers. |H| drift is round-off for every N
#: (the integrator conserves H); it is reported, not judged.
HEADLINES = (
    ("cone_angle_end_deg", "cone angle end", "deg", True),
    ("cone_angle_change_deg", "cone-angle change", "deg", True),
    ("spin_rate_end_hz", "spin rate end", "Hz", True),
    ("dissipated_energy_J", "dissipated energy", "J", True),
    ("bending_amplitude_max", "peak bending-pair amplitude", "√kg m", True),
    ("H_relative_drift", "|H| drift", "1", False),
)


def _rel(new: float | None, old: float | None) -> float | None:
    """|new − old| / |old|; None if either is missing or not finite, or old is 0."""
    if new is None or old is None or not (math.isfinite(new) and math.isfinite(old)):
        return None
    return abs(new - old) / abs(old) if old != 0.0 else None


def headline(result) -> dict:
    """The headline numbers of a :class:`quadmodes.runs.simulate.RunResult` (keys of
    :data:`HEADLINES`; the bending amplitude ``sqrt(s_b1² + s_b2²)`` in kg^0.5 m, None without a
    bending pair)."""
    d = result.diagnostics
    h = np.asarray(d.H, float)
    h0 = float(np.linalg.norm(h[0]))
    pair = list(result.initial.bending_modes)
    amp = None
    if pair:
        s = rsys.split_state(result.system, result.solution.y)[2]
        amp = float(np.max(np.sqrt(np.sum(s[:, pair] ** 2, axis=1))))
    return {
        "cone_angle_end_deg": float(np.degrees(d.cone_angle[-1])),
        "cone_angle_change_deg": float(np.degrees(d.cone_angle[-1] - d.cone_angle[0])),
        "spin_rate_end_hz": float(d.spin_rate[-1] / (2 * math.pi)),
        "dissipated_energy_J": float(d.E_d[-1]),
        "bending_amplitude_max": amp,
        "H_relative_drift": float(np.max(np.linalg.norm(h - h[0], axis=1)) / h0),
    }


def _row(result, reduce_s: float, previous: dict | None) -> dict:
    """One row: mode count, the modes added since ``previous``, run figures, the headlines and
    their relative changes from ``previous`` (``rel_change_<key>``; None in the first row)."""
    model = result.model
    n = int(result.system.n_modes)
    first = int(previous["n_modes"]) if previous else 0
    row = {
        "n_modes": n,
        "added_modes": [
            {"mode": k + 1, "label": str(model.labels[k]), "frequency_hz": float(model.frequencies_hz[k])}
            for k in range(first, n)
        ] if previous else [],
        "steps": int(result.solution.stats.get("n_steps", 0)),
        "complete": bool(result.complete),
        "valid": None if result.validity is None else bool(result.validity.valid),
        "t_end_s": float(result.diagnostics.t[-1]),
        "wall_s": float(result.wall_s),
        "reduce_s": float(reduce_s),
    }  # fmt: skip
    row.update(headline(result))
    for key, *_ in HEADLINES:
        row[f"rel_change_{key}"] = _rel(row[key], previous[key]) if previous else None
    return row


def verdict(rows: list[dict], tolerance: float = MODE_TOLERANCE) -> dict:
    """Whether the first row's N is converged: every judged headline changes by at most
    ``tolerance`` (relative) to the next count. Also ``converged_at`` (the first N whose change
    to the next row is within it; None), the largest change per step and a one-line ``text``."""
    judged = [key for key, _, _, j in HEADLINES if j]
    steps = []
    for prev, row in zip(rows, rows[1:], strict=False):
        changes = {k: row[f"rel_change_{k}"] for k in judged if row[f"rel_change_{k}"] is not None}
        worst = max(changes, key=changes.get) if changes else None
        steps.append({"from": prev["n_modes"], "to": row["n_modes"], "worst": worst,
                      "worst_rel_change": changes.get(worst) if worst else None,
                      "within": all(v <= tolerance for v in changes.values())})  # fmt: skip
    at = next((s["from"] for s in steps if s["within"]), None)
    ok = bool(steps) and steps[0]["within"]
    labels = {key: label for key, label, _, _ in HEADLINES}
    n0 = rows[0]["n_modes"]
    if not steps:
        text = f"N = {n0}: no larger pair-whole mode count to compare with"
    else:
        s = steps[0]
        change = (
            "no judged change"
            if s["worst"] is None
            else (f"largest change {s['worst_rel_change']:.2g} ({labels[s['worst']]})")
        )
        text = (
            f"N = {n0} {'converged' if ok else 'not converged'} at {100 * tolerance:g} %: "
            f"{change} from N = {s['from']} to {s['to']}"
        )
        if not ok:
            text += f"; first within tolerance: N = {at}" if at else "; none within tolerance"
    return {"tolerance": tolerance, "judged": judged, "converged": ok, "converged_at": at,
            "steps": steps, "text": text}  # fmt: skip


def mode_convergence(
    setup,
    first=None,
    progress: Progress | None = None,
    steps: int = MODE_STEPS,
    tolerance: float = MODE_TOLERANCE,
) -> dict:
    """Run ``setup`` (a :class:`quadmodes.runs.simulate.RunSetup` with N modes) again with the
    next ``steps`` pair-whole mode counts above N (``first``: the run with N modes, if done) and
    return ``{"rows": [...], **verdict(rows, tolerance)}``: per row ``n_modes``,
    ``added_modes``, ``steps``, ``complete``, ``valid``, ``t_end_s``, ``wall_s``, ``reduce_s``
    (s to get its reduced model: 0 for a cache hit), the :data:`HEADLINES` and their
    ``rel_change_*`` from the row before."""
    from quadmodes.runs import simulate

    run = setup.run
    if run.reduced.formulation == "rigid":
        raise CaseError(
            '--mode-convergence: reduced.formulation = "rigid" has no elastic modes',
            field="reduced.formulation",
        )
    result = first if first is not None else simulate.execute(setup, progress)
    rows = [_row(result, 0.0, None)]
    for n in next_counts(setup.model_case, int(run.reduced.modes), steps, progress):
        start = time.perf_counter()
        model = reduced_model_for(setup.model_case, n, progress, spin=run.reference_spin,
                                  axis=run.reference_axis)  # fmt: skip
        reduce_s = time.perf_counter() - start
        sub = simulate.prepare(with_modes(run, n), model, model_case=setup.model_case)
        rows.append(_row(simulate.execute(sub, progress), reduce_s, rows[-1]))
    return {"rows": rows, **verdict(rows, tolerance)}
