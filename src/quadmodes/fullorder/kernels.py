"""Fast kernels of a full-order step: the energy–momentum step force and the blocks of its
Jacobian, one kernel per element set with everything that does not change during a run computed
once (:class:`StepOperators`), and the Newton matrix assembled straight into the CSC data of its
sparsity pattern on the free DOFs (pattern and scatter map computed once per run).

Each element set supplies its own kernel (``ElementSet.step_kernel``; the contract in
:mod:`quadmodes.fe.step_kernels`, the membranes' kernels in :mod:`quadmodes.fe.membrane_kernels`,
the bars' and the pressure's beside their sets; any other set: its ``step_force`` and
``step_block`` assembled). Same equations as :func:`quadmodes.fullorder.step.step_force` and
:func:`quadmodes.fullorder.newton.step_jacobian` (the straightforward forms, kept as the
reference the tests compare with); only the arithmetic is arranged differently.

SI units; states ``(n, 3)``; element arrays as in :mod:`quadmodes.fe.assembly`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.assembly import CsrPattern, SubmatrixMap, csr_pattern, submatrix_map
from quadmodes.fe.model import Structure


def jit_module():
    """:mod:`quadmodes.fullorder.jit` if numba is importable, else None (looked up once)."""
    global _JIT
    if _JIT is None:
        try:
            from quadmodes.fullorder import jit
        except ImportError:  # numba cannot be imported on this platform
            jit = False
        _JIT = jit
    return _JIT or None


_JIT = None


@dataclass(frozen=True, eq=False)
class StepOperators:
    """What the step force and the Newton matrix of one run need, computed once.

    kernels: one per element set (in the structure's order, ``ElementSet.step_kernel``), each
    with ``start(x0)``, ``force(start, x1)`` (nodal forces (n,3)), ``block(x0, x1)`` (element
    Jacobian blocks) and ``energy(x)`` (:mod:`quadmodes.fe.step_kernels`).
    pattern: CSR pattern of
    ``M + J`` (3n, 3n) (element blocks, then the mass entries); mass_data ``(nnz,)``: M in
    that pattern (kg); free_map: CSC of the free-DOF submatrix."""

    n: int
    kernels: tuple
    pattern: CsrPattern
    n_block_entries: int
    mass_data: np.ndarray
    free_map: SubmatrixMap

    @classmethod
    def build(cls, structure: Structure, m_full: sp.spmatrix, free: np.ndarray,
              energy_momentum: bool, jit: bool | None = None) -> StepOperators:  # fmt: skip
        """Operators of ``structure`` with mass ``m_full`` (3n,3n) and free scalar DOFs
        ``free`` (sorted). jit: the compiled membrane and pressure forces
        (:mod:`~quadmodes.fullorder.jit`; None: if numba is importable; False: numpy)."""
        module = jit_module() if jit is None or jit else None
        if jit and module is None:
            raise ValueError("jit: numba cannot be imported here (a core dependency: reinstall quadmodes)")
        kernels = tuple(e.step_kernel(structure.n, energy_momentum, module)
                        for e in structure.elements)  # fmt: skip
        conns = [np.asarray(e.conn) for e in structure.elements]
        m = sp.coo_matrix(m_full)
        pattern = csr_pattern(conns, structure.n, [(m.row, m.col)])
        n_blocks = pattern.slots.size - m.nnz
        mass = np.bincount(pattern.slots[n_blocks:], weights=m.data,
                           minlength=pattern.indices.size)  # fmt: skip
        return cls(structure.n, kernels, pattern, n_blocks, mass,
                   submatrix_map(pattern, np.asarray(free)))  # fmt: skip

    def energy(self, x: np.ndarray) -> float:
        """Total potential energy (J) at x (n,3), as :func:`quadmodes.fe.model.strain_energy`
        (each set's through its kernel: the membranes' are faster)."""
        total = 0.0
        for k in self.kernels:
            total += k.energy(x)
        return total

    def start(self, x0: np.ndarray) -> list:
        """Per-set data of the step's start state x0 (n,3) (strains, gradients)."""
        return [k.start(x0) for k in self.kernels]

    def step_force(self, start: list, x1: np.ndarray) -> np.ndarray:
        """Step force (n,3) N of the step from the state of ``start`` to x1 (n,3)."""
        out = np.zeros((self.n, 3))
        for k, s in zip(self.kernels, start, strict=True):
            out += k.force(s, x1)
        return out

    def newton_matrix(self, x0: np.ndarray, x1: np.ndarray, weight: float,
                      skip: tuple | list = ()) -> sp.csc_matrix:  # fmt: skip
        """``M + weight·J(x₀, x₁)`` on the free DOFs (CSC), J the step Jacobian without the
        global rank-one terms and without the sets whose kernel indices are in ``skip``;
        weight in s² (Δt²/2)."""
        parts, slots, start = [], [], 0
        for k, kern in enumerate(self.kernels):
            size = kern.conn.shape[0] * (3 * kern.conn.shape[1]) ** 2
            if k not in skip:
                parts.append(kern.block(x0, x1).ravel())
                slots.append(self.pattern.slots[start : start + size])
            start += size
        data = np.bincount(np.concatenate(slots), weights=np.concatenate(parts),
                           minlength=self.mass_data.size)  # fmt: skip
        return self.free_map.csc(self.mass_data + weight * data)
