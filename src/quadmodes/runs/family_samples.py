"""The samples of a spin-family path (``reduced.path_model = "spin-family"``,
:mod:`quadmodes.runs.spin_family`) and the models they belong to.

A family path's saved samples are each in the chart of the member that integrated it (its
modal coordinates are that member's). Which member is stored with them: ``results.nc`` variable
``model_reference_spin`` (time; rad/s), the spin the sample's member is expanded about. A
switch's own sample (the last of a member, at the switch time) belongs to the member before the
switch; the state mapped onto the new member at that time is not saved (the run continued from
it). Readers of a family path (``quadmodes compare --at``, :mod:`quadmodes.analysis.family_point`)
rebuild or load a sample's member from the cache with :class:`Members`, the same call the path
made (:func:`quadmodes.models.build.reduced_model_for` about that spin, the run's axis request
and modes), and run a window from a sample with one member: :func:`member_run`.
"""

from __future__ import annotations

import numpy as np

from quadmodes.rom import system as rsys
from quadmodes.runs.manifold_system import run_system

#: results.nc variable: the spin (rad/s) of the member that integrated each sample.
MEMBER_SPIN_VARIABLE = "model_reference_spin"
MEMBER_SPIN_LONG_NAME = ("spin rate the reduced model that integrated the sample is expanded "
                         "about (spin family: its member; the sample's modal coordinates are in "
                         "that member's chart)")  # fmt: skip


def sample_member_spins(t, spin0: float, switches) -> np.ndarray:
    """(k,) rad/s: the spin of the member that integrated each sample at times ``t`` (k,) s of
    a family path that started with the member about ``spin0`` (rad/s) and switched at
    ``switches`` (:class:`~quadmodes.runs.spin_family.Switch`, in time order). A switch's own
    sample (t = switch time) belongs to the member before it."""
    t = np.asarray(t, float)
    spins = np.full(len(t), float(spin0))
    for sw in switches:
        after = t > sw.time + 1e-9 * max(1.0, abs(sw.time))  # the grid's samples are steps apart
        spins[after] = float(sw.spin_to)
    return spins


def is_family(run) -> bool:
    """True for a run case whose path is integrated by a family of models."""
    return getattr(run.reduced, "path_model", "fixed") == "spin-family"


def member_run(run, spin: float):
    """``run`` (its modes resolved) as the one-model run of its member about ``spin`` (rad/s):
    ``reduced.path_model = "fixed"`` and ``initial.spin_rate = spin``, so that its model
    (:func:`quadmodes.runs.simulate.prepare`, the full order's
    :func:`~quadmodes.analysis.full_order_runs.setup_for_run`) is the member the family path
    used, from the same cache entry; its initial state is replaced by the caller's, and it has
    no ``until`` event (a window from a point of the path runs its whole length)."""
    reduced = run.reduced.model_copy(update={"path_model": "fixed", "path_switch": None,
                                                 "path_tolerance": None})
    initial = run.initial.model_copy(update={"spin_rate": float(spin)})
    integ = run.integration.model_copy(update={"until": None})
    return run.model_copy(update={"reduced": reduced, "initial": initial, "integration": integ})


class Members:
    """The members of ``run``'s family (a run case with its modes resolved), by spin (rad/s):
    :meth:`model` (loaded from the cache, else built and cached, as the path did) and
    :meth:`system` (the run's formulation), each made once."""

    def __init__(self, run, model_case=None, progress=None):
        self.run, self.progress = run, progress
        self.model_case = model_case if model_case is not None else run.model_case()
        self._models: dict[float, object] = {}
        self._systems: dict[float, rsys.ReducedSystem] = {}

    def model(self, spin: float):
        from quadmodes.models.build import reduced_model_for

        spin = float(spin)
        if spin not in self._models:
            self._models[spin] = reduced_model_for(self.model_case, self.run.reduced.modes,
                                                   self.progress, spin=spin,
                                                   axis=self.run.reference_axis)  # fmt: skip
        return self._models[spin]

    def system(self, spin: float) -> rsys.ReducedSystem:
        spin = float(spin)
        if spin not in self._systems:
            self._systems[spin] = run_system(self.run, self.model(spin), self.model_case)
        return self._systems[spin]
