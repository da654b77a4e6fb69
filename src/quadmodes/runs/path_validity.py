"""Validity of the reduced model along a run's path, not only at its start.

A reduced model is expanded about one state: about a spinning state (``reference =
"spinning"``) its stiffness Λ holds the centrifugal prestress of the reference angular velocity
ω_ref = Ω_ref e, and about the state at rest the centrifugal load enters through the quadratic
modes only. As a body cones, its spin about the reference axis falls and its angular velocity
tilts in the body, so the run leaves the state its model was built for. Three checks, on every
saved sample of the path:

* **Centrifugal load** (models about a spinning state): the centrifugal acceleration field is
  C(ω) r with C(ω) = ωωᵀ − |ω|² I. The model carries the load of every ω exactly (½ ωᵀJ1ω) and
  holds fixed the stiffness of the prestress of ω_ref, which the stiff condensed degrees of
  freedom would change quasi-statically; so its departure δ is the part of C(ω) − C(ω_ref) that
  lasts in the body frame, relative to Ω_ref² (:mod:`quadmodes.runs.centrifugal_load`): the
  spin's change and the tilt's second-order part, max(|Ω² − Ω_ref²|, ||ω|² − Ω_ref²|, |ω_t|²) /
  Ω_ref² (tan²β for a tilt by β at a fixed spin). The tilt's first-order part turns in the body
  at the nutation frequency: it is the coning forcing, whose response the modal-amplitude check
  judges, and changes the prestress's effect on the coning response at second order only (a
  body whose tilt does not turn, ν < ½, is judged by the whole ‖C(ω) − C(ω_ref)‖₂, sin β; a
  planar body by the in-plane block). The prestress is linear in the load, so the part of the
  stiffness the model holds fixed is off by at most δ of the centrifugal prestress, itself at
  most the whole stiffness: the squared rotating-frame frequencies by at most δ, the
  frequencies by δ/2. With the model's frequency tolerance of 1 % (:data:`FREQUENCY_TOLERANCE`:
  every rotating-frame branch of the paper models within 1 % of the full order,
  docs/full-order.md) the limit is δ ≤ 2 % (:data:`CENTRIFUGAL_LIMIT`): a spin within ±1 % of
  the reference, or an angular velocity tilted by at most 8.0° (tan²β ≤ 2 %). This is an upper
  bound of what the model leaves out, far from tight (the 41 Hz model of paper-41hz-coarse at
  37.7 Hz is within 0.09 % of the model rebuilt there, docs/validation.md); where a path passes
  it and the run checks its path against the FE model (``quadmodes run``), the spin's range is
  measured instead (:func:`with_measured_range`, :mod:`quadmodes.runs.spin_check`): the
  frequencies and, what the run's answer is made of, the energy-sink coning rate (300 × more
  sensitive to the spin than the frequencies on paper-41hz-coarse), each against the model
  rebuilt about the spin; the tilt's part keeps the a-priori bound.
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
from quadmodes.runs import spin_check
from quadmodes.runs.centrifugal_load import (  # noqa: F401  (the path check's departures, re-exported)
    PLANAR_TOLERANCE,
    centrifugal_departure,
    is_planar,
    load_departure,
    plane_departure,
    quasi_static_departure,
    spin_and_tilt,
    tilt_departure,
    tilt_turns,
)
from quadmodes.runs.validity import DEFORMATION_ENERGY_TOLERANCE

#: Relative frequency error the reduced models are held to (every rotating-frame branch within
#: 1 % of the full order on the paper models, docs/full-order.md).
FREQUENCY_TOLERANCE = spin_check.FREQUENCY_TOLERANCE
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
    fraction of the peak deformation at which an element taut at the reference first loses
    tension along its manifold ray (exact strain; inf: not up to 4 ×); left_at (s): the first sample where a check fails (None: none), with left_spin
    (rad/s), left_cone (rad) and left_reason; checked / unchecked: the checks made and not;
    measured_spin (rad/s) and measured_error: where the centrifugal range was measured against a
    model rebuilt about that spin and the largest relative difference of the rotating-frame
    frequencies there (NaN: not measured; then centrifugal_limit is the a-priori bound);
    measured_sink_spin (rad/s) and measured_sink_error: the last spin where the energy-sink
    coning rates of the run's and the rebuilt model were compared and their relative
    difference (NaN: not measured, :func:`quadmodes.runs.spin_check.spin_limit`);
    least_tension (N/m): the smallest minor principal resultant of the membrane elements taut at
    the reference on the checked samples, slack_area the largest fraction of their area slack,
    reference_slack_area the reference's own slack area (NaN: no tension check,
    :mod:`quadmodes.runs.taut_path`), slack_where where the slack elements are ("at the seam of
    end body 'front'"; "": none or no end bodies); slack_at (s): the first checked sample where one is slack
    (None: none, or not judged); slack_judged: the loss of tension is judged (a membrane held
    taut by its spin alone), else recorded only; tension_samples: ``(times (s), least tension
    (N/m))`` arrays of the checked samples (empty: no tension check); failures: every failing
    check's ``(time (s) of its first failing sample, reason)``, in time order (the first is
    left_at / left_reason)."""

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
    measured_sink_spin: float = math.nan
    measured_sink_error: float = math.nan
    least_tension: float = math.nan
    slack_area: float = math.nan
    reference_slack_area: float = math.nan
    slack_where: str = ""
    slack_at: float | None = None
    slack_judged: bool = False
    tension_samples: tuple = ()
    failures: tuple = ()

    @property
    def valid(self) -> bool:
        """Every check ran and none failed."""
        return self.left_at is None and not self.unchecked

    @property
    def amplitudes_fail(self) -> bool:
        """The modal-amplitude check failed somewhere on the path (its largest error, inf when
        the FE energy did not converge, above the tolerance; False when not checked)."""
        return bool(self.amplitude_error > DEFORMATION_ENERGY_TOLERANCE)

    @property
    def taut(self) -> bool | None:
        """The membrane stays taut where it is taut at the reference (None: not judged)."""
        if math.isnan(self.least_tension) or not self.slack_judged:
            return None
        return self.slack_at is None

    def message(self) -> str:
        """One line ("" when valid): where the path leaves, and every check that fails."""
        if self.left_at is not None:
            others = [f"{reason} (from t = {when:.6g} s)" for when, reason in self.failures
                      if reason != self.left_reason]  # fmt: skip
            also = f"; also failing: {'; '.join(others)}" if others else ""
            if self.slack_at is not None and not any("loses tension" in r for _, r in self.failures):
                also += (f"; the membrane also loses tension from t = {self.slack_at:.6g} s "
                         f"(least tension {self.least_tension:.3g} N/m, "
                         f"{100 * self.slack_area:.3g} % of its taut area slack)")  # fmt: skip
            return (f"the run leaves its reduced model's range at t = {self.left_at:.6g} s "
                    f"(spin {self.left_spin / (2 * math.pi):.5g} Hz, cone "
                    f"{math.degrees(self.left_cone):.4g} deg): {self.left_reason}{also}")  # fmt: skip
        if self.unchecked:
            return f"not checked along the path: {', '.join(self.unchecked)}"
        return ""


