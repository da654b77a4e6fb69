"""Two-node Green-strain bar (truss) elements, exactly frame invariant; used as stiff ties.

Strain ``ε = (|d|² − L₀²) / (2 L₀²)`` with ``d = x_b − x_a``; energy ``½ EA L₀ ε²``; the force
``f_b = −f_a = EA ε d / L₀`` is cubic in the positions, so ``B`` is exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.fe.elements import ElementSet
from quadmodes.fe.step_kernels import StepKernel, node_operator, rowdot


@dataclass(frozen=True)
class BarSet(ElementSet):
    """Bars ``conn`` ``(ne, 2)`` with stress-free lengths ``length0`` ``(ne,)`` (m) and axial
    stiffness ``EA`` ``(ne,)`` (N). Massless."""

    conn: np.ndarray
    length0: np.ndarray
    EA: np.ndarray

    def _d(self, x: np.ndarray) -> np.ndarray:
        return x[self.conn[:, 1]] - x[self.conn[:, 0]]

    def strain(self, x: np.ndarray) -> np.ndarray:
        d = self._d(x)
        return (np.einsum("ei,ei->e", d, d) - self.length0**2) / (2.0 * self.length0**2)

    def energy(self, x: np.ndarray) -> float:
        return float(0.5 * np.sum(self.EA * self.length0 * self.strain(x) ** 2))

    def force(self, x: np.ndarray) -> np.ndarray:
        fb = (self.EA * self.strain(x) / self.length0)[:, None] * self._d(x)
        return np.stack([-fb, fb], 1)

    def stiffness(self, x: np.ndarray) -> np.ndarray:
        d = self._d(x)
        k = self.EA / self.length0
        kb = k[:, None, None] * (
            self.strain(x)[:, None, None] * np.eye(3)
            + np.einsum("ei,ej->eij", d, d) / (self.length0**2)[:, None, None]
        )
        return np.block([[kb, -kb], [-kb, kb]])

    def second_order(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        d = self._d(x)
        du = u[self.conn[:, 1]] - u[self.conn[:, 0]]
        dv = v[self.conn[:, 1]] - v[self.conn[:, 0]]
        l2 = self.length0**2
        eu = np.einsum("ei,ei->e", d, du) / l2
        ev = np.einsum("ei,ei->e", d, dv) / l2
        euv = np.einsum("ei,ei->e", du, dv) / l2
        k = self.EA / self.length0
        fb = 0.5 * k[:, None] * (eu[:, None] * dv + ev[:, None] * du + euv[:, None] * d)
        return np.stack([-fb, fb], 1)

    def mass(self) -> None:
        return None

    # ---------------------------------------------------------------- full-order step
    def step_start(self, x0: np.ndarray) -> np.ndarray:
        """Strains ``(ne,)`` at the step's start state."""
        return self.strain(x0)

    def step_force(self, x0: np.ndarray, x1: np.ndarray, start=None) -> np.ndarray:
        """Energy–momentum step force ``(ne, 2, 3)``: ``∓ EA ε̄ d½ / L₀``, ε̄ = (ε₀ + ε₁)/2
        (exact work, since ε is quadratic in x)."""
        e0 = self.strain(x0) if start is None else start
        ebar = 0.5 * (e0 + self.strain(x1))
        fb = (self.EA * ebar / self.length0)[:, None] * self._d(0.5 * (x0 + x1))
        return np.stack([-fb, fb], 1)

    def step_block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """``∂ step_force / ∂x1`` ``(ne, 6, 6)``: ``½ EA/L₀ [ε̄ I + d½ ⊗ d₁ / L₀²]`` per end
        pair."""
        dh, d1 = self._d(0.5 * (x0 + x1)), self._d(x1)
        ebar = 0.5 * (self.strain(x0) + self.strain(x1))
        k = self.EA / self.length0
        kb = (0.5 * k)[:, None, None] * (
            ebar[:, None, None] * np.eye(3)
            + np.einsum("ei,ej->eij", dh, d1) / (self.length0**2)[:, None, None]
        )
        return np.block([[kb, -kb], [-kb, kb]])

    def step_kernel(self, n: int, energy_momentum: bool, jit=None) -> StepKernel:
        """:class:`BarKernel` (a tie) with the energy–momentum average."""
        return BarKernel(self, n, jit) if energy_momentum else super().step_kernel(n, False, jit)


