"""Follower pressure on a closed, outward-oriented triangle surface.

The load is conservative with potential ``Π = −∫ p dV`` over the enclosed volume
``V = Σ x₁·(x₂×x₃)/6``. Per triangle ``∇_{x_a} V = x_b × x_c / 6`` (cyclic), so the force, load
stiffness and second-order term are exact polynomials (quadratic force for constant pressure) and
the element Hessian is symmetric; translation and rotation invariance hold once assembled over a
closed surface. With ``gas_law_exponent κ > 0`` the pressure follows ``p V^κ = const`` through the
reference state ``(p_ref, V_ref)``; the extra load stiffness ``−p'(V) ∇V ∇Vᵀ`` is rank one and
global, so it is returned separately by :func:`gas_rank_one`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.assembly import assemble_vector
from quadmodes.fe.elements import ElementSet
from quadmodes.fe.step_kernels import StepKernel, cross_rows

_CYCLIC = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])


def enclosed_volume(x: np.ndarray, triangles: np.ndarray) -> float:
    """Volume (m³) enclosed by outward triangles ``(nt, 3)`` at positions ``x`` ``(n, 3)``."""
    xe = x[triangles]
    return float(np.einsum("ei,ei->", xe[:, 0], np.cross(xe[:, 1], xe[:, 2])) / 6.0)


def volume_gradient_elements(xe: np.ndarray) -> np.ndarray:
    """Per-triangle ``∂V/∂x_a`` ``(nt, 3, 3)`` (m²)."""
    return np.cross(xe[:, _CYCLIC[:, 1]], xe[:, _CYCLIC[:, 2]]) / 6.0


def volume_hessian_elements(xe: np.ndarray) -> np.ndarray:
    """Per-triangle ``∂²V/∂x_a∂x_b`` ``(nt, 9, 9)`` (m)."""
    nt = xe.shape[0]
    h = np.zeros((nt, 3, 3, 3, 3))
    sixth = xe / 6.0
    # ∇_a V = x_b × x_c / 6: d/dx_b = −[x_c]x / 6, d/dx_c = [x_b]x / 6. The nonzero entries of
    # [v]x (v = x_d / 6 of node d) are written straight into the blocks: ±v_k at (i, j) for the
    # cyclic (i, j, k): [v]x[i, j] = −v_k, [v]x[j, i] = v_k.
    for a, b, c in _CYCLIC:
        for i, j, k in _CYCLIC:
            vb, vc = sixth[:, b, k], sixth[:, c, k]
            h[:, a, i, b, j] = vc  # −[x_c]x[i, j] = v_c,k for (i, j, k) cyclic
            h[:, a, j, b, i] = -vc
            h[:, a, i, c, j] = -vb
            h[:, a, j, c, i] = vb
    return h.reshape(nt, 9, 9)


def volume_third_elements(ue: np.ndarray, ve: np.ndarray) -> np.ndarray:
    """Per-triangle ``D²(∇_a V)[u, v]`` ``(nt, 3, 3)`` = ``(u_b × v_c + v_b × u_c) / 6``."""
    b, c = _CYCLIC[:, 1], _CYCLIC[:, 2]
    return (np.cross(ue[:, b], ve[:, c]) + np.cross(ve[:, b], ue[:, c])) / 6.0


@dataclass(frozen=True)
class PressureSet(ElementSet):
    """Pressure ``reference_pressure`` (Pa) on outward triangles ``conn`` ``(nt, 3)``.

    ``load_factor`` scales the pressure (load stepping). ``gas_law_exponent`` 0 means constant
    pressure; otherwise ``p = p_ref (V_ref / V)^κ`` with ``reference_volume`` ``V_ref`` (m³).
    """

    conn: np.ndarray
    reference_pressure: float
    load_factor: float = 1.0
    gas_law_exponent: float = 0.0
    reference_volume: float = 0.0

    def volume(self, x: np.ndarray) -> float:
        return enclosed_volume(x, self.conn)

    def pressure(self, x: np.ndarray) -> float:
        """Current pressure (Pa)."""
        p = self.load_factor * self.reference_pressure
        if self.gas_law_exponent:
            p *= (self.reference_volume / self.volume(x)) ** self.gas_law_exponent
        return p

    def pressure_derivatives(self, x: np.ndarray) -> tuple[float, float, float]:
        """``p``, ``dp/dV``, ``d²p/dV²`` at the current volume (Pa, Pa/m³, Pa/m⁶)."""
        p = self.pressure(x)
        k = self.gas_law_exponent
        if not k:
            return p, 0.0, 0.0
        v = self.volume(x)
        return p, -k * p / v, k * (k + 1.0) * p / v**2

    def energy(self, x: np.ndarray) -> float:
        v = self.volume(x)
        p0 = self.load_factor * self.reference_pressure
        k = self.gas_law_exponent
        if not k:
            return -p0 * v
        vr = self.reference_volume
        if k == 1.0:
            return -p0 * vr * np.log(v / vr)
        return -p0 * vr**k * (v ** (1.0 - k) - vr ** (1.0 - k)) / (1.0 - k)

    def force(self, x: np.ndarray) -> np.ndarray:
        return -self.pressure(x) * volume_gradient_elements(x[self.conn])

    def stiffness(self, x: np.ndarray) -> np.ndarray:
        """Element part ``−p ∇²V`` (N/m); add :func:`gas_rank_one` for ``κ > 0``."""
        h = volume_hessian_elements(x[self.conn])
        h *= -self.pressure(x)
        return h

    def second_order(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Element part of ``B(u, v)``; for ``κ > 0`` the global terms are added by
        :func:`gas_second_order`."""
        return -0.5 * self.pressure(x) * volume_third_elements(u[self.conn], v[self.conn])

    def mass(self) -> None:
        return None

    def step_kernel(self, n: int, energy_momentum: bool, jit=None) -> StepKernel:
        """:class:`PressureKernel` (the plain midpoint ``f(x½)`` with or without the
        energy–momentum average: the constant-pressure potential is cubic, and the midpoint's
        energy error is the enclosed volume of the increment field, zero for a rigid rotation)."""
        return PressureKernel(self, n, jit)