def spin_range(omega_ref: float, limit: float = CENTRIFUGAL_LIMIT) -> tuple[float, float]:
    """Spins (rad/s) about the reference axis whose δ = |Ω² − Ω_ref²| / Ω_ref² is ``limit``."""
    return omega_ref * math.sqrt(max(1.0 - limit, 0.0)), omega_ref * math.sqrt(1.0 + limit)


def _stiffness(system: rsys.ReducedSystem, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sample indices, smallest eigenvalue of Λ − ωᵀJ2ω there (s⁻²)) on at most
    :data:`STIFFNESS_SAMPLES` samples of ω (k,3) and the sample of largest |ω|."""
    k = len(w)
    if k == 0:  # no sample (a family member that switched on its first)
        return np.zeros(0, int), np.zeros(0)
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


def _centrifugal_failure(t, w, system, spin_limit, basis: str):
    """(sample index, reason) where the centrifugal load first leaves the range, or None: δ
    (:func:`~quadmodes.runs.centrifugal_load.load_departure`) past :data:`CENTRIFUGAL_LIMIT` (a
    priori), or with a measured ``spin_limit`` the spin part past it or the tilt's part past the
    a-priori bound: its second-order part |ω_t|² / Ω_ref² where the tilt turns in the body, else
    sin β. A planar body's δ is its in-plane departure, all of it judged as a spin part."""
    w_ref = np.asarray(system.reference_omega, float)
    planar, turns = is_planar(system), tilt_turns(system)
    spin_hz = float(np.linalg.norm(w_ref)) / (2 * math.pi)
    part = (" in the body's plane (planar body: the tilt's out-of-plane part is rigid)" if planar
            else " in its quasi-static part (the tilt's first-order part turns in the body at "
            "the nutation frequency: the coning forcing)" if turns else "")  # fmt: skip
    if spin_limit is None:
        delta = load_departure(system, w)
        k = _first(delta > CENTRIFUGAL_LIMIT)
        return None if k is None else (k, (
            f"the centrifugal load departs by {100 * delta[k]:.3g} %{part} from the model's at "
            f"{spin_hz:.5g} Hz (limit {100 * CENTRIFUGAL_LIMIT:g} %: ±"
            f"{100 * FREQUENCY_TOLERANCE:g} % in the rotating-frame frequencies)"))  # fmt: skip
    if planar:
        spin, tilt = plane_departure(w, w_ref), np.zeros(len(w))
    else:
        spin, sine = spin_and_tilt(w, w_ref)
        tilt = tilt_departure(w, w_ref) if turns else sine
    ks, kt = _first(spin > spin_limit), _first(tilt > CENTRIFUGAL_LIMIT)
    plane = part if planar else ""
    if ks is not None and (kt is None or ks <= kt):
        return ks, (f"the spin departs by {100 * spin[ks]:.3g} % (in Ω²){plane} from the model's "
                    f"{spin_hz:.5g} Hz (limit {100 * spin_limit:.3g} %: {basis})")  # fmt: skip
    if kt is None:
        return None
    beta = math.degrees(math.asin(min(spin_and_tilt(w[kt], w_ref)[1][0], 1.0)))
    if turns:
        return kt, (f"the angular velocity is tilted by {beta:.3g} deg from the model's axis: the "
                    f"quasi-static (second-order) part of its centrifugal load departs by "
                    f"{100 * tilt[kt]:.3g} % (|ω_t|²/Ω², limit {100 * CENTRIFUGAL_LIMIT:g} %)")  # fmt: skip
    return kt, (f"the angular velocity is tilted by {beta:.3g} deg from the model's axis (limit "
                f"sin β ≤ {100 * CENTRIFUGAL_LIMIT:g} %: the tilt does not turn in the body)")  # fmt: skip


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
        fail = _centrifugal_failure(t, w, system, spin_limit, basis)
        fails += [fail] if fail is not None else []
        dmax = float(load_departure(system, w).max()) if len(w) else 0.0
    idx, kmin = _stiffness(system, w)
    bad = np.flatnonzero(kmin <= 0.0)
    if len(bad):
        fails.append((int(idx[bad[0]]), "the rotating-frame stiffness Λ − ωᵀJ2ω is not "
                      f"positive definite (smallest eigenvalue {kmin[bad[0]]:.4g} s⁻²)"))  # fmt: skip
    amp = np.linalg.norm(s, axis=1) if s.shape[1] else np.zeros(len(t))
    peak = int(np.argmax(amp)) if len(amp) else 0
    unchecked = ("modal amplitudes",) if s.shape[1] and len(amp) and amp[peak] > 0 else ()
    path = PathValidity(spin_ref, dmax, limit,
                        spin_range(spin_ref, limit) if spin_ref else (math.nan, math.nan),
                        float(kmin.min()) if len(kmin) else math.inf,
                        float(amp[peak]) if len(amp) else 0.0, float(t[peak]) if len(t) else 0.0,
                        None, checked=tuple(checked), unchecked=unchecked)  # fmt: skip
    return with_failures(path, fails, t, diag)


