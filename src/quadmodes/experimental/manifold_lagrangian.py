"""A consistent fourth-order reduced Lagrangian (research prototype, issue 29, docs/path-validity.md
"A consistent fourth-order Lagrangian"): the **exact kinetic energy of the quadratic manifold**
with formulation Q4's potential and the full order's damping projected on the manifold's tangent.

Formulation Q keeps the kinetic energy to second order (J̃ = J0 + J1 s + J2 ss, the coupling
linear in s, the modal mass μ constant) and the potential to second order; Q4 raises the potential
to fourth order (V3, V4) and keeps Q's kinetics, which makes it inconsistent: the cubic terms of
the kinetic energy (the kinetic T3 = 2 (ΦᵀM g^{mn})_k ṡ_k s_m ṡ_n, the centrifugal s³ of the actual
ω) that cancel the strain energy's V3 at small cone are missing, and Q4 cones 7–17 % too fast on the
coarse spin-family path. Here the body-frame kinetic energy of the manifold field
r(s) = X + Φs + Σ s_m s_n g^{mn} is kept whole,

    T = ½ Σ M (ω × r + u̇)·(ω × r + u̇),   u̇ = Σ ṡ_k T_k(s),   T_k = ∂r/∂s_k = Φ_k + 2 Σ_n s_n g^{kn},

a polynomial of degree 4 in (s, ṡ) (ω counted of order 0), so that with V = F1·s + ½sᵀΛs +
V3 sss + V4 ssss (Q4's) both energies are complete to fourth order. Written with the fields
Y_α = (X, Φ_k, g^{mn} (m ≤ n, doubled off the diagonal)) and z(s) = (1, s_k, s_m s_n) so that
r = Σ z_α Y_α, every term is a contraction of the constant mass-weighted outer products
O_αβ = Σ M Y_α Y_βᵀ (K×K×3×3, K = 1 + N + N(N+1)/2): J(s) = tr(P) I − P with P = zᵀOz, the
coupling Σ M r × T_k, μ_kl = Σ M T_k·T_l. Damping: the Rayleigh function of the full order's
modal damping (``fullorder.damping``: modes Φ_d, C_d) on the manifold velocity,
C(s) = Bᵀ C_d B with B = Φ_dᵀ M (Φ + 2 Σ s_n g^{·n}) (``C(0)`` is the reduced model's projected C).

State ``y = [q (4), h (3) body angular momentum, s (N), p (N) modal momenta, E_d]``; the velocities
ν = (ω, ṡ) from 𝕄(s) ν = (h, p); equations ḣ = −ω × h, ṗ = ∂T/∂s − ∂V/∂s − C(s) ṡ, Ė_d = ṡᵀCṡ.
The equations are integrated by an explicit Runge–Kutta method of scipy (``run``): a prototype
to measure the formulation, not a product integrator (no energy–momentum step, no compiled kernel).
"""

from __future__ import annotations

import numpy as np

from quadmodes.rom import dynamics as dyn
from quadmodes.rom import system as rsys
from quadmodes.rotations import quat_rate


def cross_part(o: np.ndarray) -> np.ndarray:
    """``Σ M u × v`` (..., 3) from ``o = Σ M u vᵀ`` (..., 3, 3)."""
    return np.stack([o[..., 1, 2] - o[..., 2, 1], o[..., 2, 0] - o[..., 0, 2],
                     o[..., 0, 1] - o[..., 1, 0]], -1)  # fmt: skip


