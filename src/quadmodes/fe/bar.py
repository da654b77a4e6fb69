"""Two-node Green-strain bar (truss) elements, exactly frame invariant; used as stiff ties.

Strain ``ε = (|d|² − L₀²) / (2 L₀²)`` with ``d = x_b − x_a``; energy ``½ EA L₀ ε²``; the force
``f_b = −f_a = EA ε d / L₀`` is cubic in the positions, so ``B`` is exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BarSet:
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


def bar_set(conn: np.ndarray, reference: np.ndarray, EA: float | np.ndarray) -> BarSet:
    """Bars between vector DOFs ``conn`` ``(ne, 2)``, stress-free at ``reference`` ``(n, 3)``."""
    conn = np.asarray(conn, dtype=np.int64)
    length0 = np.linalg.norm(reference[conn[:, 1]] - reference[conn[:, 0]], axis=1)
    if np.any(length0 <= 0.0):
        raise ValueError("ties: a bar joins two coincident points; move the end-body points apart")
    return BarSet(conn, length0, np.broadcast_to(np.asarray(EA, float), length0.shape).copy())
