"""What a full-order transient computes once: the step count, the body, the DOF partition, the
mass and damping operators, the Newton scale, and the discrete state that is carried from step
to step (:class:`RunState`).

SI units; states are ``(n, 3)`` arrays of vector DOFs (slope rows of a cable dimensionless).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

import quadmodes.fullorder.kinematics as kin
from quadmodes.fe.beam import BeamSectionSet
from quadmodes.fe.model import Structure, centre_of_mass, mass_matrix, strain_energy
from quadmodes.fullorder.damping import DampingModes, retained_damping
from quadmodes.rom.reduced import ReducedModel


def step_count(t_span, dt: float) -> tuple[int, float]:
    """``(n_steps, h)``: the number of steps over ``t_span`` (s) and the step
    ``h = span / ceil(span/dt)`` (s), so that the steps end exactly at ``t_span[1]``."""
    span = float(t_span[1]) - float(t_span[0])
    if not span > 0 or not dt > 0:
        raise ValueError("t_span must be increasing and dt positive")
    n = max(1, math.ceil(span / dt - 1e-9))
    return n, span / n


@dataclass(frozen=True, eq=False)
class FullOrderProblem:
    """The constant data of one full-order transient.

    structure: the FE model (n vector DOFs). body: frames and diagnostics data
    (:class:`~quadmodes.fullorder.kinematics.Body`). hub: the hub drive of a clamped body or None
    (free); point (3,) m its axis point (None when free). X (n,3): body reference (x_ref about
    its CoM, or about the hub point). tr (n,): translational indicator (float). fixed_rows: rows
    with a clamped component. free: indices of the free scalar DOFs (of 3n). ms (n,n) kg: scalar
    mass; m_full (3n,3n) csc: ``M_s ⊗ I₃``. c (N,N) 1/s: modal damping or None (no damping).
    t0 s, h s, n_steps: the time grid. scale m: body size; tol m: Newton tolerance. v_ref J:
    strain energy of x_ref. energy_momentum: averaged-stress step force. mapped: the steady
    rotation map is applied (free bodies with ``rotation_map``). triads (k,3): the rows
    ``[t, d₂, d₃]`` of the beam nodes whose slope and directors are DOFs
    (:class:`~quadmodes.fe.beam.BeamSectionSet`; None without beams): Newton turns them as
    frames, and a step of such a body restarts in full Newton when a kept matrix does not
    converge it (:func:`~quadmodes.fullorder.newton.solve_step`)."""

    structure: Structure
    body: kin.Body
    hub: kin.HubDrive | None
    point: np.ndarray | None
    X: np.ndarray
    tr: np.ndarray
    fixed_rows: np.ndarray
    free: np.ndarray
    ms: sp.csr_matrix
    m_full: sp.csc_matrix
    c: np.ndarray | None
    MPhi_d: np.ndarray | None
    damping: DampingModes | None
    t0: float
    h: float
    n_steps: int
    scale: float
    tol: float
    v_ref: float
    energy_momentum: bool
    mapped: bool
    triads: np.ndarray | None = None

    @property
    def n(self) -> int:
        """Number of vector DOFs."""
        return self.structure.n

    def time(self, step: int) -> float:
        """Time (s) after ``step`` steps."""
        return self.t0 + step * self.h


def setup_problem(
    structure: Structure,
    x_ref: np.ndarray,
    t_span: tuple[float, float],
    dt: float,
    *,
    model: ReducedModel | None,
    damping: bool | DampingModes,
    hub: kin.HubDrive | None,
    newton_tol: float,
    energy_momentum: bool,
    rotation_map: bool,
) -> FullOrderProblem:
    """:class:`FullOrderProblem` of :func:`~quadmodes.fullorder.integrator.integrate_full_order`
    (same arguments; a clamped structure without a hub gets a fixed clamp; ``damping``: see
    :func:`damping_modes`). Raises ValueError for
    a hub on a free structure, a model whose X is not x_ref's, or a bad time grid."""
    x_ref = np.asarray(x_ref, float)
    tr = structure.translational.astype(float)
    if hub is None and not structure.is_free:
        hub = kin.HubDrive(angle=lambda t: (0.0, 0.0))
    if hub is not None and structure.is_free:
        raise ValueError("hub: the structure has no clamped DOFs to drive")
    point = None if hub is None else np.asarray(hub.point, float)
    origin_ref = centre_of_mass(structure, x_ref) if hub is None else point
    big_x = x_ref - np.outer(tr, origin_ref)
    if model is not None:
        if model.X.shape != big_x.shape or not np.allclose(model.X, big_x, atol=1e-9, rtol=0):
            raise ValueError("model: its reference X does not match x_ref of the structure")
    body = kin.make_body(
        structure.mass_scalar, structure.translational, big_x, model, hub is not None
    )
    modes = damping_modes(damping, model, big_x.shape)
    c = None if modes is None else modes.C
    mphi_d = None if modes is None else np.stack([structure.mass_scalar @ p for p in modes.shapes])
    m_full = mass_matrix(structure).tocsc()
    n_steps, h = step_count(t_span, dt)
    scale = float(np.max(np.linalg.norm(big_x[tr > 0], axis=1)))
    return FullOrderProblem(
        structure=structure, body=body, hub=hub, point=point, X=big_x, tr=tr,
        fixed_rows=np.flatnonzero(structure.fixed.any(axis=1)), free=structure.free_dofs,
        ms=structure.mass_scalar, m_full=m_full, c=c, MPhi_d=mphi_d, damping=modes,
        t0=float(t_span[0]), h=h, n_steps=n_steps, scale=scale, tol=newton_tol * scale,
        v_ref=strain_energy(structure, x_ref), energy_momentum=energy_momentum,
        mapped=rotation_map and hub is None, triads=section_triads(structure),
    )  # fmt: skip


