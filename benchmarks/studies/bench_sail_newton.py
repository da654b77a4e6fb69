"""Why the full order of a membrane on a hub stops at a large nutation (docs/sails.md,
"Full-order comparisons in time on the hub-mounted bodies"): the membrane's loss of tension,
measured step by step, and the Newton matrix where it fails.

Runs the full order of a run case (default ``spinning-annulus-nutation-large``, 5°, independent
damping) with every step sampled and prints, every ``--every`` steps: the largest out-of-plane
deflection of the membrane relative to the hub (in the hub's frame), the share of elements in
compression, the least and largest principal stress resultants. On the Newton failure it prints
the error and, at the last state reached: cond(A) of the step matrix ``A = M + (Δt²/2)K``, the
extreme eigenvalues of its M-scaled symmetric part, the count and the most negative of the
M-scaled tangent's eigenvalues (a membrane in compression), and for the stalled iterations the
correction that the hub's rows of the residual produce alone against the membrane rows'
for the last iterations whose correction is near the tolerance (hypothesis (a): the triad
penalty's round-off). Nothing is asserted. Usage (~15 s)::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_sail_newton
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_sail_newton --dt 0.01 --window 8 --every 25
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_sail_newton --case ikaros-sail-nutation-large --dt 0.2
"""

from __future__ import annotations

import argparse
import os

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import quadmodes.fullorder.newton as newton  # noqa: E402
from quadmodes.analysis.full_order_runs import full_order_for_run, setup_for_run  # noqa: E402
from quadmodes.fe.hub import HUB_DOFS  # noqa: E402
from quadmodes.structure.membrane_tension import membrane_sets  # noqa: E402


def hub_frame_state(structure, x: np.ndarray) -> dict:
    """Deflection relative to the hub (m), compression share and resultants (N/m) at x."""
    c, axes = x[0], x[1:HUB_DOFS]
    body = (x[HUB_DOFS:] - c) @ np.linalg.inv(axes)  # x = c + Σ ξ_i a_i
    res = np.concatenate([e.principal_stress_resultants(x) for e in membrane_sets(structure)])
    return {"w": float(np.abs(body[:, 2]).max()), "compressed": float(np.mean(res[:, 0] < 0)),
            "least": float(res[:, 0].min()), "largest": float(res.max()),
            "triad": float(np.abs(axes @ axes.T - np.eye(3)).max())}  # fmt: skip


def step_matrix_report(problem, x: np.ndarray) -> str:
    """cond(A), M-scaled eig(A) range, negative eigenvalues of the M-scaled tangent at x."""
    weight, free = 0.5 * problem.h**2, problem.free
    jac, _ = newton.step_jacobian(problem.structure, x, x, True)
    a = (problem.m_full + weight * jac)[free][:, free].toarray()
    d = 1.0 / np.sqrt(problem.m_full[free][:, free].diagonal())
    k = jac[free][:, free].toarray()
    ea = np.linalg.eigvalsh(0.5 * (a + a.T) * np.outer(d, d))
    ek = np.linalg.eigvalsh(0.5 * (k + k.T) * np.outer(d, d))
    return (f"cond(A) {np.linalg.cond(a):.3g}; M-scaled eig(A) {ea.min():.3g} … {ea.max():.3g}; "
            f"M-scaled tangent: {int(np.sum(ek < 0))} negative, the most negative "
            f"{ek.min():.4g} 1/s² ((Δt²/2)·it = {weight * ek.min():.3g})")  # fmt: skip


class SplitLog:
    """Wraps ``newton._step_to``: for each iteration whose correction is below 1e-8 m but
    above the tolerance, the corrections that the hub's rows and the membrane's rows of the
    residual produce alone."""

    def __init__(self):
        self.rows, self._orig = [], getattr(newton, "_step_to", None)
        self.problem = None

    def __enter__(self):
        if self._orig is not None:
            newton._step_to = self._wrapped
        return self

    def __exit__(self, *exc):
        if self._orig is not None:
            newton._step_to = self._orig

    def _wrapped(self, problem, matrix, residual_at, x1, r, rot, search=False):
        y, dx = self._orig(problem, matrix, residual_at, x1, r, rot, search)
        self.problem, size = problem, float(np.abs(dx).max())
        if problem.tol < size < 1e-8:
            hub, mem = r.copy(), r.copy()
            hub[HUB_DOFS:], mem[:HUB_DOFS] = 0.0, 0.0
            ch = newton._correction(problem, matrix, hub, rot)
            cm = newton._correction(problem, matrix, mem, rot)
            self.rows.append((size, float(np.abs(r[:HUB_DOFS]).max()),
                              float(np.abs(r[HUB_DOFS:]).max()), float(np.abs(ch).max()),
                              float(np.abs(cm).max())))  # fmt: skip
        return y, dx


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="spinning-annulus-nutation-large")
    ap.add_argument("--dt", type=float, default=0.05, help="full-order step (s)")
    ap.add_argument("--window", type=float, default=3.0, help="simulated window (s)")
    ap.add_argument("--every", type=int, default=1, help="print every so many steps")
    args = ap.parse_args()
    st = setup_for_run(args.case)
    last = {}

    def on_sample(t, x):
        last["x"] = x
        s = hub_frame_state(st.structure, x)
        print(f"t = {t:7.3f} s  w {s['w']:.4g} m  compressed {100 * s['compressed']:5.1f} %  "
              f"least {s['least']:+.3g} N/m  largest {s['largest']:.3g} N/m  "
              f"triad {s['triad']:.2g}", flush=True)  # fmt: skip

    with SplitLog() as log:
        try:
            sol = full_order_for_run(st.run, dt=args.dt, window=args.window, setup=st,
                                     save_every=args.every, on_sample=on_sample)  # fmt: skip
            print(f"ran to the end: cone {np.degrees(sol.cone_angle[-1]):.4f} deg")
        except newton.FullOrderNewtonError as err:
            print(err)
    if log.problem is not None and "x" in last:
        print("at the last sampled state:", step_matrix_report(log.problem, last["x"]))
    for size, rh, rm, ch, cm in log.rows[-5:]:
        print(f"iteration near the tolerance: correction {size:.3g} m (tol {log.problem.tol:.2g}); residual "
              f"hub rows {rh:.3g} N, membrane rows {rm:.3g} N; corrections from the hub rows "
              f"{ch:.3g} m, from the membrane rows {cm:.3g} m")  # fmt: skip


if __name__ == "__main__":
    main()
