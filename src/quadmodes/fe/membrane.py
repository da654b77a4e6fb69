"""3-node total-Lagrangian membrane: Green–Lagrange strain, St Venant–Kirchhoff plane stress.

Per element the deformation gradient is ``F = Σ_a x_a ⊗ G_a`` (3×2), with ``G`` ``(3, 2)`` the
constant shape-function gradients in an orthonormal frame of the stress-free triangle. Then
``E = ½(FᵀF − I)``, ``S = D : E`` and the nodal internal force is ``f_a = A₀ t F S G_a``, a cubic
polynomial in the nodal positions, so its second-order term ``B`` is exact.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from quadmodes.fe import wrinkling
from quadmodes.fe.elements import ElementSet
from quadmodes.fe.membrane_kernels import MembraneKernel, RelaxedMembraneKernel
from quadmodes.fe.step_kernels import StepKernel


def membrane_reference_gradients(reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shape-function gradients ``G`` ``(ne, 3, 2)`` (1/m) and areas ``A₀`` ``(ne,)`` (m²).

    ``reference`` ``(ne, 3, 3)`` holds the stress-free node positions of each triangle.
    """
    e1 = reference[:, 1] - reference[:, 0]
    e2 = reference[:, 2] - reference[:, 0]
    normal = np.cross(e1, e2)
    double_area = np.linalg.norm(normal, axis=1)
    if np.any(double_area <= 0.0):
        raise ValueError("mesh: degenerate (zero-area) membrane triangle; remesh the surface")
    t1 = e1 / np.linalg.norm(e1, axis=1)[:, None]
    t2 = np.cross(normal / double_area[:, None], t1)
    # Edge vectors in the local orthonormal frame (t1, t2): Dm = [[e1·t1, e2·t1], [e1·t2, e2·t2]]
    dm = np.stack(
        [
            np.stack([np.einsum("ei,ei->e", e1, t1), np.einsum("ei,ei->e", e2, t1)], -1),
            np.stack([np.einsum("ei,ei->e", e1, t2), np.einsum("ei,ei->e", e2, t2)], -1),
        ],
        -2,
    )
    dm_inv = np.linalg.inv(dm)
    corner = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    gradients = np.einsum("ak,ekj->eaj", corner, dm_inv)
    return gradients, 0.5 * double_area


def plane_stress_matrix(youngs_modulus: float, poisson_ratio: float) -> np.ndarray:
    """Voigt plane-stress matrix ``D`` (3×3, Pa) acting on ``[E11, E22, 2E12]``."""
    nu = poisson_ratio
    c = youngs_modulus / (1.0 - nu * nu)
    return c * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]])


def _voigt_stress(d: np.ndarray, strain: np.ndarray) -> np.ndarray:
    """Stress tensors ``(ne, 2, 2)`` from strain tensors ``(ne, 2, 2)`` through Voigt ``D``."""
    ev = np.stack([strain[:, 0, 0], strain[:, 1, 1], 2.0 * strain[:, 0, 1]], -1)
    sv = ev @ d.T
    return np.stack([np.stack([sv[:, 0], sv[:, 2]], -1), np.stack([sv[:, 2], sv[:, 1]], -1)], -2)


