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
  leaves out, far from tight (the 41 Hz model of paper-41hz-coarse at 37.7 Hz is within 0.09 %
  of the model rebuilt there, docs/validation.md); where a path passes it and the run checks its
  path against the FE model (``quadmodes run``), the range is measured instead
  (:func:`with_measured_range`, :mod:`quadmodes.runs.spin_check`).
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
    (rad/s), left_cone (rad) and left_reason; checked / unchecked: the checks made and not;
    measured_spin (rad/s) and measured_error: where the centrifugal range was measured against a
    model rebuilt about that spin and the largest relative difference of the rotating-frame
    frequencies there (NaN: not measured; then centrifugal_limit is the a-priori bound)."""

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
    measured_spin: float = math.nan
    measured_error: float = math.nan

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


def _first(bad: np.ndarray) -> int | None:
    """Index of the first True of ``bad`` (None if none)."""
    hits = np.flatnonzero(bad)
    return int(hits[0]) if len(hits) else None


def spin_and_tilt(omega: np.ndarray, omega_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two parts of the departure for ω (k,3) rad/s from ω_ref = Ω_ref e: of the spin about
    e, |(ω·e)² / Ω_ref² − 1| (δ of a pure spin change), and of the direction, sin β = |ω × e| / |ω|
    (δ of a pure tilt by β), each (k,)."""
    w = np.atleast_2d(np.asarray(omega, float))
    spin_ref = float(np.linalg.norm(omega_ref))
    e = np.asarray(omega_ref, float) / spin_ref
    spin = np.abs((w @ e) ** 2 / spin_ref**2 - 1.0)
    norm = np.linalg.norm(w, axis=1)
    tilt = np.linalg.norm(np.cross(w, e), axis=1) / np.where(norm > 0, norm, 1.0)
    return spin, tilt


def _centrifugal_failure(t, w, w_ref, spin_limit, basis: str):
    """(sample index, reason) where the centrifugal load first leaves the range, or None: δ past
    :data:`CENTRIFUGAL_LIMIT` (a priori), or with a measured ``spin_limit`` the spin part past it
    or the tilt part past the a-priori bound."""
    spin_hz = float(np.linalg.norm(w_ref)) / (2 * math.pi)
    if spin_limit is None:
        delta = centrifugal_departure(w, w_ref)
        k = _first(delta > CENTRIFUGAL_LIMIT)
        return None if k is None else (k, (
            f"the centrifugal load departs by {100 * delta[k]:.3g} % from the model's at "
            f"{spin_hz:.5g} Hz (limit {100 * CENTRIFUGAL_LIMIT:g} %: ±"
            f"{100 * FREQUENCY_TOLERANCE:g} % in the rotating-frame frequencies)"))  # fmt: skip
    spin, tilt = spin_and_tilt(w, w_ref)
    ks, kt = _first(spin > spin_limit), _first(tilt > CENTRIFUGAL_LIMIT)
    if ks is not None and (kt is None or ks <= kt):
        return ks, (f"the spin departs by {100 * spin[ks]:.3g} % (in Ω²) from the model's "
                    f"{spin_hz:.5g} Hz (limit {100 * spin_limit:.3g} %: {basis})")  # fmt: skip
    if kt is not None:
        return kt, (f"the angular velocity is tilted by {math.degrees(math.asin(min(tilt[kt], 1.0))):.3g}"
                    f" deg from the model's axis (limit sin β ≤ {100 * CENTRIFUGAL_LIMIT:g} %)")  # fmt: skip
    return None


