"""Large amplitude on a wrinkling membrane: the reduced model with the condensed tension-field
potential (Q kinetics, ``V = ½ sᵀΛs + W_B(s) − ½ sᵀH0 s``,
:mod:`quadmodes.experimental.condensed_potential`) and plain Q against the tension-field full
order, at each initial bending amplitude: bending frequency (upward zero crossings of the first
bending coordinate, over the first three periods and over the window) and the modal-amplitude
envelope error.

Models (``--models``): Q; Q+condensed (the snapshot basis condensed, massless); Q+snapshots
(``--aug-pod`` leading POD vectors of the minimisers as dynamic coordinates, the rest
condensed); Q+trajectory-POD, an oracle: the dynamic coordinates from the POD of the full
order's own displacements (an upper bound on what a projection model with this potential can
do; it needs the full order it is compared with, so it is a diagnostic, not a model).

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_wrinkled_rom \
        [--case benchmarks/cases/paper-0.5hz-coarse-tf.toml] [--amplitudes 0.5,1] [--window "1 s"] \
        [--full-dt "0.5 ms"] [--train "0.125,0.25,0.5,0.75,1,1.25"] [--directions 4] [--pod 30]

The snapshot basis is trained once per case (W_c minimisers of the FE model at the training
amplitudes, in, along ``--directions`` random directions and ± each bending mode); the full-order
series are kept in ``--store`` so a rerun with another basis only integrates the reduced models.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from benchmarks.common import (
    EARLY_PERIODS,
    body_displacements,
    crossing_frequency,
    recorded_full_order,
    variant,
)
from quadmodes.analysis import compare as cmp
from quadmodes.analysis.full_order_runs import full_order_for_run, setup_for_run
from quadmodes.case import load_run_case
from quadmodes.case.units import parse_quantity
from quadmodes.experimental import augmented_basis as aug
from quadmodes.experimental import condensed_potential as cpot
from quadmodes.fullorder.integrator import FullOrderNewtonError
from quadmodes.rom import manifold_energy as me
from quadmodes.rom import system as rsys
from quadmodes.runs import simulate
from quadmodes.runs.deformation_check import deformation_structure

FIELDS = ("t", "amplitude", "cone_angle", "spin_rate", "H_norm", "E", "E_d")


def full_series(run, dt: float, store: Path) -> tuple[cmp.Series, np.ndarray]:
    """Full-order :class:`Series` and modal coordinates (k, N) of ``run``, from ``store`` if
    computed before."""
    path = store / f"{run.name}-{run.integration.duration:g}s-{dt:g}.npz"
    if not path.exists():
        sol = full_order_for_run(run, dt=dt)
        s = cmp.series_from_full_order(sol)
        store.mkdir(parents=True, exist_ok=True)
        np.savez(path, modal=np.asarray(sol.modal_coordinates), wall=s.wall_s,
                 complete=s.complete, **{f: getattr(s, f) for f in FIELDS})  # fmt: skip
    d = np.load(path)
    series = cmp.Series("full", *(d[f] for f in FIELDS), wall_s=float(d["wall"]),
                        complete=bool(d["complete"]))  # fmt: skip
    return series, d["modal"]


def trained_potential(setup, amplitudes_in, directions: int, pod: int | None):
    """The :class:`~quadmodes.experimental.condensed_potential.CondensedPotential` of a prepared
    run, trained at ``amplitudes_in``; returns it with its report and the training wall time."""
    start = time.perf_counter()
    ctx = me.energy_context(deformation_structure(setup), setup.model.X, setup.model)
    train = cpot.training_points(setup.model, 0.0254 * np.asarray(amplitudes_in), directions)
    basis, report = cpot.snapshot_basis(ctx, train, max_vectors=pod)
    return cpot.CondensedPotential(ctx, basis), report, time.perf_counter() - start


def full_displacements(run, dt: float, store: Path) -> np.ndarray:
    """Body-frame displacements ``(k, 3n)`` m of the full order of ``run`` at its samples (the
    transient run again, recording positions; kept in ``store``)."""
    path = store / f"{run.name}-{run.integration.duration:g}s-{dt:g}-displacements.npy"
    if not path.exists():
        store.mkdir(parents=True, exist_ok=True)
        np.save(path, recorded_full_order(run, dt)[2])
    return np.load(path)


def snapshot_coordinates(pot, snapshots, pod: int) -> tuple[np.ndarray, float]:
    """The first ``pod`` POD vectors of the condensed minimisers ``snapshots`` (the training
    report's; they carry the end bodies' mass) and their share of the snapshots' M-norm."""
    ys = [r.unknowns for r in snapshots if r.converged]
    return aug.pod_of_minimisers(pot.ctx, np.array(ys), max_vectors=pod)