def with_failures(path: PathValidity, fails: list, t, diag) -> PathValidity:
    """``path`` with the failures ``fails`` (a list of (sample index, reason)) on the samples of
    times ``t`` (k,) s added to its ``failures``; it leaves the range at the earliest of them all
    (its time, and the spin and cone angle of ``diag`` there). Used by every check of a path and
    by a spin family's (:mod:`quadmodes.runs.family_validity`)."""
    if not fails:
        return path
    listed = sorted({*path.failures, *((float(t[k]), reason) for k, reason in fails)})
    path = dataclasses.replace(path, failures=tuple(listed))
    k, reason = min(fails, key=lambda f: f[0])
    if path.left_at is not None and path.left_at <= t[k]:
        return path
    return dataclasses.replace(path, left_at=float(t[k]), left_spin=float(diag.spin_rate[k]),
                               left_cone=float(diag.cone_angle[k]), left_reason=reason)  # fmt: skip


#: Bisections of the amplitude at which the path leaves the potential's range (the range then
#: known to 1/16 of the path's largest amplitude).
AMPLITUDE_BISECTIONS = 4


def amplitude_error(setup, y: np.ndarray, structure) -> tuple[float, tuple | None]:
    """The modal-amplitude check at one state: (relative error |V − W_c| / W_c of the reduced
    potential against the FE model's statically condensed energy at the modal coordinates of the
    state ``y`` (7+2N,) of the prepared run ``setup`` (inf: the condensation failed; both
    without the reference load's work, :func:`~quadmodes.runs.deformation_check.
    initial_deformation_energies`), the slack onset along it (:func:`~quadmodes.runs.
    deformation_check.initial_slack_onset`, None: none)). ``structure``: the FE structure
    (:func:`~quadmodes.runs.deformation_check.deformation_structure`). One static FE solve."""
    from quadmodes.runs import deformation_check as dc

    at = dataclasses.replace(setup, initial=dataclasses.replace(setup.initial, y0=y))
    found = dc.initial_slack_onset(at, structure)
    slack = None if found is None else found[2]
    continuation = not dc.linear_slack_fraction(at, structure) < dc.SLACK_CONTINUATION_LIMIT
    energies = dc.initial_deformation_energies(at, None, continuation, structure)
    reduced, condensed = energies if energies is not None else (0.0, 0.0)
    if condensed > 0:
        return abs(reduced - condensed) / condensed, slack
    return (0.0 if reduced == 0 else math.inf), slack


