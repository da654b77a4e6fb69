"""Formulation QM linearised about its *own* relative equilibrium, against what the analyses use
for it (Q4's linearisation, ``runs.manifold_system.linear_formulation``) and against the model
rebuilt about the spin (docs/manifold-formulation.md, "Analyses of a QM run").

At a spin Ω the relative equilibrium of QM solves ∂T/∂s(s*, (Ω e, 0)) = ∂V/∂s(s*) with the
manifold's exact T; its body-frame equations (state z = (ω, s, ṡ)) are
𝕄(s) ν̇ = [−ω × h; ∂T/∂s − ∂V/∂s] − 𝕄̇ν, ν = (ω, ṡ), h = (𝕄ν)[:3], with 𝕄̇ν = Σ ṡ_k ∂𝕄/∂s_k ν
from the five-point derivative of ε ↦ 𝕄(s + εṡ)ν (a quartic in ε: exact to round-off). The
undamped roots are the eigenvalues of their central-difference Jacobian (the steps of
:mod:`quadmodes.analysis.reduced_linearisation`). At the model's reference spin (s* = 0) they
are Q4's (QM's kinetic energy to second order about s = 0 is Q's); away from it QM's
𝕄(s*) differs from Q's by O(|s*|) and the roots follow.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_qm_linearisation CASE.toml \\
        --spins 41,40,39,37

``CASE.toml``: a run case of formulation QM (e.g. ``benchmarks/cases/path-41hz-coarse.toml``
with ``formulation = "QM"``). One JSON line per spin: the positive rotating-frame frequencies
(Hz) of the rebuilt model (Q4 about its own spinning state, s* = 0), QM's and Q4's
linearisations of the run's model, and the largest relative error of each above 5 Hz.
"""

from __future__ import annotations

import argparse
import dataclasses
import json

import numpy as np

from quadmodes.analysis.reduced_linearisation import linearise
from quadmodes.case import load_run_case
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import dynamics as dy
from quadmodes.rom import manifold_kinetics as mk
from quadmodes.rom import system as rsys
from quadmodes.rom.spin_axis import resolve_axis
from quadmodes.rom.steady_spin import relative_equilibrium
from quadmodes.runs import simulate