def trajectory_coordinates(pot, u: np.ndarray, modal: np.ndarray, pod: int):
    """An oracle, not a model: the first ``pod`` POD vectors of the full order's own
    displacements ``u`` ``(k, 3n)`` outside the chart (``u − Φs − Σ ss g`` at its modal
    coordinates ``modal`` ``(k, N)``, then [Φ Ψ] projected out) — the best linear dynamic basis
    a projection model could have for this transient."""
    ctx = pot.ctx
    rest = u - modal @ ctx.phi - np.einsum("km,kn,mnj->kj", modal, modal, ctx.g)
    return aug.pod_of_minimisers(ctx, rest, tol=1e-12, max_vectors=pod)


def augmented_setup(setup, pot, dyn: np.ndarray, captured: float, cutoff_hz: float):
    """The prepared run with the columns of ``dyn`` ``(m, p)`` as dynamic coordinates and the
    rest of the snapshot basis condensed (:mod:`quadmodes.experimental.augmented_basis`); the
    initial q from the condensed minimiser at s0. ``captured``: the M-share of ``dyn``
    (reported)."""
    ctx = pot.ctx
    ctx_aug = aug.augmented_context(ctx, dyn)
    rest = aug.split_basis(ctx.mass, pot.basis, dyn)
    cond = cpot.CondensedPotential(ctx_aug, rest)
    zeta = float(np.max(setup.model.damping_ratio))
    model = aug.augmented_model(setup.model, ctx.structure, dyn, cond.hessian0, zeta, cutoff_hz)
    system = rsys.with_nonlinear_potential(rsys.reduced_system(model, "Q"), cond)
    n, p = setup.model.n_modes, dyn.shape[1]
    s0 = setup.initial.y0[7 : 7 + n]
    y_c = me.condensed_energy_along_ray(ctx, s0).unknowns
    q0 = dyn.T @ (ctx.mass @ y_c)
    y0 = np.concatenate([setup.initial.y0[:7], s0, q0, np.zeros(n + p)])
    init = dataclasses.replace(setup.initial, y0=y0)
    w2 = np.linalg.eigvals(np.linalg.solve(model.mu, model.Lam)).real
    print(f"<!-- {p} dynamic coordinates (M-share {captured:.4f}) + {rest.shape[1]} "
          f"condensed; taut condensed pencil (Hz): "
          f"{np.round(np.sort(np.sqrt(np.abs(w2))) / (2 * np.pi), 1).tolist()} -->", flush=True)
    return simulate.RunSetup(setup.run, setup.model_case, model, system, init)