def with_amplitude_check(path: PathValidity, setup, solution, diag, structure=None,
                         peak_error: tuple | None = None) -> PathValidity:  # fmt: skip
    """``path`` with its modal amplitudes checked against the FE model
    (:mod:`quadmodes.runs.deformation_check` at the state of a sample: the reduced potential
    within :data:`~quadmodes.runs.validity.DEFORMATION_ENERGY_TOLERANCE` of the condensed
    energy; where the membrane first loses tension along it, linearised, is recorded, not
    judged, as for the initial deformation: the FE model is an SVK membrane too). First at the
    largest amplitude ‖s‖ of the path; if it fails, the amplitude where the range ends is
    bisected (:data:`AMPLITUDE_BISECTIONS` more solves, each at the first sample reaching the
    amplitude) and the path leaves at the first sample past the largest amplitude found good.
    ``peak_error``: :func:`amplitude_error` at the path's largest ‖s‖ when already known (a spin
    family's scan of its segments), not solved again."""
    from quadmodes.runs import deformation_check as dc

    if "modal amplitudes" not in path.unchecked:
        return path
    t, y = np.asarray(solution.t, float), np.asarray(solution.y, float)
    amp = np.linalg.norm(rsys.split_state(setup.system, y)[2], axis=1)
    peak = int(np.argmax(amp))
    structure = structure or dc.deformation_structure(setup)
    if is_round_off_state(setup, y[peak]):  # no deformation: both energies are 0
        return dataclasses.replace(path, checked=(*path.checked, "modal amplitudes"),
                                   unchecked=(), amplitude_error=0.0)  # fmt: skip
    err, slack = peak_error if peak_error is not None else amplitude_error(setup, y[peak], structure)
    checked = dataclasses.replace(
        path, checked=(*path.checked, "modal amplitudes"), unchecked=(),
        amplitude_error=float(err), amplitude_slack_fraction=math.inf if slack is None else float(slack.fraction),
    )  # fmt: skip
    if err <= DEFORMATION_ENERGY_TOLERANCE:
        return checked
    good, bad = float(amp[0]), float(amp[peak])
    for _ in range(AMPLITUDE_BISECTIONS):
        level = 0.5 * (good + bad)
        j = int(np.argmax(amp >= level))
        if amplitude_error(setup, y[j], structure)[0] <= DEFORMATION_ENERGY_TOLERANCE:
            good = max(good, float(amp[j]))
        else:
            bad = min(bad, float(amp[j]))
    k = _first(amp > good * (1.0 + 1e-12)) or 0
    where = f"at the largest modal amplitude (t = {t[peak]:.6g} s)"
    reason = (f"the FE model's condensed energy did not converge {where}" if math.isinf(err) else
              f"the reduced potential is {100 * err:.3g} % off the FE model's condensed energy "
              f"{where}; limit {100 * DEFORMATION_ENERGY_TOLERANCE:g} %, passed below "
              f"|s| = {good:.3g} kg^0.5 m")  # fmt: skip
    if slack is not None and slack.fraction < 1.0:
        reason += f"; the membrane loses tension at {100 * slack.fraction:.3g} % of it"
    return with_failures(checked, [(k, reason)], t, diag)


def is_round_off_state(setup, y: np.ndarray) -> bool:
    """The manifold displacement at the state ``y`` (7+2N,) of the prepared run ``setup`` is
    below the round-off of a deformation (:func:`~quadmodes.runs.taut_path.is_round_off`): its
    amplitude check's error is 0 (both energies are 0), no FE solve."""
    from quadmodes.runs.taut_path import is_round_off

    return is_round_off(setup.model, rsys.split_state(setup.system, y)[2])


