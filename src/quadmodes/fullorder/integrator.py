"""Time stepping of the full finite-element model (choices: the package docstring): the driver
loop that ties together the setup (:mod:`~quadmodes.fullorder.setup`), the step
(:mod:`~quadmodes.fullorder.step`), its Newton solve (:mod:`~quadmodes.fullorder.newton`), the
samples (:mod:`~quadmodes.fullorder.sampling`) and checkpoints
(:mod:`~quadmodes.fullorder.checkpoint`), and the sampled :class:`FullOrderSolution`.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from quadmodes.fe.model import Structure
from quadmodes.fullorder.checkpoint import checkpoint_data, resume_from, write_checkpoint
from quadmodes.fullorder.kernels import StepOperators
from quadmodes.fullorder.newton import (
    FullOrderNewtonError,
    NewtonMatrix,
    matrix_factory,
    solve_step,
)
from quadmodes.fullorder.options import FullOrderOptions
from quadmodes.fullorder.renewal import default_threads
from quadmodes.fullorder.sampling import SampledSeries
from quadmodes.fullorder.setup import (
    FullOrderProblem,
    RunState,
    discrete_initial_state,
    initial_run_state,
    setup_problem,
)
from quadmodes.fullorder.step import StepResidual, body_frame, dissipated_work, predict
from quadmodes.rom.diagnostics import cone_angle
from quadmodes.structure.membrane_tension import loss_of_tension


@dataclass(frozen=True, eq=False)
class FullOrderSolution:
    """Full-order transient, sampled (k samples; SI units).

    t (k,) s. H (k,3) inertial angular momentum about the centre of mass (kg m²/s), H_norm (k,).
    T (k,) J kinetic energy without the CoM translation; V (k,) J potential (strain + pressure)
    relative to the reference state; E = T + V; E_d (k,) J energy dissipated by the damping
    force since the start (Σ Δt v½ᵀ f_d). spin_rate (k,) rad/s: mean-axes angular velocity on the
    tracked minor principal axis of the deformed inertia; cone_angle (k,) rad in [0, π/2]
    between H and that axis; axis (k,3) the tracked axis (inertial). modal_coordinates (k,N)
    √kg·m (N = 0 without a model). tip (k,3) m hub-frame tip displacement (hub-driven) or None.
    status 0 ok, 1 stopped early (message says why); dt s; stats: n_steps, n_newton, n_factor,
    wall_s, newton_per_step, factor_per_step, damped_modes (K), damping_cutoff_hz (Hz; NaN for
    the retained modes or without damping). damping: one line naming the damping basis."""

    t: np.ndarray
    H: np.ndarray
    H_norm: np.ndarray
    H_discrete: np.ndarray
    T: np.ndarray
    V: np.ndarray
    E: np.ndarray
    E_d: np.ndarray
    spin_rate: np.ndarray
    cone_angle: np.ndarray
    axis: np.ndarray
    modal_coordinates: np.ndarray
    tip: np.ndarray | None
    status: int
    message: str
    dt: float
    stats: dict = field(default_factory=dict)
    damping: str = ""

    @property
    def E_balance(self) -> np.ndarray:
        """E + E_d (k,) J: constant for the exact dynamics."""
        return self.E + self.E_d


def integrate_full_order(
    structure: Structure,
    x_ref: np.ndarray,
    x0: np.ndarray,
    v0: np.ndarray,
    t_span: tuple[float, float],
    dt: float,
    options: FullOrderOptions | None = None,
    *,
    progress: Callable[[float], None] | None = None,
    on_sample: Callable[[float, np.ndarray], None] | None = None,
    **legacy,
) -> FullOrderSolution:
    """Integrate ``M ẍ + f_d + f(x) = 0`` with the implicit midpoint from ``(x0, v0)`` (n,3).

    structure, x_ref (n,3): the FE model and its reference (inflated equilibrium) state; V is
    measured from x_ref and the body reference X is x_ref about its CoM (free) or the hub point.
    t_span (s): (t0, t1); the step is ``span / ceil(span/dt)``. options: a
    :class:`~quadmodes.fullorder.options.FullOrderOptions` (model, damping, sampling, hub,
    Newton, checkpoints; default: its defaults). progress(fraction). on_sample(t, x): called
    with every sample's physical positions x (n,3) m (e.g.
    :class:`quadmodes.io.animation.FullOrderRecorder`).

    Deprecated, kept for one release: the options as keyword arguments (``model=…,
    damping=…, newton_tol=…``, the field names of ``FullOrderOptions``); they update
    ``options`` and warn (``DeprecationWarning``).

    Raises :class:`FullOrderNewtonError` on a Newton failure; Ctrl-C returns what was computed
    with status 1."""
    opts = FullOrderOptions() if options is None else options
    if legacy:
        warnings.warn("integrate_full_order: pass the options as options=FullOrderOptions(...)",
                      DeprecationWarning, stacklevel=2)  # fmt: skip
        opts = opts.updated(**legacy)
    start = time.perf_counter()
    problem = setup_problem(
        structure, x_ref, t_span, dt, model=opts.model, damping=opts.damping, hub=opts.hub,
        newton_tol=opts.newton_tol, energy_momentum=opts.energy_momentum,
        rotation_map=opts.rotation_map,
    )  # fmt: skip
    ops = StepOperators.build(structure, problem.m_full, problem.free, opts.energy_momentum)
    samples = SampledSeries(problem, opts.spin_axis, ops.energy if ops is not None else None,
                            on_sample)  # fmt: skip
    ck = Path(opts.checkpoint) if opts.checkpoint is not None else None
    state = initial_run_state(x0, v0)
    if opts.resume and ck is not None and ck.is_file():
        state = resume_from(ck, problem, samples, opts.checkpoint_key)
    if state.step == 0 and samples.last_time() is None:
        state = discrete_initial_state(problem, state)
        samples.record(problem.t0, state.x, state.v, state.e_d)
    state, status, message = _run_steps(
        problem, state, samples, ops, max_newton=opts.max_newton, full_newton=opts.full_newton,
        save_every=opts.save_every, checkpoint=ck,
        checkpoint_every=opts.checkpoint_every, progress=progress, start=start,
        key=opts.checkpoint_key, policy=opts.newton_policy,
        threads=default_threads() if opts.threads is None else opts.threads,
    )  # fmt: skip
    modes = problem.damping
    stats = {"n_newton": state.n_newton, "n_factor": state.n_factor, "n_steps": state.step,
             "wall_s": state.wall_before + time.perf_counter() - start,
             "damped_modes": 0 if modes is None else modes.n_modes,
             "damping_cutoff_hz": float("nan") if modes is None else modes.cutoff_hz}  # fmt: skip
    sol = _solution(samples.series, status, message, problem.h, stats, problem.hub)
    return replace(sol, damping="full-order damping: none" if modes is None else modes.describe())


def _run_steps(
    problem: FullOrderProblem, state: RunState, samples: SampledSeries, ops: StepOperators, *,
    max_newton: int, full_newton: bool, save_every: int, checkpoint: Path | None, checkpoint_every: int,
    progress: Callable[[float], None] | None, start: float, key: str = "", policy: str = "fixed",
    threads: int = 1,
) -> tuple[RunState, int, str]:  # fmt: skip
    """Step ``state`` to the end of the problem, sampling every ``save_every`` steps (and the
    last), checkpointing every ``checkpoint_every`` (the factorisation is renewed after each,
    so that a resumed run repeats the uninterrupted one); ``start``: perf_counter at the start
    of this run; ``key``: the checkpoints' key; ``policy``: the Newton policy
    (:data:`~quadmodes.fullorder.newton.POLICIES`); ``threads``: see
    :func:`~quadmodes.fullorder.newton.matrix_factory`. Returns ``(state, status, message)``; Ctrl-C stops with status 1 (the state
    reached is sampled)."""
    n_steps, matrix = problem.n_steps, None
    report = max(1, n_steps // 100)
    make = matrix_factory(problem, ops, full_newton, policy, threads)
    try:
        while state.step < n_steps:
            state, matrix = _advance(problem, state, matrix, max_newton, checkpoint, ops, make,
                                     full_newton, policy)  # fmt: skip
            step = state.step
            if step % save_every == 0 or step == n_steps:
                samples.record(problem.time(step), state.x, state.v, state.e_d)
            if checkpoint is not None and step % checkpoint_every == 0 and step < n_steps:
                wall = state.wall_before + time.perf_counter() - start
                write_checkpoint(checkpoint, checkpoint_data(problem, state, samples, wall, key))
                matrix = None  # the same factorisation history with and without a resume
            if progress and (step % report == 0 or step == n_steps):
                progress(step / n_steps)
    except KeyboardInterrupt:
        t = problem.time(state.step)
        if samples.last_time() != t:
            samples.record(t, state.x, state.v, state.e_d)
        return state, 1, f"interrupted at t = {t:.6g} s"
    return state, 0, "ok"


def _advance(
    problem: FullOrderProblem, state: RunState, matrix: NewtonMatrix | None, max_newton: int,
    checkpoint: Path | None, ops: StepOperators | None = None, make=None, full_newton=False,
    policy: str = "fixed",
) -> tuple[RunState, NewtonMatrix]:  # fmt: skip
    """One step: predictor, Newton (reusing ``matrix`` if given), end velocity ``v₁ = 2v½ − v₀``
    and the damping work. Returns the new state and the Newton matrix in use. Raises
    :class:`FullOrderNewtonError` (naming ``checkpoint`` if it exists) if Newton fails."""
    x, v, h = state.x, state.v, problem.h
    t_now, t1 = problem.time(state.step), problem.time(state.step + 1)
    frame_now = body_frame(problem.body, x, problem.hub, t_now)
    x1, rot = predict(problem, x, v, state.frame_prev, frame_now, t1)
    residual = StepResidual.start(problem, x, v, t_now, None if full_newton else ops)
    res = solve_step(problem, matrix, x, x1, rot, residual, max_newton, make, full_newton, policy)
    if not res.converged:
        kept = checkpoint if checkpoint is not None and checkpoint.is_file() else None
        # the last state reached (a membrane that has lost its tension: docs/sails.md)
        cause = loss_of_tension(problem.structure, x, problem.X)
        raise FullOrderNewtonError(state.step + 1, t1, res.correction / problem.scale, kept, cause)
    e_d = state.e_d + dissipated_work(problem, x, res.x1, res.vh, res.fd, t_now + 0.5 * h)
    renewed = getattr(res.matrix, "take_renewals", lambda: 0)()  # on a second thread
    new = RunState(state.step + 1, res.x1, 2.0 * res.vh - v, e_d, frame_now,
                   state.n_newton + res.n_newton, state.n_factor + res.n_factor + renewed,
                   state.wall_before)  # fmt: skip
    return new, res.matrix


def _solution(series, status, message, dt, stats, hub) -> FullOrderSolution:
    """Assemble the :class:`FullOrderSolution` from the sampled series (lists, one entry a
    sample: :class:`~quadmodes.fullorder.sampling.SampledSeries`) and the run's stats."""
    t = np.asarray(series["t"], float)
    big_h, h_disc, omega, axis = (
        np.asarray(series[k], float).reshape(-1, 3) for k in ("H", "Hd", "omega", "axis")
    )
    t_kin, v_pot, e_d = (np.asarray(series[k], float) for k in ("T", "V", "E_d"))
    steps = max(int(stats.get("n_steps", 0)), 1)
    stats = dict(stats, newton_per_step=stats.get("n_newton", 0) / steps,
                 factor_per_step=stats.get("n_factor", 0) / steps)  # fmt: skip
    return FullOrderSolution(
        t=t, H=big_h, H_norm=np.linalg.norm(big_h, axis=1), H_discrete=h_disc,
        T=t_kin, V=v_pot, E=t_kin + v_pot, E_d=e_d, spin_rate=np.sum(omega * axis, axis=1),
        cone_angle=cone_angle(big_h, axis), axis=axis,
        modal_coordinates=np.asarray(series["s"], float).reshape(len(t), -1),
        tip=np.asarray(series["tip"], float).reshape(-1, 3) if hub is not None else None,
        status=status, message=message, dt=dt, stats=stats,
    )  # fmt: skip
