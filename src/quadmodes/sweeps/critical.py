"""Critical speeds of a spin sweep: where a rotating-frame branch passes through zero
(divergence) or two branches merge (flutter), bracketed on the sweep's grid and refined.

Brackets (:func:`brackets`) are consecutive spin rates of the sweep (the other parameters
fixed) between which, in the *undamped* linearisation about the relative equilibrium,

* the smallest eigenvalue of the rotating-frame stiffness Λ − ωᵀJ2ω changes sign: a zero root of
  ``(λ²μ + λΓ + K) φ = 0`` needs det K = 0, so a branch frequency passes through zero there
  ("divergence"); or
* the number of roots with Re λ > 0 changes: a real pair appears (divergence) or two branches
  merge into a complex quadruplet (flutter).

Each bracket is refined by bisection (:func:`refine`, :data:`STEPS` halvings) on the reduced
model of its lower point, linearised (undamped) at intermediate spin rates: a reduced model
expanded about one spin is used a little beyond it, as ``quadmodes campbell`` does. The branches
are named at the refined crossing: for the stiffness crossing by the model mode dominating the
eigenvector of the smallest eigenvalue of Λ − ωᵀJ2ω (the static mode that passes through zero);
otherwise by the MAC tracking of :func:`quadmodes.analysis.campbell.campbell` over the two ends
of the final interval: the branch that changes stability, and for flutter its partner, the
branch of nearest frequency.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from quadmodes.analysis.campbell import campbell
from quadmodes.analysis.reduced_linearisation import linearise
from quadmodes.rom import reduced as red
from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys
from quadmodes.rom.spin_axis import resolve_axis
from quadmodes.runs.manifold_system import linear_formulation

#: Bisection steps of :func:`refine`: the bracket shrinks by 2^-STEPS.
STEPS = 24


@dataclass(frozen=True)
class Bracket:
    """Two neighbouring points (indices into the sweep's points) and their spin rates (rad/s)
    between which the stability changes; ``reason`` "stiffness" or "roots"."""

    lo: int
    hi: int
    spin_lo: float
    spin_hi: float
    reason: str


@dataclass(frozen=True)
class CriticalSpeed:
    """A refined critical speed: ``spin`` rad/s, ``kind`` "divergence" or "flutter", the
    ``branch`` label and, for flutter, the ``partner`` branch ("" otherwise); ``entering``
    True if the undamped model is unstable above it (in the sweep's direction), ``bracket``."""

    spin: float
    kind: str
    branch: str
    partner: str
    entering: bool
    bracket: Bracket


def _unstable_count(p: dict) -> int:
    scale = 1e-7 * (1.0 + max([abs(f) for f in p["branch_frequency"]], default=0.0))
    return sum(1 for g in p["branch_growth_undamped"] if g > scale)


def brackets(spins: list[float], points: list[dict], indices: list[int]) -> list[Bracket]:
    """Brackets along one line of the sweep: ``spins`` (rad/s) ascending, the point results
    (:func:`quadmodes.sweeps.points.run_point` dicts, None for failed points) and their indices.
    A good point followed by a failed one (e.g. no spinning state beyond a divergence) gives a
    bracket of reason "extend": :func:`extend` decides on the good point's model."""
    out = []
    for k in range(len(spins) - 1):
        a, b = points[k], points[k + 1]
        if a is not None and b is None:
            out.append(Bracket(indices[k], indices[k + 1], spins[k], spins[k + 1], "extend"))
        if a is None or b is None:
            continue
        ka, kb = a["min_rotating_stiffness"], b["min_rotating_stiffness"]
        if (ka > 0) != (kb > 0):
            out.append(Bracket(indices[k], indices[k + 1], spins[k], spins[k + 1], "stiffness"))
        elif _unstable_count(a) != _unstable_count(b):
            out.append(Bracket(indices[k], indices[k + 1], spins[k], spins[k + 1], "roots"))
    return out


def _linearisation(model: red.ReducedModel, sys: rsys.ReducedSystem, spin: float, axis):
    """Undamped roots at ``spin`` (rad/s) about the relative equilibrium."""
    return linearise(sys, model, spin, axis, damped=False)


def _state(lin, reason: str):
    """The stability indicator: sign of the rotating stiffness, or the number of roots with
    Re λ > 0 (beyond round-off, relative to the largest root)."""
    if reason == "stiffness":
        return bool(lin.min_stiffness > 0)
    scale = 1e-7 * (1.0 + float(np.max(np.abs(lin.lam), initial=0.0)))
    return int(np.sum(lin.lam.real > scale))


def refine(
    model: red.ReducedModel, bracket: Bracket, formulation: str = "Q", axis=None
) -> CriticalSpeed:
    """Bisect ``bracket`` on ``model`` (the reduced model of its lower point) to the spin where
    the indicator of :func:`brackets` changes (plain linearisations, no tracking); classify and
    name the branches there. ``axis``: the run's ``initial.spin_axis`` (None: the default)."""
    sys = rsys.reduced_system(model, linear_formulation(formulation))  # QM: Q4's linearisation
    request, axis = axis, resolve_axis(model, axis, "initial.spin_axis")
    lo, hi = bracket.spin_lo, bracket.spin_hi
    start = _state(_linearisation(model, sys, lo, axis), bracket.reason)
    for _ in range(STEPS):
        mid = 0.5 * (lo + hi)
        if _state(_linearisation(model, sys, mid, axis), bracket.reason) == start:
            lo = mid
        else:
            hi = mid
    kind, branch, partner, entering = _classify(model, sys, axis, lo, hi, bracket.reason, formulation,
                                                request)  # fmt: skip
    return CriticalSpeed(0.5 * (lo + hi), kind, branch, partner, entering, bracket)


def extend(model: red.ReducedModel, bracket: Bracket, formulation: str = "Q", axis=None):
    """For a bracket of reason "extend": the model of the good (lower) point linearised at the
    failed point's spin; the refined :class:`CriticalSpeed` if the rotating stiffness or the
    number of unstable roots changes there, else None."""
    sys = rsys.reduced_system(model, linear_formulation(formulation))  # QM: Q4's linearisation
    request, axis = axis, resolve_axis(model, axis, "initial.spin_axis")
    below = _linearisation(model, sys, bracket.spin_lo, axis)
    above = _linearisation(model, sys, bracket.spin_hi, axis)
    for reason in ("stiffness", "roots"):
        if _state(below, reason) != _state(above, reason):
            return refine(model, replace(bracket, reason=reason), formulation, request)
    return None


def _static_mode_label(model, sys, spin: float, axis) -> str:
    """Label of the model mode dominating the eigenvector of the smallest eigenvalue of the
    rotating-frame stiffness at ``spin`` (rad/s): the static mode that passes through zero."""
    k = rf.rotating_frame_matrices(sys, spin * np.asarray(axis, float))[2]
    if k.size == 0:
        return ""
    vec = np.linalg.eigh(k)[1][:, 0]
    return str(model.labels[int(np.argmax(np.abs(vec)))])


def _classify(model, sys, axis, lo: float, hi: float, reason: str, formulation: str,
              request=None):  # fmt: skip
    """(kind, branch, partner, entering) at a refined crossing [lo, hi] (rad/s): the labels from
    the MAC tracking of :func:`~quadmodes.analysis.campbell.campbell` over the two spins."""
    below, above = (_linearisation(model, sys, x, axis) for x in (lo, hi))
    if reason == "stiffness":
        label = _static_mode_label(model, sys, 0.5 * (lo + hi), axis)
        return "divergence", label, "", not above.min_stiffness > 0
    entering = _state(above, reason) > _state(below, reason)
    unstable = above if entering else below
    scale = 1e-7 * (1.0 + float(np.max(np.abs(unstable.lam), initial=0.0)))
    grow = unstable.lam[unstable.lam.real > scale]
    divergence = bool(grow.size and np.all(np.abs(grow.imag) <= 1e3 * scale))
    try:
        track = campbell(model, [lo, hi], request, formulation=formulation, max_bisections=3,
                         max_refinements=4)  # fmt: skip
    except (ValueError, RuntimeError, np.linalg.LinAlgError):
        return ("divergence" if divergence else "flutter"), "", "", bool(entering)
    labels, f = track.labels, track.frequency[1 if entering else 0]
    changed = np.flatnonzero(track.unstable[0] != track.unstable[1])
    elastic = [i for i, lab in enumerate(labels) if lab != "nutation"] or list(range(len(labels)))
    if divergence:
        i = int(changed[0]) if changed.size else min(elastic, key=lambda j: np.nanmin(track.frequency[:, j]))
        return "divergence", labels[i], "", bool(entering)
    if changed.size == 0:
        target = float(np.abs(grow.imag).min()) if grow.size else 0.0
        changed = np.array([int(np.nanargmin(np.abs(f - target)))])
    i = int(changed[0])
    others = [j for j in range(len(labels)) if j != i]
    # a branch that ended (or starts) at this end has NaN there: never the partner
    j = min(others, key=lambda k: np.nan_to_num(abs(f[k] - f[i]), nan=np.inf)) if others else i
    return "flutter", labels[i], labels[j] if j != i else "", bool(entering)


def critical_speed_record(c: CriticalSpeed) -> dict:
    """JSON-ready record of a critical speed (SI)."""
    return {"spin": float(c.spin), "kind": c.kind, "branch": c.branch, "partner": c.partner,
            "entering": bool(c.entering), "lo": c.bracket.lo, "hi": c.bracket.hi,
            "spin_lo": c.bracket.spin_lo, "spin_hi": c.bracket.spin_hi,
            "reason": c.bracket.reason, "bracket_width": c.bracket.spin_hi - c.bracket.spin_lo,
            "resolution": abs(c.bracket.spin_hi - c.bracket.spin_lo) * 2.0**-STEPS}  # fmt: skip
