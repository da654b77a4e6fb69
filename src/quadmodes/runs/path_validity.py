"""Validity of the reduced model along a run's path, not only at its start.

A reduced model is expanded about one state: about a spinning state (``reference =
"spinning"``) its stiffness Λ holds the centrifugal prestress of the reference angular velocity
ω_ref = Ω_ref e, and about the state at rest the centrifugal load enters through the quadratic
modes only. As a body cones, its spin about the reference axis falls and its angular velocity
tilts in the body, so the run leaves the state its model was built for. Three checks, on every
saved sample of the path:

* **Centrifugal load** (models about a spinning state): the centrifugal acceleration field is
  C(ω) r with C(ω) = ωωᵀ − |ω|² I; its departure from the model's is
  δ = ‖C(ω) − C(ω_ref)‖₂ / Ω_ref² (the largest change of the acceleration per unit distance,
  relative to the reference's Ω_ref²; magnitude and direction of ω both enter). The prestress
  the centrifugal load causes is linear in it, so the part of the stiffness the model holds
  fixed is off by at most δ of the centrifugal prestress, itself at most the whole stiffness:
  the squared rotating-frame frequencies by at most δ, the frequencies by δ/2. With the model's
  frequency tolerance of 1 % (:data:`FREQUENCY_TOLERANCE`: every rotating-frame branch of the
  paper models within 1 % of the full order, docs/full-order.md) the limit is δ ≤ 2 %
  (:data:`CENTRIFUGAL_LIMIT`): a spin within ±1 % of the reference, or an angular velocity
  tilted by at most 1.1° from the reference axis. This is an upper bound of what the model
  leaves out (docs/validation.md compares it with a model rebuilt at the lower spin).
* **Rotating-frame stiffness**: Λ − ωᵀJ2ω positive definite at the path's angular velocities
  (on at most :data:`STIFFNESS_SAMPLES` samples and the one of largest |ω|), the check
  :mod:`quadmodes.runs.validity` makes at the initial spin.
* **Modal amplitudes**: the largest modal amplitude ‖s‖ of the path set beside the FE model's
  condensed energy (and where the membrane would first lose tension, recorded) (:func:`with_amplitude_check`, what
  :mod:`quadmodes.runs.deformation_check` does for the initial deformation; one static FE
  solve); without it the amplitudes are *unchecked* and the path is not called valid.

The path is valid when every check ran and none failed; where the first fails the run "leaves
the model's range" (time, spin, cone angle of that sample).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys
from quadmodes.runs.validity import DEFORMATION_ENERGY_TOLERANCE

#: Relative frequency error the reduced models are held to (every rotating-frame branch within
#: 1 % of the full order on the paper models, docs/full-order.md).
FREQUENCY_TOLERANCE = 0.01
#: Largest departure δ of the centrifugal load from the model's: 2 × the frequency tolerance
#: (δ bounds the relative error of the squared frequencies, module docstring).
CENTRIFUGAL_LIMIT = 2.0 * FREQUENCY_TOLERANCE
#: The rotating-frame stiffness is checked on at most this many samples of the path.
STIFFNESS_SAMPLES = 200


@dataclass(frozen=True)
class PathValidity:
    """The model's validity along a run's path.

    reference_spin (rad/s; 0 about the state at rest); centrifugal_max: the largest departure δ
    of the centrifugal load (NaN about the state at rest); centrifugal_limit; spin_range (rad/s):
    the spins about the reference axis within the limit (no tilt); min_stiffness (s⁻²): smallest
    eigenvalue of Λ − ωᵀJ2ω on the path; amplitude_peak (kg^½ m): largest ‖s‖, at
    amplitude_peak_time (s); amplitude_error: the reduced potential's relative error there
    against the FE model's condensed energy (NaN: not checked); amplitude_slack_fraction: the
    fraction of the peak deformation at which the membrane first loses tension (linearised; inf:
    never); left_at (s): the first sample where a check fails (None: none), with left_spin
    (rad/s), left_cone (rad) and left_reason; checked / unchecked: the checks made and not."""

    reference_spin: float
    centrifugal_max: float
    centrifugal_limit: float
    spin_range: tuple[float, float]
    min_stiffness: float
    amplitude_peak: float
    amplitude_peak_time: float
    left_at: float | None
    left_spin: float = math.nan
    left_cone: float = math.nan
    left_reason: str = ""
    checked: tuple[str, ...] = ()
    unchecked: tuple[str, ...] = ()
    amplitude_error: float = math.nan
    amplitude_slack_fraction: float = math.inf

    @property
    def valid(self) -> bool:
        """Every check ran and none failed."""
        return self.left_at is None and not self.unchecked

    def message(self) -> str:
        """One line ("" when valid)."""
        if self.left_at is not None:
            return (f"the run leaves its reduced model's range at t = {self.left_at:.6g} s "
                    f"(spin {self.left_spin / (2 * math.pi):.5g} Hz, cone "
                    f"{math.degrees(self.left_cone):.4g} deg): {self.left_reason}")  # fmt: skip
        if self.unchecked:
            return f"not checked along the path: {', '.join(self.unchecked)}"
        return ""


def centrifugal_departure(omega: np.ndarray, omega_ref: np.ndarray) -> np.ndarray:
    """δ (k,) = ‖C(ω) − C(ω_ref)‖₂ / |ω_ref|² for ω (k,3) rad/s, C(w) = wwᵀ − |w|² I (the
    centrifugal acceleration per unit distance)."""
    w = np.atleast_2d(np.asarray(omega, float))
    w0 = np.asarray(omega_ref, float)

    def c(v):
        return np.einsum("...a,...b->...ab", v, v) - np.einsum("...a,...a->...", v, v)[
            ..., None, None
        ] * np.eye(3)

    d = c(w) - c(w0)
    return np.abs(np.linalg.eigvalsh(d)).max(axis=-1) / float(w0 @ w0)


def spin_range(omega_ref: float, limit: float = CENTRIFUGAL_LIMIT) -> tuple[float, float]:
    """Spins (rad/s) about the reference axis whose δ = |Ω² − Ω_ref²| / Ω_ref² is ``limit``."""
    return omega_ref * math.sqrt(max(1.0 - limit, 0.0)), omega_ref * math.sqrt(1.0 + limit)


def _stiffness(system: rsys.ReducedSystem, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sample indices, smallest eigenvalue of Λ − ωᵀJ2ω there (s⁻²)) on at most
    :data:`STIFFNESS_SAMPLES` samples of ω (k,3) and the sample of largest |ω|."""
    k = len(w)
    idx = np.unique(np.r_[np.linspace(0, k - 1, min(k, STIFFNESS_SAMPLES)).astype(int),
                          int(np.argmax(np.linalg.norm(w, axis=1)))])  # fmt: skip
    if system.n_modes == 0:
        return idx, np.full(len(idx), math.inf)
    vals = [
        float(np.linalg.eigvalsh(rf.rotating_frame_matrices(system, w[i])[2]).min()) for i in idx
    ]
    return idx, np.asarray(vals)