def section_triads(structure: Structure) -> np.ndarray | None:
    """Rows ``[t, d₂, d₃]`` ``(k, 3)`` of every :class:`~quadmodes.fe.beam.BeamSectionSet` of
    structure (None without beams)."""
    rows = [e.triads for e in structure.elements if isinstance(e, BeamSectionSet)]
    rows = [r for r in rows if r is not None and len(r)]
    return np.unique(np.concatenate(rows), axis=0) if rows else None


def damping_modes(
    damping: bool | DampingModes, model: ReducedModel | None, shape: tuple
) -> DampingModes | None:
    """The damping basis of a problem: ``damping`` itself (a :class:`DampingModes`), the
    reduced model's retained modes and C for ``True`` (none without a model or with C = 0), or
    None for ``False`` and for a basis without modes or damping. Raises ValueError for shapes
    of another structure (``shape`` = (n, 3))."""
    if isinstance(damping, DampingModes):
        modes = damping
    elif damping and model is not None and model.n_modes:
        modes = retained_damping(model)
    else:
        return None
    if modes.shapes.shape[1:] != tuple(shape):
        raise ValueError(
            f"damping: mode shapes {modes.shapes.shape[1:]} do not fit the structure {shape}"
        )
    return modes if modes.n_modes and np.any(modes.C) else None


@dataclass(frozen=True, eq=False)
class RunState:
    """The discrete state after ``step`` steps: x, v (n,3) m, m/s; e_d J dissipated so far;
    frame_prev: the body frame ``(c, R, b)`` of the previous state (the predictor's history;
    None at the start or after a resume without one); n_newton, n_factor: Newton iterations and
    factorisations so far; wall_before s: wall time of the runs before a resume."""

    step: int
    x: np.ndarray
    v: np.ndarray
    e_d: float = 0.0
    frame_prev: tuple | None = None
    n_newton: int = 0
    n_factor: int = 0
    wall_before: float = 0.0


def initial_run_state(x0: np.ndarray, v0: np.ndarray) -> RunState:
    """:class:`RunState` at step 0 from the initial state (x0, v0) (n,3) (copied)."""
    return RunState(0, np.asarray(x0, float).copy(), np.asarray(v0, float).copy())


def discrete_initial_state(problem: FullOrderProblem, state: RunState) -> RunState:
    """The initial state mapped to the scheme's steady-rotation form (``problem.mapped``; see
    :func:`~quadmodes.fullorder.kinematics.to_discrete_rotation`), else unchanged."""
    if not problem.mapped:
        return state
    x, v = kin.to_discrete_rotation(
        problem.body, state.x, state.v, problem.h, not problem.energy_momentum
    )
    return replace(state, x=x, v=v)
