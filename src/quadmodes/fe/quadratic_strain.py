"""Element sets whose strains are quadratic forms of vector DOFs, with energy quadratic in strain.

Every strain of such a set is a dot-product form of the element's vector DOFs
``q = x[conn]`` ``(k, 3)``::

    ε_s(q) = ½ Σ_jl a_s,jl (q_j · q_l) − c_s,      W = Σ_points w ½ Σ_s C_s ε_s²,

with symmetric scalar operators ``a_s`` ``(k, k)`` (the same for the three components, so
``ε`` is exactly invariant under ``q_j → Q q_j`` and under translations that leave ``a q``
unchanged), constants ``c_s``, moduli ``C_s`` and point weights ``w``. Green strains of bars and
St Venant–Kirchhoff continua, the 3-D beam's axial strain, curvatures and twist, and the
orthonormality of a rigid body's director triad all have this form. It gives, exactly,

* force ``f_j = Σ w C_s ε_s (a_s q)_j`` (cubic in q),
* tangent ``K = Σ w [C_s (a_s q) ⊗ (a_s q) + C_s ε_s a_s ⊗ I₃]``,
* the quadratic part of the force ``B(u, v) = ½ Σ w C_s [(u·a_s v) a_s q + (q·a_s u) a_s v
  + (q·a_s v) a_s u]``,
* an energy–momentum step force ``Σ w C_s ε̄_s a_s q½`` with ``ε̄ = (ε(q₀) + ε(q₁))/2``: because
  ε is quadratic, ``ε(q₁) − ε(q₀) = (a q½)·(q₁ − q₀)``, so the step's work equals the energy
  change (Simo & Tarnow 1992) and, the force being equilibrated at q½, momentum is kept.

Operators are stored per element and point: ``a`` ``(ne, np, ns, k, k)``; elements tied to other
DOFs through a linear map ``q_local = P q`` (a beam clamped to a rigid hub) simply carry
``Pᵀ a P``. Units: ``C ε²`` times ``w`` is an energy (J).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.fe.elements import ElementSet


@dataclass(frozen=True, eq=False)
class QuadraticStrainSet(ElementSet):
    """An element set with quadratic strains (see the module docstring).

    conn: ``(ne, k)`` vector-DOF indices. operators: ``a`` ``(ne, np, ns, k, k)`` symmetric.
    offsets: ``c`` ``(ne, np, ns)``. moduli: ``C`` ``(ne, np, ns)``. weights: ``w`` ``(ne, np)``.
    mass_blocks: scalar consistent mass ``(ne, k, k)`` (kg, …) or None.
    """

    conn: np.ndarray
    operators: np.ndarray
    offsets: np.ndarray
    moduli: np.ndarray
    weights: np.ndarray
    mass_blocks: np.ndarray | None = None

    # ---------------------------------------------------------------- strain evaluation
    def _q(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=float)[self.conn]

    def _gradients(self, q: np.ndarray) -> np.ndarray:
        """``g_s = a_s q`` ``(ne, np, ns, k, 3)``: ``∂ε_s/∂q``."""
        return np.einsum("epsjl,elc->epsjc", self.operators, q, optimize=True)

    def strains(self, x: np.ndarray) -> np.ndarray:
        """Strains ``ε`` ``(ne, np, ns)`` at the global state ``x`` ``(n, 3)``."""
        q = self._q(x)
        return 0.5 * np.einsum("epsjc,ejc->eps", self._gradients(q), q) - self.offsets

    def _weighted_stress(self, eps: np.ndarray) -> np.ndarray:
        return self.weights[:, :, None] * self.moduli * eps

    # ---------------------------------------------------------------- contract
    def energy(self, x: np.ndarray) -> float:
        """Strain energy (J)."""
        eps = self.strains(x)
        return float(0.5 * np.sum(self._weighted_stress(eps) * eps))

    def force(self, x: np.ndarray) -> np.ndarray:
        """Element internal forces ``(ne, k, 3)``, the gradient of :meth:`energy`."""
        q = self._q(x)
        g = self._gradients(q)
        eps = 0.5 * np.einsum("epsjc,ejc->eps", g, q) - self.offsets
        return np.einsum("eps,epsjc->ejc", self._weighted_stress(eps), g)

    def stiffness(self, x: np.ndarray) -> np.ndarray:
        """Element tangent ``(ne, 3k, 3k)``, the Hessian of :meth:`energy`, ordered like
        ``x[conn].reshape(ne, 3k)``."""
        q = self._q(x)
        g = self._gradients(q)
        eps = 0.5 * np.einsum("epsjc,ejc->eps", g, q) - self.offsets
        return self._tangent(g, g, self._weighted_stress(eps))

    def _tangent(self, g_left: np.ndarray, g_right: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """``Σ w C g_left ⊗ g_right + Σ σ a ⊗ I₃`` ``(ne, 3k, 3k)``."""
        ne, k = self.conn.shape
        wc = self.weights[:, :, None] * self.moduli
        mat = np.einsum("eps,epsjc,epsld->ejcld", wc, g_left, g_right, optimize=True)
        geo = np.einsum("eps,epsjl->ejl", sigma, self.operators)
        mat += geo[:, :, None, :, None] * np.eye(3)[None, None, :, None, :]
        return mat.reshape(ne, 3 * k, 3 * k)

    def second_order(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``B(u, v) = ½ D²f(x)[u, v]`` ``(ne, k, 3)``, symmetric in ``u, v`` ``(n, 3)``."""
        q, qu, qv = self._q(x), self._q(u), self._q(v)
        g, gu, gv = self._gradients(q), self._gradients(qu), self._gradients(qv)
        wc = self.weights[:, :, None] * self.moduli
        uv = np.einsum("epsjc,ejc->eps", gu, qv)
        qu_ = np.einsum("epsjc,ejc->eps", gu, q)
        qv_ = np.einsum("epsjc,ejc->eps", gv, q)
        out = (
            np.einsum("eps,epsjc->ejc", wc * uv, g)
            + np.einsum("eps,epsjc->ejc", wc * qu_, gv)
            + np.einsum("eps,epsjc->ejc", wc * qv_, gu)
        )
        return 0.5 * out

    def mass(self) -> np.ndarray | None:
        """Scalar consistent mass blocks ``(ne, k, k)`` or None."""
        return self.mass_blocks

    # ---------------------------------------------------------------- energy–momentum step
    def step_force(self, x0: np.ndarray, x1: np.ndarray, start=None) -> np.ndarray:
        """Energy–momentum element forces ``(ne, k, 3)`` of the step ``x0 → x1``: the stress of
        the averaged strain times the strain gradient at the midpoint (exact work); ``start``
        unused."""
        qh = 0.5 * (self._q(x0) + self._q(x1))
        ebar = 0.5 * (self.strains(x0) + self.strains(x1))
        return np.einsum("eps,epsjc->ejc", self._weighted_stress(ebar), self._gradients(qh))

    def step_block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """``∂(step_force)/∂x1`` ``(ne, 3k, 3k)`` (not symmetric):
        ``½ Σ w C (a q½) ⊗ (a q₁) + ½ Σ w C ε̄ a ⊗ I₃``."""
        q0, q1 = self._q(x0), self._q(x1)
        ebar = 0.5 * (self.strains(x0) + self.strains(x1))
        gh, g1 = self._gradients(0.5 * (q0 + q1)), self._gradients(q1)
        return 0.5 * self._tangent(gh, g1, self._weighted_stress(ebar))