def _first(t: np.ndarray, bad: np.ndarray) -> int | None:
    hits = np.flatnonzero(bad)
    return int(hits[0]) if len(hits) else None


def path_validity(setup, solution, diag) -> PathValidity:
    """:class:`PathValidity` of a run (a :class:`~quadmodes.runs.simulate.RunSetup`, its
    merged :class:`~quadmodes.rom.solution.Solution` and its
    :class:`~quadmodes.rom.diagnostics.Diagnostics`) from the saved samples; the modal
    amplitudes are left unchecked (:func:`with_amplitude_check` checks them)."""
    system = setup.system
    t = np.asarray(solution.t, float)
    _, w, s, _ = rsys.split_state(system, np.asarray(solution.y, float))
    w_ref = np.asarray(system.reference_omega, float)
    spin_ref = float(np.linalg.norm(w_ref))
    fails: list[tuple[int, str]] = []
    checked = ["rotating-frame stiffness"]
    if spin_ref > 0.0:
        delta = centrifugal_departure(w, w_ref)
        checked.insert(0, "centrifugal load")
        k = _first(t, delta > CENTRIFUGAL_LIMIT)
        if k is not None:
            fails.append((k, f"the centrifugal load departs by {100 * delta[k]:.3g} % from the "
                             f"model's at {spin_ref / (2 * math.pi):.5g} Hz (limit "
                             f"{100 * CENTRIFUGAL_LIMIT:g} %: ±{100 * FREQUENCY_TOLERANCE:g} % in "
                             "the rotating-frame frequencies)"))  # fmt: skip
        dmax = float(delta.max()) if len(delta) else 0.0
    else:
        dmax = math.nan
    idx, kmin = _stiffness(system, w)
    bad = np.flatnonzero(kmin <= 0.0)
    if len(bad):
        fails.append((int(idx[bad[0]]), "the rotating-frame stiffness Λ − ωᵀJ2ω is not "
                      f"positive definite (smallest eigenvalue {kmin[bad[0]]:.4g} s⁻²)"))  # fmt: skip
    amp = np.linalg.norm(s, axis=1) if s.shape[1] else np.zeros(len(t))
    peak = int(np.argmax(amp)) if len(amp) else 0
    unchecked = ("modal amplitudes",) if s.shape[1] and amp[peak] > 0 else ()
    path = PathValidity(spin_ref, dmax, CENTRIFUGAL_LIMIT,
                        spin_range(spin_ref) if spin_ref else (math.nan, math.nan),
                        float(kmin.min()) if len(kmin) else math.inf,
                        float(amp[peak]) if len(amp) else 0.0, float(t[peak]) if len(t) else 0.0,
                        None, checked=tuple(checked), unchecked=unchecked)  # fmt: skip
    return _with_failures(path, fails, t, diag)


