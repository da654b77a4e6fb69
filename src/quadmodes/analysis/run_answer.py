"""The linear answer of a free-body run: does its spin cone, how fast, and is it stable?

Stages::

    run case + reduced model ──spin_roots──▶ rotating-frame roots at the run's spin (undamped and
                                             damped) and the relative equilibrium (s*, ω0)
                             ──linear_answer──▶ LinearAnswer: the energy-sink estimate
                                             (:mod:`quadmodes.rom.energy_sink`) at the run's
                                             cone angle, the nutation root, the stability verdict

``quadmodes sweep`` stores the same numbers per point (``sweeps.points`` calls
:func:`spin_roots` and the same energy-sink estimate), so a run and a sweep point of the same
case give the same time constant. The simulated answer (the secular cone-growth rate fitted over
the quasi-steady part of the run, :func:`quadmodes.runs.secular.run_fits`) is computed from the
run's own diagnostics in :mod:`quadmodes.runs.results`; this module adds what needs the
linearisation (a layer above the runs).

**Stability rule** (:data:`STABILITY_RULE`): the spin is *unstable* when the rotating-frame
stiffness Λ − ωᵀJ2ω is not positive definite at the spin (a divergence: no relative equilibrium
to cone about) or the coning rate σ is positive; *stable* when σ < 0, *neutral* when σ = 0 (no
dissipation). σ is the energy-sink law's when the body is quasi-rigid (elastic momentum ratio ≤
0.1): there the sign is exact, P > 0 with damping and σ has the sign of I_t − I_a (a spin about
the minor axis cones, about the major axis it settles), however slow (0.5 Hz: τ ≈ 10¹⁰ s).
Otherwise σ is the real part of the damped linearisation's nutation root (the estimate is not
trusted there: the elastic response feeds back on the rotation).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from quadmodes.analysis.campbell import campbell
from quadmodes.rom.energy_sink import EnergySink, energy_sink
from quadmodes.runs import secular

#: The rule of :attr:`LinearAnswer.stability` in words (stored with the outputs).
STABILITY_RULE = (
    "unstable if the rotating-frame stiffness Lambda - omega^T J2 omega is not positive definite "
    "at the spin (divergence) or the coning rate sigma > 0; stable if sigma < 0; neutral if "
    "sigma = 0 (no dissipation). sigma: the energy-sink law's (sign of I_t - I_a with damping) "
    "when quasi-rigid (elastic momentum ratio <= 0.1), else the real part of the damped "
    "linearisation's nutation root"
)


def spin_roots(run, model) -> dict:
    """Rotating-frame roots of ``model`` at the spin of ``run`` (its formulation and spin axis):
    undamped (frequencies, critical speeds) and with the modal damping (growth rates), and the
    relative equilibrium (``_s_eq`` (N,) √kg·m, ``_omega0`` (3,) rad/s). SI; lists per branch."""
    spin = float(run.initial.spin_rate)
    form = run.reduced.formulation
    axis = run.initial.spin_axis  # None: the default axis
    undamped = campbell(model, [spin], axis, formulation=form, damped=False,
                        axis_option="initial.spin_axis")  # fmt: skip
    damped = campbell(model, [spin], axis, formulation=form, damped=True,
                      axis_option="initial.spin_axis")  # fmt: skip
    nut = [i for i, lab in enumerate(damped.labels) if lab == "nutation"]
    return {
        "linearised_spin": spin,
        "branch_label": list(undamped.labels),
        "branch_frequency": [float(x) for x in undamped.frequency[0]],
        "branch_growth_undamped": [float(x) for x in undamped.growth[0]],
        "branch_frequency_damped": [float(x) for x in damped.frequency[0]],
        "branch_growth": [float(x) for x in damped.growth[0]],
        "branch_label_damped": list(damped.labels),
        "nutation_growth_rate": float(damped.growth[0][nut[0]]) if nut else math.nan,
        "min_rotating_stiffness": float(undamped.min_stiffness[0]),
        "unstable_undamped": bool(undamped.unstable[0].any()),
        "_s_eq": undamped.s_eq[0],
        "_omega0": undamped.spin_axis[0] * spin,
    }


@dataclass(frozen=True)
class LinearAnswer:
    """The linear answer at a run's spin and initial cone angle (SI): ``sink`` the energy-sink
    estimate (power W, growth rate 1/s, time constant s, ...), ``nutation_growth_rate`` (1/s)
    the real part of the damped linearisation's nutation root (NaN if none is labelled),
    ``min_rotating_stiffness`` (1/s²), ``stability`` "stable", "unstable" or "neutral" by
    :data:`STABILITY_RULE`, ``coning_rate`` (1/s) the σ the verdict used. ``fit_sink``: the
    same estimate at the mean spin ``fit_spin`` (rad/s) and cone angle ``fit_cone`` (rad) of
    the run's quasi-steady part, the state the run's own fitted rate belongs to (a long run
    drifts: paper-41hz loses 0.09 Hz of spin over 120 s, which alone lengthens τ by 1.4 %);
    None when not computed."""

    sink: EnergySink
    nutation_growth_rate: float
    min_rotating_stiffness: float
    stability: str
    coning_rate: float
    rule: str = STABILITY_RULE
    fit_sink: EnergySink | None = None
    fit_spin: float = math.nan
    fit_cone: float = math.nan


def verdict(sink: EnergySink, nutation_growth_rate: float,
            min_rotating_stiffness: float) -> tuple[str, float]:  # fmt: skip
    """(stability, σ (1/s)) by :data:`STABILITY_RULE`."""
    sigma = sink.growth_rate if sink.quasi_rigid else nutation_growth_rate
    if not min_rotating_stiffness > 0.0:
        return "unstable", sigma
    if not math.isfinite(sigma):
        return "unknown", sigma
    return ("unstable" if sigma > 0 else "stable" if sigma < 0 else "neutral"), sigma


def linear_answer(run, model, system, fit_state: tuple[float, float] | None = None) -> LinearAnswer:
    """:class:`LinearAnswer` of ``run`` on ``model`` (restricted to the run's modes) and its
    ``system`` (the run's formulation), at the run's initial spin and cone angle; with
    ``fit_state`` = (spin rad/s, cone angle rad) also the estimate there (``fit_sink``)."""
    roots = spin_roots(run, model)
    sink = energy_sink(system, roots["_s_eq"], roots["_omega0"], float(run.initial.cone_angle))
    stability, sigma = verdict(sink, roots["nutation_growth_rate"], roots["min_rotating_stiffness"])
    answer = LinearAnswer(sink, roots["nutation_growth_rate"], roots["min_rotating_stiffness"],
                          stability, sigma)  # fmt: skip
    if fit_state is None or not all(math.isfinite(x) and x > 0 for x in fit_state):
        return answer
    spin, cone = fit_state
    moved = run.model_copy(update={"initial": run.initial.model_copy(
        update={"spin_rate": spin, "cone_angle": cone})})  # fmt: skip
    try:
        eq = spin_roots(moved, model)  # the relative equilibrium at the fit's spin
    except (ValueError, ArithmeticError, KeyError):  # none there: the answer at the start stands
        return answer
    fit_sink = energy_sink(system, eq["_s_eq"], eq["_omega0"], cone)
    return dataclasses.replace(answer, fit_sink=fit_sink, fit_spin=spin, fit_cone=cone)


def fit_state(result) -> tuple[float, float]:
    """(mean spin rate rad/s, mean cone angle rad) of ``result`` over the quasi-steady part of
    its run (:func:`quadmodes.runs.secular.run_fits`)."""
    d, model = result.diagnostics, result.model
    if len(d.t) < 2:
        return math.nan, math.nan
    q = secular.run_fits(d.t, d.cone_angle, d.E_d, d.spin_rate, model.frequencies_hz,
                         model.damping_ratio).interval  # fmt: skip
    sel = (d.t >= q.start_s) & (d.t <= q.end_s)
    if not sel.any():
        return math.nan, math.nan
    return float(np.mean(d.spin_rate[sel])), float(np.mean(d.cone_angle[sel]))


def with_linear_answer(result):
    """``result`` (a :class:`quadmodes.runs.simulate.RunResult`) with its ``linear`` answer (and
    the drawing of its model's Campbell diagram, :mod:`quadmodes.analysis.run_campbell`); a
    rigid run (no elastic mode) or one whose spin has no relative equilibrium keeps None and a
    note saying why."""
    if result.system.n_modes == 0:
        return result
    try:
        answer = linear_answer(result.run, result.model, result.system, fit_state(result))
    except (ValueError, ArithmeticError, KeyError) as exc:  # no relative equilibrium at the spin
        note = f"no energy-sink estimate or stability verdict: {exc}"
        return dataclasses.replace(result, notes=(*result.notes, note))
    from quadmodes.analysis.run_campbell import with_campbell  # its report's Campbell diagram

    return with_campbell(dataclasses.replace(result, linear=answer))
