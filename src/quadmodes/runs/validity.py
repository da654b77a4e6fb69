"""Validity of the reduced model at a run's spin: the rotating-frame stiffness Λ − ωᵀJ2ω must
stay positive definite from rest up to the spin, and (Q4 only) the initial modal energy must
stay below the lowest barrier of the truncated quartic potential."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from quadmodes.rom import dynamics as dyn
from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys

#: Spin rates scanned (uniformly from 0 to the run's spin) by :func:`rotating_validity`.
VALIDITY_SCAN = 64
#: Largest relative error of the reduced potential at the initial deformation against the FE
#: model's condensed energy (:mod:`quadmodes.runs.deformation_check`): ε in energy is about
#: ε/2 in the frequency of the oscillation it starts, so 2 % stands for the 1 % target.
DEFORMATION_ENERGY_TOLERANCE = 0.02


@dataclass(frozen=True)
class Validity:
    """Whether the rotating-frame stiffness K(ω) = Λ − ωᵀJ2ω of the reduced model stays
    positive definite for every spin rate from 0 up to the run's (ω scaled along its direction).

    min_eigenvalue (1/s²): smallest eigenvalue of K at the run's ω (mass-normalised modal
    coordinates, so the square of a rotating-frame frequency); spin_rate (rad/s): |ω|;
    lost_at (rad/s): the spin rate at which K stops being positive definite (None if it does
    not); valid: ``lost_at is None``."""

    formulation: str
    spin_rate: float
    min_eigenvalue: float
    lost_at: float | None
    modal_energy: float = 0.0
    barrier_energy: float = math.inf
    deformation_energy_reduced: float = math.nan
    deformation_energy_condensed: float = math.nan
    past_maximum_on_ray: bool = False
    slack_onset_fraction: float = math.inf
    slack_onset_amplitude: float = math.nan
    slack_fraction: float = math.nan
    reference_slack_fraction: float = math.nan
    slack_onset_position: tuple = ()
    slack_judged: bool = False

    @property
    def beyond_barrier(self) -> bool:
        """Q4 only: the initial modal energy exceeds the quartic potential's lowest barrier, or
        the initial deformation already lies beyond the potential's maximum along its own
        direction (there the truncated potential falls, even below zero)."""
        return self.modal_energy > self.barrier_energy or self.past_maximum_on_ray

    @property
    def deformation_error(self) -> float:
        """Relative error of the reduced potential at the initial deformation against the FE
        model's condensed energy (NaN when not checked; inf when the condensation failed)."""
        red, cond = self.deformation_energy_reduced, self.deformation_energy_condensed
        if math.isnan(red):
            return math.nan
        if math.isnan(cond) or cond <= 0.0:
            return math.inf
        return abs(red - cond) / cond

    @property
    def beyond_deformation_range(self) -> bool:
        """The initial deformation is outside the range where the reduced potential holds."""
        return self.deformation_error > DEFORMATION_ENERGY_TOLERANCE  # False for NaN

    @property
    def slackens(self) -> bool:
        """A membrane element taut at the reference loses tension within the initial deformation
        (exact strain of the manifold displacement, :mod:`quadmodes.structure.tension_margin`)
        and the onset is judged (``slack_judged``: a membrane held taut by its spin alone; for a
        pressurised one it is recorded, and the energy check judges, docs/sails.md)."""
        return self.slack_judged and self.slack_onset_fraction < 1.0

    @property
    def valid(self) -> bool:
        return self.spin_valid and self.initial_deformation_valid

    @property
    def spin_valid(self) -> bool:
        """The spin check: Λ − ωᵀJ2ω positive definite up to the spin (Q4: below its barrier)."""
        return self.lost_at is None and not self.beyond_barrier

    @property
    def initial_deformation_valid(self) -> bool:
        """The initial-deformation check: the reduced potential within
        :data:`DEFORMATION_ENERGY_TOLERANCE` of the FE model's condensed energy, and the
        membrane taut wherever it is taut at the reference (True: unchecked)."""
        return not self.beyond_deformation_range and not self.slackens

    def slack_note(self) -> str:
        """Where the membrane first loses tension along the initial deformation, when that lies
        before the deformation ("" otherwise; :mod:`quadmodes.structure.tension_margin`)."""
        if not self.slack_onset_fraction < 1.0:
            return ""
        where = ("" if not self.slack_onset_position else " at (" + ", ".join(
            f"{v:.3g}" for v in self.slack_onset_position) + ") m")
        rest = (f"; {100 * self.reference_slack_fraction:.2g} % of it already slack at the "
                "reference state, not judged" if self.reference_slack_fraction > 0 else "")
        return (f"the membrane first loses tension (wrinkles){where} at "
                f"{100 * self.slack_onset_fraction:.2g} % of this deformation "
                f"({1e3 * self.slack_onset_amplitude:.3g} mm of largest displacement; "
                f"{100 * self.slack_fraction:.2g} % of the membrane taut at the reference slack "
                f"at the full deformation, exact strain{rest}), beyond which neither the taut model "
                "nor any smooth reduced potential holds")  # fmt: skip

    def message(self) -> str:
        """One line for a warning ("" when valid)."""
        if self.valid:
            return ""
        if (self.lost_at is None and not self.beyond_barrier and self.slackens
                and not self.beyond_deformation_range):
            return (f"formulation {self.formulation}: the initial deformation takes the membrane "
                    f"out of tension: {self.slack_note()}; use a smaller "
                    "initial.bending_amplitude (or a smaller modal amplitude)")  # fmt: skip
        if self.beyond_deformation_range and self.lost_at is None and not self.beyond_barrier:
            err = self.deformation_error
            what = ("the FE model's condensed energy did not converge" if math.isinf(err) else
                    f"the reduced potential is {100 * err:.1f} % off the FE model's condensed "
                    f"energy ({self.deformation_energy_reduced:.4g} J against "
                    f"{self.deformation_energy_condensed:.4g} J)")  # fmt: skip
            slack = self.slack_note()
            return (
                f"formulation {self.formulation}: the initial deformation is outside the range "
                f"of the reduced potential: {what}{'; ' + slack if slack else ''}; its frequency "
                f"and decay at this amplitude are not trusted (limit "
                f"{100 * DEFORMATION_ENERGY_TOLERANCE:g} %): use a smaller "
                "initial.bending_amplitude or check with quadmodes compare"
            )
        if self.lost_at is None and self.past_maximum_on_ray:
            return (
                f"formulation {self.formulation} is outside its validity: the initial deformation "
                "lies beyond the maximum of its truncated quartic potential along its own "
                f"direction (modal energy {self.modal_energy:.4g} J, lowest barrier "
                f"{self.barrier_energy:.4g} J), where Q4 means nothing; use Q, or a smaller "
                "initial deformation"
            )
        if self.lost_at is None:
            return (
                f"formulation {self.formulation} is outside its validity: the initial modal energy "
                f"{self.modal_energy:.4g} J exceeds the lowest barrier {self.barrier_energy:.4g} J "
                "of its truncated quartic potential, so the motion may leave the range where Q4 "
                "means anything; use Q, or a smaller initial deformation"
            )
        return (
            f"formulation {self.formulation} is outside its validity: the rotating-frame "
            f"stiffness Λ − ωᵀJ2ω is not positive definite above a spin rate of "
            f"{self.lost_at:.4g} rad/s ({self.lost_at / (2 * math.pi):.4g} Hz); the run's spin "
            f"is {self.spin_rate:.4g} rad/s (smallest eigenvalue {self.min_eigenvalue:.4g} s⁻²)"
        )

    def as_dict(self) -> dict:
        return {
            "valid": self.valid,
            "formulation": self.formulation,
            "rotating_stiffness_min_eigenvalue": float(self.min_eigenvalue),
            "rotating_stiffness_min_eigenvalue_units": "s-2",
            "spin_rate_rad_s": float(self.spin_rate),
            "lost_at_spin_rate_rad_s": None if self.lost_at is None else float(self.lost_at),
            "initial_modal_energy_J": float(self.modal_energy),
            "potential_barrier_J": None
            if math.isinf(self.barrier_energy)
            else float(self.barrier_energy),
            "initial_deformation_energy_reduced_J": _json_float(self.deformation_energy_reduced),
            "initial_deformation_energy_condensed_J": _json_float(
                self.deformation_energy_condensed
            ),
            "initial_deformation_energy_error": _json_float(self.deformation_error),
            "slack_onset_fraction_of_initial_deformation": _json_float(self.slack_onset_fraction),
            "slack_onset_amplitude_m": _json_float(self.slack_onset_amplitude),
            "slack_membrane_fraction_at_initial_deformation": _json_float(self.slack_fraction),
            "reference_slack_fraction": _json_float(self.reference_slack_fraction),
            "message": self.message(),
        }


