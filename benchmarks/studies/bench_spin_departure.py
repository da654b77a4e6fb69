"""How far from its expansion spin a model about a spinning state holds: the rotating-frame
frequencies of the model built about the run's initial spin Ω_ref, linearised at a lower spin Ω,
against those of the model rebuilt about Ω itself (same case, same mode count), beside the bound
δ/2 = |Ω² − Ω_ref²| / (2 Ω_ref²) that :mod:`quadmodes.runs.path_validity` uses.

For each Ω: the elastic roots of both models at Ω (free body, relative equilibrium about the
reference axis, :func:`quadmodes.analysis.reduced_linearisation.linearise`), sorted by frequency
and paired in order (the spins are close, the order does not change), below ``--below`` × Ω_ref;
the largest relative difference and the bound.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_spin_departure \
        [RUN_CASE] [--spins-hz 40.6 40 39 37.7] [--below 3.2]

One model build per spin (about 30 s each on the coarse mesh, cached).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from quadmodes.analysis.reduced_linearisation import linearise
from quadmodes.case import load_run_case
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import system as rsys


def elastic_hz(model, spin: float) -> np.ndarray:
    """The elastic root frequencies (Hz, sorted) of ``model`` at ``spin`` (rad/s) about its
    reference axis: the roots' positive imaginary parts without the zero root and without the
    nutation root (the one nearest the rigid body-frame nutation frequency Ω |1 − I_a / I_t|)."""
    sys = rsys.reduced_system(model, "Q")
    axis = np.asarray(model.reference_axis, float)
    lin = linearise(sys, model, spin, axis, damped=False)
    f = np.sort(lin.lam.imag[lin.lam.imag > 1e-6] / (2 * math.pi))
    i_a = float(axis @ model.J0 @ axis)
    i_t = 0.5 * (np.trace(model.J0) - i_a)
    nutation = spin * abs(1.0 - i_a / i_t) / (2 * math.pi)
    return np.delete(f, int(np.argmin(np.abs(f - nutation))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", nargs="?", default="paper-41hz-coarse")
    ap.add_argument("--spins-hz", type=float, nargs="+", default=[40.6, 40.0, 39.0, 37.7])
    ap.add_argument("--below", type=float, default=3.2, help="compare roots below this × Ω_ref")
    args = ap.parse_args()
    run = load_run_case(args.case)
    mc = run.model_case()
    spin_ref = run.initial.spin_rate
    ref = reduced_model_for(mc, 16, spin=spin_ref)
    n = ref.n_modes
    print(f"{args.case}: model about {spin_ref / (2 * math.pi):.4g} Hz, N = {n}")
    print(f"{'spin Hz':>8} {'bound δ/2':>10} {'max |Δf|/f':>11} {'branch Hz':>10}  per branch")
    for hz in args.spins_hz:
        spin = 2 * math.pi * hz
        own = reduced_model_for(mc, n, spin=spin)
        fa, fb = elastic_hz(ref, spin), elastic_hz(own, spin)
        keep = fb < args.below * spin_ref / (2 * math.pi)
        fa, fb = fa[keep], fb[keep]
        rel = np.abs(fa - fb) / fb
        k = int(np.argmax(rel))
        bound = abs(spin**2 - spin_ref**2) / (2 * spin_ref**2)
        per = " ".join(f"{r:.1e}" for r in rel)
        print(f"{hz:8.4g} {bound:10.2e} {rel[k]:11.2e} {fb[k]:10.4g}  {per}")


if __name__ == "__main__":
    main()
