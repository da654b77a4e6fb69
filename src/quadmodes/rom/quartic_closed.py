"""The cubic-force tensor ``E_mnpq = u^q · C(u^m, u^n, u^p)`` of
:func:`quadmodes.rom.reduced.cubic_force_tensor` in closed form, where every element set has one.

Why: the finite-difference form evaluates the second-order force N²(N+1)/2 times over the whole
mesh (2448 evaluations for 16 modes): 18 of the 24 s of a model build on paper-membrane-coarse
(profiled, docs/path-validity.md "Cheaper members"), which a spin family pays per member.

* An SVK membrane (:class:`~quadmodes.fe.membrane.MembraneSet`; with ``tension_field`` its
  :meth:`second_order` is SVK's too, so the finite-difference tensor is SVK's): with
  ``F_u = Σ_a u_a ⊗ G_a`` and ``Q(u, v) = sym(F_uᵀ F_v)`` the Green strain of ``x + U`` is
  ``E(x) + sym(FᵀF_U) + ½ Q(U, U)``, so the strain energy's quartic part is
  ``(V/8) Q(U,U) : D : Q(U,U)`` (Voigt, V = A₀ t). It is ``¼ U·C(U,U,U) = ¼ E(U,U,U,U)``, hence
  ``E`` is the full symmetrisation of ``Σ_e (V_e/2) Q_e(u^m,u^n) : D : Q_e(u^p,u^q)``,
  independent of the state x.
* A Green-strain bar (:class:`~quadmodes.fe.bar.BarSet`, energy ``½ EA L₀ ε²``,
  ``ε = (|d|² − L₀²)/(2L₀²)``): the same with ``Q(u, v) = Δu·Δv / L₀²`` and ``EA L₀`` for
  ``V D``.
* A constant pressure (:class:`~quadmodes.fe.pressure.PressureSet` without gas law): its
  force ``p ∂V/∂x`` is quadratic in x, so C = 0.

Any other element set (cables, image sets, quadratic-strain sets, a gas law): None, and the
caller takes the finite differences.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from quadmodes.fe.bar import BarSet
from quadmodes.fe.membrane import MembraneSet
from quadmodes.fe.pressure import PressureSet


def _membrane_pairs(e: MembraneSet, shapes: np.ndarray) -> np.ndarray:
    """``Σ_e (V_e/2) Q_e(u^m,u^n) : D : Q_e(u^p,u^q)`` as an (N, N, N, N) array (J per unit⁴)."""
    fu = np.einsum("meai,eaj->meij", shapes[:, e.conn], e.gradients)  # (N, ne, 3, 2)
    iu, ju = np.triu_indices(shapes.shape[0])
    q = np.einsum("peki,pekj->peij", fu[iu], fu[ju])  # F_mᵀ F_n per pair (P, ne, 2, 2)
    qv = np.stack([q[..., 0, 0], q[..., 1, 1], q[..., 0, 1] + q[..., 1, 0]], -1)  # Voigt 2·sym
    weighted = np.einsum("pek,lk->pel", qv, e.d) * (0.5 * e.area0 * e.thickness)[None, :, None]
    return _tensor(qv.reshape(len(iu), -1) @ weighted.reshape(len(iu), -1).T, iu, ju)


def _bar_pairs(e: BarSet, shapes: np.ndarray) -> np.ndarray:
    """``Σ_e (EA L₀/2) Q_e(u^m,u^n) Q_e(u^p,u^q)``, ``Q = Δu·Δv/L₀²`` (N, N, N, N)."""
    du = shapes[:, e.conn[:, 1]] - shapes[:, e.conn[:, 0]]  # (N, ne, 3)
    iu, ju = np.triu_indices(shapes.shape[0])
    q = np.einsum("pei,pei->pe", du[iu], du[ju]) / e.length0**2
    return _tensor(q @ (q * (0.5 * e.EA * e.length0)).T, iu, ju)


def _tensor(pairs: np.ndarray, iu: np.ndarray, ju: np.ndarray) -> np.ndarray:
    """The (N, N, N, N) array of a (P, P) matrix over the pairs m ≤ n (both pairs symmetric)."""
    n = int(iu.max()) + 1
    out = np.zeros((n, n, n, n))
    for a, (m, k) in enumerate(zip(iu, ju, strict=True)):
        out[m, k] = out[k, m] = _unpack(pairs[a], iu, ju, n)
    return out


def _unpack(row: np.ndarray, iu: np.ndarray, ju: np.ndarray, n: int) -> np.ndarray:
    """The symmetric (N, N) matrix of the upper-triangle entries ``row``."""
    m = np.zeros((n, n))
    m[iu, ju] = row
    m[ju, iu] = row
    return m


def symmetrise(t: np.ndarray) -> np.ndarray:
    """Average of ``t`` ``(N, …, N)`` over all permutations of its axes (fully symmetric part)."""
    perms = list(itertools.permutations(range(t.ndim)))
    return sum(np.transpose(t, p) for p in perms) / math.factorial(t.ndim)


def cubic_force_tensor_closed(structure, shapes: np.ndarray) -> np.ndarray | None:
    """``E_mnpq`` (N, N, N, N) (J per unit⁴ of the shapes (N, n, 3)), fully symmetric, in
    closed form (module docstring); None if an element set has none."""
    n = shapes.shape[0]
    total = np.zeros((n,) * 4)
    for e in structure.elements:
        if isinstance(e, MembraneSet):
            total += _membrane_pairs(e, shapes)
        elif isinstance(e, BarSet):
            total += _bar_pairs(e, shapes)
        elif isinstance(e, PressureSet) and not e.gas_law_exponent:
            continue  # a quadratic force: no cubic term
        else:
            return None
    return symmetrise(total)
