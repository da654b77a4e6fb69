"""Where a spin family switches and to which member (:mod:`quadmodes.runs.spin_family`): the
members' spins and the monitor that cuts a segment at the first sample past its member's range.

Two spacings (docs/path-validity.md, "Members chosen adaptively"):

* :class:`GridSpacing` (``reduced.path_switch``, default 0.75 %): the members sit on the geometric
  grid Ω₀(1 + spacing)^k and the nearest grid point integrates; a switch waits until the spin is
  nearer another grid point by :data:`HYSTERESIS` × half a spacing.
* :class:`AdaptiveSpacing` (``reduced.path_tolerance``): member k is used over the spin
  departures |ln(Ω/Ω_k)| ≤ d_k, d_k chosen so that the member's energy-sink coning rate θ̇/θ
  (what the path's cone growth is made of, :func:`quadmodes.runs.spin_check.coning_rate`) is at
  most the tolerance off the rate of a member about the path's spin: d_k = tol / σ, with σ the
  coning rate's relative change per unit of ln Ω **measured between the last two members** at
  the path's cone angle (0.3 s, no model build), at most :data:`GROWTH` × the previous d, at most
  :data:`D_MAX` (the a-priori centrifugal bound of the path check: δ ≈ 2d ≤ 1.6 % < 2 %, so no
  member is rebuilt to judge the path), at least :data:`D_MIN`. The next member's spin is placed
  past the switching spin by d_{k+1} / :data:`HYSTERESIS`, so the path enters it inside its range
  with a margin against switching back.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from quadmodes.rom import system as rsys
from quadmodes.runs import chunked

#: Grid: the default spacing of the members' spins (relative): 0.75 %, so the spin departs from
#: its member's by at most about 0.41 % (the centrifugal load by 0.83 %, inside the path
#: check's 2 %; the cone growth by about 0.45 %, docs/path-validity.md).
DEFAULT_TOLERANCE = 0.0075
#: Members are expanded about spins rounded to this (Hz), so that paths share cached members.
SPIN_RESOLUTION_HZ = 1e-4
#: Grid: a switch waits until the spin is nearer another grid point by this factor on half a
#: spacing; adaptive: the next member's spin lies d / HYSTERESIS past the switching spin.
HYSTERESIS = 1.1
#: Adaptive: the first member's departure (ln Ω), before any sensitivity is measured (the
#: 0.75 % grid's 0.41 %).
D_START = 0.00375
#: Adaptive: the largest departure: the path check's a-priori centrifugal bound is 2 % in
#: δ ≈ 2 × the spin departure, 1.6 % here (with room for the tilt of ω and the sampling).
D_MAX = 0.008
#: Adaptive: the smallest departure (a sensitivity this large means a resonance; members 0.1 %
#: apart at least).
D_MIN = 0.0005
#: Adaptive: the departure grows at most by this factor from one member to the next.
GROWTH = 1.5


def member_hz(spin: float) -> float:
    """The spin (Hz) a member about ``spin`` (rad/s) is expanded about: rounded to
    :data:`SPIN_RESOLUTION_HZ`."""
    return round(spin / (2 * math.pi) / SPIN_RESOLUTION_HZ) * SPIN_RESOLUTION_HZ


def member_spin(system, y: np.ndarray) -> np.ndarray:
    """Spin about the member's reference axis ω·e (k,) rad/s of states y (k, 7+2N)."""
    w_ref = np.asarray(system.reference_omega, float)
    return rsys.split_state(system, np.atleast_2d(y))[1] @ (w_ref / np.linalg.norm(w_ref))


def grid_spin(spin: float, spin0: float, spacing: float) -> float:
    """The member spin (rad/s) for ``spin``: the point of the geometric grid
    Ω₀(1 + spacing)^k nearest it (in ln Ω), rounded to :data:`SPIN_RESOLUTION_HZ`."""
    k = round(math.log(spin / spin0) / math.log1p(spacing))
    return 2 * math.pi * member_hz(spin0 * (1.0 + spacing) ** k)


@dataclasses.dataclass
class GridSpacing:
    """The fixed grid Ω₀(1 + spacing)^k (module docstring)."""

    spin0: float
    spacing: float

    def limit(self) -> float:
        """The largest |ln(Ω/Ω_member)| before a switch."""
        return HYSTERESIS * 0.5 * math.log1p(self.spacing)

    def target(self, spin_ref: float, spin: float) -> float:
        """The next member's spin (rad/s) for a sample at ``spin`` past the range of the member
        about ``spin_ref``."""
        return grid_spin(spin, self.spin0, self.spacing)

    def predicted(self, spin_ref: float, sign: float) -> float:
        """The member after the one about ``spin_ref`` in the direction ``sign`` (±1)."""
        return grid_spin(spin_ref * (1.0 + self.spacing) ** sign, self.spin0, self.spacing)

    def switched(self, sensitivity: float) -> None:
        """After a switch: the measured sensitivity (unused by the grid)."""

    def state(self) -> np.ndarray:
        return np.array([self.spacing])

    def describe(self) -> str:
        return f"members {100 * self.spacing:.3g} % apart in spin"