class PressureKernel(StepKernel):
    """Fast step of a follower pressure, ``f(x½)``: ``−p(x½) ∇V`` per triangle (cross
    products written out, or ``jit.pressure_gradient`` compiled); block ``½K(x½)``."""

    def __init__(self, e: PressureSet, n: int, jit=None):
        super().__init__(e, n)
        self.conn, self.jit = np.ascontiguousarray(e.conn), jit
        ne = e.conn.shape[0]
        # corners a = 0, 1, 2 of every triangle stacked (3ne × n); its transpose scatters
        rows = np.arange(3 * ne)
        self.gather = sp.csr_matrix((np.ones(3 * ne), (rows, e.conn.T.ravel())), shape=(3 * ne, n))
        self.scatter = self.gather.T.tocsr()
        self.ne = ne

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


def volume_gradient(x: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Assembled ``∇V`` ``(n, 3)`` (m²)."""
    return assemble_vector(triangles, volume_gradient_elements(x[triangles]), x.shape[0])


def gas_rank_one(pressure_set: PressureSet, x: np.ndarray) -> tuple[float, np.ndarray] | None:
    """Global gas-law stiffness ``−p'(V) ∇V ∇Vᵀ`` as ``(coefficient, ∇V flat (3n,))``, or None."""
    if not pressure_set.gas_law_exponent:
        return None
    _, dp, _ = pressure_set.pressure_derivatives(x)
    return -dp, volume_gradient(x, pressure_set.conn).ravel()


def gas_second_order(
    pressure_set: PressureSet, x: np.ndarray, u: np.ndarray, v: np.ndarray
) -> np.ndarray:
    """Global (non-element) part of ``B(u, v)`` for the gas law, ``(n, 3)`` (N)."""
    n = x.shape[0]
    if not pressure_set.gas_law_exponent:
        return np.zeros((n, 3))
    _, dp, d2p = pressure_set.pressure_derivatives(x)
    tri = pressure_set.conn
    grad = volume_gradient(x, tri)
    hess_e = volume_hessian_elements(x[tri])

    def hess_times(w: np.ndarray) -> np.ndarray:
        hw = np.einsum("eab,eb->ea", hess_e, w[tri].reshape(-1, 9)).reshape(-1, 3, 3)
        return assemble_vector(tri, hw, n)

    gu, gv = np.sum(grad * u), np.sum(grad * v)
    # f = −p(V)∇V; D²f[u,v] = −p''(gu gv)∇V − p'(H[u,v]·1 ... ) expanded term by term:
    d2 = -d2p * gu * gv * grad - dp * (
        np.sum(u * hess_times(v)) * grad + gu * hess_times(v) + gv * hess_times(u)
    )
    return 0.5 * d2
