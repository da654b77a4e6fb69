"""Calibration stage: fit the end-body masses so that the prestressed free-free modes match
target frequencies (the seed's rear-mass rocking pair at 31.2 Hz and bending pair at 38.0 Hz).

The end bodies keep their shape (uniform solid cylinders, or fixed inertia-to-mass ratios), so
their point-mass clusters scale linearly with the masses and the stiffness does not depend on
them (no gravity): the structure is inflated once and each trial only re-assembles ``M_s`` and
re-solves the eigenproblem.

Steps: :func:`shape_fixed_case` (explicit inertias and fixed cluster arms), :class:`EndBodyModel`
(the inflated structure with the end bodies as functions of log-parameters), :class:`TrialSolves`
(cached eigen-solves of trial parameters), mode tracking by mass-weighted overlap
(:func:`family_indices`, :func:`family_residual`), and the damped Newton iteration
(:func:`damped_newton`); :func:`calibrate_end_masses` runs them.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from quadmodes.case import Case, EndBody
from quadmodes.errors import QuadmodesError
from quadmodes.fe.model import Structure
from quadmodes.fe.rigid import point_mass_cluster
from quadmodes.structure.labels import label_modes
from quadmodes.structure.modes import ModalResult, compute_modes
from quadmodes.structure.pipeline import reference_state, structure_for_case, with_gas_law

Progress = Callable[[str, float], None]
log = logging.getLogger(__name__)

#: ``(m, I_ax, I_tr, arm)`` of one end body: kg, kg m², kg m², m.
BodyValues = tuple[float, float, float, float]

#: Residual of each family at an infeasible trial (a cluster that cannot carry the inertia).
INFEASIBLE_RESIDUAL = 10.0


class CalibrationError(QuadmodesError, RuntimeError):
    """The targets could not be met; one-line message."""


@dataclass(frozen=True)
class CalibrationResult:
    """The calibrated case and its modes.

    masses_kg: end-body name -> fitted mass. frequencies_hz, labels: the ``(N,)`` elastic
    frequencies and labels of the calibrated model. rocking_hz, bending_hz, axial_hz: mean
    frequency of each tracked family (axial None without an axial target). evaluations: number
    of eigen-solves.
    """

    case: Case
    masses_kg: dict[str, float]
    frequencies_hz: np.ndarray
    labels: list[str]
    rocking_hz: float
    bending_hz: float
    axial_hz: float | None
    evaluations: int


@dataclass(frozen=True)
class CalibrationTargets:
    """Target frequencies (Hz) of the mode families; with ``axial_hz`` None only the rocking
    and bending pairs are fitted (masses only). ``rear`` names the rear end body."""

    rocking_hz: float
    bending_hz: float
    axial_hz: float | None
    rear: str

    @property
    def fit_inertia(self) -> bool:
        """Whether the rear transverse inertia is a third unknown (for the axial target)."""
        return self.axial_hz is not None

    @property
    def family_sizes(self) -> dict[str, int]:
        """Modes per fitted family: a pair for rocking and bending, one axial mode."""
        sizes = {"rocking": 2, "bending": 2}
        if self.fit_inertia:
            sizes["axial"] = 1
        return sizes

    def frequency_hz(self, family: str) -> float:
        return {"rocking": self.rocking_hz, "bending": self.bending_hz, "axial": self.axial_hz}[
            family
        ]

    def start_label(self, family: str) -> str:
        """The label (:func:`quadmodes.structure.labels.label_modes`) of a family's modes in the
        starting model."""
        return {
            "rocking": f"rocking ({self.rear} mass)",
            "bending": "bending",
            "axial": f"axial ({self.rear} mass)",
        }[family]


def _cluster_masses(body_mass: float, i_ax: float, i_tr: float, arm: float, name: str):
    return point_mass_cluster(
        np.zeros(3), np.array([0.0, 0.0, 1.0]), body_mass, i_ax, i_tr, arm, name=name
    )[1]


def _with_bodies(structure: Structure, bodies: dict[str, BodyValues]) -> Structure:
    """The structure with each end body's cluster point masses set for ``(m, I_ax, I_tr, arm)``."""
    change = np.zeros(structure.n)
    current = structure.mass_scalar.diagonal()
    for name, (m, i_ax, i_tr, arm) in bodies.items():
        idx = structure.groups[f"body:{name}"]
        change[idx] = _cluster_masses(m, i_ax, i_tr, arm, name) - current[idx]
    return replace(structure, mass_scalar=(structure.mass_scalar + sp.diags(change)).tocsr())


