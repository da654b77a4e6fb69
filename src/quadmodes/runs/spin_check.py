"""The centrifugal range of a model about a spinning state, measured: the run's model against
the model rebuilt about the spin its path reached.

:mod:`quadmodes.runs.path_validity` bounds the frequency error of a model whose path has left its
expansion spin by δ/2 (δ the departure of the centrifugal load): an upper bound that takes the
whole stiffness for centrifugal prestress and credits the model with none of the change. Where a
path passes that bound (and the run checks its path against the FE model, as ``quadmodes run``
does), the model of the same case and mode count is built about the spin of the path's sample
of largest δ (one model build, cached like any other: the first member of a family of models
along the path) and the rotating-frame frequencies of both are compared at that angular
velocity (:func:`rotating_frequencies`). If they agree within the tolerance the path is within
the range up to that δ; if not, the range ends at δ_ext · tol / ε (the error taken linear in δ
from the reference: on paper-41hz-coarse it grows more slowly, docs/validation.md).

The frequencies are not what a run's answer is made of. The coning response is forced at the
nutation frequency, near the rotating-frame branches, and its amplitude follows the small
detuning a spin change makes (in the prestress, the reference shape, the forcing), so the cone
growth moves 10–300 × more than the frequencies (paper-41hz-coarse: 1.25 % per 1 % of spin,
docs/path-validity.md). Hence a second measure with the same rebuilt model
(:func:`sink_error`): the energy-sink coning rate θ̇/θ (:func:`coning_rate`, the estimate of
:mod:`quadmodes.rom.energy_sink` restated on the model layer: the forced response at the
nutation frequency and the power it dissipates) of the run's model linearised about its
relative equilibrium at the path's spin, against the rebuilt model's about its own reference,
held to
:data:`SINK_TOLERANCE`. Where it fails, :func:`spin_limit` measures once more at the departure
the first measurement predicts (a second model build), so the limit is interpolated, not
extrapolated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys
from quadmodes.rom.energy_sink import energy_sink
from quadmodes.rom.steady_spin import relative_equilibrium
from quadmodes.runs.manifold_system import linear_formulation

#: The models' frequency tolerance (:data:`quadmodes.runs.path_validity.FREQUENCY_TOLERANCE`,
#: which is this one).
FREQUENCY_TOLERANCE = 0.01


def rotating_frequencies(system: rsys.ReducedSystem, omega: np.ndarray) -> np.ndarray:
    """Undamped rotating-frame frequencies (Hz, (N,) ascending) of ``system`` at the angular
    velocity ``omega`` (3,) rad/s: the roots of (λ²μ + λΓ(ω) + Λ − ωᵀJ2ω) φ = 0 about s = 0
    (:func:`quadmodes.rom.rotating_frame.rotating_frame_matrices`), positive imaginary parts."""
    mu, gam, k = rf.rotating_frame_matrices(system, np.asarray(omega, float))
    n = len(mu)
    if n == 0:
        return np.zeros(0)
    minv = np.linalg.inv(mu)
    companion = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ gam]])
    lam = np.linalg.eigvals(companion)
    return np.sort(lam.imag[lam.imag > 0]) / (2 * math.pi)


def frequency_difference(fa: np.ndarray, fb: np.ndarray, floor_hz: float = 1e-3) -> float:
    """Largest relative difference of two ascending frequency lists paired in order (those of
    ``fb`` below ``floor_hz`` left out); inf when their counts differ."""
    if len(fa) != len(fb):
        return math.inf
    keep = fb > floor_hz
    if not keep.any():
        return 0.0
    return float(np.max(np.abs(fa[keep] - fb[keep]) / fb[keep]))


def measured_error(setup, omega: np.ndarray) -> tuple[float, float]:
    """(spin about the reference axis (rad/s), ε): the largest relative difference of the
    rotating-frame frequencies at ``omega`` (3,) rad/s between the run's model
    (``setup.system``) and the model of the same case and mode count built about that spin."""
    from quadmodes.models.build import reduced_model_for

    e = np.asarray(setup.model.reference_axis, float)
    spin = abs(float(np.asarray(omega, float) @ e))
    rebuilt = reduced_model_for(setup.model_case, setup.model.n_modes, spin=spin,
                                axis=setup.run.reference_axis)  # the run's own axis
    other = rsys.reduced_system(rebuilt, linear_formulation(setup.run.reduced.formulation))
    fa = rotating_frequencies(setup.system, omega)
    fb = rotating_frequencies(other, omega)
    return spin, frequency_difference(fa, fb)


#: Relative change of the energy-sink coning rate θ̇/θ allowed from the spin departure: the
#: reduced paths meet the full order within 5 % in their cone growth (issue 29), the models'
#: own error at their spin is 2.0–2.4 % (× 0.976–0.980, docs/full-order.md), so a spin departure
#: may add 2 % more (the amplitude check's tolerance in energy too).
SINK_TOLERANCE = 0.02


def _rebuilt(setup, spin: float):
    """(model, system) of the run's case and mode count rebuilt about ``spin`` (rad/s; cached)."""
    from quadmodes.models.build import reduced_model_for

    model = reduced_model_for(setup.model_case, setup.model.n_modes, spin=spin,
                              axis=setup.run.reference_axis)  # fmt: skip
    return model, rsys.reduced_system(model, linear_formulation(setup.run.reduced.formulation))


