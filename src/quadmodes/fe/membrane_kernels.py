"""Fast step kernels of the membrane sets (:class:`~quadmodes.fe.membrane.MembraneSet`):
St Venant–Kirchhoff (with the compiled force of :mod:`quadmodes.fullorder.jit` when given) and
under the wrinkling law. Same equations as ``MembraneSet.step_force`` and ``step_block`` (the
straightforward forms the tests compare with); only the arithmetic is arranged differently.
The kernel contract: :mod:`quadmodes.fe.step_kernels`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.step_kernels import StepKernel, node_operator, rowdot


class MembraneKernel(StepKernel):
    """Fast step of St Venant–Kirchhoff membranes: start data ``(f0, f1, ε₀)``, the columns of
    F(x₀) ``(ne, 3)`` each and the Voigt strain ``[E11, E22, 2E12]`` ``(3, ne)``. The
    deformation gradient is linear in x, so ``F(x½) = (F(x₀) + F(x₁))/2`` with F(x₀) computed
    once per step; the 2×2 and 3×3 products are written out on ``(ne,)`` arrays; gather and
    scatter are sparse products with operators built once. jit: the compiled force
    (:mod:`quadmodes.fullorder.jit`) or None."""

    def __init__(self, e, n: int, jit=None):
        super().__init__(e, n)
        self.conn, self.jit = np.ascontiguousarray(e.conn), jit
        self.g0, self.g1 = e.gradients[:, :, 0].copy(), e.gradients[:, :, 1].copy()
        self.vol = e.area0 * e.thickness
        self.ne = len(self.vol)
        self.vg0, self.vg1 = self.vol[:, None] * self.g0, self.vol[:, None] * self.g1
        # F columns = G x (2ne × n); nodal forces = (vol G)ᵀ [F S̄ columns] (n × 2ne)
        self.grad_op = sp.vstack([node_operator(e.conn, self.g0, n),
                                  node_operator(e.conn, self.g1, n)], format="csr")  # fmt: skip
        vol2 = np.concatenate([self.vol, self.vol])
        self.force_op = sp.csr_matrix(sp.diags(vol2) @ self.grad_op).T.tocsr()
        self.d = np.asarray(e.d, float)

    def columns(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Columns ``F[:, :, 0]``, ``F[:, :, 1]`` ``(ne, 3)`` of the deformation gradient."""
        f = self.grad_op @ x
        return f[: self.ne], f[self.ne :]

    @staticmethod
    def strain(f0: np.ndarray, f1: np.ndarray) -> np.ndarray:
        """Voigt Green strain ``[E11, E22, 2E12]`` ``(3, ne)``."""
        return np.stack([0.5 * (rowdot(f0, f0) - 1.0), 0.5 * (rowdot(f1, f1) - 1.0),
                         rowdot(f0, f1)])  # fmt: skip

    def start(self, x0: np.ndarray):
        f0, f1 = self.columns(x0)
        return f0, f1, self.strain(f0, f1)

    def _stress(self, e_bar: np.ndarray) -> np.ndarray:
        """Voigt stress ``[S11, S22, S12]`` ``(3, ne)`` (Pa) of a Voigt strain ``(3, ne)``."""
        return self.d @ e_bar

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        """Nodal forces (n,3) of ``A₀t F(x½) S̄ Gᵀ``, S̄ the stress of (ε₀ + ε₁)/2."""
        a0, b0, e0 = start
        if self.jit is not None:
            out = np.zeros((self.n, 3))
            self.jit.membrane_force(self.conn, self.g0, self.g1, self.vg0, self.vg1, self.d,
                                    a0, b0, e0, np.ascontiguousarray(x1), out)  # fmt: skip
            return out
        a1, b1 = self.columns(x1)
        s11, s22, s12 = self._stress(0.5 * (e0 + self.strain(a1, b1)))
        fh0, fh1 = 0.5 * (a0 + a1), 0.5 * (b0 + b1)
        p = np.concatenate([fh0 * s11[:, None] + fh1 * s12[:, None],
                            fh0 * s12[:, None] + fh1 * s22[:, None]])  # fmt: skip
        return self.force_op @ p

    def _rows(self, f0: np.ndarray, f1: np.ndarray) -> np.ndarray:
        """Strain–displacement rows ``(ne, 3, 9)`` of ``[E11, E22, 2E12]`` at F = [f0 f1]."""
        g0, g1 = self.g0[:, :, None], self.g1[:, :, None]
        ne = f0.shape[0]
        rows = np.empty((ne, 3, 3, 3))
        rows[:, 0] = g0 * f0[:, None, :]
        rows[:, 1] = g1 * f1[:, None, :]
        rows[:, 2] = g1 * f0[:, None, :] + g0 * f1[:, None, :]
        return rows.reshape(ne, 3, 9)

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """``½ A₀t [K_geo(S̄) + B(x½)ᵀ D B(x₁)]`` ``(ne, 9, 9)``."""
        a0, b0, e0 = self.start(x0)
        a1, b1 = self.columns(x1)
        s11, s22, s12 = self._stress(0.5 * (e0 + self.strain(a1, b1)))
        bh = self._rows(0.5 * (a0 + a1), 0.5 * (b0 + b1))
        db1 = np.einsum("pq,eqb->epb", self.d, self._rows(a1, b1))
        k = np.matmul(bh.transpose(0, 2, 1), db1).reshape(-1, 3, 3, 3, 3)
        g0, g1 = self.g0, self.g1
        geo = (s11[:, None, None] * g0[:, :, None] * g0[:, None, :]
               + s12[:, None, None] * (g0[:, :, None] * g1[:, None, :]
                                       + g1[:, :, None] * g0[:, None, :])
               + s22[:, None, None] * g1[:, :, None] * g1[:, None, :])  # fmt: skip
        for i in range(3):
            k[:, :, i, :, i] += geo
        return (0.5 * self.vol)[:, None, None] * k.reshape(-1, 9, 9)

    def energy(self, x: np.ndarray) -> float:
        """Strain energy (J) at x (n,3) through the kernel's operators (faster than the set's)."""
        e = self.strain(*self.columns(x))
        return 0.5 * float(np.sum(self.vol * np.sum(e * self._stress(e), axis=0)))


