"""The Newton matrix of a full-order step with its stiff ties condensed: a factorisation that
is kept over many steps for the soft part and renewed at every iteration for the ties.

Why: the end-body ties (Green-strain bars, :class:`~quadmodes.fe.bar.BarSet`) are about 10⁴
times stiffer than anything the step resolves (ωΔt ~ 10²), so their block of
``A = M + (Δt²/2) J`` turns with every small wobble of a tie direction, and a frozen A then
contracts the Newton iteration only 2–5× per iteration (profile of ``paper-41hz-coarse``:
5–6 iterations and 0.3 factorisations per step). The membrane and pressure blocks change
little from step to step in the body frame. So the free DOFs are split into T, those of the
nodes the ties touch (a few dozen), and I, the rest, and

    A = [[A_II, A_IT], [A_TI, A_TT + (Δt²/2) J_ties(z)]]

is solved by block elimination: A_II (sparse LU) and the Schur complement of the soft part
``S_soft = A_TT − A_TI A_II⁻¹ A_IT`` (dense, |T|²) are computed once per factorisation at a
body-frame pair; the ties' block at the current iterate is added to S_soft (dense LU of
|T|×|T|) at every iteration. The linear algebra is exact block elimination: only which
configuration each block is taken at differs from a fresh factorisation.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from quadmodes.fe.assembly import element_dofs
from quadmodes.fe.model import tangent_low_rank
from quadmodes.fullorder.kernels import StepOperators, jit_module
from quadmodes.fullorder.setup import FullOrderProblem
from quadmodes.linalg.factor import factorize


class TieSplit:
    """The I/T split of the free DOFs of a run (computed once): ``tie`` (|T|,) and ``soft``
    (|I|,) positions in the free-DOF vector; ``scatter`` (Σ nb·(3k)²,) position of every entry of
    the ties' element blocks in the raveled |T|×|T| matrix (−1: a clamped row or column);
    ``stiff`` the indices of the tie kernels in ``ops.kernels``."""

    def __init__(self, ops: StepOperators, free: np.ndarray, stiff: list[int]):
        n_dof = 3 * ops.n
        where = np.full(n_dof, -1)
        where[free] = np.arange(len(free))
        dofs = [element_dofs(ops.kernels[k].conn) for k in stiff]
        tie_free = np.unique(where[np.concatenate([d.ravel() for d in dofs])])
        self.tie = tie_free[tie_free >= 0]
        self.soft = np.setdiff1d(np.arange(len(free)), self.tie)
        in_t = np.full(len(free), -1)
        in_t[self.tie] = np.arange(len(self.tie))
        parts = []
        nt = len(self.tie)
        for d in dofs:
            loc = np.where(where[d] >= 0, in_t[np.maximum(where[d], 0)], -1)  # (nb, 3k)
            m = loc.shape[1]
            rows, cols = np.repeat(loc, m, axis=1).ravel(), np.tile(loc, (1, m)).ravel()
            parts.append(np.where((rows >= 0) & (cols >= 0), rows * nt + cols, -1))
        self.scatter = np.concatenate(parts)
        self.positions = [part.reshape(len(d), -1) for part, d in zip(parts, dofs, strict=True)]
        # per tie set (nb, (3k)²)
        self.stiff = stiff

    @classmethod
    def of(cls, ops: StepOperators, free: np.ndarray) -> TieSplit | None:
        """The split of the tie kernels (those whose ``tie`` is True: bars with the
        energy–momentum average), or None without ties."""
        stiff = [k for k, kern in enumerate(ops.kernels) if kern.tie]
        return cls(ops, free, stiff) if stiff else None


class CondensedNewtonMatrix:
    """``A = M + (Δt²/2)[J_soft(z_f) + J_ties(z)]`` on the free DOFs, solved by condensing
    onto the tie DOFs (module docstring): the soft part at the frozen pair z_f given here,
    the ties at the pair of :meth:`update` (call it before :meth:`solve`). single: A_II
    factorised in float32 (:func:`~quadmodes.linalg.factor.factorize`), so solves are exact to
    about 1e-5 relative, which only adds that much to the Newton contraction factor."""

    def __init__(self, problem: FullOrderProblem, ops: StepOperators, split: TieSplit,
                 z0: np.ndarray, z1: np.ndarray, single: bool = True):  # fmt: skip
        self.problem, self.ops, self.split = problem, ops, split
        self.weight = 0.5 * problem.h * problem.h
        a = ops.newton_matrix(z0, z1, self.weight, skip=split.stiff).tocsr()
        soft, tie = split.soft, split.tie
        self.a_ti = a[tie][:, soft]
        a_it = a[soft][:, tie].tocsc()
        # single precision (default): this is an approximate inverse already (the soft part is
        # frozen over many steps); its round-off (~1e-5 relative) is far below the staleness
        self.lu = factorize(a[soft][:, soft].tocsc(), symmetric=True, single=single)
        # Z = A_II⁻¹ A_IT (|I|, |T|), kept for the coupled columns only (those of the end-body
        # points, which no membrane touches, are zero) and in the precision of A_II's factors
        self.coupled = np.flatnonzero(np.diff(a_it.indptr))
        z = (self.lu.solve(a_it[:, self.coupled].toarray()) if len(self.coupled)
             else np.zeros((len(soft), 0)))  # fmt: skip
        self.z = z.astype(np.float32 if single else np.float64)
        self.s_soft = a[tie][:, tie].toarray()
        self.s_soft[:, self.coupled] -= self.a_ti @ z
        self.s_lu = None
        self.low = []

    def update(self, z0: np.ndarray, z1: np.ndarray) -> None:
        """Take the ties' block (and the gas-law rank-one terms) at the body-frame pair
        (z0, z1) (n,3)."""
        nt = len(self.split.tie)
        jit = jit_module()
        if jit is not None:  # the ties' blocks summed straight into the Schur matrix
            s = self.s_soft.copy().ravel()
            z0, z1 = np.ascontiguousarray(z0, float), np.ascontiguousarray(z1, float)
            for k, pos in zip(self.split.stiff, self.split.positions, strict=True):
                kern = self.ops.kernels[k]
                if not kern.add_tie_blocks(jit, z0, z1, pos, self.weight, s):
                    keep = pos >= 0  # a tie kernel without a compiled form
                    np.add.at(s, pos[keep], self.weight * kern.block(z0, z1).reshape(pos.shape)[keep])
            s = s.reshape(nt, nt)
        else:
            blocks = np.concatenate([self.ops.kernels[k].block(z0, z1).ravel()
                                     for k in self.split.stiff])  # fmt: skip
            keep = self.split.scatter >= 0
            ties = np.bincount(self.split.scatter[keep], weights=blocks[keep], minlength=nt * nt)
            s = self.s_soft + self.weight * ties.reshape(nt, nt)
        self.s_lu = sla.lu_factor(s, check_finite=False)
        low = tangent_low_rank(self.problem.structure, 0.5 * (z0 + z1))
        self.low = []
        for coef, vec in low:
            vf = np.asarray(vec).ravel()[self.problem.free]
            self.low.append((self.weight * 0.5 * coef, vf, self._solve(vf)))

    def _solve(self, rhs: np.ndarray) -> np.ndarray:
        soft, tie = self.split.soft, self.split.tie
        y_soft = self.lu.solve(rhs[soft])
        y_tie = sla.lu_solve(self.s_lu, rhs[tie] - self.a_ti @ y_soft, check_finite=False)
        out = np.empty_like(rhs)
        out[soft] = y_soft - self.z @ y_tie[self.coupled].astype(self.z.dtype)
        out[tie] = y_tie
        return out

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``A⁻¹ rhs`` (n_free,) with the ties of the last :meth:`update`."""
        y = self._solve(rhs)
        for coef, vec, av in self.low:  # Sherman–Morrison for c v vᵀ
            y = y - av * (coef * (vec @ y) / (1.0 + coef * (vec @ av)))
        return y