def _json_float(value: float) -> float | None:
    return None if not math.isfinite(value) else float(value)


def _min_stiffness(system: rsys.ReducedSystem, omega: np.ndarray) -> float:
    k = rf.rotating_frame_matrices(system, omega)[2]
    return float(np.linalg.eigvalsh(k).min()) if k.shape[0] else math.inf


def rotating_validity(
    system: rsys.ReducedSystem, omega, formulation: str, n_scan: int = VALIDITY_SCAN
) -> Validity:
    """:class:`Validity` of ``system`` (its formulation's J2) spinning at ``omega`` (3,) rad/s:
    the smallest eigenvalue of Λ − ωᵀJ2ω on a scan of ``n_scan`` spin rates α·ω (0 < α ≤ 1),
    the first loss of definiteness refined by bisection."""
    from scipy.optimize import brentq

    omega = np.asarray(omega, float)
    rate = float(np.linalg.norm(omega))
    if system.n_modes == 0 or rate == 0.0:
        return Validity(formulation, rate, math.inf if system.n_modes == 0 else
                        _min_stiffness(system, omega), None)  # fmt: skip
    alphas = np.linspace(0.0, 1.0, n_scan + 1)
    values = [_min_stiffness(system, a * omega) for a in alphas]
    lost = None
    for k in range(1, len(alphas)):
        if values[k] <= 0.0:
            if values[k - 1] > 0.0:
                a = brentq(lambda x: _min_stiffness(system, x * omega), alphas[k - 1], alphas[k])
            else:
                a = alphas[k - 1]
            lost = float(a * rate)
            break
    return Validity(formulation, rate, values[-1], lost)


def initial_validity(system: rsys.ReducedSystem, y0: np.ndarray, formulation: str) -> Validity:
    """:func:`rotating_validity` at the angular velocity of the initial state ``y0`` (7+2N,);
    for a quartic (Q4) system also the initial modal energy ½ṡᵀμṡ + V(s) (J; the effective
    potential for a model about a spinning state) and the lowest barrier of its potential (J)."""
    omega0 = rsys.split_state(system, y0)[1]
    validity = rotating_validity(system, omega0, formulation)
    if system.quartic:
        _, _, s0, sd0 = rsys.split_state(system, y0)
        e_modal = float(0.5 * sd0 @ system.mu @ sd0 + dyn.effective_potential(system, s0))
        validity = dataclasses.replace(
            validity, modal_energy=e_modal, barrier_energy=dyn.potential_barrier(system)[0],
            past_maximum_on_ray=dyn.beyond_ray_maximum(system, s0),
        )  # fmt: skip
    return validity
