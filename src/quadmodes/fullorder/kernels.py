"""Fast kernels of a full-order step: the energy–momentum step force and the blocks of its
Jacobian, per element set, with everything that does not change during a run computed once
(:class:`StepOperators`), and the Newton matrix assembled straight into the CSC data of its
sparsity pattern on the free DOFs (pattern and scatter map computed once per run).

Same equations as :func:`quadmodes.fullorder.step.step_force` and
:func:`quadmodes.fullorder.newton.step_jacobian` (the straightforward forms, kept as the
reference the tests compare with); only the arithmetic is arranged differently: the
deformation gradient is linear in x, so ``F(x½) = (F(x₀) + F(x₁))/2`` with F(x₀) computed once
per step; the 2×2 and 3×3 products are written out on ``(ne,)`` arrays instead of einsum; the
gather of F from the nodes and the scatter of the element forces back are sparse products with
operators built once (no ``x[conn]`` and no per-element force arrays).

SI units; states ``(n, 3)``; element arrays as in :mod:`quadmodes.fe.assembly`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.assembly import (
    CsrPattern,
    SubmatrixMap,
    assemble_vector,
    csr_pattern,
    submatrix_map,
)
from quadmodes.fe.bar import BarSet
from quadmodes.fe.membrane import MembraneSet
from quadmodes.fe.model import Structure
from quadmodes.fe.pressure import PressureSet
from quadmodes.fe.quadratic_strain import QuadraticStrainSet


def _rowdot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
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


def jit_module():
    """:mod:`quadmodes.fullorder.jit` if numba is importable, else None (looked up once)."""
    global _JIT
    if _JIT is None:
        try:
            from quadmodes.fullorder import jit
        except ImportError:  # numba (the [jit] / [fast] extra) not installed
            jit = False
        _JIT = jit
    return _JIT or None


_JIT = None


def _node_operator(conn: np.ndarray, weights: np.ndarray, n: int) -> sp.csr_matrix:
    """Sparse ``(ne, n)`` matrix with ``weights[e, a]`` at ``(e, conn[e, a])``: applied to a
    state ``(n, 3)`` it forms per element ``Σ_a w_a x_a`` (no gather of ``x[conn]``)."""
    ne, k = conn.shape
    rows = np.repeat(np.arange(ne), k)
    return sp.csr_matrix((weights.ravel(), (rows, conn.ravel())), shape=(ne, n))


class _Membrane:
    """St Venant–Kirchhoff membranes: start data ``(f0, f1, ε₀)``, the columns of F(x₀)
    ``(ne, 3)`` each and the Voigt strain ``[E11, E22, 2E12]`` ``(3, ne)``."""

    tie = False

    def __init__(self, e: MembraneSet, n: int, jit=None):
        self.set, self.conn, self.n, self.jit = e, np.ascontiguousarray(e.conn), n, jit
        self.g0, self.g1 = e.gradients[:, :, 0].copy(), e.gradients[:, :, 1].copy()
        self.vol = e._volume()
        self.ne = len(self.vol)
        self.vg0, self.vg1 = self.vol[:, None] * self.g0, self.vol[:, None] * self.g1
        # F columns = G x (2ne × n); nodal forces = (vol G)ᵀ [F S̄ columns] (n × 2ne)
        self.grad_op = sp.vstack([_node_operator(e.conn, self.g0, n),
                                  _node_operator(e.conn, self.g1, n)], format="csr")  # fmt: skip
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
        return np.stack([0.5 * (_rowdot(f0, f0) - 1.0), 0.5 * (_rowdot(f1, f1) - 1.0),
                         _rowdot(f0, f1)])  # fmt: skip

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


class _RelaxedMembrane(_Membrane):
    """Membranes under the wrinkling law (:mod:`quadmodes.fe.wrinkling`): the set's
    energy-exact step stress (``MembraneSet.step_stress``) and its tangent ``∂S̄/∂E₁``
    (``step_tangent``) in place of SVK's ``D (ε₀ + ε₁)/2`` and ``½ D``; numpy only."""

    def __init__(self, e: MembraneSet, n: int, jit=None):
        super().__init__(e, n, None)

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


class _Bar:
    """Green-strain bars: start data ``(d₀, ε₀)``, the bar vectors ``(ne, 3)`` and strains.
    ``tie``: these are the stiff ties that :mod:`~quadmodes.fullorder.condensed` condenses."""

    tie = True

    def __init__(self, e: BarSet, n: int):
        self.set, self.conn = e, np.ascontiguousarray(e.conn)
        self.l2 = e.length0**2
        self.k = e.EA / e.length0
        signs = np.broadcast_to(np.array([-1.0, 1.0]), e.conn.shape)
        self.diff_op = _node_operator(e.conn, signs, n)  # d = x_b − x_a
        self.force_op = self.diff_op.T.tocsr()

    def _d(self, x: np.ndarray) -> np.ndarray:
        return self.diff_op @ x

    def start(self, x0: np.ndarray):
        d0 = self._d(x0)
        return d0, (_rowdot(d0, d0) - self.l2) / (2.0 * self.l2)

    def _mean_strain(self, e0: np.ndarray, d1: np.ndarray) -> np.ndarray:
        return 0.5 * (e0 + (_rowdot(d1, d1) - self.l2) / (2.0 * self.l2))

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        """Nodal forces (n,3): ``∓ EA ε̄ d½ / L₀`` on the two ends."""
        d0, e0 = start
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