def shape_fixed_case(case: Case, front: str, rear: str) -> Case:
    """The case with explicit inertias and fixed cluster arms on every end body.

    Fixed cluster arms keep K independent of the fit; three times the smallest feasible arm at
    the start admits inertia-to-mass ratios up to 9 times the starting one. The arm is a
    representation detail (the cluster is rigid), not a physical parameter.
    """
    names = {b.name for b in case.end_body}
    if {front, rear} - names:
        raise CalibrationError(
            f"calibrate: the case needs end bodies named {front!r} and {rear!r} (has "
            f"{sorted(names)}); add them as [[end_body]] tables"
        )
    arms = {}
    for b in case.end_body:
        i_ax, i_tr = b.inertias()
        arms[b.name] = float(3.0 * np.sqrt((i_ax + 2.0 * i_tr) / (2.0 * b.mass)))
    return case.model_copy(
        update={
            "end_body": tuple(
                b.model_copy(
                    update={
                        "arm": arms[b.name],
                        "inertia_axial": b.inertias()[0],
                        "inertia_transverse": b.inertias()[1],
                        "radius": None,
                        "height": None,
                    }
                )
                for b in case.end_body
            )
        }
    )


@dataclass(frozen=True)
class EndBodyModel:
    """The inflated structure with the front and rear end bodies as functions of the
    log-parameters ``log_p = (ln m_front, ln m_rear[, ln I_tr,rear])`` (kg, kg m²).

    structure: for vibrations about ``x`` (gas law applied). x: ``(n, 3)`` inflated state (m).
    bodies: name -> the shape-fixed starting end body. Without ``fit_inertia`` each body's
    inertias scale with its mass; with it the rear keeps its axial-to-transverse ratio.
    """

    structure: Structure
    x: np.ndarray
    bodies: dict[str, EndBody]
    front: str
    rear: str
    fit_inertia: bool

    @classmethod
    def inflate(
        cls, case: Case, front: str, rear: str, fit_inertia: bool, progress: Progress | None
    ) -> EndBodyModel:
        """Build and inflate the structure of a shape-fixed case (:func:`shape_fixed_case`)."""
        structure = structure_for_case(case)
        x, _ = reference_state(case, structure, progress)
        structure = with_gas_law(case, structure, x)
        bodies = {b.name: b for b in case.end_body}
        return cls(structure, x, bodies, front, rear, fit_inertia)

    def start(self) -> np.ndarray:
        """The log-parameters of the starting bodies."""
        start = [self.bodies[self.front].mass, self.bodies[self.rear].mass]
        if self.fit_inertia:
            start.append(self.bodies[self.rear].inertia_transverse)
        return np.log(start)

    def body_values(self, log_p: np.ndarray) -> dict[str, BodyValues]:
        """``(m, I_ax, I_tr, arm)`` of the front and rear bodies at ``log_p``."""
        out = {}
        for k, name in enumerate((self.front, self.rear)):
            b = self.bodies[name]
            m = float(np.exp(log_p[k]))
            if self.fit_inertia and name == self.rear:
                i_tr = float(np.exp(log_p[2]))
                i_ax = b.inertia_axial / b.inertia_transverse * i_tr
            else:
                i_ax, i_tr = b.inertia_axial * m / b.mass, b.inertia_transverse * m / b.mass
            out[name] = (m, i_ax, i_tr, b.arm)
        return out

    def structure_with(self, values: dict[str, BodyValues]) -> Structure:
        """The structure with these end bodies (``ValueError`` if a cluster is infeasible)."""
        return _with_bodies(self.structure, values)


@dataclass(frozen=True)
class Trial:
    """One trial: body values and, unless the clusters were infeasible, modes and labels."""

    values: dict[str, BodyValues]
    modes: ModalResult | None
    labels: list[str] | None


