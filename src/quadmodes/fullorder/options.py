"""The options of a full-order transient (:func:`~quadmodes.fullorder.integrator.integrate_full_order`)
in one frozen object."""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np

import quadmodes.fullorder.kinematics as kin
from quadmodes.fullorder.damping import DampingModes
from quadmodes.rom.reduced import ReducedModel


@dataclass(frozen=True, eq=False)
class FullOrderOptions:
    """How :func:`~quadmodes.fullorder.integrator.integrate_full_order` integrates (SI units).

    model: the reduced model whose modes give the modal coordinates (None: N = 0) and, with
    ``damping=True``, the damping. damping: the modal damping basis
    (:class:`~quadmodes.fullorder.damping.DampingModes`, e.g. the independent one), True: the
    model's retained modes and C, False: none. save_every: sample every so many steps (and the
    last). hub: prescribed rotation of the clamped DOFs (needed iff the structure has fixed
    DOFs; default for a clamped structure: a fixed clamp). spin_axis (3,): nominal spin axis in
    the initial body frame for the axis tracking (default: the minor axis of the initial
    inertia). rotation_map: map the initial state to the scheme's steady-rotation form and the
    sampled end states back for the diagnostics (free bodies; see the package docstring).
    energy_momentum: averaged-stress internal force (False: plain ``f(x½)``). newton_tol:
    relative (to the body size) Newton correction at convergence. max_newton: iterations per
    step. full_newton: a fresh factorisation of the whole Newton matrix at every iteration,
    matrix and step force computed the straightforward way
    (:func:`~quadmodes.fullorder.newton.step_jacobian`,
    :func:`~quadmodes.fullorder.step.step_force`; the reference the tests compare the default
    with; several times slower). checkpoint: .npz path written every ``checkpoint_every``
    steps (atomic); resume: continue from it (same t0, dt; the end may differ) — the result
    equals the uninterrupted run's (the factorisation is renewed after every checkpoint in
    both). checkpoint_key: text naming what the run is of (e.g. a hash of the run case and
    its model, :func:`quadmodes.analysis.full_order_runs.checkpoint_key`), written into the
    checkpoint; a resume from a checkpoint with another key is refused. newton_policy:
    ``"adaptive"`` (the default since issue 27: converged also when the contraction estimate of
    the error left is below a tenth of the tolerance, the Krylov preconditioner renewed when
    its marginal cost passes the average; :data:`quadmodes.fullorder.newton.RATE_STOP`,
    :data:`quadmodes.fullorder.krylov.FACTOR_COST`) or ``"fixed"`` (the rules before it, kept
    for the side-by-side benchmark and the tests). threads: threads the run may use (None:
    :func:`~quadmodes.fullorder.renewal.default_threads`: ``$QUADMODES_THREADS``, else 1); with 2 or more, the Krylov path's preconditioner is renewed on a
    second thread (:mod:`~quadmodes.fullorder.renewal`; same answers to the Newton
    tolerance, repeatable whatever the load).
    """

    model: ReducedModel | None = None
    damping: bool | DampingModes = True
    save_every: int = 1
    hub: kin.HubDrive | None = None
    spin_axis: np.ndarray | None = None
    rotation_map: bool = True
    energy_momentum: bool = True
    newton_tol: float = 1e-11
    max_newton: int = 40
    full_newton: bool = False
    checkpoint: Path | None = None
    checkpoint_every: int = 1000
    resume: bool = False
    checkpoint_key: str = ""
    newton_policy: str = "adaptive"
    threads: int | None = None

    def __post_init__(self):
        if self.newton_policy not in ("adaptive", "fixed"):
            raise ValueError(f"newton_policy {self.newton_policy!r}: choose adaptive or fixed")
        if self.threads is not None and self.threads < 1:
            raise ValueError(f"threads {self.threads}: at least 1 (None: the cores available)")

    def updated(self, **changes) -> FullOrderOptions:
        """A copy with ``changes`` (option names as the fields; ``TypeError`` for others)."""
        unknown = set(changes) - {f.name for f in fields(self)}
        if unknown:
            raise TypeError(f"unknown full-order option(s): {', '.join(sorted(unknown))}")
        return replace(self, **changes) if changes else self
