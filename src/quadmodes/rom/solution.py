"""The result of :func:`quadmodes.rom.integrators.integrate`: samples, dissipated energy, status
and the work counters of the run."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class Solution:
    """Result of :func:`~quadmodes.rom.integrators.integrate`.

    t (k,) s; y (k, 7+2N) states ``[q, ω, s, ṡ]``; dissipated (k,) J: energy dissipated by
    modal damping since t0 (the scheme's own discrete form); method; stats (n_steps, n_rhs,
    n_newton, n_jac, wall_s, backend; Radau adds n_lu); status 0 (success) or 1 (failure);
    message; dt (s) for fixed-step methods, else None.
    """

    t: np.ndarray
    y: np.ndarray
    method: str
    stats: dict
    status: int
    message: str
    dissipated: np.ndarray = field(default_factory=lambda: np.zeros(0))
    dt: float | None = None

    @property
    def success(self) -> bool:
        return self.status == 0


def work_counters(n_steps: int, n_rhs: int, n_newton: int, n_jac: int) -> dict:
    """The ``stats`` counters every method reports: accepted steps, evaluations of the
    right-hand side (or of the step residual for implicit methods), Newton iterations and
    Jacobian evaluations (``wall_s`` and ``backend`` are added by ``integrate``)."""
    return {"n_steps": n_steps, "n_rhs": n_rhs, "n_newton": n_newton, "n_jac": n_jac}