class TrialSolves:
    """Cached eigen-solves (``count`` modes) of an :class:`EndBodyModel` at trial parameters;
    ``evaluations`` counts the solves actually made."""

    def __init__(self, model: EndBodyModel, count: int, progress: Progress | None = None):
        self.model, self.count, self.progress = model, count, progress
        self.evaluations = 0
        self._cache: dict[tuple, Trial] = {}

    def __call__(self, log_p: np.ndarray) -> Trial:
        key = tuple(np.round(log_p, 12))
        if key not in self._cache:
            self._cache[key] = self._solve(log_p)
        return self._cache[key]

    def _solve(self, log_p: np.ndarray) -> Trial:
        values = self.model.body_values(log_p)
        try:
            s = self.model.structure_with(values)
        except ValueError:  # infeasible cluster: report as a failed trial
            return Trial(values, None, None)
        modes = compute_modes(s, self.model.x, self.count)
        labels = label_modes(s, self.model.x, modes.shapes)
        self.evaluations += 1
        if self.progress:
            self.progress("calibration", min(self.evaluations / 40.0, 0.99))
        return Trial(values, modes, labels)


def family_indices(
    modes: ModalResult, reference: dict[str, np.ndarray], m_scalar, sizes: dict[str, int]
) -> dict[str, np.ndarray]:
    """Indices of each family's modes: highest mass-weighted overlap with the reference.

    reference: family -> ``(k, n, 3)`` shapes it is tracked by. m_scalar: ``(n, n)`` nodal
    scalar mass matrix. sizes: family -> number of modes to pick (ascending indices).
    """
    phi = modes.shapes.reshape(len(modes.frequencies_hz), -1)
    out = {}
    for fam, ref in reference.items():
        # overlap of each mode with the family subspace (shapes are mass-normalised)
        mref = np.stack([(m_scalar @ r.reshape(-1, 3)).ravel() for r in ref])
        overlap = np.sum((phi @ mref.T) ** 2, axis=1)
        out[fam] = np.sort(np.argsort(-overlap)[: sizes[fam]])
    return out


def family_frequencies(
    trials: TrialSolves, log_p: np.ndarray, reference, targets: CalibrationTargets
) -> dict[str, float] | None:
    """Mean frequency (Hz) of each tracked family at ``log_p``; None if the trial failed."""
    trial = trials(log_p)
    if trial.modes is None:
        return None
    s = trials.model.structure_with(trial.values)
    idx = family_indices(trial.modes, reference, s.mass_scalar, targets.family_sizes)
    return {fam: float(np.mean(trial.modes.frequencies_hz[i])) for fam, i in idx.items()}


def family_residual(
    trials: TrialSolves, log_p: np.ndarray, reference, targets: CalibrationTargets
) -> np.ndarray:
    """Relative misfit ``f / f_target - 1`` of each fitted family (in ``family_sizes`` order)."""
    freqs = family_frequencies(trials, log_p, reference, targets)
    if freqs is None:
        return np.full(len(targets.family_sizes), INFEASIBLE_RESIDUAL)
    return np.array([freqs[fam] / targets.frequency_hz(fam) - 1.0 for fam in targets.family_sizes])


def start_below_bending(
    trials: TrialSolves, log_p: np.ndarray, targets: CalibrationTargets
) -> np.ndarray:
    """Raise the rear inertia (``log_p[2]``, in place) until the rocking pair is below bending.

    The seed orders the rear-mass rocking pair below the bending pair. Rocking and bending are
    both n = 1 and veer; this starts on the seed's side of the veering (at most 8 steps of 1.5).
    """
    trial = trials(log_p)
    for _ in range(8):
        f0 = trial.modes.frequencies_hz
        rocking = targets.start_label("rocking")
        rock = [fk for fk, lab in zip(f0, trial.labels, strict=True) if lab == rocking]
        bend = [fk for fk, lab in zip(f0, trial.labels, strict=True) if lab == "bending"]
        if rock and bend and rock[0] < bend[0]:
            break
        log_p[2] += np.log(1.5)
        trial = trials(log_p)
    return log_p


def reference_shapes(
    start: Trial, targets: CalibrationTargets, count: int
) -> dict[str, np.ndarray]:
    """Family -> ``(k, n, 3)`` shapes of the first modes of the starting model (``count``
    solved) that carry the family's label."""
    reference = {}
    for fam, count_f in targets.family_sizes.items():
        label = targets.start_label(fam)
        idx = [i for i, lab in enumerate(start.labels) if lab == label][:count_f]
        if len(idx) < count_f:
            raise CalibrationError(
                f"calibrate: the starting model has no {label!r} "
                f"{'pair' if count_f == 2 else 'mode'} among its first {count} modes; "
                "start from end-body masses closer to the targets"
            )
        reference[fam] = start.modes.shapes[idx]
    return reference