def with_relaxed_extra_modes(setup, run_seed):
    """``setup`` (N > 5 modes) started where the full order of ``run_seed`` starts: the modal
    coordinates beyond the seed's five are those of the full order's relaxed initial deformation
    (M-projection of its body-frame displacement on the further modes), not zero."""
    st = setup_for_run(run_seed)
    u0 = body_displacements(st, st.x0[None])[0]
    n, n_seed = setup.model.n_modes, st.model.n_modes
    mphi = np.stack([st.structure.mass_scalar @ p for p in np.asarray(setup.model.Phi)])
    y0 = np.array(setup.initial.y0, float)
    y0[7 + n_seed : 7 + n] = np.einsum("kia,ia->k", mphi, u0)[n_seed:]
    return dataclasses.replace(setup, initial=dataclasses.replace(setup.initial, y0=y0))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="benchmarks/cases/paper-0.5hz-coarse-tf.toml")
    ap.add_argument("--amplitudes", default="0.5,1", help="initial bending, in")
    ap.add_argument("--window", default="1 s")
    ap.add_argument("--full-dt", default="0.5 ms")
    ap.add_argument("--train", default="0.125,0.25,0.5,0.75,1,1.25", help="amplitudes, in")
    ap.add_argument("--directions", type=int, default=4)
    ap.add_argument("--pod", type=int, default=30, help="largest number of POD vectors")
    ap.add_argument("--store", default="out/wrinkled-rom")
    ap.add_argument("--models", default="Q,Q+snapshots",
                    help="of Q, Q+condensed, Q+snapshots, Q+trajectory-POD (an oracle)")
    ap.add_argument("--aug-pod", type=int, default=3,
                    help="dynamic coordinates of Q+snapshots / Q+trajectory-POD")
    ap.add_argument("--cutoff", type=float, default=115.0, help="damping cutoff, Hz")
    ap.add_argument("--modes", type=int, default=5, help="retained modes of the reduced models "
                    "(the full order's modal coordinates stay the seed's five)")  # fmt: skip
    args = ap.parse_args()
    window = parse_quantity(args.window, "time", "--window")
    full_dt = parse_quantity(args.full_dt, "time", "--full-dt")
    train = [float(a) for a in args.train.split(",")]
    pot = None
    print("| bending (in) | model | bending frequency, first 3 periods (Hz) | vs full "
          "| over the window (Hz) | vs full | envelope error | wall (s) |")
    print("|---|---|---|---|---|---|---|---|")
    case = load_run_case(args.case)
    for amp in (float(a) for a in args.amplitudes.split(",")):
        run = cmp.window_run(variant(case, amp, "spinning", 5), window, "Q")
        try:
            full, modal = full_series(run, full_dt, Path(args.store))
        except FullOrderNewtonError as exc:  # no reference at this amplitude: say so, go on
            print(f"| {amp:g} | full order (tension field) | — | — | — | — | — | {exc} |")
            continue
        setup = simulate.prepare(run)
        if args.modes != 5:
            setup = with_relaxed_extra_modes(
                simulate.prepare(cmp.window_run(variant(case, amp, "spinning", args.modes),
                                                window, "Q")), run)  # fmt: skip
        k = setup.initial.bending_modes[0]
        f3_full = crossing_frequency(full.t, modal[:, k], EARLY_PERIODS)
        f_full = crossing_frequency(full.t, modal[:, k])
        print(f"| {amp:g} | full order (tension field) | {f3_full:.3f} | — | {f_full:.3f} | — | — "
              f"| {full.wall_s:.0f} |")  # fmt: skip
        if pot is None:
            pot, report, wall = trained_potential(setup, train, args.directions, args.pod)
            print(f"<!-- basis: {report.n_quadratic} G⊥ + {report.n_pod} POD vectors "
                  f"(captured {report.captured:.6f}), {len(report.snapshots)} snapshots, "
                  f"trained in {wall:.0f} s -->", flush=True)  # fmt: skip
        period = 1.0 / float(np.min(setup.model.frequencies_hz))
        variants = {"Q": lambda st=setup: st,
                    "Q+condensed": lambda st=setup, pt=pot: simulate.RunSetup(
                        st.run, st.model_case, st.model,
                        rsys.with_nonlinear_potential(st.system, pt), st.initial),
                    "Q+snapshots": lambda st=setup, pt=pot, rp=report: augmented_setup(
                        st, pt, *snapshot_coordinates(pt, rp.snapshots, args.aug_pod),
                        args.cutoff),
                    "Q+trajectory-POD": lambda st=setup, pt=pot, r=run, md=modal: augmented_setup(
                        st, pt, *trajectory_coordinates(
                            pt, full_displacements(r, full_dt, Path(args.store)), md,
                            args.aug_pod), args.cutoff)}  # fmt: skip
        for name in args.models.split(","):
            r = simulate.execute(variants[name]())
            s = r.solution.y[:, 7 + k]
            n = setup.model.n_modes
            f = crossing_frequency(r.solution.t, s)
            f3 = crossing_frequency(r.solution.t, s, EARLY_PERIODS)
            series = dataclasses.replace(cmp.series_from_run(name, r), amplitude=np.linalg.norm(
                r.solution.y[:, 7 : 7 + modal.shape[1]], axis=1))  # the full order's modes
            err = cmp.errors(series, full, period)["envelope_error"]
            np.savez(Path(args.store) / f"{run.name}-{name}-{n}modes.npz",
                     t=r.solution.t, s=r.solution.y[:, 7 : 7 + n])  # fmt: skip
            if not r.complete:  # an early stop is a result too, but not a frequency over 1 s
                name = f"{name} (stopped at t = {r.solution.t[-1]:.3f} s)"
            print(f"| {amp:g} | {name} | {f3:.3f} | {100 * (f3 / f3_full - 1):+.1f} % | {f:.3f} "
                  f"| {100 * (f / f_full - 1):+.2f} % | {err:.4f} | {r.wall_s:.1f} |",
                  flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
