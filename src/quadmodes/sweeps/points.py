"""One sweep point: the reduced model of its structural inputs, the time run's headline scalars,
the rotating-frame roots and the energy-sink estimate.

Stages::

    PointCase ──model_for_group──▶ (ReducedModel, modes per point)   (once per structural key)
    PointCase + ReducedModel ──run_point──▶ dict of SI scalars and per-branch lists (JSON-ready)

Everything here is a plain function of picklable inputs, so that a dask worker can run it.
"""

from __future__ import annotations

import math
import time

import numpy as np

from quadmodes.analysis.run_answer import spin_roots
from quadmodes.case import RunCase
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import reduced as red
from quadmodes.rom import system as rsys
from quadmodes.rom.energy_sink import energy_sink
from quadmodes.runs import secular
from quadmodes.runs import simulate as sim
from quadmodes.runs.mode_choice import resolve_modes
from quadmodes.sweeps.overrides import PointCase


def structural_key(point: PointCase) -> str:
    """What the reduced model of a point depends on: the model case (SI TOML), the run's
    ``[reduced]`` table and, when the model is expanded about the spinning state or its mode
    count is chosen from the spin (``modes = "auto"``), the spin rate. Points with the same key
    share one model (about the state at rest: built with the largest mode count of the group
    and restricted per point)."""
    run = point.run
    red_table = run.reduced.model_dump_json(exclude={"formulation"})
    spin = (repr((run.reference_spin, run.reference_axis)) if run.reduced.reference == "spinning"
            else "rest")  # fmt: skip
    return f"{point.model_case.to_toml()}\n{red_table}\n{spin}"


def model_for_group(points: list[PointCase]) -> tuple[red.ReducedModel, list[int]]:
    """The reduced model shared by ``points`` (one structural key) and the mode count of each
    point (``modes = "auto"`` resolved per point; the model has the largest)."""
    counts = []
    for p in points:
        resolved, _ = resolve_modes(p.run, p.model_case)
        counts.append(int(resolved.reduced.modes))
    first = points[0]
    n = max(counts)
    if first.run.reduced.formulation == "rigid":
        n = max(n, 1)
    model = reduced_model_for(first.model_case, n, spin=first.run.reference_spin,
                              axis=first.run.reference_axis)  # fmt: skip
    return model, counts


def spin_axis_request(run: RunCase):
    """The spin-axis request of the point's linearisations (its roots, critical speeds and
    full-order markers): the run's ``initial.spin_axis``; None is the default axis of
    :func:`quadmodes.rom.spin_axis.resolve_axis` (the symmetry axis of a free body)."""
    return run.initial.spin_axis


def _fixed_modes(run: RunCase, n_modes: int) -> RunCase:
    """``run`` with ``reduced.modes = n_modes`` (``"auto"`` resolved, margin dropped)."""
    table = run.reduced.model_copy(update={"modes": int(n_modes), "mode_margin": None})
    return run.model_copy(update={"reduced": table})


def _finite(x) -> float:
    x = float(x)
    return x if math.isfinite(x) else math.nan


def _path_fields(path) -> dict:
    """The time run's validity along its path (:mod:`quadmodes.runs.path_validity`): in range
    (no check that ran failed), where it leaves the range (s, NaN), valid (every check ran and
    passed: a sweep does not check the modal amplitudes against the FE model, so a point is in
    range at best) and the checks not made."""
    if path is None:
        return {}
    left = path.left_at
    return {"path_in_range": left is None, "path_left_range_at": math.nan if left is None
            else float(left), "path_valid": bool(path.valid),
            "path_unchecked": ", ".join(path.unchecked)}  # fmt: skip


def _time_run(setup: sim.RunSetup) -> dict:
    """Headline scalars of the time run of ``setup`` (secular fits over the quasi-steady part,
    :mod:`quadmodes.runs.secular`)."""
    result = sim.execute(setup)
    d = result.diagnostics
    fits = secular.run_fits(d.t, d.cone_angle, d.E_d, d.spin_rate, setup.model.frequencies_hz,
                            setup.model.damping_ratio)  # fmt: skip
    q, cone = fits.interval, fits.cone
    s = rsys.split_state(setup.system, result.solution.y)[2]
    return {
        "cone_growth_rate": _finite(cone.slope),
        "cone_growth_rate_standard_error": _finite(cone.se),
        "simulated_growth_rate": _finite(fits.growth_rate),
        "cone_growth_significant": fits.significant,
        "dissipated_power": _finite(fits.power.slope),
        "spin_rate_change": _finite(fits.spin.slope * (q.end_s - q.start_s)),
        "max_modal_amplitude": _finite(np.max(np.abs(s))) if s.size else 0.0,
        "cone_angle_end": _finite(d.cone_angle[-1]),
        "quasi_steady_start": float(q.start_s),
        "complete": bool(result.complete),
        "incomplete_reason": result.reason,
        **_path_fields(result.path),
        "run_wall_s": float(result.wall_s),
    }


def run_point(point: PointCase, model: red.ReducedModel, n_modes: int,
              time_run: bool = True) -> dict:  # fmt: skip
    """Everything a sweep stores for one point (SI; lists per rotating-frame branch); a time run
    only if ``time_run``."""
    start = time.perf_counter()
    run = _fixed_modes(point.run, n_modes)
    setup = sim.prepare(run, model, model_case=point.model_case)
    out: dict = {"n_modes": int(setup.model.n_modes),
                 "valid": bool(setup.validity.valid) if setup.validity else True}  # fmt: skip
    roots = spin_roots(setup.run, setup.model)
    sink = energy_sink(setup.system, roots.pop("_s_eq"), roots.pop("_omega0"),
                       float(run.initial.cone_angle))  # fmt: skip
    out.update(roots)
    out.update({
        "energy_sink_power": sink.power,
        "energy_sink_cone_rate": sink.cone_rate,
        "energy_sink_growth_rate": sink.growth_rate,
        "coning_time_constant": sink.time_constant,
        "nutation_frequency": sink.nutation_frequency,
        "elastic_momentum_ratio": sink.elastic_momentum_ratio,
        "quasi_rigid": bool(sink.quasi_rigid),
    })  # fmt: skip
    if time_run:
        out.update(_time_run(setup))
    out["wall_s"] = time.perf_counter() - start
    return out
