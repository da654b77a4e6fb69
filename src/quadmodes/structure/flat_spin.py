"""The spinning relative equilibrium of a flat membrane that has no stiffness at rest.

A flat, stress-free membrane (a sail, a disc) has no out-of-plane stiffness: at rest its
tangent ``K_T`` is zero on every out-of-plane direction, and the centrifugal softening
``Ω² M P̂`` of a spin about the membrane's normal ``e`` acts only in its plane, so the Newton
matrix ``K_T − Ω² M P̂`` of :func:`quadmodes.structure.spinning.relative_equilibrium` is singular
on the whole out-of-plane space at the flat start. The flat state is however a relative
equilibrium *out of the plane* exactly: membrane forces of a plane membrane lie in its plane and
so does the centrifugal force about its normal. The problem therefore splits:

1. the **in-plane problem**: Newton on the in-plane components only (``x = x₀ + T u``,
   ``T = I_n ⊗ [a b]`` with ``a, b`` an orthonormal basis of the plane), where
   ``Tᵀ(K_T − Ω² M P̂)T`` is regular once the in-plane rotation about ``e`` (a null direction of
   the spinning problem) is removed by its mass-weighted frame condition ``ψ_eᵀ M δx = 0``
   (in-plane translations are not null at Ω ≠ 0: they meet the centrifugal load −Ω² m δc);
2. the **spun state** so found is tensioned by the centrifugal stress, whose geometric stiffness
   now carries the out-of-plane directions; the full relative-equilibrium Newton
   (:func:`~quadmodes.structure.spinning.relative_equilibrium`) then starts from it at its own
   spin and only confirms it (its residual is already at round-off).

Units: m, rad/s, N.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from quadmodes.fe.model import Structure, mass_matrix, rigid_body_modes
from quadmodes.rotations import unit_axis
from quadmodes.structure.bordered import bordered_solver
from quadmodes.structure.prestress import ConvergenceError, backtracking_step
from quadmodes.structure.spinning import (
    SpinningEquilibrium,
    centrifugal_force,
    default_centre,
    relative_equilibrium,
    rotating_residual,
    rotating_stiffness,
)

__all__ = ["flat_spinning_equilibrium", "in_plane_equilibrium", "is_flat", "plane_basis"]


def plane_basis(axis) -> np.ndarray:
    """Orthonormal basis ``(3, 2)`` of the plane normal to ``axis`` (3,)."""
    e = unit_axis(axis)
    trial = np.eye(3)[int(np.argmin(np.abs(e)))]
    a = np.cross(e, trial)
    a /= np.linalg.norm(a)
    return np.column_stack([a, np.cross(e, a)])


def is_flat(x: np.ndarray, axis, rtol: float = 1e-9) -> bool:
    """True if every row of ``x`` (n, 3) (m) lies in one plane normal to ``axis``."""
    h = x @ unit_axis(axis)
    extent = float(np.ptp(x, axis=0).max()) if x.size else 1.0
    return bool(np.ptp(h) <= rtol * max(extent, 1e-300))


def in_plane_equilibrium(
    structure: Structure,
    x_flat: np.ndarray,
    spin: float,
    axis,
    rtol: float = 1e-11,
    max_iterations: int = 30,
) -> tuple[np.ndarray, float, int]:
    """In-plane relative equilibrium (module docstring, step 1) of the flat free membrane
    ``x_flat`` (n, 3) (m) spinning at ``spin`` (rad/s, ≠ 0) about its normal ``axis`` through
    its centre of mass: ``(x (n, 3) m, relative residual, iterations)``."""
    if not structure.is_free:
        raise ValueError("flat spinning equilibrium: only free membranes are supported")
    if not is_flat(x_flat[structure.translational], axis):
        raise ValueError("flat spinning equilibrium: the membrane is not flat normal to the axis")
    e = unit_axis(axis)
    centre = default_centre(structure, x_flat)
    t = sp.kron(sp.identity(structure.n, format="csr"), plane_basis(e), format="csr")
    psi_e = rigid_body_modes(structure, x_flat)[:, 3:] @ e
    constraint = (t.T @ (mass_matrix(structure) @ psi_e))[:, None]

    def residual(y: np.ndarray) -> np.ndarray:
        return t.T @ rotating_residual(structure, y, spin, e, centre).ravel()

    x = np.array(x_flat, float)
    r = residual(x)
    scale = max(np.linalg.norm(centrifugal_force(structure, x, spin, e, centre)), 1e-300)
    history = [np.linalg.norm(r) / scale]
    for it in range(max_iterations + 1):
        rel = history[-1]
        # the residual's round-off floor is ~ eps / strain (the centrifugal strain of a slow
        # spin is ~1e-7, of a 14 m sail at 1 rpm 3e-10, with a hub's stiff triad above it):
        # stop when it no longer falls
        stalled = len(history) > 3 and rel < 1e-4 and rel > 0.5 * min(history[-4:-1])
        if rel <= rtol or stalled:
            return x, float(rel), it
        k = (t.T @ rotating_stiffness(structure, x, spin, e) @ t).tocsr()
        du = -bordered_solver(k, constraint, [])(r)
        x, r, _ = backtracking_step(residual, x, (t @ du).reshape(-1, 3), r, rel, 1e-6)
        history.append(np.linalg.norm(r) / scale)
    raise ConvergenceError(
        f"flat spinning equilibrium: the in-plane Newton did not converge at "
        f"{spin / (2 * np.pi):.4g} Hz (relative residual {rel:.2e})"
    )


def flat_spinning_equilibrium(
    structure: Structure, x_flat: np.ndarray, spin: float, axis
) -> SpinningEquilibrium:
    """Relative equilibrium of the flat, stress-free free membrane ``x_flat`` (n, 3) (m) spinning
    at ``spin`` (rad/s, ≠ 0) about its normal ``axis`` (module docstring: the in-plane problem,
    then the full Newton from the spun state)."""
    if spin == 0.0:
        raise ValueError(
            "a flat membrane without pressure has no stiffness at rest; give it a spin > 0"
        )
    x, rel, its = in_plane_equilibrium(structure, x_flat, spin, axis)
    eq = relative_equilibrium(structure, x, spin, axis, start_spin=spin, reference=x_flat,
                              rtol=max(1e-10, 10.0 * rel))  # fmt: skip
    return SpinningEquilibrium(**{**eq.__dict__, "iterations": eq.iterations + its})