def coning_rate(sys: rsys.ReducedSystem, spin: float, axis: np.ndarray, cone: float) -> float:
    """θ̇/θ (1/s) of the energy-sink law (:func:`quadmodes.rom.energy_sink.energy_sink`, its
    ``growth_rate``) of ``sys`` about its relative equilibrium at ``spin`` (rad/s) near ``axis``
    (3,), at the cone angle ``cone`` (rad, > 0). NaN for a quartic or nonlinear potential."""
    if sys.nonlinear or sys.n_modes == 0:
        return math.nan
    w0, s_eq, _ = relative_equilibrium(sys, spin, np.asarray(axis, float) / np.linalg.norm(axis))
    return float(energy_sink(sys, s_eq, w0, cone).growth_rate)


def sink_error(setup, omega: np.ndarray, cone: float) -> float:
    """|θ̇/θ of the run's model / that of the model rebuilt about the spin − 1| at the angular
    velocity ``omega`` (3,) rad/s along the reference axis and the cone angle ``cone`` (rad):
    the energy-sink coning rates (:func:`coning_rate`), each model about its relative
    equilibrium at that spin. NaN where it cannot be measured (a quartic or nonlinear
    potential, no relative equilibrium, no dissipation)."""
    spin = float(np.linalg.norm(omega))
    axis = np.asarray(omega, float) / spin
    cone = max(float(cone), 1e-3)  # the ratio has a limit at θ → 0
    try:
        rates = [coning_rate(setup.system, spin, axis, cone),
                 coning_rate(_rebuilt(setup, spin)[1], spin, axis, cone)]  # fmt: skip
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        return math.nan
    if not (math.isfinite(rates[0]) and math.isfinite(rates[1]) and rates[1] != 0.0):
        return math.nan
    return abs(rates[0] / rates[1] - 1.0)


@dataclass(frozen=True)
class SpinLimit:
    """The measured limit of the spin part of δ (``limit``) and how (``basis``, one phrase);
    ``spin`` (rad/s) and ``frequency_error`` where the frequencies were compared (the sample of
    largest departure); ``sink_spin`` (rad/s) and ``sink_error``: the energy-sink rates'
    relative difference at the last spin measured (NaN: not measurable)."""

    limit: float
    basis: str
    spin: float
    frequency_error: float
    sink_spin: float = math.nan
    sink_error: float = math.nan


def _crossing(d1: float, e1: float, d2: float, e2: float, tol: float) -> float:
    """δ where the error, linear through (d1, e1) and (d2, e2) (d1 < d2), reaches ``tol``;
    through the origin and (d1, e1) when e1 > tol already."""
    if e1 > tol or not e2 > e1:
        return d1 * tol / e1
    return d1 + (d2 - d1) * (tol - e1) / (e2 - e1)


def spin_limit(setup, departure: np.ndarray, rate: np.ndarray, cone: np.ndarray, e: np.ndarray,
               ) -> SpinLimit:  # fmt: skip
    """The limit of the spin part δ (k,) of a path's departure, measured: at the sample k of
    largest δ (spin ``rate[k]`` rad/s about the unit axis ``e`` (3,), cone angle ``cone[k]``
    rad) the rotating-frame frequencies (:func:`measured_error`, :data:`FREQUENCY_TOLERANCE`)
    and the energy-sink coning rate (:func:`sink_error`, :data:`SINK_TOLERANCE`) of the run's
    model against the model rebuilt there. Within both: δ_k. Else the smaller of δ_k·tol/ε
    (frequencies) and, for the coning rate, a second measurement at the first sample past
    δ_k·tol/ε with the limit interpolated between the two (two model builds in all, cached)."""
    k = int(np.argmax(departure))
    d_k = float(departure[k])
    spin, eps = measured_error(setup, rate[k] * e)
    limits = [d_k if eps <= FREQUENCY_TOLERANCE else d_k * FREQUENCY_TOLERANCE / eps]
    basis = (f"measured: the model rebuilt about {spin / (2 * math.pi):.5g} Hz differs by "
             f"{100 * eps:.2g} % in its rotating-frame frequencies")  # fmt: skip
    sink = sink_error(setup, rate[k] * e, float(cone[k]))
    sink_spin, sink_at = abs(float(rate[k])), sink
    if not math.isfinite(sink):
        return SpinLimit(min(limits), basis + " (coning rate not measurable there)", spin, eps)
    basis += f" and by {100 * sink:.2g} % in its energy-sink coning rate"
    if sink > SINK_TOLERANCE:
        j = int(np.argmax(departure >= d_k * SINK_TOLERANCE / sink))
        d_j = float(departure[j])
        sink_j = sink_error(setup, rate[j] * e, float(cone[j])) if 0 < d_j < d_k else math.nan
        if math.isfinite(sink_j):
            limits.append(_crossing(d_j, sink_j, d_k, sink, SINK_TOLERANCE))
            sink_spin, sink_at = abs(float(rate[j])), sink_j
            basis += (f", {100 * sink_j:.2g} % about {sink_spin / (2 * math.pi):.5g} Hz; "
                      f"limit {100 * SINK_TOLERANCE:g} %, interpolated")  # fmt: skip
        else:
            limits.append(d_k * SINK_TOLERANCE / sink)
            basis += f"; limit {100 * SINK_TOLERANCE:g} %, taken linear in the departure"
    elif eps > FREQUENCY_TOLERANCE:
        basis += ", frequencies taken linear in the departure"
    return SpinLimit(min(limits), basis, spin, eps, sink_spin, sink_at)
