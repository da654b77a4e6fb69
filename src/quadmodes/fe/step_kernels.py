"""Step kernels: what an element set offers to the full order's fast step
(:class:`quadmodes.fullorder.kernels.StepOperators`), and the two generic ones every set gets
from :class:`~quadmodes.fe.elements.ElementSet`.

A step kernel is built once per run (``ElementSet.step_kernel(n, energy_momentum, jit)``) and
holds whatever does not change during the run (gather and scatter operators, reference
gradients). Its contract, for the step ``x₀ → x₁`` of states ``(n, 3)``:

``start(x0)``
    data of the start state computed once per step (strains, gradients; anything).
``force(start, x1) -> (n, 3)``
    the set's assembled step force (N), equal to ``assemble_vector(conn, set.step_force(x0,
    x1))`` up to round-off.
``block(x0, x1) -> (ne, 3k, 3k)``
    its Jacobian blocks ``∂(step force)/∂x₁`` (N/m), equal to ``set.step_block(x0, x1)``.
``energy(x) -> float``
    the set's potential energy (J) (default: ``set.energy(x)``).
``tie``
    True for the stiff ties that :mod:`quadmodes.fullorder.condensed` condenses; such a kernel
    may add its blocks straight into the dense tie matrix (:meth:`StepKernel.add_tie_blocks`).

SI units; element arrays as in :mod:`quadmodes.fe.assembly`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.assembly import assemble_vector


def rowdot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product ``(ne,)`` of ``(ne, 3)`` arrays."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product ``(ne, 3)`` of ``(ne, 3)`` arrays, or of a ``(3,)`` vector with
    the rows of the other (np.cross without its axis handling)."""
    a, b = np.broadcast_arrays(a, b)
    out = np.empty(a.shape)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def node_operator(conn: np.ndarray, weights: np.ndarray, n: int) -> sp.csr_matrix:
    """Sparse ``(ne, n)`` matrix with ``weights[e, a]`` at ``(e, conn[e, a])``: applied to a
    state ``(n, 3)`` it forms per element ``Σ_a w_a x_a`` (no gather of ``x[conn]``)."""
    ne, k = conn.shape
    rows = np.repeat(np.arange(ne), k)
    return sp.csr_matrix((weights.ravel(), (rows, conn.ravel())), shape=(ne, n))


class StepKernel:
    """Base of the step kernels (module docstring): the set ``set`` with connectivity
    ``conn`` in a structure of ``n`` vector DOFs."""

    tie = False

    def __init__(self, e, n: int):
        self.set, self.conn, self.n = e, e.conn, n

    def start(self, x0: np.ndarray):
        return x0

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def energy(self, x: np.ndarray) -> float:
        """Potential energy (J) of the set at x (n,3)."""
        return float(self.set.energy(x))

    def add_tie_blocks(self, jit, z0: np.ndarray, z1: np.ndarray, positions: np.ndarray,
                       weight: float, out: np.ndarray) -> bool:  # fmt: skip
        """Add ``weight ×`` the blocks at (z0, z1) to the raveled dense tie matrix ``out`` at
        ``positions`` (ne, (3k)²) (−1: skipped) with the compiled module ``jit``; False if
        this kernel has no compiled form (the caller then scatters :meth:`block`)."""
        return False


class MidpointKernel(StepKernel):
    """The plain midpoint: ``f(x½)`` and ``½K(x½)`` (every set without the energy–momentum
    average)."""

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        return assemble_vector(self.conn, self.set.force(0.5 * (start + x1)), self.n)

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        return 0.5 * self.set.stiffness(0.5 * (x0 + x1))


class StepForceKernel(StepKernel):
    """The set's own energy–momentum step (``set.step_force``, ``set.step_block``), assembled;
    the default kernel of a set with the energy–momentum average."""

    def start(self, x0: np.ndarray):
        return x0, self.set.step_start(x0)

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        x0, data = start
        return assemble_vector(self.conn, self.set.step_force(x0, x1, data), self.n)

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        return self.set.step_block(x0, x1)
