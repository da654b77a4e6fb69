"""The series a full-order transient samples: per sample the discrete and the mapped angular
momentum, energies, the tracked minor axis, the spin rate, modal coordinates and the tip
(definitions: :func:`quadmodes.fullorder.kinematics.sample`)."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

import quadmodes.fullorder.kinematics as kin
from quadmodes.fe.model import strain_energy
from quadmodes.fullorder.setup import FullOrderProblem
from quadmodes.rom.reduced import cross_form

#: Names of the sampled series (and, prefixed ``series_``, their checkpoint entries).
SERIES = ("t", "H", "Hd", "T", "V", "E_d", "omega", "axis", "s", "tip")


class SampledSeries:
    """Lists of the sampled values (``series[name]``, one entry a sample; names
    :data:`SERIES`), and the tracked axis ``axis_prev`` (3,) of the last sample (None before
    the first). ``spin_axis`` (3,): nominal spin axis in the initial body frame for the first
    sample's axis (None: the minor axis of the initial inertia). ``energy(x)``: the potential
    energy (J) of a state (default :func:`~quadmodes.fe.model.strain_energy`)."""

    def __init__(self, problem: FullOrderProblem, spin_axis: np.ndarray | None = None,
                 energy: Callable[[np.ndarray], float] | None = None,
                 on_sample=None):  # fmt: skip
        self.problem, self.spin_axis = problem, spin_axis
        self.energy = energy if energy is not None else partial(strain_energy, problem.structure)
        self.on_sample = on_sample  # on_sample(t, x): x (n,3) m the sampled physical positions
        self.series: dict[str, list] = {k: [] for k in SERIES}
        self.axis_prev: np.ndarray | None = None

    def restore(self, arrays: dict, axis_prev: np.ndarray) -> None:
        """Continue the series of a checkpoint (``arrays``: its entries ``series_<name>``)."""
        self.axis_prev = axis_prev
        for k in SERIES:
            if f"series_{k}" in arrays:
                self.series[k] = list(arrays[f"series_{k}"])

    def last_time(self) -> float | None:
        """Time (s) of the last sample, or None."""
        return self.series["t"][-1] if self.series["t"] else None

    def _first_axis(self, smp: kin.Sample, xs: np.ndarray, rot: np.ndarray | None):
        if self.spin_axis is None:
            return kin.minor_axis(smp.inertia)
        body = self.problem.body
        r0 = rot if rot is not None else kin.best_fit_rotation(body, xs, kin.centre(body, xs))
        return r0 @ (np.asarray(self.spin_axis, float) / np.linalg.norm(self.spin_axis))

    def record(self, t: float, xs: np.ndarray, vs: np.ndarray, e_d: float) -> None:
        """Append the sample of state (xs, vs) (n,3) at time t (s), e_d J dissipated so far."""
        p, series = self.problem, self.series
        body, hub = p.body, p.hub
        rs = xs - np.outer(p.tr, kin.centre(body, xs))
        series["Hd"].append(cross_form(rs.T @ (p.ms @ vs)))
        if p.mapped:
            xs, vs = kin.to_physical_rotation(body, xs, vs, p.h, not p.energy_momentum)
        if self.on_sample is not None:
            self.on_sample(t, xs)
        rot = hub.rotation(t) if hub is not None else None
        om = hub.angular_velocity(t) if hub is not None else None
        smp = kin.sample(body, xs, vs, rot, p.point, om)
        if self.axis_prev is None:
            self.axis_prev = self._first_axis(smp, xs, rot)
        self.axis_prev = kin.track(smp.inertia, self.axis_prev)
        series["axis"].append(self.axis_prev)
        series["t"].append(t)
        series["H"].append(smp.H)
        series["T"].append(smp.T)
        series["V"].append(self.energy(xs) - p.v_ref)
        series["E_d"].append(e_d)
        series["omega"].append(smp.omega)
        series["s"].append(smp.s)
        series["tip"].append(smp.tip if smp.tip is not None else np.full(3, np.nan))
