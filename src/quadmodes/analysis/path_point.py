"""The full order from any point of a reduced path (issue 29 item 4): ``quadmodes compare RUN
--at "cone 10 deg" --window "1 s"``.

A point of a reduced run's path is given as an event (:mod:`quadmodes.case.run_events`: "cone
10 deg", "time 100 s", "spin 40 Hz", "flat spin"). The reduced run is integrated to it
(``integration.until``, the event located to the step, :mod:`quadmodes.runs.events`), or its
saved samples are read from a ``results.nc`` of the same run and model; the state at the step
of the event is the sample before it integrated forward step by step with the run's own method
and step (the steps the run took, up to the Newton tolerance). That reduced state ``y = [q, ω,
s, ṡ]`` starts both sides of a short checking window:

* the reduced formulations from ``y`` itself (:func:`quadmodes.analysis.compare.compare`,
  ``start``);
* the full order from ``y`` mapped by the seed paper's kinematics with the part outside the
  retained modes relaxed (:func:`quadmodes.analysis.full_order_runs.full_state_from_reduced`:
  the statically condensed deformation and its rate, the centrifugal stretch of ω), the map
  that starts every comparison at t = 0.

Times in the window start at 0 at the point; the point's own time, step, cone angle, spin and
the energy the reduced path dissipated up to it are in :class:`PathPoint`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from quadmodes.case import CaseError, RunCase
from quadmodes.rom import integrators
from quadmodes.runs.events import event_monitor

#: Saved samples of the reduced run to a path point: one every this many seconds (the event is
#: located to the step between them, so they need not be dense).
PATH_SAMPLE_S = 0.05
#: The longest reduced path a point is looked for on (s): 3 h, the issue's horizon.
PATH_LIMIT_S = 3 * 3600.0
#: Steps per chunk of a path integrated by the numpy step of formulation "QM" (2–4 ms a step at
#: N = 16: 4–8 s a chunk). The event is checked after every chunk, and the run's own chunks are
#: 1/200 of the path (108,000 steps of 0.5 ms for PATH_LIMIT_S): "cone 6.001 deg", reached at
#: step 19, cost 331 s of QM steps past it (the compiled Q steps the same chunk in about 1 s).
NUMPY_PATH_CHUNK = 2000


@dataclass(frozen=True, eq=False)
class PathPoint:
    """A state of a reduced run's path (SI).

    at: the event as written; kind: its kind; time s and step: where the run reached it (the
    first step at or past the level, t = step·Δt); y (7+2N,): the reduced state ``[q, ω, s, ṡ]``
    at that step; dissipated J: the energy the path dissipated from t = 0 to it; cone_angle rad,
    spin_rate rad/s: at the step (diagnostics' definitions); source: "integrated" or the
    results file read; path_valid: False where the reduced path left its model's range before
    the point (:mod:`quadmodes.runs.path_validity`), else None (not judged here)."""

    at: str
    kind: str
    time: float
    step: int
    y: np.ndarray
    dissipated: float
    cone_angle: float
    spin_rate: float
    source: str
    path_valid: bool | None = None
    path_message: str = ""  # the checks made up to it, or why the path left the range
    member_spin: float | None = None  # rad/s: a spin-family path's member at the point (y in its chart)

    def describe(self) -> str:
        """One line: where the full order starts (and that the path had left its model's range
        before, if it had)."""
        text = (f"started from the reduced path at {self.at}: t = {self.time:.6g} s (step "
                f"{self.step}), cone {math.degrees(self.cone_angle):.4g} deg, spin "
                f"{self.spin_rate / (2 * math.pi):.5g} Hz, dissipated {self.dissipated:.5g} J "
                f"({self.source})")  # fmt: skip
        if self.member_spin is not None:
            text += (f"; spin-family member about {self.member_spin / (2 * math.pi):.6g} Hz "
                     "(the reduced and full-order windows use its model)")  # fmt: skip
        if self.path_valid is False:
            text += f"; beyond the reduced model's range: {self.path_message}"
        return text

    def as_json(self) -> dict:
        return {"at": self.at, "kind": self.kind, "time_s": self.time, "step": self.step,
                "cone_angle_deg": math.degrees(self.cone_angle),
                "spin_rate_hz": self.spin_rate / (2 * math.pi), "dissipated_J": self.dissipated,
                "source": self.source, "path_valid": self.path_valid,
                "path_message": self.path_message,
                "member_spin_hz": None if self.member_spin is None
                else self.member_spin / (2 * math.pi)}  # fmt: skip


def path_run(run: RunCase, at: str) -> RunCase:
    """``run`` integrated to the event ``at``: ``integration.until = at``, a duration of
    :data:`PATH_LIMIT_S` (a time event: just past it) and a sample every
    :data:`PATH_SAMPLE_S`."""
    from quadmodes.case.run_events import parse_until

    kind, level = parse_until(at)
    integ = run.integration
    duration = level + 2 * float(integ.dt) if kind == "time" else max(PATH_LIMIT_S, integ.duration)
    every = max(1, int(round(PATH_SAMPLE_S / float(integ.dt))))
    integ = integ.model_copy(update={"until": at, "duration": duration, "save_every": every})
    return run.model_copy(update={"integration": integ})


def state_at_step(system, integ, t: float, y: np.ndarray, step: int) -> tuple[np.ndarray, float]:
    """``(y, dissipated)``: the state at step ``step`` (t = step·Δt) integrated from the saved
    sample ``(t, y)`` on the same grid with the run's method and step, and the energy (J)
    dissipated from ``t`` to it."""
    h = float(integ.dt)
    n = step - int(round(t / h))
    if n < 0:
        raise ValueError(f"step {step} is before the sample at t = {t} s")
    if n == 0:
        return np.array(y, float), 0.0
    sol = integrators.integrate(system, y, (t, step * h), integ.method, dt=h, rtol=integ.rtol,
                                save_every=n)  # fmt: skip
    if sol.status != 0:
        raise RuntimeError(f"the reduced run failed on its way to the path point: {sol.message}")
    return np.asarray(sol.y[-1], float), float(sol.dissipated[-1])


def point_on_samples(system, integ, at: str, t, y, e_d, spin_axis, source: str) -> PathPoint:
    """The :class:`PathPoint` of event ``at`` on the saved samples ``t`` (k,) s, ``y`` (k,
    7+2N), ``e_d`` (k,) J of a run of ``system`` with integration settings ``integ`` (fixed
    step) about the nominal axis ``spin_axis`` (3,); ValueError when the samples do not reach
    it."""
    check_fixed_step(integ)
    t, y, e_d = np.asarray(t, float), np.asarray(y, float), np.asarray(e_d, float)
    mon = event_monitor(system, y[0], at, spin_axis)
    g = mon.g(t, y)
    j = first_reached(mon, t, g, at)
    return located_point(mon, integ, (t[j - 1], y[j - 1], g[j - 1]), (t[j], y[j], g[j]),
                         float(e_d[j - 1]), source)  # fmt: skip


def check_fixed_step(integ) -> None:
    """ValueError (naming --at) for a method without steps of its own to locate a point to."""
    if integ.method == "adaptive":
        raise ValueError("--at: a path point needs a fixed-step method (midpoint, "
                         "backward_euler); the adaptive method has no steps to locate it to")  # fmt: skip


def first_reached(mon, t: np.ndarray, g: np.ndarray, at: str) -> int:
    """The index (> 0) of the first sample past the event of monitor ``mon`` (g (k,) at the
    samples' times ``t`` (k,) s); ValueError when none is."""
    hits = np.flatnonzero(mon.reached(g))
    hits = hits[hits > 0]
    if not len(hits):
        raise ValueError(f"--at: the reduced path does not reach {at!r} by t = {t[-1]:.6g} s")
    return int(hits[0])


def located_point(mon, integ, before, past, dissipated: float, source: str,
                  member_spin: float | None = None) -> PathPoint:  # fmt: skip
    """The :class:`PathPoint` of the event of ``mon`` between the samples ``before`` and
    ``past`` ((t s, y (7+2N,), g) each, both in the chart of ``mon.system``): located to the
    step (the run's own steps from ``before``), the state there, ``dissipated`` (J, up to
    ``before``) plus what the steps to it dissipated."""
    from quadmodes.runs.events import state_measures

    (ta, ya, ga), (tb, yb, gb) = before, past
    h = float(integ.dt)
    hit = mon.locate(float(ta), ya, float(ga), float(tb), yb, float(gb), integ, h)
    y_at, extra = state_at_step(mon.system, integ, float(ta), ya, hit.step)
    m = state_measures(mon.system, y_at[None, :], mon.axis0)
    return PathPoint(mon.text, hit.kind, hit.step * h, hit.step, y_at, dissipated + extra,
                     float(m["cone"][0]), float(m["spin"][0]), source, member_spin=member_spin)  # fmt: skip


def integrated_point(run: RunCase, at: str, model=None, progress=None) -> PathPoint:
    """The :class:`PathPoint` of ``at`` on ``run``'s reduced path, integrated to it
    (:func:`path_run`; ``model``: the run's reduced model, else from the cache)."""
    from quadmodes.runs import simulate

    path_case = path_run(run, at)
    chunks = (None if run.reduced.formulation != "QM"
              else max(1, math.ceil(path_case.integration.n_steps / NUMPY_PATH_CHUNK)))  # fmt: skip
    result = simulate.simulate(path_case, model=model, progress=progress, max_chunks=chunks)
    if result.event is None:
        raise ValueError(f"--at: the reduced path does not reach {at!r} within "
                         f"{result.solution.t[-1]:.6g} s ({result.reason or 'not reached'})")  # fmt: skip
    d = result.diagnostics
    point = point_on_samples(result.system, result.run.integration, at, d.t, result.solution.y,
                             d.E_d, result.initial.spin_axis, "integrated")  # fmt: skip
    path = result.path
    if path is None or path.left_at is None or path.left_at > point.time:
        # inside the range by the checks made (the modal amplitudes against the FE model are
        # not checked here: `quadmodes run` does that)
        return replace(point, path_message="" if path is None else "; ".join(path.checked))
    return replace(point, path_valid=False, path_message=path.message())


def read_path_results(results: Path, run: RunCase, model, family: bool = False) -> dict:
    """The samples of a ``results.nc`` written by a run of ``run`` whose (first) model is
    ``model``: ``{"t" (K,) s, "y" (K, 7 + 2N), "e_d" (K,) J, "axis" (3,), "left" s (nan: in range
    all along), "message", "integration" (the run's, with the file's method), "spins" (K,) rad/s
    of the member that integrated each sample (``family``; else None)}``. Raises
    :class:`~quadmodes.case.CaseError` naming ``--results`` for a file that is unreadable, of
    another model or time step, a family path read as a one-model path or the reverse."""
    import xarray as xr

    from quadmodes.runs.family_samples import MEMBER_SPIN_VARIABLE

    results = Path(results)
    try:
        ds = xr.open_dataset(results)
    except (OSError, ValueError) as exc:
        raise CaseError(f"--results: cannot read {results} ({type(exc).__name__})",
                        field="--results") from None  # fmt: skip
    with ds:
        key = str(model.provenance.get("content_key", ""))
        if "quaternion" not in ds or str(ds.attrs.get("reduced_model_key", "")) != key:
            raise CaseError(f"--results: {results} is not a run of this run case's reduced model "
                            f"(key {key}); run it again or drop --results", field="--results")  # fmt: skip
        if not family and 'path_model = "spin-family"' in str(ds.attrs.get("case_toml", "")):
            raise CaseError(f"--results: {results} is a spin-family path (its samples are in "
                            "the charts of several models); compare the run case it was made "
                            'with (reduced.path_model = "spin-family")', field="--results")  # fmt: skip
        if family and MEMBER_SPIN_VARIABLE not in ds:
            raise CaseError(f"--results: {results} does not say which member integrated each "
                            f"sample (no {MEMBER_SPIN_VARIABLE}: a one-model path, or a family "
                            "path written before it was stored); run it again or drop --results",
                            field="--results")  # fmt: skip
        written = str(ds.attrs.get("formulation", run.reduced.formulation))
        if written != run.reduced.formulation:  # its samples are another formulation's path
            raise CaseError(f"--results: {results} is a path of formulation {written}, this run "
                            f"case's is {run.reduced.formulation}; drop --results",
                            field="--results")  # fmt: skip
        if float(ds.attrs.get("dt", math.nan)) != float(run.integration.dt):
            raise CaseError(f"--results: {results} was run at another time step; drop --results",
                            field="--results")  # fmt: skip
        return {
            "t": ds["time"].values,
            "y": np.hstack([ds["quaternion"].values, ds["omega_body"].values,
                            ds["modal_coordinates"].values, ds["modal_velocities"].values]),
            "e_d": ds["dissipated_energy"].values,
            "axis": np.asarray(ds.attrs["spin_axis_body"], float),
            "left": float(ds.attrs.get("path_left_at", math.nan)),
            "message": str(ds.attrs.get("path_message", "")),
            "integration": run.integration.model_copy(
                update={"method": str(ds.attrs.get("method", "midpoint"))}),
            "spins": ds[MEMBER_SPIN_VARIABLE].values if family else None,
        }  # fmt: skip


def results_point(results: Path, run: RunCase, system, model, at: str) -> PathPoint:
    """The :class:`PathPoint` of ``at`` on the samples of a ``results.nc`` written by a run of
    ``run`` with ``model`` (:func:`read_path_results`)."""
    r = read_path_results(results, run, model)
    t, y, e_d, axis, integ = r["t"], r["y"], r["e_d"], r["axis"], r["integration"]
    left, message = r["left"], r["message"]
    point = point_on_samples(system, integ, at, t, y, e_d, axis, str(results))
    if math.isfinite(left) and left <= point.time:  # the run's own verdict on its path
        return replace(point, path_valid=False, path_message=message)
    return point


def path_point(run: RunCase, at: str, *, model=None, results: Path | None = None,
               progress=None) -> PathPoint:  # fmt: skip
    """The state of ``run``'s reduced path at the event ``at`` (e.g. "cone 10 deg", "time 100
    s"): integrated to it, or read from ``results`` (a results.nc of the same run and model).
    ``run`` must have its modes resolved (a whole ``reduced.modes``). Raises
    :class:`~quadmodes.case.CaseError` (field ``--at``) for an event the path does not reach.
    A spin-family run's samples are in several members' charts: its point is
    :func:`quadmodes.analysis.family_point.family_path_point`'s (refused here)."""
    from quadmodes.runs.manifold_system import run_system

    if run.reduced.path_model == "spin-family":
        raise CaseError('--at: a reduced.path_model = "spin-family" path is read by '
                        "quadmodes.analysis.family_point.family_path_point (as compare --at "
                        "does), not as one model's", field="--at")  # fmt: skip
    try:
        if results is None:
            return integrated_point(run, at, model, progress)
        if model is None:
            from quadmodes.runs import simulate

            model = simulate.prepare(run).model
        system = run_system(run, model, run.model_case())
        return results_point(results, run, system, model, at)
    except ValueError as exc:
        text = str(exc)
        raise CaseError(text if text.startswith("--at") else f"--at: {text}", field="--at") from None


def reduced_run_from(run: RunCase, model, start: np.ndarray):
    """The reduced run of ``run`` (its modes resolved) with ``model`` from the reduced state
    ``start`` (7+2N,) instead of its initial state (a formulation with a shorter state, rigid,
    takes its first entries: attitude and angular velocity): a
    :class:`~quadmodes.runs.simulate.RunResult` whose times start at 0 at ``start``."""
    from quadmodes.runs import simulate

    setup = simulate.prepare(run, model)
    y0 = np.asarray(start, float)[: setup.system.n_state]
    setup = replace(setup, initial=replace(setup.initial, y0=y0))
    return simulate.execute(setup)


def full_order_setup_at(setup, point: PathPoint):
    """The full-order setup ``setup`` (of the run at t = 0,
    :func:`~quadmodes.analysis.full_order_runs.setup_for_run`) started at ``point`` instead:
    its state mapped by :func:`~quadmodes.analysis.full_order_runs.full_state_from_reduced`."""
    from quadmodes.analysis.full_order_runs import full_state_from_reduced
    from quadmodes.fe.model import centre_of_mass

    rest = setup.x_rest if setup.x_rest is not None else setup.x_ref
    centre = centre_of_mass(setup.structure, rest)
    try:
        x0, v0, notes = full_state_from_reduced(setup.structure, setup.x_ref, setup.model,
                                                point.y, centre, stretch=True)  # fmt: skip
    except ValueError:  # the static condensation of a large deformation did not converge
        amp = float(np.linalg.norm(point.y[7 : 7 + setup.model.n_modes]))
        raise CaseError(f"--at: the full order's relaxed deformation at {point.at} (|s| = "
                        f"{amp:.3g} kg^0.5 m) did not converge; choose an earlier point",
                        field="--at") from None  # fmt: skip
    kept = tuple(n for n in setup.notes if not n.startswith("full order: "))
    start = f"{point.at} (step {point.step})"
    return replace(setup, x0=x0, v0=v0, notes=(*kept, *notes, point.describe()), start=start)


def start_attributes(start: dict | None) -> dict:
    """Attributes of the reduced path point a comparison starts from ({} at t = 0): its
    event, time (s), step, cone angle (rad), spin rate (rad/s), energy dissipated before (J)."""
    if not start:
        return {}
    return {"start_at": start["at"], "start_time": start["time_s"], "start_time_units": "s",
            "start_step": int(start["step"]),
            "start_cone_angle": math.radians(start["cone_angle_deg"]),
            "start_cone_angle_units": "rad",
            "start_spin_rate": 2 * math.pi * start["spin_rate_hz"],
            "start_spin_rate_units": "rad/s", "start_dissipated_energy": start["dissipated_J"],
            "start_dissipated_energy_units": "J", "start_source": start["source"],
            **({} if start.get("member_spin_hz") is None else {
                "start_member_spin": 2 * math.pi * start["member_spin_hz"],
                "start_member_spin_units": "rad/s"})}  # fmt: skip

