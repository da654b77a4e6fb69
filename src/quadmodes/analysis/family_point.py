"""A point of a spin-family path (``reduced.path_model = "spin-family"``) for ``quadmodes compare
RUN --at "cone 12 deg"`` (issue 29 items 2 and 4, docs/path-validity.md).

A family path's samples are each in the chart of the member that integrated it
(:mod:`quadmodes.runs.family_samples`: ``results.nc`` ``model_reference_spin``, or the run's
switches). The point is found as on a one-model path (:mod:`quadmodes.analysis.path_point`),
with each sample's own member:

* the event's scalar (cone angle, spin, …) at every sample with that sample's member system;
* at the first sample past the level, its member is the point's member; the sample before it,
  if it belongs to the member before a switch (the switch's own sample), is mapped onto the
  point's member first (:func:`quadmodes.runs.spin_family.mapped_state`: what the path did at
  that switch, H kept to round-off);
* from there the event is located to the step and the state at that step integrated with the
  member's system, the path's own steps.

The point carries its member's spin (``PathPoint.member_spin``, rad/s); the comparison then runs
both windows with that member: the reduced formulations from the point's state in its chart, the
full order from that state reconstructed by the member's model (relaxed outside its retained
modes, :func:`~quadmodes.analysis.path_point.full_order_setup_at`), the member's run being the
run case with ``initial.spin_rate`` at the member's spin and ``path_model = "fixed"``
(:func:`quadmodes.runs.family_samples.member_run`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from quadmodes.analysis.path_point import (
    PathPoint,
    check_fixed_step,
    first_reached,
    located_point,
    path_run,
    read_path_results,
)
from quadmodes.case import CaseError
from quadmodes.runs.events import event_monitor
from quadmodes.runs.family_samples import Members, sample_member_spins
from quadmodes.runs.spin_family import mapped_state


def family_point_on_samples(members: Members, integ, at: str, t, y, e_d, spins, spin_axis,
                            source: str) -> PathPoint:  # fmt: skip
    """The :class:`PathPoint` of ``at`` on a family path's samples ``t`` (k,) s, ``y`` (k,
    7+2N) each in the chart of its member about ``spins`` (k,) rad/s, ``e_d`` (k,) J
    (module docstring); ValueError when the samples do not reach it."""
    check_fixed_step(integ)
    t, y, e_d = np.asarray(t, float), np.asarray(y, float), np.asarray(e_d, float)
    spins = np.asarray(spins, float)
    mon0 = event_monitor(members.system(spins[0]), y[0], at, spin_axis)
    g = np.empty(len(t))
    for spin in np.unique(spins):  # each sample's scalar with its own member
        k = spins == spin
        g[k] = replace(mon0, system=members.system(spin)).g(t[k], y[k])
    j = first_reached(mon0, t, g, at)
    mon = replace(mon0, system=members.system(spins[j]))
    ya, ga = y[j - 1], g[j - 1]
    if spins[j - 1] != spins[j]:  # the switch's own sample: onto the new member, as the path did
        ya = mapped_state(members.system(spins[j - 1]), members.model(spins[j - 1]), mon.system,
                          members.model(spins[j]), ya)  # fmt: skip
        ga = float(mon.g(np.array([t[j - 1]]), ya[None, :])[0])
    return located_point(mon, integ, (t[j - 1], ya, ga), (t[j], y[j], g[j]), float(e_d[j - 1]),
                         source, member_spin=float(spins[j]))  # fmt: skip


def integrated_family_point(run, at: str, members: Members, progress=None) -> PathPoint:
    """The :class:`PathPoint` of ``at`` on ``run``'s family path integrated to it
    (:func:`~quadmodes.analysis.path_point.path_run`) at the run's own sampling: a family
    switches at its saved samples, so another sampling would be another path."""
    from quadmodes.runs import simulate

    path = path_run(run, at)
    integ = path.integration.model_copy(update={"save_every": run.integration.save_every})
    result = simulate.simulate(path.model_copy(update={"integration": integ}), progress=progress)
    if result.event is None:
        raise ValueError(f"--at: the reduced path does not reach {at!r} within "
                         f"{result.solution.t[-1]:.6g} s ({result.reason or 'not reached'})")  # fmt: skip
    d = result.diagnostics
    spins = sample_member_spins(d.t, float(result.model.reference_spin), result.family)
    point = family_point_on_samples(members, result.run.integration, at, d.t, result.solution.y,
                                    d.E_d, spins, result.initial.spin_axis, "integrated")  # fmt: skip
    path = result.path
    if path is None or path.left_at is None or path.left_at > point.time:
        return replace(point, path_message="" if path is None else "; ".join(path.checked))
    return replace(point, path_valid=False, path_message=path.message())


def results_family_point(results: Path, run, at: str, members: Members) -> PathPoint:
    """The :class:`PathPoint` of ``at`` on the samples of a ``results.nc`` of ``run``'s family
    path (its first member's key, its time step and the members' spins per sample must be
    there: :func:`~quadmodes.analysis.path_point.read_path_results`)."""
    r = read_path_results(results, run, members.model(run.reference_spin), family=True)
    t, y, e_d, spins, axis = r["t"], r["y"], r["e_d"], r["spins"], r["axis"]
    left, message, integ = r["left"], r["message"], r["integration"]
    point = family_point_on_samples(members, integ, at, t, y, e_d, spins, axis, str(results))
    if math.isfinite(left) and left <= point.time:  # the run's own verdict on its path
        return replace(point, path_valid=False, path_message=message)
    return point


def family_path_point(run, at: str, *, results: Path | None = None, progress=None) -> PathPoint:
    """The state of ``run``'s spin-family path at the event ``at`` (its modes resolved), in the
    chart of its member there (``PathPoint.member_spin``): integrated to it, or read from
    ``results`` (a results.nc of the same run). Raises :class:`~quadmodes.case.CaseError`
    (field ``--at``) for an event the path does not reach."""
    members = Members(run, progress=progress)
    try:
        if results is None:
            return integrated_family_point(run, at, members, progress)
        return results_family_point(results, run, at, members)
    except ValueError as exc:
        if isinstance(exc, CaseError):
            raise
        text = str(exc)
        raise CaseError(text if text.startswith("--at") else f"--at: {text}", field="--at") from None
