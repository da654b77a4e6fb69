"""The reduced model linearised about steady spin at one spin rate (one point of a Campbell
diagram, :mod:`quadmodes.analysis.campbell`).

* **Clamped body on a spinning hub** (``model.free is False``): the hub turns at the constant
  rate Ω about ``axis``; the modal equation linearised about s = 0 is the quadratic eigenproblem

      (λ² μ + λ (Γ(ω) [+ C]) + Λ − ωᵀJ2ω) φ = 0,    ω = Ω e,

  solved through its companion matrix (:func:`quadmodes.rom.rotating_frame.rotating_frame_matrices`). The
  steady centrifugal forcing ½ωᵀJ1ω only shifts the static equilibrium, which does not enter the
  linear (s-independent) coefficients.
* **Free body spinning about a principal axis** (``model.free is True``): the relative
  equilibrium is ``ṡ = 0``, ``s = s*`` and ``ω = Ω e*``, where ``s*`` is the quasi-static
  centrifugal deformation, ``(Λ − ωᵀJ2ω) s* = ½ ωᵀJ1ω``, and ``e*`` the principal axis of the
  deformed inertia J̃(s*) for the requested axis (``ω × J̃(s*)ω = 0``; for equal moments the
  requested axis itself, :mod:`quadmodes.rom.spin_axis`), found by a fixed-point
  iteration (:func:`relative_equilibrium`). The full body-frame Q equations of
  :mod:`quadmodes.rom.dynamics` (state ``z = (ω, s, ṡ)``, 3 + 2N values; the attitude q does not
  enter them) are linearised about it by central differences of
  :func:`quadmodes.rom.dynamics.rhs`, so the three rotational perturbations and all rotation–
  deformation couplings (A(s*), J̃(s*), the ω̇ coupling c + s*D) are included. Its 3 + 2N roots
  are a zero root (the neighbouring relative equilibrium at another spin rate), the nutation pair
  and the 2N elastic roots.

Each point carries the energy weight used for mode tracking: kinetic 𝕄 on velocities plus
|Λ − ωᵀJ2ω| on displacements.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.rom import dynamics as dy
from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys
from quadmodes.rom.reduced import ReducedModel
from quadmodes.rom.steady_spin import relative_equilibrium
from quadmodes.rotations import unit_axis


@dataclass(frozen=True)
class SpinLinearisation:
    """All roots of the reduced model linearised at one spin rate.

    lam (m,) complex 1/s: eigenvalues of the state Jacobian (m = 3 + 2N free, 2N clamped).
    vectors (m, m) complex: state eigenvectors (columns; free: δω, δs, δṡ; clamped: δs, δṡ).
    weight (m, m): energy weight W of the state (tracking inner product ``xᴴ W y``).
    min_stiffness 1/s²: smallest eigenvalue of the rotating stiffness Λ − ωᵀJ2ω (at s = s*).
    s (N,) √kg·m: relative-equilibrium modal coordinates (zero for a clamped body).
    axis (3,): unit axis of the relative equilibrium (the requested one for a clamped body).
    """

    lam: np.ndarray
    vectors: np.ndarray
    weight: np.ndarray
    min_stiffness: float
    s: np.ndarray
    axis: np.ndarray


def _abs_sym(k: np.ndarray) -> np.ndarray:
    """Matrix absolute value of a symmetric matrix, floored to stay positive definite."""
    if k.size == 0:
        return k
    lam, vec = np.linalg.eigh(k)
    a = np.abs(lam)
    a = np.maximum(a, 1e-12 * max(a.max(), 1e-300))
    return (vec * a) @ vec.T


def _free_jacobian(sys: rsys.ReducedSystem, w: np.ndarray, s: np.ndarray, mass: float, length):
    """Central-difference Jacobian (3+2N, 3+2N) of the body-frame equations in z = (ω, s, ṡ)."""
    n = sys.n_modes
    z0 = np.concatenate([w, s, np.zeros(n)])
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    s_scale = np.sqrt(mass) * length  # s that changes the inertia by O(1)
    w_scale = max(float(np.linalg.norm(w)), 1.0)
    rate = np.sqrt(max(float(np.max(np.diag(sys.Lam), initial=1.0)), 1.0))
    steps = np.concatenate(
        [np.full(3, 1e-6 * w_scale), np.full(n, 1e-6 * s_scale), np.full(n, 1e-6 * s_scale * rate)]
    )
    m = 3 + 2 * n
    jac = np.empty((m, m))
    for j in range(m):
        zp, zm = z0.copy(), z0.copy()
        zp[j] += steps[j]
        zm[j] -= steps[j]
        fp = dy.rhs(sys, 0.0, np.concatenate([q0, zp]))[4:]
        fm = dy.rhs(sys, 0.0, np.concatenate([q0, zm]))[4:]
        jac[:, j] = (fp - fm) / (2.0 * steps[j])
    return jac


def _free_point(sys: rsys.ReducedSystem, model: ReducedModel, spin: float, axis, damped: bool):
    """``(Jacobian, energy weight, rotating stiffness K, s*, equilibrium axis)`` of a free body."""
    n = sys.n_modes
    w, s, _ = relative_equilibrium(sys, spin, axis)
    sys_l = sys if damped else rsys.with_damping(sys, np.zeros((n, n)))
    length = float(np.sqrt(np.trace(model.J0) / max(model.mass, 1e-300)))
    jac = _free_jacobian(sys_l, w, s, model.mass, length)
    mm = dy.mass_matrix(sys, s)
    k = rf.rotating_frame_matrices(sys, w)[2] if n else np.zeros((0, 0))
    if sys.quartic and n:  # stiffness of the full potential at s*
        k = k + dy.potential_hessian(sys, s) - sys.Lam
    # energy weight on z = (δω, δs, δṡ): ½ νᵀ𝕄ν with ν = (δω, δṡ), plus ½ δsᵀ|K|δs
    wgt = np.zeros((3 + 2 * n, 3 + 2 * n))
    vel = np.r_[0:3, 3 + n : 3 + 2 * n]
    wgt[np.ix_(vel, vel)] = 0.5 * (mm + mm.T)
    wgt[3 : 3 + n, 3 : 3 + n] = _abs_sym(k)
    e_eq = w / spin if spin != 0.0 else unit_axis(axis)
    return jac, wgt, k, s, e_eq


def _clamped_point(sys: rsys.ReducedSystem, spin: float, axis, damped: bool):
    """``(companion matrix, energy weight, rotating stiffness K, s = 0, axis)`` of a body clamped
    to a hub spinning at ``spin`` (rad/s)."""
    n = sys.n_modes
    w = spin * unit_axis(axis)
    mu, g, k = rf.rotating_frame_matrices(sys, w)
    if not damped:
        g = g - sys.C
    minv = np.linalg.inv(mu)
    jac = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ g]])
    wgt = np.zeros((2 * n, 2 * n))
    wgt[:n, :n] = _abs_sym(k)
    wgt[n:, n:] = mu
    return jac, wgt, k, np.zeros(n), unit_axis(axis)


def linearise(
    sys: rsys.ReducedSystem, model: ReducedModel, spin: float, axis: np.ndarray, damped: bool
) -> SpinLinearisation:
    """Roots and state eigenvectors of ``sys`` (from ``model``) linearised at ``spin`` (rad/s)
    about ``axis`` (3,); ``damped``: keep the modal damping C in the roots."""
    n = sys.n_modes
    if sys.free:
        jac, wgt, k, s, e_eq = _free_point(sys, model, spin, axis, damped)
    else:
        jac, wgt, k, s, e_eq = _clamped_point(sys, spin, axis, damped)
    if not (np.isfinite(jac).all() and np.isfinite(k).all()):
        # next to a divergence the relative equilibrium overflows: no roots there
        m = jac.shape[0]
        return SpinLinearisation(np.full(m, np.nan + 0j), np.full((m, m), np.nan + 0j), wgt,
                                 np.nan, s, e_eq)  # fmt: skip
    lam, vec = np.linalg.eig(jac)
    kmin = float(np.linalg.eigvalsh(k).min()) if n else np.inf
    return SpinLinearisation(lam, vec, wgt, kmin, s, e_eq)
