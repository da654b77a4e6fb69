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
"""

from __future__ import annotations

import math

import numpy as np

from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys


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
    other = rsys.reduced_system(rebuilt, setup.run.reduced.formulation)
    fa = rotating_frequencies(setup.system, omega)
    fb = rotating_frequencies(other, omega)
    return spin, frequency_difference(fa, fb)