def green_strain(gradients: np.ndarray, xe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Deformation gradient ``F`` ``(ne, 3, 2)`` and Green–Lagrange strain ``E`` ``(ne, 2, 2)``."""
    f = np.einsum("eai,eaj->eij", xe, gradients)
    e = 0.5 * (np.einsum("eki,ekj->eij", f, f) - np.eye(2))
    return f, e


def deformation_strain(gradients: np.ndarray, xe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`green_strain` by batched matrix products (about twice as fast; equal to round-off,
    not bit for bit): the statics' kernels use it, the full order keeps :func:`green_strain`
    (its discrete-gradient reference amplifies round-off in ``E``)."""
    f = np.matmul(np.swapaxes(xe, 1, 2), gradients)  # Σ_a x_a ⊗ G_a
    e = 0.5 * (np.matmul(np.swapaxes(f, 1, 2), f) - np.eye(2))
    return f, e


def strain_displacement(f: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Rows of ``δ[E11, E22, 2E12]`` per nodal displacement: ``B`` ``(ne, 3, 9)`` (1/m), column
    ``3a + i`` for node a, component i; f ``(ne, 3, 2)`` deformation gradients, g ``(ne, 3, 2)``
    shape-function gradients (1/m)."""
    g0, g1 = g[:, :, 0, None], g[:, :, 1, None]  # (ne, a, 1)
    f0, f1 = f[:, None, :, 0], f[:, None, :, 1]  # (ne, 1, i)
    bm = np.empty((len(g), 3, 3, 3))
    bm[:, 0] = g0 * f0
    bm[:, 1] = g1 * f1
    bm[:, 2] = g1 * f0 + g0 * f1
    return bm.reshape(-1, 3, 9)


@dataclass(frozen=True)
class MembraneSet(ElementSet):
    """CST membrane elements over triangles ``conn`` ``(ne, 3)``.

    ``gradients`` ``(ne, 3, 2)`` and ``area0`` ``(ne,)`` come from the stress-free reference
    (see :func:`membrane_set`); ``thickness`` (m), ``youngs_modulus`` (Pa), ``poisson_ratio``,
    ``density`` (kg/m³), ``lumped_mass`` selects row-sum lumping.
    ``tension_field``: the wrinkling relaxation of :mod:`quadmodes.fe.wrinkling` (no
    compressive stress); equal to SVK wherever the membrane is taut. :meth:`second_order` is
    the SVK term, exact about a taut state. ``bonded`` ``(ne,)`` bool: elements held by a rigid
    end body (all three nodes on its patch), which keep SVK: they cannot wrinkle, and their
    near-zero strains would only put kinks of the relaxed law into the Newton iterations.
    """

    conn: np.ndarray
    gradients: np.ndarray
    area0: np.ndarray
    thickness: float
    youngs_modulus: float
    poisson_ratio: float
    density: float
    lumped_mass: bool = False
    tension_field: bool = False
    bonded: np.ndarray | None = None
    d: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "d", plane_stress_matrix(self.youngs_modulus, self.poisson_ratio))

    def _volume(self) -> np.ndarray:
        return self.area0 * self.thickness

    def _law(self) -> tuple[np.ndarray, float, float]:
        return self.d, self.youngs_modulus, self.poisson_ratio

    def _relaxing(self) -> np.ndarray | None:
        """Indices of the elements under the wrinkling law, or None."""
        if not self.tension_field:
            return None
        return np.arange(len(self.conn)) if self.bonded is None else np.flatnonzero(~self.bonded)

    def material_stress(self, strain: np.ndarray) -> np.ndarray:
        """2nd Piola–Kirchhoff stress ``(ne,2,2)`` (Pa) of Green strains ``(ne,2,2)``."""
        s = _voigt_stress(self.d, strain)
        if (r := self._relaxing()) is not None:
            s[r] = wrinkling.stress(*self._law(), strain[r])
        return s

    def material_tangent(self, strain: np.ndarray) -> np.ndarray:
        """Voigt tangent ``∂S/∂E`` ``(ne,3,3)`` (Pa) at Green strains ``(ne,2,2)``."""
        d = np.broadcast_to(self.d, (len(strain), 3, 3))
        if (r := self._relaxing()) is None:
            return d
        d = d.copy()
        d[r] = wrinkling.tangent(*self._law(), strain[r])
        return d

    def energy_density(self, strain: np.ndarray) -> np.ndarray:
        """Strain energy per unit reference volume ``(ne,)`` (J/m³)."""
        ev = np.stack([strain[:, 0, 0], strain[:, 1, 1], 2.0 * strain[:, 0, 1]], -1)
        w = 0.5 * np.einsum("ep,pq,eq->e", ev, self.d, ev)
        if (r := self._relaxing()) is not None:
            w[r] = wrinkling.energy_density(*self._law(), strain[r])
        return w

    def step_stress(self, strain0: np.ndarray, strain1: np.ndarray) -> np.ndarray:
        """Energy-exact step stress ``S̄`` ``(ne,2,2)`` (Pa): ``S̄:(E₁ − E₀) = W(E₁) − W(E₀)``
        (SVK: ``S((E₀ + E₁)/2)``, Simo–Tarnow; relaxed: its discrete gradient)."""
        s = _voigt_stress(self.d, 0.5 * (strain0 + strain1))
        if (r := self._relaxing()) is not None:
            s[r] = wrinkling.discrete_gradient_stress(*self._law(), strain0[r], strain1[r])
        return s

    def step_tangent(self, strain0: np.ndarray, strain1: np.ndarray) -> np.ndarray:
        """``∂S̄/∂E₁`` ``(ne,3,3)`` (Pa, Voigt) of :meth:`step_stress` (SVK: ``½ D``)."""
        t = np.broadcast_to(0.5 * self.d, (len(strain0), 3, 3))
        if (r := self._relaxing()) is None:
            return t
        t = t.copy()
        t[r] = wrinkling.discrete_gradient_tangent(*self._law(), strain0[r], strain1[r])
        return t

    def strain_stress(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``F`` ``(ne,3,2)``, Green strain ``E`` and 2nd Piola–Kirchhoff stress ``S`` ``(ne,2,2)`` (Pa)."""
        f, e = deformation_strain(self.gradients, x[self.conn])
        return f, e, self.material_stress(e)

    def energy(self, x: np.ndarray) -> float:
        if self.tension_field:
            _, e = green_strain(self.gradients, x[self.conn])
            return float(np.sum(self._volume() * self.energy_density(e)))
        _, e, s = self.strain_stress(x)
        return float(0.5 * np.sum(self._volume() * np.einsum("eij,eij->e", e, s)))

    def force(self, x: np.ndarray) -> np.ndarray:
        f, _, s = self.strain_stress(x)
        # f_a = V F S G_a: (G (F S)ᵀ)[e, a, i], batched 3×2 products (einsum over three
        # operands was 3–4 times slower)
        out = np.matmul(self.gradients, np.swapaxes(np.matmul(f, s), 1, 2))
        out *= self._volume()[:, None, None]
        return out

    def stiffness(self, x: np.ndarray) -> np.ndarray:
        """Element tangents ``(ne, 9, 9)`` (N/m): material ``V Bᵀ D B`` plus geometric
        ``V (G S Gᵀ) ⊗ I₃``, rows and columns ordered ``3a + i`` (node a, component i)."""
        f, e, s = self.strain_stress(x)
        g = self.gradients
        bm = strain_displacement(f, g)
        tangent = self.material_tangent(e) if self._relaxing() is not None else self.d
        k = np.matmul(np.swapaxes(bm, 1, 2), np.matmul(tangent, bm))
        k_geo = np.matmul(np.matmul(g, s), np.swapaxes(g, 1, 2))  # (ne, 3, 3): G_a S G_b
        blocks = k.reshape(-1, 3, 3, 3, 3)  # (ne, a, i, b, j)
        for i in range(3):
            blocks[:, :, i, :, i] += k_geo
        k *= self._volume()[:, None, None]
        return k

    def second_order(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        g = self.gradients
        f, _, s = self.strain_stress(x)  # SVK's B; with tension_field exact where x is taut
        fu = np.einsum("eai,eaj->eij", u[self.conn], g)
        fv = np.einsum("eai,eaj->eij", v[self.conn], g)

        def sym(a: np.ndarray) -> np.ndarray:
            return 0.5 * (a + np.swapaxes(a, 1, 2))

        su = _voigt_stress(self.d, sym(np.einsum("eki,ekj->eij", f, fu)))
        sv = _voigt_stress(self.d, sym(np.einsum("eki,ekj->eij", f, fv)))
        suv = _voigt_stress(self.d, sym(np.einsum("eki,ekj->eij", fu, fv)))
        d2 = (
            np.einsum("eij,ejk,eak->eai", f, suv, g)
            + np.einsum("eij,ejk,eak->eai", fu, sv, g)
            + np.einsum("eij,ejk,eak->eai", fv, su, g)
        )
        return 0.5 * self._volume()[:, None, None] * d2

    def mass(self) -> np.ndarray:
        m = self.density * self._volume()
        if self.lumped_mass:
            return m[:, None, None] * (np.eye(3) / 3.0)
        return m[:, None, None] * ((np.ones((3, 3)) + np.eye(3)) / 12.0)

    # ---------------------------------------------------------------- full-order step
    # (green_strain, not deformation_strain: the discrete-gradient reference amplifies
    # round-off in E)
    def step_start(self, x0: np.ndarray) -> np.ndarray:
        """Green strains ``(ne, 2, 2)`` at the step's start state."""
        return green_strain(self.gradients, x0[self.conn])[1]

    def step_force(self, x0: np.ndarray, x1: np.ndarray, start=None) -> np.ndarray:
        """Energy–momentum step force ``(ne, 3, 3)`` (N): ``V F(x½) S̄ Gᵀ`` with the step
        stress S̄ of :meth:`step_stress` (SVK: the stress of the averaged strain, Simo &
        Tarnow; relaxed: its discrete gradient). ε being quadratic in x, ``E₁ − E₀ =
        Dε(x½)(x₁ − x₀)``, so the work equals the energy change; ``start``: :meth:`step_start`
        at x0 (else computed)."""
        e0 = self.step_start(x0) if start is None else start
        fh, _ = green_strain(self.gradients, (0.5 * (x0 + x1))[self.conn])
        _, e1 = green_strain(self.gradients, x1[self.conn])
        sbar = self.step_stress(e0, e1)
        return self._volume()[:, None, None] * np.einsum("eij,ejk,eak->eai", fh, sbar,
                                                         self.gradients)  # fmt: skip

    def step_block(self, x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
        """``∂ step_force / ∂x1`` ``(ne, 9, 9)``: ``V [½ K_geo(S̄) + B(x½)ᵀ (∂S̄/∂E₁) B(x₁)]``
        (SVK: ``∂S̄/∂E₁ = ½ D``)."""
        g = self.gradients
        fh, _ = green_strain(g, (0.5 * (x0 + x1))[self.conn])
        f1, e1 = green_strain(g, x1[self.conn])
        _, e0 = green_strain(g, x0[self.conn])
        sbar = self.step_stress(e0, e1)
        t = self.step_tangent(e0, e1)
        k_mat = np.einsum("epa,epq,eqb->eab", strain_displacement(fh, g), t,
                          strain_displacement(f1, g))  # fmt: skip
        k_geo = np.einsum("eak,ekl,ebl->eab", g, sbar, g)
        k_geo = np.einsum("eab,ij->eaibj", k_geo, np.eye(3)).reshape(-1, 9, 9)
        return self._volume()[:, None, None] * (k_mat + 0.5 * k_geo)

    def step_kernel(self, n: int, energy_momentum: bool, jit=None) -> StepKernel:
        """The fast membrane kernel (compiled force with ``jit``) or, under the wrinkling law,
        its numpy form with the set's step stress; the plain midpoint without the average."""
        if not energy_momentum:
            return super().step_kernel(n, False, jit)
        if self.tension_field:
            return RelaxedMembraneKernel(self, n)
        return MembraneKernel(self, n, jit)

    def principal_stress_resultants(self, x: np.ndarray) -> np.ndarray:
        """Principal Cauchy stress resultants ``(ne, 2)`` (N/m), ascending, in the current state."""
        f, _, s = self.strain_stress(x)
        c = np.einsum("eki,ekj->eij", f, f)
        jac_area = np.sqrt(np.linalg.det(c))
        # Cauchy resultant t F S Fᵀ / J shares its in-plane eigenvalues with t S C / J.
        a = np.einsum("eij,ejk->eik", s, c) * (self.thickness / jac_area)[:, None, None]
        half_trace = 0.5 * (a[:, 0, 0] + a[:, 1, 1])
        det = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
        root = np.sqrt(np.maximum(half_trace**2 - det, 0.0))
        return np.stack([half_trace - root, half_trace + root], -1)


def membrane_set(
    conn: np.ndarray,
    reference: np.ndarray,
    thickness: float,
    youngs_modulus: float,
    poisson_ratio: float,
    density: float,
    lumped_mass: bool = False,
    tension_field: bool = False,
) -> MembraneSet:
    """Membrane set from triangles ``conn`` ``(ne, 3)`` and stress-free positions ``(n, 3)`` (m);
    ``tension_field``: wrinkling relaxation (:mod:`quadmodes.fe.wrinkling`)."""
    conn = np.asarray(conn, dtype=np.int64)
    gradients, area0 = membrane_reference_gradients(reference[conn])
    return MembraneSet(
        conn, gradients, area0, thickness, youngs_modulus, poisson_ratio, density, lumped_mass,
        tension_field,
    )
