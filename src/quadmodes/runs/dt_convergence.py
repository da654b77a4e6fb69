"""Convergence in the time step: rerun a prepared run at dt/2 and dt/4 and judge the headline,
the cone growth (``quadmodes run --dt-convergence``), as ``--mode-convergence`` judges it in N.

Stages::

    RunSetup (dt) + its RunResult ──dt_convergence──▶ {rows: dt, dt/2, dt/4; verdict}

Each row has the end values (cone angle, spin rate, dissipated energy), the cone-angle change
θ(T) − θ(0) and the secular cone-growth rate over the quasi-steady part
(:func:`quadmodes.runs.secular.run_fits`, with its standard error), and their relative changes
from the row before. **Judged** (:func:`verdict`, :data:`DT_TOLERANCE`): the cone-growth rate and
the cone-angle change, the answer a run gives. The end cone angle changes far less than its
growth (θ(T) = θ(0) + growth: a 4e-3 change of the growth is a 1.5e-4 change of θ(T) at 41 Hz
over 2 s), so judging θ(T) would call a step converged that is not. Where the run's cone growth
is not distinguishable from zero (|slope| < 2 standard errors at the finest step: the spin cones
too slowly for the run to see) the rate and the change are ripple, not a headline: the end cone
angle and spin rate are judged instead, and the verdict says so.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from quadmodes.case import CaseError
from quadmodes.runs import secular
from quadmodes.runs.simulate import RunResult, RunSetup, execute

Progress = Callable[[str, float], None]

#: Step refinements of :func:`dt_convergence`: dt, dt/2, dt/4.
DT_FACTORS = (1, 2, 4)
#: Verdict: converged if every judged quantity changes by at most this (relative) from dt to
#: dt/2 (the run's own step against its half).
DT_TOLERANCE = 0.01
#: (key, label, unit) of the row quantities; the first two are the headline (judged when the
#: cone growth is significant), the next two are judged otherwise.
QUANTITIES = (
    ("cone_growth_rate_deg_per_s", "cone-growth rate", "deg/s"),
    ("cone_angle_change_deg", "cone-angle change", "deg"),
    ("cone_angle_deg", "cone angle end", "deg"),
    ("spin_rate_hz", "spin rate end", "Hz"),
    ("dissipated_energy_J", "dissipated energy", "J"),
)


def _rel(new: float, old: float) -> float | None:
    if not (math.isfinite(new) and math.isfinite(old)) or old == 0.0:
        return None
    return abs(new - old) / abs(old)


def _row(result: RunResult, dt: float) -> dict:
    """One row of the table: the run's step, end values, cone growth (change and secular rate
    with its standard error and significance)."""
    d = result.diagnostics
    model = result.model
    fits = secular.run_fits(d.t, d.cone_angle, d.E_d, d.spin_rate, model.frequencies_hz,
                            model.damping_ratio)  # fmt: skip
    return {
        "dt_s": float(dt),
        "steps": int(result.solution.stats.get("n_steps", 0)),
        "complete": bool(result.complete),
        "t_end_s": float(d.t[-1]),
        "cone_angle_deg": float(np.degrees(d.cone_angle[-1])),
        "cone_angle_change_deg": float(np.degrees(d.cone_angle[-1] - d.cone_angle[0])),
        "cone_growth_rate_deg_per_s": float(np.degrees(fits.cone.slope)),
        "cone_growth_rate_se_deg_per_s": float(np.degrees(fits.cone.se)),
        "cone_growth_significant": fits.significant,
        "spin_rate_hz": float(d.spin_rate[-1] / (2 * math.pi)),
        "dissipated_energy_J": float(d.E_d[-1]),
        "wall_s": float(result.wall_s),
    }


def verdict(rows: list[dict], tolerance: float = DT_TOLERANCE) -> dict:
    """Whether the run's dt (the first row) is converged: every judged quantity changes by at
    most ``tolerance`` (relative) from dt to dt/2. Judged: the cone-growth rate and the
    cone-angle change when the cone growth is significant at the finest step, else the end cone
    angle and spin rate (module docstring). Also the largest change per refinement and a
    one-line ``text``."""
    labels = {k: label for k, label, _ in QUANTITIES}
    headline = bool(rows[-1]["cone_growth_significant"])
    judged = [k for k, *_ in (QUANTITIES[:2] if headline else QUANTITIES[2:4])]
    steps = []
    for prev, row in zip(rows, rows[1:], strict=False):
        changes = {k: row[f"rel_change_{k}"] for k in judged if row[f"rel_change_{k}"] is not None}
        worst = max(changes, key=changes.get) if changes else None
        steps.append({"from_dt_s": prev["dt_s"], "to_dt_s": row["dt_s"], "worst": worst,
                      "worst_rel_change": changes.get(worst) if worst else None,
                      "within": bool(changes) and all(v <= tolerance for v in changes.values())})  # fmt: skip
    ok = bool(steps) and steps[0]["within"]
    what = ("the cone growth" if headline else
            "the end cone angle and spin rate (the cone growth is not distinguishable from 0 "
            "over this run)")  # fmt: skip
    if not steps:
        text = "no refinement to compare with"
    else:
        s = steps[0]
        change = ("no judged change" if s["worst"] is None else
                  f"largest change {s['worst_rel_change']:.2g} ({labels[s['worst']]})")  # fmt: skip
        text = (f"dt = {1e3 * rows[0]['dt_s']:.4g} ms {'converged' if ok else 'not converged'} "
                f"at {100 * tolerance:g} % in {what}: {change} from dt to dt/2")  # fmt: skip
    return {"tolerance": tolerance, "judged": judged, "converged": ok, "steps": steps,
            "text": text}  # fmt: skip


def dt_convergence(
    setup: RunSetup,
    first: RunResult | None = None,
    progress: Progress | None = None,
    factors: tuple[int, ...] = DT_FACTORS,
    tolerance: float = DT_TOLERANCE,
) -> dict:
    """Run ``setup`` at dt/f for f in ``factors`` (fixed-step methods only; ``first``: the run
    at the case's dt, if already done) and return ``{"rows": [...], **verdict(rows)}``: per row
    ``dt_s``, ``steps``, ``complete``, ``t_end_s``, the :data:`QUANTITIES` and their
    ``rel_change_*`` from the previous row (None for the first row or a zero reference), the
    cone-growth rate's standard error and significance. ``save_every`` scales with the
    refinement so the samples stay on the same times. A run with a controlled step
    (``integration.step_tolerance``) is refined by its tolerance, divided by f² (its steps,
    ∝ √tol for the second-order midpoint, by about f), and its first step by f."""
    run = setup.run
    if run.integration.method == "adaptive":
        raise CaseError(
            "--dt-convergence: needs a fixed-step method (midpoint or backward-euler), not "
            '"adaptive"',
            field="integration.method",
        )
    rows: list[dict] = []
    for f in factors:
        if f == 1 and first is not None:
            result = first
        else:
            update = {"dt": run.integration.dt / f, "save_every": run.integration.save_every * f}
            if run.integration.step_tolerance is not None:  # a controlled step: h ∝ √tol
                update["step_tolerance"] = run.integration.step_tolerance / f**2
            integ = run.integration.model_copy(update=update)
            sub = dataclasses.replace(setup, run=run.model_copy(update={"integration": integ}),
                                      fe_checks=False)  # the table needs the rates, not the path check
            result = execute(sub, progress)
        row = _row(result, run.integration.dt / f)
        for key, *_ in QUANTITIES:
            row[f"rel_change_{key}"] = _rel(row[key], rows[-1][key]) if rows else None
        rows.append(row)
    return {"rows": rows, **verdict(rows, tolerance)}
