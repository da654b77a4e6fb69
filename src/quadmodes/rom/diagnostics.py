"""Time series of invariants, energies, spin and cone angle from a :class:`Solution`.

All quantities are evaluated at the saved samples (k of them), vectorised over time, except the
continuity tracking of the minor axis (a short loop over samples). SI units.

Spin rate and cone angle follow theory.md §6: eigen-decompose the instantaneous inertia J̃(s)
(rotational-row arrays) in the body frame; the tracked axis v_a is, at the first sample, the
eigenvector nearest the nominal spin axis (default: the minor principal axis of J0), then at
each sample the eigenvector nearest the previous one, with the sign fixed by continuity.
Cone angle θ = angle between H and the axis, folded to [0, π/2]:
θ = atan2(|h × v_a|, |h·v_a|) (body frame, identical to the inertial definition since
H = R h). Spin rate ω_s = ω·v_a. I_a = v_aᵀJ̃v_a; I_t = mean of the other two eigenvalues.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.rom import dynamics as dyn
from quadmodes.rom import system as rsys
from quadmodes.rom.solution import Solution
from quadmodes.rotations import rotation_matrix


@dataclass(frozen=True, eq=False)
class Diagnostics:
    """Time series (k samples).

    t (k,) s. H (k,3) inertial angular momentum about the centre of mass, kg m²/s;
    H_norm (k,); H_dir (k,3) unit inertial direction. T, V, E (k,) J: kinetic, potential,
    total (T + V); E_d (k,) J: energy dissipated by modal damping since t0; E_balance = E + E_d.
    axis_body (k,3): tracked principal axis v_a (body frame); axis_inertial (k,3) = R v_a.
    spin_rate (k,) rad/s = ω·v_a. cone_angle (k,) rad. I_a, I_t (k,) kg m².
    """

    t: np.ndarray
    H: np.ndarray
    H_norm: np.ndarray
    H_dir: np.ndarray
    T: np.ndarray
    V: np.ndarray
    E: np.ndarray
    E_d: np.ndarray
    E_balance: np.ndarray
    axis_body: np.ndarray
    axis_inertial: np.ndarray
    spin_rate: np.ndarray
    cone_angle: np.ndarray
    I_a: np.ndarray
    I_t: np.ndarray

    def as_dict(self) -> dict:
        """The series as a plain dict of arrays."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def nominal_spin_axis(sys: rsys.ReducedSystem, which: str = "minor") -> np.ndarray:
    """Principal axis (3,) of J0 ("minor", "intermediate" or "major"), sign: largest component
    positive."""
    lam, vec = np.linalg.eigh(sys.J0)
    v = vec[:, {"minor": 0, "intermediate": 1, "major": 2}[which]]
    return v * np.sign(v[np.argmax(np.abs(v))])


def track_axis(vectors: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Tracked unit axes (k,3): at each sample the eigenvector (a column of ``vectors``
    (k,3,3)) nearest the previous choice (the first: nearest ``start`` (3,)), sign continuous."""
    k = vectors.shape[0]
    out = np.empty((k, 3))
    prev = np.asarray(start, float)
    for i in range(k):
        d = prev @ vectors[i]
        j = int(np.argmax(np.abs(d)))
        v = vectors[i, :, j]
        if d[j] < 0.0:
            v = -v
        out[i] = v
        prev = v
    return out


def principal_axis(sys: rsys.ReducedSystem, s: np.ndarray, spin_axis=None):
    """Tracked principal axis of J̃(s) for s (k,N): returns (v_a (k,3), I_a (k,), I_t (k,),
    J̃ (k,3,3)). ``spin_axis`` (3,) body frame; default the minor axis of J0."""
    jt = dyn.inertia_tensor(sys, s, "rot")
    jt = 0.5 * (jt + np.swapaxes(jt, -1, -2))
    lam, vec = np.linalg.eigh(jt)
    start = nominal_spin_axis(sys) if spin_axis is None else np.asarray(spin_axis, float)
    va = track_axis(vec, start / np.linalg.norm(start))
    ia = np.einsum("ka,kab,kb->k", va, jt, va)
    it = 0.5 * (lam.sum(-1) - ia)
    return va, ia, it, jt


def cone_angle(h: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Angle (rad, in [0, π/2]) between momentum h (...,3) and axis (...,3) (any frame)."""
    cr = np.linalg.norm(np.cross(h, axis), axis=-1)
    return np.arctan2(cr, np.abs(np.sum(h * axis, -1)))


def dissipated_energy(sys: rsys.ReducedSystem, sol: Solution) -> np.ndarray:
    """E_d (k,) J: the integrator's own discrete value if it provided one, else the cumulative
    trapezoid of ṡᵀCṡ over the samples."""
    if sol.dissipated is not None and len(sol.dissipated) == len(sol.t):
        return np.asarray(sol.dissipated, float)
    p = dyn.dissipation_rate(sys, sol.y)
    out = np.zeros_like(p)
    out[1:] = np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(sol.t))
    return out


def diagnostics(sys: rsys.ReducedSystem, sol: Solution, spin_axis=None) -> Diagnostics:
    """All diagnostics of ``sol`` (see :class:`Diagnostics`); ``spin_axis`` (3,): nominal body
    spin axis for the tracking (default: the minor principal axis of J0)."""
    y = sol.y
    q, w, s, _ = rsys.split_state(sys, y)
    r = rotation_matrix(q)
    h = dyn.body_momentum(sys, y)
    big_h = np.einsum("kab,kb->ka", r, h)
    hn = np.linalg.norm(big_h, axis=-1)
    t_kin = dyn.kinetic_energy(sys, y)
    v_pot = dyn.potential_energy(sys, y)
    e = t_kin + v_pot
    e_d = dissipated_energy(sys, sol)
    va, ia, it, _ = principal_axis(sys, s, spin_axis)
    return Diagnostics(
        t=np.asarray(sol.t, float),
        H=big_h,
        H_norm=hn,
        H_dir=big_h / np.where(hn > 0, hn, 1.0)[:, None],
        T=t_kin,
        V=v_pot,
        E=e,
        E_d=e_d,
        E_balance=e + e_d,
        axis_body=va,
        axis_inertial=np.einsum("kab,kb->ka", r, va),
        spin_rate=np.einsum("ka,ka->k", w, va),
        cone_angle=cone_angle(h, va),
        I_a=ia,
        I_t=it,
    )
