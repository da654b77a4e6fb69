"""Where the large-amplitude motion lives: the full order's body-frame displacement of a
large initial bending, projected on every FE mode of the inflated state, and the bending
coordinate's frequency cycle by cycle.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_wrinkling_participation.py \
        [--case benchmarks/cases/paper-0.5hz-coarse-tf.toml] [--amplitude 0.5] [--window "1 s"] \
        [--full-dt "0.5 ms"] [--top 12]

Prints (markdown) the share of the time-averaged kinetic energy ``⟨q̇_j²⟩`` and displacement
``⟨q_j²⟩`` of the leading FE modes ``q_j = φ_jᵀ M u`` (M-orthonormal, the tangent stiffness at
the inflated reference), the shares by frequency band, and the bending coordinate's frequency
and amplitude per period (upward zero crossings about zero). A dense eigensolution: meant for
the coarse meshes (758 nodes: seconds; the transient about a minute). Figures in
docs/full-order.md ("Session 10").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.linalg as sla

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_large_amplitude import upward_crossings, variant  # noqa: E402

import quadmodes.fullorder.kinematics as kin  # noqa: E402
from quadmodes.analysis import compare as cmp  # noqa: E402
from quadmodes.analysis.full_order_runs import full_order_for_run, setup_for_run  # noqa: E402
from quadmodes.case import load_run_case  # noqa: E402
from quadmodes.case.units import parse_quantity  # noqa: E402
from quadmodes.fe.model import mass_matrix, tangent_stiffness  # noqa: E402

BANDS_HZ = (1.0, 40.0, 80.0, 150.0, 400.0, np.inf)


def body_displacements(st, positions: np.ndarray) -> np.ndarray:
    """Mean-axes body-frame displacements ``(k, n, 3)`` m of sampled positions ``(k, n, 3)``
    relative to the reference about the centre of mass."""
    tr = st.structure.translational
    x_ref = np.asarray(st.model.X, float)
    body = kin.make_body(st.structure.mass_scalar, tr, x_ref, None, False)
    out = np.empty_like(positions)
    for i, x in enumerate(positions):  # diagnostics on ~10^3 samples, not a hot path
        c = kin.centre(body, x)
        out[i] = (x - np.outer(tr, c)) @ kin.best_fit_rotation(body, x, c) - x_ref
    return out


def recorded_full_order(run, dt: float):
    """``(sol, st, u)``: the full order of ``run`` at step ``dt`` (s), its setup and its
    body-frame displacements ``(k, 3n)`` m at the samples (:func:`body_displacements`)."""
    st = setup_for_run(run)
    samples: list[np.ndarray] = []
    sol = full_order_for_run(run, dt=dt, setup=st, on_sample=lambda t, x: samples.append(x.copy()))
    return sol, st, body_displacements(st, np.array(samples)).reshape(len(samples), -1)


def fe_modes(st) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(f, V, M)``: signed frequencies (Hz), M-orthonormal modes ``(m, m)`` and mass of the
    FE model at the reference (dense)."""
    mass = mass_matrix(st.structure).toarray()
    k = tangent_stiffness(st.structure, st.x_ref).toarray()
    w2, v = sla.eigh(0.5 * (k + k.T), mass)
    return np.sign(w2) * np.sqrt(np.abs(w2)) / (2.0 * np.pi), v, mass


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="benchmarks/cases/paper-0.5hz-coarse-tf.toml")
    ap.add_argument("--amplitude", type=float, default=0.5, help="initial bending, in")
    ap.add_argument("--window", default="1 s")
    ap.add_argument("--full-dt", default="0.5 ms")
    ap.add_argument("--top", type=int, default=12)
    args = ap.parse_args()
    window = parse_quantity(args.window, "time", "--window")
    dt = parse_quantity(args.full_dt, "time", "--full-dt")
    run = cmp.window_run(variant(load_run_case(args.case), args.amplitude, "spinning", 5), window)
    sol, st, u = recorded_full_order(run, dt)
    t = np.asarray(sol.t)
    f, v, mass = fe_modes(st)
    q = u @ (mass @ v)
    e_u, e_k = np.mean(q**2, axis=0), np.mean(np.gradient(q, t, axis=0) ** 2, axis=0)
    print(f"{run.name}, {window:g} s, full order at {dt:g} s ({sol.stats['wall_s']:.0f} s wall)\n")
    print("| FE mode | frequency (Hz) | kinetic share | displacement share |\n|---|---|---|---|")
    for j in np.argsort(-e_k)[: args.top]:
        print(f"| {j} | {f[j]:.2f} | {e_k[j] / e_k.sum():.4f} | {e_u[j] / e_u.sum():.4f} |")
    cum = np.cumsum(np.sort(e_k)[::-1]) / e_k.sum()
    print(f"\nmodes holding 99 % / 99.9 % of the kinetic energy: {np.searchsorted(cum, 0.99) + 1}"
          f" / {np.searchsorted(cum, 0.999) + 1}\n")  # fmt: skip
    print("| band (Hz) | modes | kinetic share | displacement share |\n|---|---|---|---|")
    lows = (0.0, *BANDS_HZ[:-1])
    for lo, hi in zip(lows, BANDS_HZ, strict=True):
        sel = (np.abs(f) >= lo) & (np.abs(f) < hi)
        print(f"| {lo:g}–{hi:g} | {sel.sum()} | {e_k[sel].sum() / e_k.sum():.4f} "
              f"| {e_u[sel].sum() / e_u.sum():.4f} |")  # fmt: skip
    k = int(np.argmax(np.abs(np.asarray(sol.modal_coordinates)[0])))
    y = np.asarray(sol.modal_coordinates)[:, k]
    tc = upward_crossings(t, y)
    print(f"\nbending coordinate {k}, per period:\n\n| from (s) | frequency (Hz) | peak |\n|---|---|---|")
    for a, b in zip(tc[:-1], tc[1:], strict=True):
        print(f"| {a:.3f} | {1.0 / (b - a):.2f} | {np.max(np.abs(y[(t >= a) & (t < b)])):.3e} |")


if __name__ == "__main__":
    main()