def path_validity(setup, solution, diag, spin_limit: float | None = None,
                  basis: str = "") -> PathValidity:  # fmt: skip
    """:class:`PathValidity` of a run (a :class:`~quadmodes.runs.simulate.RunSetup`, its
    merged :class:`~quadmodes.rom.solution.Solution` and its
    :class:`~quadmodes.rom.diagnostics.Diagnostics`) from the saved samples; the modal
    amplitudes are left unchecked (:func:`with_amplitude_check` checks them). ``spin_limit``:
    a measured limit of the spin part of δ (:func:`with_measured_range`; ``basis`` says how),
    None for the a-priori bound on δ."""
    system = setup.system
    t = np.asarray(solution.t, float)
    _, w, s, _ = rsys.split_state(system, np.asarray(solution.y, float))
    w_ref = np.asarray(system.reference_omega, float)
    spin_ref = float(np.linalg.norm(w_ref))
    fails: list[tuple[int, str]] = []
    checked = ["rotating-frame stiffness"]
    limit = CENTRIFUGAL_LIMIT if spin_limit is None else spin_limit
    dmax = math.nan
    if spin_ref > 0.0:
        checked.insert(0, "centrifugal load")
        fail = _centrifugal_failure(t, w, w_ref, spin_limit, basis)
        fails += [fail] if fail is not None else []
        dmax = float(centrifugal_departure(w, w_ref).max()) if len(w) else 0.0
    idx, kmin = _stiffness(system, w)
    bad = np.flatnonzero(kmin <= 0.0)
    if len(bad):
        fails.append((int(idx[bad[0]]), "the rotating-frame stiffness Λ − ωᵀJ2ω is not "
                      f"positive definite (smallest eigenvalue {kmin[bad[0]]:.4g} s⁻²)"))  # fmt: skip
    amp = np.linalg.norm(s, axis=1) if s.shape[1] else np.zeros(len(t))
    peak = int(np.argmax(amp)) if len(amp) else 0
    unchecked = ("modal amplitudes",) if s.shape[1] and amp[peak] > 0 else ()
    path = PathValidity(spin_ref, dmax, limit,
                        spin_range(spin_ref, limit) if spin_ref else (math.nan, math.nan),
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


#: Bisections of the amplitude at which the path leaves the potential's range (the range then
#: known to 1/16 of the path's largest amplitude).
AMPLITUDE_BISECTIONS = 4


def _amplitude_error(setup, y: np.ndarray, structure) -> tuple[float, tuple | None]:
    """(relative error of the reduced potential against the FE model's condensed energy at the
    modal coordinates of state ``y`` (inf: the condensation failed), slack onset along it
    (:func:`~quadmodes.runs.deformation_check.initial_slack_onset`, None: none))."""
    from quadmodes.runs import deformation_check as dc

    at = dataclasses.replace(setup, initial=dataclasses.replace(setup.initial, y0=y))
    slack = dc.initial_slack_onset(at, structure)
    continuation = slack is None or not slack[0] < dc.SLACK_CONTINUATION_LIMIT
    energies = dc.initial_deformation_energies(at, None, continuation, structure)
    reduced, condensed = energies if energies is not None else (0.0, 0.0)
    if condensed > 0:
        return abs(reduced - condensed) / condensed, slack
    return (0.0 if reduced == 0 else math.inf), slack


def with_amplitude_check(path: PathValidity, setup, solution, diag) -> PathValidity:
    """``path`` with its modal amplitudes checked against the FE model
    (:mod:`quadmodes.runs.deformation_check` at the state of a sample: the reduced potential
    within :data:`~quadmodes.runs.validity.DEFORMATION_ENERGY_TOLERANCE` of the condensed
    energy; where the membrane first loses tension along it, linearised, is recorded, not
    judged, as for the initial deformation: the FE model is an SVK membrane too). First at the
    largest amplitude ‖s‖ of the path; if it fails, the amplitude where the range ends is
    bisected (:data:`AMPLITUDE_BISECTIONS` more solves, each at the first sample reaching the
    amplitude) and the path leaves at the first sample past the largest amplitude found good."""
    from quadmodes.runs import deformation_check as dc

    if "modal amplitudes" not in path.unchecked:
        return path
    t, y = np.asarray(solution.t, float), np.asarray(solution.y, float)
    amp = np.linalg.norm(rsys.split_state(setup.system, y)[2], axis=1)
    peak = int(np.argmax(amp))
    structure = dc.deformation_structure(setup)
    err, slack = _amplitude_error(setup, y[peak], structure)
    checked = dataclasses.replace(
        path, checked=(*path.checked, "modal amplitudes"), unchecked=(),
        amplitude_error=float(err), amplitude_slack_fraction=math.inf if slack is None else float(slack[0]),
    )  # fmt: skip
    if err <= DEFORMATION_ENERGY_TOLERANCE:
        return checked
    good, bad = float(amp[0]), float(amp[peak])
    for _ in range(AMPLITUDE_BISECTIONS):
        level = 0.5 * (good + bad)
        j = int(np.argmax(amp >= level))
        if _amplitude_error(setup, y[j], structure)[0] <= DEFORMATION_ENERGY_TOLERANCE:
            good = max(good, float(amp[j]))
        else:
            bad = min(bad, float(amp[j]))
    k = _first(amp > good * (1.0 + 1e-12)) or 0
    where = f"at the largest modal amplitude (t = {t[peak]:.6g} s)"
    reason = (f"the FE model's condensed energy did not converge {where}" if math.isinf(err) else
              f"the reduced potential is {100 * err:.3g} % off the FE model's condensed energy "
              f"{where}; limit {100 * DEFORMATION_ENERGY_TOLERANCE:g} %, passed below "
              f"|s| = {good:.3g} kg^0.5 m")  # fmt: skip
    if slack is not None and slack[0] < 1.0:
        reason += f"; the membrane loses tension at {100 * slack[0]:.3g} % of it, linearised"
    return _with_failures(checked, [(k, reason)], t, diag)


def run_path_validity(setup, solution, diag) -> PathValidity:
    """:func:`path_validity` of a run, its modal amplitudes checked against the FE model
    (:func:`with_amplitude_check`) when ``setup.fe_checks`` (set by
    :func:`~quadmodes.runs.deformation_check.with_deformation_check`, as ``quadmodes run``)."""
    path = path_validity(setup, solution, diag)
    if not setup.fe_checks:
        return path
    path = with_measured_range(path, setup, solution, diag)
    return with_amplitude_check(path, setup, solution, diag)


def with_measured_range(path: PathValidity, setup, solution, diag) -> PathValidity:
    """``path`` with its spin range measured (:mod:`quadmodes.runs.spin_check`) when the path
    passes the a-priori bound: the model rebuilt about the spin of the sample of largest spin
    departure, the rotating-frame frequencies of both compared there (a pure spin about the
    reference axis); the limit of the spin part of δ becomes that departure if they agree within
    :data:`FREQUENCY_TOLERANCE`, else departure · tolerance / ε. The tilt keeps the a-priori
    bound (a tilted steady spin is no state a model is built about)."""
    from quadmodes.runs.spin_check import measured_error

    if not path.reference_spin or not path.centrifugal_max > path.centrifugal_limit:
        return path
    w_ref = np.asarray(setup.system.reference_omega, float)
    w = rsys.split_state(setup.system, np.asarray(solution.y, float))[1]
    spin = spin_and_tilt(w, w_ref)[0]
    k = int(np.argmax(spin))
    e = w_ref / np.linalg.norm(w_ref)
    rate, eps = measured_error(setup, float(w[k] @ e) * e)
    ok = eps <= FREQUENCY_TOLERANCE
    limit = float(spin[k]) if ok else float(spin[k]) * FREQUENCY_TOLERANCE / eps
    basis = (f"measured: the model rebuilt about {rate / (2 * math.pi):.5g} Hz differs by "
             f"{100 * eps:.2g} % in its rotating-frame frequencies there"
             + ("" if ok else ", taken linear in the departure"))  # fmt: skip
    measured = path_validity(setup, solution, diag, limit, basis)
    return dataclasses.replace(measured, measured_spin=rate, measured_error=eps)