class _Pressure:
    """Follower pressure, ``f(x½)``: ``−p(x½) ∇V`` per triangle (cross products written out)."""

    tie = False

    def __init__(self, e: PressureSet, n: int, jit=None):
        self.set, self.conn, self.n, self.jit = e, np.ascontiguousarray(e.conn), n, jit
        ne = e.conn.shape[0]
        # corners a = 0, 1, 2 of every triangle stacked (3ne × n); its transpose scatters
        rows = np.arange(3 * ne)
        self.gather = sp.csr_matrix((np.ones(3 * ne), (rows, e.conn.T.ravel())), shape=(3 * ne, n))
        self.scatter = self.gather.T.tocsr()
        self.ne = ne

    def start(self, x0: np.ndarray):
        return x0

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        e, ne = self.set, self.ne
        p = e.load_factor * e.reference_pressure
        if self.jit is not None:
            grad = np.zeros((self.n, 3))
            volume = self.jit.pressure_gradient(self.conn, 0.5 * (start + x1), grad)
            if e.gas_law_exponent:
                p *= (e.reference_volume / volume) ** e.gas_law_exponent
            return (-p) * grad
        corners = self.gather @ (0.5 * (start + x1))
        x0, x1_, x2 = corners[:ne], corners[ne : 2 * ne], corners[2 * ne :]
        grad = np.concatenate([cross_rows(x1_, x2), cross_rows(x2, x0), cross_rows(x0, x1_)])
        if e.gas_law_exponent:
            volume = float(np.sum(x0 * grad[:ne])) / 6.0  # Σ x₁·(x₂×x₃)/6
            p *= (e.reference_volume / volume) ** e.gas_law_exponent
        return (-p / 6.0) * (self.scatter @ grad)

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        return 0.5 * self.set.stiffness(0.5 * (x0 + x1))


class _Midpoint:
    """Any other set (and every set without the energy–momentum average): ``f(x½)``, ½K(x½)."""

    tie = False

    def __init__(self, e, n: int):
        self.set, self.conn, self.n = e, e.conn, n

    def start(self, x0: np.ndarray):
        return x0

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        return assemble_vector(self.conn, self.set.force(0.5 * (start + x1)), self.n)

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        return 0.5 * self.set.stiffness(0.5 * (x0 + x1))


class _QuadraticStrain:
    """A set with quadratic strains (beams, rigid hubs): its own energy–momentum step force
    (stress of the averaged strain, :meth:`QuadraticStrainSet.step_force`) and Jacobian."""

    tie = False

    def __init__(self, e: QuadraticStrainSet, n: int):
        self.set, self.conn, self.n = e, e.conn, n

    def start(self, x0: np.ndarray):
        return x0

    def force(self, start, x1: np.ndarray) -> np.ndarray:
        return assemble_vector(self.conn, self.set.step_force(start, x1), self.n)

    def block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        return self.set.step_block(x0, x1)


def _kernel(e, n: int, energy_momentum: bool, jit):
    if isinstance(e, PressureSet):
        return _Pressure(e, n, jit)
    if energy_momentum and isinstance(e, MembraneSet):
        relaxed = e.tension_field  # the wrinkling law: numpy kernel with the set's step stress
        return _RelaxedMembrane(e, n) if relaxed else _Membrane(e, n, jit)
    if energy_momentum and isinstance(e, BarSet):
        return _Bar(e, n)
    if energy_momentum and isinstance(e, QuadraticStrainSet):
        return _QuadraticStrain(e, n)
    return _Midpoint(e, n)


@dataclass(frozen=True, eq=False)
class StepOperators:
    """What the step force and the Newton matrix of one run need, computed once.

    kernels: one per element set (in the structure's order), each with ``start(x0)``,
    ``force(start, x1)`` (nodal forces (n,3)) and ``block(x0, x1)`` (element Jacobian blocks).
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
            raise ValueError("jit: numba is not installed (pip install 'quadmodes[fast]')")
        kernels = tuple(_kernel(e, structure.n, energy_momentum, module)
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
        (the membranes' through their kernels, which are faster)."""
        total = 0.0
        for k in self.kernels:
            if isinstance(k, _Membrane) and not isinstance(k, _RelaxedMembrane):
                e = k.strain(*k.columns(x))
                total += 0.5 * float(np.sum(k.vol * np.sum(e * k._stress(e), axis=0)))
            else:
                total += float(k.set.energy(x))
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
