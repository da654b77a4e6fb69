"""Right-preconditioned GMRES: solve ``A x = b`` with an approximate inverse ``P ≈ A⁻¹``.

Used by the inflation Newton (:mod:`quadmodes.structure.prestress`) to keep one sparse
factorisation over several iterations: the factorisation of an earlier tangent is the
preconditioner, the current tangent the operator. Right preconditioning (``A P y = b``,
``x = P y``) makes the minimised residual the true residual ``‖b − A x‖``, so the stopping test
is on the equations themselves, not on the preconditioned ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

Apply = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class KrylovResult:
    """x: ``(m,)`` solution. residual: ``‖b − A x‖ / ‖b‖`` (its Arnoldi estimate, exact in
    exact arithmetic). iterations: operator applications. converged: residual ≤ rtol."""

    x: np.ndarray
    residual: float
    iterations: int
    converged: bool


def gmres(
    operator: Apply, preconditioner: Apply, b: np.ndarray, rtol: float, max_iterations: int,
    first: np.ndarray | None = None,
) -> KrylovResult:  # fmt: skip
    """GMRES (no restart, modified Gram–Schmidt) for ``A x = b``, right-preconditioned by ``P``.

    operator: ``v (m,) -> A v``. preconditioner: ``v (m,) -> P v`` with ``P ≈ A⁻¹``. rtol: stop
    when the relative residual ``‖b − A x‖/‖b‖`` is at most this. max_iterations: at most this
    many Krylov vectors (the result then has ``converged=False``, with the best ``x`` found);
    after four steps, the iteration also stops unconverged when the mean residual reduction per
    step so far extrapolates to more than ``10 rtol`` at ``max_iterations`` (a poor
    preconditioner is recognised early). first: ``P b`` if the caller has it already (saves
    one application of P)."""
    beta = float(np.linalg.norm(b))
    if beta == 0.0:
        return KrylovResult(np.zeros_like(b), 0.0, 0, True)
    basis = [b / beta]
    h = np.zeros((max_iterations + 1, max_iterations))
    z_cols = []
    residual, k = 1.0, 0
    y = np.zeros(0)
    for k in range(1, max_iterations + 1):
        z = first / beta if k == 1 and first is not None else preconditioner(basis[-1])
        z_cols.append(z)
        w = operator(z)
        for i, v in enumerate(basis):
            h[i, k - 1] = v @ w
            w = w - h[i, k - 1] * v
        h[k, k - 1] = np.linalg.norm(w)
        rhs = np.zeros(k + 1)
        rhs[0] = beta
        y = np.linalg.lstsq(h[: k + 1, :k], rhs, rcond=None)[0]
        residual = float(np.linalg.norm(h[: k + 1, :k] @ y - rhs)) / beta
        if residual <= rtol or h[k, k - 1] <= 1e-14 * beta:
            break
        # Give up early when the mean reduction so far would not reach rtol by the last step.
        if k >= 4 and residual ** (max_iterations / k) > 10.0 * rtol:
            break
        basis.append(w / h[k, k - 1])
    x = np.column_stack(z_cols) @ y
    return KrylovResult(x, residual, k, residual <= rtol)