@dataclasses.dataclass
class AdaptiveSpacing:
    """Departures chosen from the measured sensitivity of the coning rate (module docstring):
    ``tolerance`` the coning-rate error allowed, ``d`` the current member's departure (ln Ω),
    ``sigma`` the last measured sensitivity (NaN: none yet), ``d_next`` the next member's."""

    tolerance: float
    d: float = D_START
    sigma: float = math.nan
    d_next: float = math.nan

    def limit(self) -> float:
        return self.d

    def proposal(self) -> float:
        """The next member's departure from the last sensitivity measured."""
        d = self.tolerance / self.sigma if self.sigma > 0 else self.d
        return float(min(max(min(d, GROWTH * self.d, D_MAX), D_MIN), D_MAX))

    def target(self, spin_ref: float, spin: float) -> float:
        self.d_next = self.proposal()
        return self.predicted(spin_ref, 1.0 if spin > spin_ref else -1.0)

    def predicted(self, spin_ref: float, sign: float) -> float:
        """The next member's spin (rad/s) past the member about ``spin_ref`` in the direction
        ``sign`` (±1): the switch's target, known when the segment starts."""
        shift = sign * (self.d + self.proposal() / HYSTERESIS)
        return 2 * math.pi * member_hz(spin_ref * math.exp(shift))

    def switched(self, sensitivity: float) -> None:
        """After a switch to the member proposed: its departure, and the sensitivity σ measured
        between the two members (NaN: not measured, the last one kept)."""
        self.d = self.d_next
        if math.isfinite(sensitivity) and sensitivity > 0:
            self.sigma = float(sensitivity)

    def state(self) -> np.ndarray:
        return np.array([self.tolerance, self.d, self.sigma, self.d_next])

    def describe(self) -> str:
        return f"members adaptive: coning-rate error ≤ {100 * self.tolerance:.3g} % over each"


def spacing_from(run, spin0: float, state: np.ndarray | None = None):
    """The spacing of a run's family (``reduced.path_tolerance``: adaptive, else the grid of
    ``reduced.path_switch``), or the one a checkpoint saved (``state``)."""
    tol = getattr(run.reduced, "path_tolerance", None)
    if tol is None:
        return GridSpacing(spin0, run.reduced.path_switch or DEFAULT_TOLERANCE)
    if state is None:
        return AdaptiveSpacing(float(tol))
    return AdaptiveSpacing(*(float(v) for v in state))


def quadratic_view(system):
    """Formulation Q of the same member: ``system`` without its cubic and quartic potential
    and without the manifold kinetics (a Q4 or QM member; others as they are). The energy-sink
    law is taken for a quadratic potential only (:func:`quadmodes.runs.spin_check.coning_rate`
    is NaN otherwise), and what the spacing measures, how the coning rate changes from one
    member's expansion spin to the next, is carried by the arrays Q shares with Q4 and QM (Λ,
    J, the coupling about the member's spinning state)."""
    if not system.quartic:
        return system
    return dataclasses.replace(system, formulation="Q", V3=None, V4=None, manifold=None)


def neighbour_errors(sys_old, sys_new, cone: float) -> tuple[float, float]:
    """(ε_c, ε_f) of the old member at the new member's spin (about its axis), against the new
    member there: the relative difference of the energy-sink coning rates θ̇/θ
    (:func:`quadmodes.runs.spin_check.coning_rate`, at the cone angle ``cone`` rad) and the
    largest relative difference of the rotating-frame frequencies; NaN where not measurable.
    Members of formulation Q4 or QM are measured by their :func:`quadratic_view`."""
    from quadmodes.runs.spin_check import coning_rate, frequency_difference, rotating_frequencies

    sys_old, sys_new = quadratic_view(sys_old), quadratic_view(sys_new)
    w_new = np.asarray(sys_new.reference_omega, float)
    spin = float(np.linalg.norm(w_new))
    try:
        eps_f = frequency_difference(rotating_frequencies(sys_old, w_new),
                                     rotating_frequencies(sys_new, w_new))  # fmt: skip
        rates = [coning_rate(s, spin, w_new / spin, max(float(cone), 1e-3)) for s in (sys_old, sys_new)]
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        return math.nan, math.nan
    if not (all(math.isfinite(r) for r in rates) and rates[1] != 0.0):
        return math.nan, eps_f
    return abs(rates[0] / rates[1] - 1.0), eps_f


