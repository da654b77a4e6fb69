"""The relative equilibrium of a free reduced model spinning steadily: ``ṡ = 0``, ``s = s*``,
``ω = Ω e*`` (:func:`relative_equilibrium`). Shared by the linearisation about steady spin
(:mod:`quadmodes.analysis.reduced_linearisation`, a Campbell point) and the runs' energy-sink
check of the spin range (:mod:`quadmodes.runs.spin_check`), which may not import each other:
this is the layer below both."""

from __future__ import annotations

import numpy as np

from quadmodes.rom import dynamics as dy
from quadmodes.rom import rotating_frame as rf
from quadmodes.rom import system as rsys
from quadmodes.rom.spin_axis import equilibrium_direction, in_degenerate_eigenspace
from quadmodes.rotations import unit_axis


def relative_equilibrium(
    sys: rsys.ReducedSystem, spin: float, axis: np.ndarray, iterations: int = 50, tol: float = 1e-13
):
    """Relative equilibrium of the free body spinning at ``spin`` (rad/s) near ``axis``.

    Fixed point of ``(Λ − ωᵀJ2ω) s = ½ ωᵀJ1ω`` (for "Q4" ``∂V/∂s − (ωᵀJ2ω) s = ½ ωᵀJ1ω``
    with the quartic manifold potential, solved by Newton) and ``ω = spin · e*``, e* the principal
    axis of J̃(s) for ``axis`` by the rule of :mod:`quadmodes.rom.spin_axis` (sign kept): the
    eigenvector nearest it, or, when it lies in the eigenspace of equal moments, ``axis`` itself
    projected onto it, so round-off never turns a body of revolution or a rod off the axis asked
    for. Returns ``(ω (3,), s (N,), residual)`` where residual is
    the largest |ż| (scaled) of the body-frame equations at (ω, s, ṡ = 0)."""
    n = sys.n_modes
    e = unit_axis(axis)
    keep = in_degenerate_eigenspace(sys.J0, e)
    s = np.zeros(n)
    w = spin * e
    for _ in range(iterations):
        w_old, s_old = w, s
        if n:
            k = rf.rotating_frame_matrices(sys, w)[2]
            f = 0.5 * np.einsum("kab,a,b->k", sys.J1, w, w) - sys.F1
            s = _static_solve(sys, k, f, s) if sys.quartic else np.linalg.solve(k, f)
        jt = dy.inertia_tensor(sys, s, "rot")
        w = spin * equilibrium_direction(jt, e, keep)
        ds = np.linalg.norm(s - s_old) / max(np.linalg.norm(s), 1e-300) if n else 0.0
        if np.linalg.norm(w - w_old) <= tol * max(abs(spin), 1e-300) and ds <= tol:
            break
    y = rsys.pack_state(sys, omega=w, s=s)
    d = dy.rhs(sys, 0.0, y)
    scale = max(abs(spin), 1e-12) ** 2
    return w, s, float(np.max(np.abs(d[4:]), initial=0.0) / scale)


def _static_solve(
    sys: rsys.ReducedSystem,
    k: np.ndarray,
    f: np.ndarray,
    s: np.ndarray,
    iterations: int = 50,
    tol: float = 1e-14,
) -> np.ndarray:
    """Newton solution (N,) of ``k s + (∂V/∂s − Λs)(s) = f`` ("Q4": k = Λ − ωᵀJ2ω, f (N,)
    the centrifugal modal force), started from ``s`` and, failing that, from the linear one."""
    for start in (s, np.linalg.solve(k, f)):
        x = start.copy()
        for _ in range(iterations):
            r = k @ x + dy.potential_nonlinear_force(sys, x) - f
            jac = k + dy.potential_hessian(sys, x) - sys.Lam
            dx = np.linalg.solve(jac, r)
            x = x - dx
            if not np.all(np.isfinite(x)):
                break
            if np.linalg.norm(dx) <= tol * max(np.linalg.norm(x), 1e-300):
                return x
    raise ValueError("relative equilibrium (Q4): Newton on the modal statics did not converge")