def _with_failures(path: PathValidity, fails: list, t, diag) -> PathValidity:
    """``path`` with its first failure (sample index, reason) of ``fails`` as where it leaves."""
    if not fails:
        return path
    k, reason = min(fails, key=lambda f: f[0])
    if path.left_at is not None and path.left_at <= t[k]:
        return path
    return dataclasses.replace(path, left_at=float(t[k]), left_spin=float(diag.spin_rate[k]),
                               left_cone=float(diag.cone_angle[k]), left_reason=reason)  # fmt: skip


def with_amplitude_check(path: PathValidity, setup, solution, diag, progress=None) -> PathValidity:
    """``path`` with its largest modal amplitude checked against the FE model
    (:mod:`quadmodes.runs.deformation_check` at the state of that sample: the reduced potential
    within :data:`~quadmodes.runs.validity.DEFORMATION_ENERGY_TOLERANCE` of the condensed
    energy; where the membrane first loses tension along it, linearised, is recorded, not
    judged, as for the initial deformation: the FE model is an SVK membrane too). When the peak
    fails, the path leaves the range at the first sample whose amplitude exceeds the initial
    one."""
    from quadmodes.runs import deformation_check as dc

    if "modal amplitudes" not in path.unchecked:
        return path
    t = np.asarray(solution.t, float)
    y = np.asarray(solution.y, float)
    s = rsys.split_state(setup.system, y)[2]
    amp = np.linalg.norm(s, axis=1)
    peak = int(np.argmax(amp))
    at_peak = dataclasses.replace(setup, initial=dataclasses.replace(setup.initial, y0=y[peak]))
    structure = dc.deformation_structure(setup)
    slack = dc.initial_slack_onset(at_peak, structure)
    continuation = slack is None or not slack[0] < dc.SLACK_CONTINUATION_LIMIT
    energies = dc.initial_deformation_energies(at_peak, progress, continuation, structure)
    reduced, condensed = energies if energies is not None else (0.0, 0.0)
    err = (
        abs(reduced - condensed) / condensed
        if condensed > 0
        else (0.0 if reduced == 0 else math.inf)
    )
    checked = dataclasses.replace(
        path, checked=(*path.checked, "modal amplitudes"), unchecked=(),
        amplitude_error=float(err), amplitude_slack_fraction=math.inf if slack is None else float(slack[0]),
    )  # fmt: skip
    problems = []
    where = f"at the largest modal amplitude (t = {t[peak]:.6g} s)"
    if math.isinf(err):
        slack_text = ("" if slack is None else f"; the membrane loses tension at "
                      f"{100 * slack[0]:.3g} % of it, linearised")  # fmt: skip
        problems.append(f"the FE model's condensed energy did not converge {where}{slack_text}")
    elif not err <= DEFORMATION_ENERGY_TOLERANCE:
        problems.append(f"the reduced potential is {100 * err:.3g} % off the FE model's "
                        f"condensed energy {where} (limit {100 * DEFORMATION_ENERGY_TOLERANCE:g} %)")  # fmt: skip
    if not problems:
        return checked
    k = _first(t, amp > amp[0] * (1.0 + 1e-12)) or 0
    return _with_failures(checked, [(k, "; ".join(problems))], t, diag)


def run_path_validity(setup, solution, diag) -> PathValidity:
    """:func:`path_validity` of a run, its modal amplitudes checked against the FE model
    (:func:`with_amplitude_check`) when ``setup.fe_checks`` (set by
    :func:`~quadmodes.runs.deformation_check.with_deformation_check`, as ``quadmodes run``)."""
    path = path_validity(setup, solution, diag)
    return with_amplitude_check(path, setup, solution, diag) if setup.fe_checks else path