class RelaxedMembraneKernel(MembraneKernel):
    """Membranes under the wrinkling law (:mod:`quadmodes.fe.wrinkling`): the set's
    energy-exact step stress (``MembraneSet.step_stress``) and its tangent ``∂S̄/∂E₁``
    (``step_tangent``) in place of SVK's ``D (ε₀ + ε₁)/2`` and ``½ D``; numpy only."""

    def __init__(self, e, n: int, jit=None):
        super().__init__(e, n, None)

    def energy(self, x: np.ndarray) -> float:
        return float(self.set.energy(x))

    @staticmethod
    def tensor(v: np.ndarray) -> np.ndarray:
        """Strain tensors ``(ne, 2, 2)`` of Voigt strains ``[E11, E22, 2E12]`` ``(3, ne)``."""
        return np.stack([np.stack([v[0], 0.5 * v[2]], -1), np.stack([0.5 * v[2], v[1]], -1)], -2)

    def _step(self, e0: np.ndarray, a1: np.ndarray, b1: np.ndarray):
        e0t, e1t = self.tensor(e0), self.tensor(self.strain(a1, b1))
        return e0t, e1t, self.set.step_stress(e0t, e1t)

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        a0, b0, e0 = start
        a1, b1 = self.columns(x1)
        sb = self._step(e0, a1, b1)[2]
        s11, s22, s12 = sb[:, 0, 0], sb[:, 1, 1], sb[:, 0, 1]
        fh0, fh1 = 0.5 * (a0 + a1), 0.5 * (b0 + b1)
        p = np.concatenate([fh0 * s11[:, None] + fh1 * s12[:, None],
                            fh0 * s12[:, None] + fh1 * s22[:, None]])  # fmt: skip
        return self.force_op @ p

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """``A₀t [½ K_geo(S̄) + B(x½)ᵀ (∂S̄/∂E₁) B(x₁)]`` ``(ne, 9, 9)``."""
        a0, b0, e0 = self.start(x0)
        a1, b1 = self.columns(x1)
        e0t, e1t, sb = self._step(e0, a1, b1)
        s11, s22, s12 = sb[:, 0, 0], sb[:, 1, 1], sb[:, 0, 1]
        bh = self._rows(0.5 * (a0 + a1), 0.5 * (b0 + b1))
        tb1 = np.matmul(self.set.step_tangent(e0t, e1t), self._rows(a1, b1))
        k = np.matmul(bh.transpose(0, 2, 1), tb1).reshape(-1, 3, 3, 3, 3)
        g0, g1 = self.g0, self.g1
        geo = 0.5 * (s11[:, None, None] * g0[:, :, None] * g0[:, None, :]
                     + s12[:, None, None] * (g0[:, :, None] * g1[:, None, :]
                                             + g1[:, :, None] * g0[:, None, :])
                     + s22[:, None, None] * g1[:, :, None] * g1[:, None, :])  # fmt: skip
        for i in range(3):
            k[:, :, i, :, i] += geo
        return self.vol[:, None, None] * k.reshape(-1, 9, 9)