def with_tension_check(path: PathValidity, setup, solution, diag,
                       structure=None) -> PathValidity:  # fmt: skip
    """``path`` with the membrane's tension checked on its samples
    (:func:`quadmodes.runs.taut_path.path_tension`): it leaves the range at the first sample
    where an element taut at the reference has lost tension (unchanged without a membrane;
    recorded, not judged, for a pressurised one: :func:`~quadmodes.runs.deformation_check.
    slack_judged`)."""
    from quadmodes.runs.taut_path import path_tension, tension_reason

    # the amplitude check's slack onset is along the same ray (the state of largest |s|)
    known = path.amplitude_slack_fraction if "modal amplitudes" in path.checked else None
    tension = path_tension(setup, solution, structure, peak_fraction=known)
    if tension is None:
        return path
    path = dataclasses.replace(
        path, checked=(*path.checked, "membrane tension"), least_tension=tension.least,
        slack_area=tension.slack_area, reference_slack_area=tension.reference_slack_area,
        slack_where=tension.slack_where, amplitude_slack_fraction=tension.peak_fraction,
        tension_samples=(tension.checked_times, tension.checked_least),
    )  # fmt: skip
    from quadmodes.runs.deformation_check import slack_judged

    judged = slack_judged(setup)
    path = dataclasses.replace(path, slack_judged=judged)
    if tension.slack_at is None or not judged:
        return path  # recorded only for a pressurised membrane (slack_judged)
    path = dataclasses.replace(path, slack_at=tension.slack_at)
    t = np.asarray(solution.t, float)
    k = int(np.argmax(t >= tension.slack_at))
    return with_failures(path, [(k, tension_reason(tension))], t, diag)


def run_path_validity(setup, solution, diag) -> PathValidity:
    """:func:`path_validity` of a run, its modal amplitudes checked against the FE model
    (:func:`with_amplitude_check`) when ``setup.fe_checks`` (set by
    :func:`~quadmodes.runs.deformation_check.with_deformation_check`, as ``quadmodes run``)."""
    path = path_validity(setup, solution, diag)
    if not setup.fe_checks:
        return path
    from quadmodes.runs.deformation_check import deformation_structure

    # built once for both FE checks (each built it before; none without modes to check)
    structure = deformation_structure(setup) if setup.system.n_modes else None
    path = with_measured_range(path, setup, solution, diag)
    path = with_amplitude_check(path, setup, solution, diag, structure)
    return with_tension_check(path, setup, solution, diag, structure)


def with_measured_range(path: PathValidity, setup, solution, diag) -> PathValidity:
    """``path`` with its spin range measured (:func:`quadmodes.runs.spin_check.spin_limit`)
    when the path passes the a-priori bound: the model rebuilt about the spin of the sample of
    largest spin departure (a pure spin about the reference axis), its rotating-frame
    frequencies (within :data:`FREQUENCY_TOLERANCE`) and its energy-sink coning rate (within
    :data:`~quadmodes.runs.spin_check.SINK_TOLERANCE`: what the run's answer is made of) against
    the run's model's there; the limit of the spin part of δ is that departure if both agree,
    else where the worse reaches its tolerance. The tilt's part keeps the a-priori bound (a
    tilted steady spin is no state a model is built about)."""
    from quadmodes.runs.spin_check import spin_limit

    if not path.reference_spin or not path.centrifugal_max > path.centrifugal_limit:
        return path
    w_ref = np.asarray(setup.system.reference_omega, float)
    w = rsys.split_state(setup.system, np.asarray(solution.y, float))[1]
    e = w_ref / np.linalg.norm(w_ref)
    if is_planar(setup.system):  # the spin, about e or whole, of the largest in-plane departure
        spin = plane_departure(w, w_ref)
        axial, whole = np.abs(w @ e), np.linalg.norm(w, axis=1)
        rate = np.where(np.abs(axial**2 - w_ref @ w_ref) >= np.abs(whole**2 - w_ref @ w_ref),
                        axial, whole)  # fmt: skip
    else:
        spin, rate = spin_and_tilt(w, w_ref)[0], w @ e
    found = spin_limit(setup, spin, rate, np.asarray(diag.cone_angle, float), e)
    measured = path_validity(setup, solution, diag, found.limit, found.basis)
    return dataclasses.replace(measured, measured_spin=found.spin,
                               measured_error=found.frequency_error,
                               measured_sink_spin=found.sink_spin,
                               measured_sink_error=found.sink_error)  # fmt: skip