class ManifoldLagrangian:
    """The consistent fourth-order Lagrangian of a reduced ``model`` (module docstring);
    ``mass_scalar`` (n,n) kg: the structure's scalar mass matrix (the same M as the model's)."""

    def __init__(self, model, mass_scalar):
        n = model.n_modes
        self.n_modes = n
        x, phi, g = (np.asarray(a, float) for a in (model.X, model.Phi, model.G))
        self.pairs = np.array([(a, b) for a in range(n) for b in range(a, n)], int).reshape(-1, 2)
        quad = [g[a, b] if a == b else 2.0 * g[a, b] for a, b in self.pairs]
        fields = np.concatenate([x[None], phi, np.array(quad).reshape(-1, *x.shape)])
        weighted = np.stack([mass_scalar @ f for f in fields])
        self.O = np.einsum("aib,gic->agbc", fields, weighted, optimize=True)  # (K,K,3,3)
        self.tr = np.einsum("agbb->ag", self.O)
        self.cr = cross_part(self.O)
        self.q4 = rsys.reduced_system(model, "Q4")
        self.C = np.asarray(model.C, float)
        self.damping_basis = None

    @property
    def size(self) -> int:
        return self.O.shape[0]

    def with_damping(self, modes, mass_scalar, model) -> ManifoldLagrangian:
        """Use the full order's damping modes ``modes`` (:class:`quadmodes.fullorder.damping.
        DampingModes`) on the manifold velocity instead of the constant projected C."""
        md = np.stack([mass_scalar @ p for p in modes.shapes])
        self.damping_basis = (np.einsum("dia,kia->dk", md, np.asarray(model.Phi, float)),
                              np.einsum("dia,mnia->dmn", md, np.asarray(model.G, float)),
                              np.asarray(modes.C, float))  # fmt: skip
        return self

    def damping(self, s: np.ndarray) -> np.ndarray:
        """C(s) (N,N) 1/s."""
        if self.damping_basis is None:
            return self.C
        pd, gd, cd = self.damping_basis
        b = pd + 2.0 * np.einsum("dmn,n->dm", gd, s)
        return b.T @ cd @ b

    def z(self, s: np.ndarray) -> np.ndarray:
        a, b = self.pairs.T
        return np.concatenate([[1.0], s, s[a] * s[b]])

    def dz(self, s: np.ndarray) -> np.ndarray:
        """∂z/∂s (N, K)."""
        n = self.n_modes
        d = np.zeros((n, self.size))
        d[np.arange(n), 1 + np.arange(n)] = 1.0
        a, b = self.pairs.T
        cols = 1 + n + np.arange(len(a))
        np.add.at(d, (a, cols), s[b])
        np.add.at(d, (b, cols), s[a])
        return d

    def mass_matrix(self, s: np.ndarray) -> np.ndarray:
        """𝕄(s) (3+N, 3+N): T = ½ νᵀ𝕄ν, ν = (ω, ṡ)."""
        z, d = self.z(s), self.dz(s)
        p = np.einsum("a,g,agbc->bc", z, z, self.O)
        j = np.trace(p) * np.eye(3) - p
        a = d @ np.einsum("a,agc->gc", z, self.cr)  # Σ M r × T_k (N, 3)
        return np.block([[j, a.T], [a, d @ self.tr @ d.T]])

    def kinetic_gradient(self, s: np.ndarray, w: np.ndarray, sd: np.ndarray) -> np.ndarray:
        """∂T/∂s (N,) at fixed (ω, ṡ): ⟨v, ∂v/∂s_j⟩ with v = ω × r + u̇, ∂v/∂s_j = ω × T_j +
        2 Σ_n ṡ_n g^{jn}; through z: ⟨v, ω × Y_β⟩ = (A z + B ż)_β, ⟨v, Y_β⟩ = (Bᵀz + C ż)_β with
        A = |ω|² tr O − ωᵀOω, B = ω·(Σ M Y_α × Y_β), C = tr O."""
        z, d = self.z(s), self.dz(s)
        zd = d.T @ sd
        az = (w @ w) * (self.tr @ z) - np.einsum("agbc,b,c->ag", self.O, w, w) @ z
        b = self.cr @ w
        a_idx, b_idx = self.pairs.T
        cols = 1 + self.n_modes + np.arange(len(a_idx))
        dzd = np.zeros((self.n_modes, self.size))  # ∂ż/∂s_j
        np.add.at(dzd, (b_idx, cols), sd[a_idx])
        np.add.at(dzd, (a_idx, cols), sd[b_idx])
        return d @ (az + b @ zd) + dzd @ (b.T @ z + self.tr @ zd)

    def velocities(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = self.n_modes
        nu = np.linalg.solve(self.mass_matrix(y[7 : 7 + n]), y[4 : 7 + 2 * n][np.r_[0:3, 3 + n : 3 + 2 * n]])
        return nu[:3], nu[3:]

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        n = self.n_modes
        s, h = y[7 : 7 + n], y[4:7]
        w, sd = self.velocities(y)
        c = self.damping(s)
        dy = np.empty_like(y)
        dy[:4] = quat_rate(y[:4], w, 1.0)
        dy[4:7] = -np.cross(w, h)
        dy[7 : 7 + n] = sd
        dy[7 + n : 7 + 2 * n] = (self.kinetic_gradient(s, w, sd) - dyn.potential_gradient(self.q4, s)
                                 - c @ sd)  # fmt: skip
        dy[-1] = sd @ c @ sd
        return dy

    def start(self, y0: np.ndarray) -> np.ndarray:
        """The state of a reduced state ``y0 = [q, ω, s, ṡ]`` (7+2N,): momenta from 𝕄(s), E_d = 0."""
        n = self.n_modes
        nu = np.concatenate([y0[4:7], y0[7 + n :]])
        mom = self.mass_matrix(y0[7 : 7 + n]) @ nu
        return np.concatenate([y0[:4], mom[:3], y0[7 : 7 + n], mom[3:], [0.0]])

    def reduced_states(self, ys: np.ndarray) -> np.ndarray:
        """States (k, 7+2N) ``[q, ω, s, ṡ]`` of prototype states ``ys`` (k, 8+2N)."""
        n = self.n_modes
        out = []
        for y in ys:
            w, sd = self.velocities(y)
            out.append(np.concatenate([y[:4], w, y[7 : 7 + n], sd]))
        return np.array(out)

    def energy(self, y: np.ndarray) -> float:
        """T + V (J) of a prototype state."""
        n = self.n_modes
        w, sd = self.velocities(y)
        kinetic = 0.5 * (w @ y[4:7] + sd @ y[7 + n : 7 + 2 * n])
        state = np.concatenate([y[:4], w, y[7 : 7 + n], sd])
        return kinetic + float(dyn.potential_energy(self.q4, state[None])[0])


def run(lag: ManifoldLagrangian, y0: np.ndarray, duration: float, sample: float = 1e-3,
        rtol: float = 1e-8):  # fmt: skip
    """``(t (k,), ys (k, 8+2N))``: the prototype from the reduced state ``y0`` over ``duration`` s
    (DOP853, samples every ``sample`` s)."""
    from scipy.integrate import solve_ivp

    y = lag.start(np.asarray(y0, float))
    t = np.arange(0.0, duration + 0.5 * sample, sample)
    sol = solve_ivp(lag.rhs, (0.0, t[-1]), y, method="DOP853", rtol=rtol,
                    atol=rtol * 1e-3 * float(np.max(np.abs(y))), t_eval=t)  # fmt: skip
    if sol.status != 0:
        raise RuntimeError(f"manifold Lagrangian: {sol.message}")
    return sol.t, sol.y.T