def sensitivity(sys_old, sys_new, cone: float) -> float:
    """σ: ε_c of :func:`neighbour_errors` per unit of |ln(Ω_new/Ω_old)|; NaN where not
    measurable."""
    step = abs(math.log(float(np.linalg.norm(sys_new.reference_omega))
                        / float(np.linalg.norm(sys_old.reference_omega))))  # fmt: skip
    eps_c = neighbour_errors(sys_old, sys_new, cone)[0]
    return eps_c / step if step > 0 and math.isfinite(eps_c) else math.nan


class SwitchMonitor:
    """``after_chunk`` of a segment's chunk loop: the run's ``until`` event first (``event``, or
    None), then the switch: at the first new sample whose spin about the member's axis departs
    from the member's by more than ``spacing.limit()`` (in ln Ω) toward another member, the
    chunk is cut there and the segment stopped (``spin``: the new member's; ``final``: the cut
    progress, whose controlled step the next segment continues). ``t0`` (s): the segment's
    start, whose state (the mapped one) never switches."""

    def __init__(self, system, spacing, event=None, t0: float = 0.0):
        self.system, self.spacing, self.event, self.t0 = system, spacing, event, t0
        self.spin_ref = float(np.linalg.norm(system.reference_omega))
        self.spin: float | None = None
        self.final = None

    def fraction(self, state, t: float, duration: float) -> float:
        """The run's completed fraction at time t (s): its event's
        (:meth:`quadmodes.runs.events.EventMonitor.fraction`), else t/``duration``."""
        if self.event is not None:
            return self.event.fraction(state, t, duration)
        return max(state.shown, chunked.time_fraction(t, duration))

    def stage(self, name: str, duration: float) -> str:
        """The run's progress stage (its event's, :func:`quadmodes.runs.chunked.stage`)."""
        return chunked.stage(name, self.event, duration)

    def after_resume(self, state, integ, h: float):
        """The event and the switch on every sample of a resumed ``state`` (a Ctrl-C may have
        come between a chunk and its check)."""
        if self.event is not None:
            state = self.event.after_resume(state, integ, h)
            if state.stop is not None:
                return state
        pieces = [k for k, p in enumerate(state.t) if len(p)]
        if not pieces:
            return state
        merged = {name: (np.concatenate([getattr(state, name)[k] for k in pieces]),)
                  for name in ("t", "y", "e_d")}  # fmt: skip
        cut = self._switch(dataclasses.replace(state, **merged), h)
        return state if cut is None else cut

    def after_chunk(self, state, integ, h: float):
        if self.event is not None:
            state = self.event.after_chunk(state, integ, h)
            if state.stop is not None:
                return state
        cut = self._switch(state, h)
        return state if cut is None else cut

    def _switch(self, state, h: float):
        """The progress cut at the first sample of its last piece past the member's range, or
        None."""
        if not state.t or not len(state.y[-1]):
            return None
        t_new, y_new, ed_new = state.t[-1], state.y[-1], state.e_d[-1]
        spins = member_spin(self.system, y_new)
        hits = np.flatnonzero((np.abs(np.log(spins / self.spin_ref)) > self.spacing.limit())
                              & (t_new > self.t0))  # not the segment's first state  # fmt: skip
        for j in map(int, hits):  # the first whose member is another one
            target = self.spacing.target(self.spin_ref, float(spins[j]))
            if abs(target - self.spin_ref) >= 0.5 * 2 * math.pi * SPIN_RESOLUTION_HZ:
                break
        else:
            return None
        self.spin = target
        pieces = dict(t=(*state.t[:-1], t_new[: j + 1]), y=(*state.y[:-1], y_new[: j + 1]),
                      e_d=(*state.e_d[:-1], ed_new[: j + 1]))  # fmt: skip
        if state.t_done is None:  # the fixed step: its global grid
            where = dict(steps=int(round(t_new[j] / h)))
        else:  # a controlled step: the step of the chunk that holds the sample
            where = dict(steps=state.local_step(float(t_new[j]), h)[1], t_done=float(t_new[j]))
        self.final = dataclasses.replace(state, y_last=y_new[j].copy(), e_d_offset=float(ed_new[j]),
                                         stop=chunked._Stop(0, "switch", ""), **where, **pieces)  # fmt: skip
        return self.final
