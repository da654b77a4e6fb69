"""Calibration stage: fit the end-body masses so that the prestressed free-free modes match
target frequencies (the seed's rear-mass rocking pair at 31.2 Hz and bending pair at 38.0 Hz).

The end bodies keep their shape (uniform solid cylinders, or fixed inertia-to-mass ratios), so
their point-mass clusters scale linearly with the masses and the stiffness does not depend on
them (no gravity): the structure is inflated once and each trial only re-assembles ``M_s`` and
re-solves the eigenproblem.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from quadmodes.config import Case
from quadmodes.fe.model import Structure
from quadmodes.fe.rigid import point_mass_cluster
from quadmodes.labels import label_modes
from quadmodes.modes import compute_modes
from quadmodes.pipeline import reference_state, structure_for_case

Progress = Callable[[str, float], None]


class CalibrationError(RuntimeError):
    """The targets could not be met; one-line message."""


@dataclass(frozen=True)
class CalibrationResult:
    case: Case
    masses_kg: dict[str, float]
    frequencies_hz: np.ndarray
    labels: list[str]
    rocking_hz: float
    bending_hz: float
    axial_hz: float | None
    evaluations: int


def _cluster_masses(body_mass: float, i_ax: float, i_tr: float, arm: float, name: str):
    return point_mass_cluster(
        np.zeros(3), np.array([0.0, 0.0, 1.0]), body_mass, i_ax, i_tr, arm, name=name
    )[1]


def _with_bodies(structure: Structure, bodies: dict[str, tuple[float, float, float, float]]):
    """The structure with each end body's cluster point masses set for ``(m, I_ax, I_tr, arm)``."""
    change = np.zeros(structure.n)
    current = structure.mass_scalar.diagonal()
    for name, (m, i_ax, i_tr, arm) in bodies.items():
        idx = structure.groups[f"body:{name}"]
        change[idx] = _cluster_masses(m, i_ax, i_tr, arm, name) - current[idx]
    return replace(structure, mass_scalar=(structure.mass_scalar + sp.diags(change)).tocsr())


def _pairs(freqs: np.ndarray, labels: list[str], kind: str) -> list[float]:
    """Mean frequencies of consecutive modes carrying label ``kind`` (degenerate pairs)."""
    idx = [i for i, lab in enumerate(labels) if lab.startswith(kind)]
    return [float(np.mean(freqs[idx[i : i + 2]])) for i in range(0, len(idx) - 1, 2)]


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
    names = {b.name for b in case.end_body}
    if {front, rear} - names:
        raise CalibrationError(
            f"calibrate: the case needs end bodies named {front!r} and {rear!r} (has "
            f"{sorted(names)}); add them as [[end_body]] tables"
        )
    bodies = {b.name: b for b in case.end_body}
    # Fixed cluster arms (twice the smallest feasible at the start) keep K independent of the fit.
    arms = {n: 2.0 * b.cluster_arm() / 1.25 if b.arm is None else b.arm for n, b in bodies.items()}
    case = case.model_copy(
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
    bodies = {b.name: b for b in case.end_body}
    structure = structure_for_case(case)
    x, _ = reference_state(case, structure, progress)
    count = max(case.modes.count, 8)
    fit_inertia = axial_hz is not None
    evaluations = 0
    cache: dict[tuple, tuple] = {}

    def body_values(log_p: np.ndarray) -> dict[str, tuple[float, float, float, float]]:
        out = {}
        for k, name in enumerate((front, rear)):
            b = bodies[name]
            m = float(np.exp(log_p[k]))
            if fit_inertia and name == rear:
                i_tr = float(np.exp(log_p[2]))
                i_ax = b.inertia_axial / b.inertia_transverse * i_tr
            else:
                i_ax, i_tr = b.inertia_axial * m / b.mass, b.inertia_transverse * m / b.mass
            out[name] = (m, i_ax, i_tr, arms[name])
        return out

    def solve(log_p: np.ndarray):
        nonlocal evaluations
        key = tuple(np.round(log_p, 12))
        if key not in cache:
            values = body_values(log_p)
            try:
                s = _with_bodies(structure, values)
            except ValueError:  # infeasible cluster: report as a failed trial
                cache[key] = (values, None, None)
                return cache[key]
            modes = compute_modes(s, x, count)
            labels = label_modes(s, x, modes.shapes)
            evaluations += 1
            if progress:
                progress("calibration", min(evaluations / 40.0, 0.99))
            cache[key] = (values, modes, labels)
        return cache[key]

    def residual(log_p: np.ndarray) -> np.ndarray:
        _, modes, labels = solve(log_p)
        if modes is None:
            return np.full(3 if fit_inertia else 2, 10.0)
        f = modes.frequencies_hz
        rock = _pairs(f, labels, f"rocking ({rear}")
        bend = _pairs(f, labels, "bending")
        out = [rock[0] / rocking_hz - 1.0 if rock else 1.0, bend[0] / bending_hz - 1.0 if bend else 1.0]
        if fit_inertia:
            ax = [fk for fk, lab in zip(f, labels, strict=True) if lab.startswith(f"axial ({rear}")]
            out.append(ax[0] / axial_hz - 1.0 if ax else 1.0)
        return np.array(out)

    start = [bodies[front].mass, bodies[rear].mass]
    if fit_inertia:
        start.append(bodies[rear].inertia_transverse)
    log_p = np.log(start)
    for _ in range(max_iterations):
        r0 = residual(log_p)
        if np.max(np.abs(r0)) <= rtol:
            break
        # Damped Newton in log-parameters with a forward-difference Jacobian; the step limit keeps
        # mode families from swapping between iterations.
        jac = np.column_stack(
            [(residual(log_p + 1e-3 * e) - r0) / 1e-3 for e in np.eye(len(log_p))]
        )
        step = np.linalg.lstsq(jac, -r0, rcond=None)[0]
        log_p = log_p + step * min(1.0, max_log_step / np.max(np.abs(step)))
    values, modes, labels = solve(log_p)
    res = residual(log_p)
    if modes is None or np.max(np.abs(res)) > 10 * rtol:
        raise CalibrationError(
            f"calibrate: could not reach the target frequencies (relative misfits "
            f"{', '.join(f'{r:+.1e}' for r in res)}); change the end-body attach radii or targets"
        )
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
    new_case = case.model_copy(update={"end_body": new_bodies})
    f = modes.frequencies_hz
    axial = [fk for fk, lab in zip(f, labels, strict=True) if lab.startswith(f"axial ({rear}")]
    if progress:
        progress("calibration", 1.0)
    return CalibrationResult(
        case=new_case,
        masses_kg={k: v[0] for k, v in values.items()},
        frequencies_hz=f,
        labels=labels,
        rocking_hz=_pairs(f, labels, f"rocking ({rear}")[0],
        bending_hz=_pairs(f, labels, "bending")[0],
        axial_hz=axial[0] if axial else None,
        evaluations=evaluations,
    )