def damped_newton(
    trials: TrialSolves,
    log_p: np.ndarray,
    reference: dict[str, np.ndarray],
    targets: CalibrationTargets,
    rtol: float,
    max_iterations: int,
    max_log_step: float,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Damped Newton in log-parameters with a forward-difference Jacobian (step 1e-3) until the
    largest relative misfit is at most ``rtol``; returns ``(log_p, reference)``.

    Modes are tracked by overlap with the last accepted iterate (``reference`` is updated after
    each step), and the step limit ``max_log_step`` keeps tracking reliable.
    """
    for _ in range(max_iterations):
        r0 = family_residual(trials, log_p, reference, targets)
        if np.max(np.abs(r0)) <= rtol:
            break
        jac = np.column_stack(
            [
                (family_residual(trials, log_p + 1e-3 * e, reference, targets) - r0) / 1e-3
                for e in np.eye(len(log_p))
            ]
        )
        step = np.linalg.lstsq(jac, -r0, rcond=None)[0]
        log.debug("calibrate: params %s residual %s step %s", np.exp(log_p), r0, step)
        log_p = log_p + step * min(1.0, max_log_step / max(np.max(np.abs(step)), 1e-300))
        trial = trials(log_p)
        if trial.modes is not None:
            m_scalar = trials.model.structure_with(trial.values).mass_scalar
            idx = family_indices(trial.modes, reference, m_scalar, targets.family_sizes)
            reference = {fam: trial.modes.shapes[i] for fam, i in idx.items()}
    return log_p, reference


def with_fitted_bodies(case: Case, values: dict[str, BodyValues]) -> Case:
    """The case with the fitted mass and inertias on the bodies named in ``values``."""
    new_bodies = tuple(
        b.model_copy(
            update={
                "mass": values[b.name][0],
                "inertia_axial": values[b.name][1],
                "inertia_transverse": values[b.name][2],
            }
        )
        if b.name in values
        else b
        for b in case.end_body
    )
    return case.model_copy(update={"end_body": new_bodies})


def calibrate_end_masses(
    case: Case,
    rocking_hz: float = 31.2,
    bending_hz: float = 38.0,
    axial_hz: float | None = float(np.sqrt(31.2 * 38.0)),
    rear: str = "rear",
    front: str = "front",
    progress: Progress | None = None,
    rtol: float = 1e-5,
    max_iterations: int = 25,
    max_log_step: float = 0.3,
) -> CalibrationResult:
    """Fit the end bodies so the lowest rear-mass rocking pair is at ``rocking_hz`` and the lowest
    bending pair at ``bending_hz``; with ``axial_hz`` also the rear-mass axial mode.

    Unknowns: the front and rear masses, and with ``axial_hz`` the rear transverse inertia (the
    axial-to-transverse inertia ratio of each body is kept). Without ``axial_hz`` each body's
    inertias scale with its mass. Returns the calibrated case with explicit inertias and arms.
    """
    case = shape_fixed_case(case, front, rear)
    targets = CalibrationTargets(rocking_hz, bending_hz, axial_hz, rear)
    model = EndBodyModel.inflate(case, front, rear, targets.fit_inertia, progress)
    trials = TrialSolves(model, max(case.modes.count, 8), progress)
    log_p = model.start()
    if targets.fit_inertia:
        log_p = start_below_bending(trials, log_p, targets)
    reference = reference_shapes(trials(log_p), targets, trials.count)
    log_p, reference = damped_newton(
        trials, log_p, reference, targets, rtol, max_iterations, max_log_step
    )
    final = trials(log_p)
    res = family_residual(trials, log_p, reference, targets)
    if final.modes is None or np.max(np.abs(res)) > 10 * rtol:
        raise CalibrationError(
            f"calibrate: could not reach the target frequencies (relative misfits "
            f"{', '.join(f'{r:+.1e}' for r in res)}); change the end-body attach radii, their "
            'attachment (e.g. attachment = "flange", docs/calibration.md) or the targets'
        )
    freqs = family_frequencies(trials, log_p, reference, targets)
    if progress:
        progress("calibration", 1.0)
    return CalibrationResult(
        case=with_fitted_bodies(case, final.values),
        masses_kg={k: v[0] for k, v in final.values.items()},
        frequencies_hz=final.modes.frequencies_hz,
        labels=final.labels,
        rocking_hz=freqs["rocking"],
        bending_hz=freqs["bending"],
        axial_hz=freqs.get("axial"),
        evaluations=trials.evaluations,
    )