def mdot_nu(ma, s: np.ndarray, sd: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """Σ_k ṡ_k ∂𝕄/∂s_k ν (3+N,): the five-point derivative at ε = 0 of 𝕄(s + εṡ)ν, a polynomial
    of degree 4 in ε, so the formula is exact (to round-off) for any step; step 1."""
    def f(e):
        return mk.mass_matrix(ma, s + e * sd) @ nu

    return (f(-2.0) - 8.0 * f(-1.0) + 8.0 * f(1.0) - f(2.0)) / 12.0


def qm_rhs(sys, z: np.ndarray) -> np.ndarray:
    """dz/dt (3+2N,) of QM's body-frame equations, z = (ω, s, ṡ), damping as ``sys``'s arrays
    hold it (the study sets it to zero)."""
    ma, n = sys.manifold, sys.n_modes
    w, s, sd = z[:3], z[3 : 3 + n], z[3 + n :]
    nu = np.concatenate([w, sd])
    m = mk.mass_matrix(ma, s)
    b = -mdot_nu(ma, s, sd, nu)
    b[:3] -= np.cross(w, (m @ nu)[:3])
    b[3:] += (mk.kinetic_gradient(ma, s, nu) - dy.potential_gradient(sys, s)
              - mk.damping_matrix(ma, s) @ sd)  # fmt: skip
    dnu = np.linalg.solve(m, b)
    return np.concatenate([dnu[:3], sd, dnu[3:]])


def qm_equilibrium(sys, w: np.ndarray, s0: np.ndarray) -> np.ndarray:
    """s* (N,) with ∂T/∂s(s*, (w, 0)) = ∂V/∂s(s*) (Newton from ``s0``, central-difference
    Jacobian; w (3,) rad/s the spin vector, kept)."""
    n = sys.n_modes
    nu = np.concatenate([w, np.zeros(n)])

    def g(s):
        return mk.kinetic_gradient(sys.manifold, s, nu) - dy.potential_gradient(sys, s)

    s = np.array(s0, float)
    for _ in range(40):
        eps = 1e-7 * max(float(np.linalg.norm(s)), 1e-6)
        jac = np.column_stack([(g(s + eps * e) - g(s - eps * e)) / (2 * eps) for e in np.eye(n)])
        ds = np.linalg.solve(jac, g(s))
        s = s - ds
        if np.linalg.norm(ds) <= 1e-11 * max(float(np.linalg.norm(s)), 1e-6):  # √kg·m
            return s
    raise ValueError("QM relative equilibrium: Newton did not converge")


def qm_roots(sys, model, w: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Eigenvalues (3+2N,) 1/s of the central-difference Jacobian of :func:`qm_rhs` at (w, s*,
    0), with the steps of :mod:`quadmodes.analysis.reduced_linearisation`."""
    n = sys.n_modes
    z0 = np.concatenate([w, s, np.zeros(n)])
    length = float(np.sqrt(np.trace(model.J0) / model.mass))
    s_scale = np.sqrt(model.mass) * length
    rate = np.sqrt(max(float(np.max(np.diag(sys.Lam))), 1.0))
    steps = np.concatenate([np.full(3, 1e-6 * max(float(np.linalg.norm(w)), 1.0)),
                            np.full(n, 1e-6 * s_scale), np.full(n, 1e-6 * s_scale * rate)])  # fmt: skip
    jac = np.empty((3 + 2 * n, 3 + 2 * n))
    for j, h in enumerate(steps):
        zp, zm = z0.copy(), z0.copy()
        zp[j] += h
        zm[j] -= h
        jac[:, j] = (qm_rhs(sys, zp) - qm_rhs(sys, zm)) / (2 * h)
    return np.linalg.eigvals(jac)


def positive_hz(lam: np.ndarray, spin: float) -> np.ndarray:
    """The rotating-frame frequencies (Hz, ascending) of the roots with Im λ > 0."""
    return np.sort(np.abs(lam.imag[lam.imag > 1e-6 * spin])) / (2 * np.pi)


def spin_row(setup, undamped_qm, spin_hz: float) -> dict:
    """The three root sets at ``spin_hz`` and the errors of QM's and Q4's against the rebuilt."""
    model = setup.model
    om = 2 * np.pi * spin_hz
    q4 = rsys.reduced_system(model, "Q4")
    axis = resolve_axis(model, None, "axis")
    w, s4, _ = relative_equilibrium(q4, om, axis)
    s = qm_equilibrium(undamped_qm, w, s4)
    f_qm = positive_hz(qm_roots(undamped_qm, model, w, s), om)
    f_q4 = positive_hz(linearise(q4, model, om, axis, damped=False).lam, om)
    rebuilt = reduced_model_for(setup.model_case, model.n_modes, spin=om,
                                axis=setup.run.reference_axis)  # fmt: skip
    r4 = rsys.reduced_system(rebuilt, "Q4")
    f_rb = positive_hz(linearise(r4, rebuilt, om, resolve_axis(rebuilt, None, "axis"),
                                 damped=False).lam, om)  # fmt: skip
    k = min(len(f_rb), len(f_qm), len(f_q4))
    hi = f_rb[:k] > 5.0

    def err(f):
        return float(np.max(np.abs(f[:k][hi] / f_rb[:k][hi] - 1.0)))

    return {"spin_hz": spin_hz, "s_star_qm": float(np.linalg.norm(s)),
            "s_star_q4": float(np.linalg.norm(s4)), "rebuilt_hz": f_rb.round(4).tolist(),
            "qm_hz": f_qm.round(4).tolist(), "q4_hz": f_q4.round(4).tolist(),
            "qm_max_error_above_5hz": err(f_qm), "q4_max_error_above_5hz": err(f_q4)}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("case", help="a run case of formulation QM")
    ap.add_argument("--spins", default="41,40,39", help="spin rates (Hz), comma-separated")
    args = ap.parse_args()
    setup = simulate.prepare(load_run_case(args.case))
    qm, n = setup.system, setup.model.n_modes
    if qm.formulation != "QM":
        raise SystemExit(f"{args.case}: reduced.formulation must be QM")
    undamped = dataclasses.replace(
        qm, manifold=dataclasses.replace(qm.manifold, B0=None, C0=np.zeros((n, n))))
    for f in (float(x) for x in args.spins.split(",")):
        try:
            print(json.dumps(spin_row(setup, undamped, f)), flush=True)
        except ValueError as exc:  # e.g. Q4's relative equilibrium not found
            print(json.dumps({"spin_hz": f, "error": str(exc)}), flush=True)


if __name__ == "__main__":
    main()