class BarKernel(StepKernel):
    """Fast step of Green-strain bars: start data ``(d₀, ε₀)``, the bar vectors ``(ne, 3)``
    and strains. ``tie``: these are the stiff ties that :mod:`~quadmodes.fullorder.condensed`
    condenses."""

    tie = True

    def __init__(self, e: BarSet, n: int, jit=None):
        super().__init__(e, n)
        self.conn, self.jit = np.ascontiguousarray(e.conn), jit
        self.l2 = e.length0**2
        self.k = e.EA / e.length0
        signs = np.broadcast_to(np.array([-1.0, 1.0]), e.conn.shape)
        self.diff_op = node_operator(e.conn, signs, n)  # d = x_b − x_a
        self.force_op = self.diff_op.T.tocsr()

    def _d(self, x: np.ndarray) -> np.ndarray:
        return self.diff_op @ x

    def start(self, x0: np.ndarray):
        d0 = self._d(x0)
        return d0, (rowdot(d0, d0) - self.l2) / (2.0 * self.l2)

    def _mean_strain(self, e0: np.ndarray, d1: np.ndarray) -> np.ndarray:
        return 0.5 * (e0 + (rowdot(d1, d1) - self.l2) / (2.0 * self.l2))

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        """Nodal forces (n,3): ``∓ EA ε̄ d½ / L₀`` on the two ends."""
        d0, e0 = start
        if self.jit is not None:  # the same sums, compiled
            out = np.zeros((self.n, 3))
            self.jit.bar_force(self.conn, self.l2, self.k, d0, e0, np.ascontiguousarray(x1), out)
            return out
        d1 = self._d(x1)
        return self.force_op @ ((self.k * self._mean_strain(e0, d1))[:, None] * (0.5 * (d0 + d1)))

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        d0, e0 = self.start(x0)
        d1 = self._d(x1)
        dh = 0.5 * (d0 + d1)
        kb = (0.5 * self.k)[:, None, None] * (
            self._mean_strain(e0, d1)[:, None, None] * np.eye(3)
            + dh[:, :, None] * d1[:, None, :] / self.l2[:, None, None]
        )
        out = np.empty((kb.shape[0], 2, 3, 2, 3))  # [[kb, −kb], [−kb, kb]]
        out[:, 0, :, 0], out[:, 1, :, 1] = kb, kb
        out[:, 0, :, 1], out[:, 1, :, 0] = -kb, -kb
        return out.reshape(-1, 6, 6)

    def add_tie_blocks(self, jit, z0, z1, positions, weight, out) -> bool:
        """The blocks summed straight into the dense tie matrix by ``jit.tie_blocks``."""
        jit.tie_blocks(self.conn, self.l2, self.k, z0, z1, positions, weight, out)
        return True


def bar_set(conn: np.ndarray, reference: np.ndarray, EA: float | np.ndarray) -> BarSet:
    """Bars between vector DOFs ``conn`` ``(ne, 2)``, stress-free at ``reference`` ``(n, 3)``."""
    conn = np.asarray(conn, dtype=np.int64)
    length0 = np.linalg.norm(reference[conn[:, 1]] - reference[conn[:, 0]], axis=1)
    if np.any(length0 <= 0.0):
        raise ValueError("ties: a bar joins two coincident points; move the end-body points apart")
    return BarSet(conn, length0, np.broadcast_to(np.asarray(EA, float), length0.shape).copy())
