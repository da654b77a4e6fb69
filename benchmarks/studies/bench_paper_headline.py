"""The seed cases' headline numbers for the default reduced model and every baseline: cone
angle, spin rate and dissipated energy at the end of ``paper-41hz`` (120 s) and
``paper-0.5hz`` (4 s), so that a reader sees how much the choice of formulation, reference
state and basis matters (docs/paper-cases.md).

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_paper_headline [--cases paper-41hz,paper-0.5hz]

Variants: the case as shipped (the default), and the baselines: Q, Q4, P, L about the state at
rest with the seed's 5 modes, Q about the state at rest with 8 modes, and rigid.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from quadmodes.case import load_run_case
from quadmodes.runs import simulate

#: (label, reduced-section update) of each variant; None: the case as shipped.
VARIANTS = (
    ("default (as shipped)", None),
    ("Q, rest, 5 modes (the seed)", {"reference": "rest", "modes": 5, "formulation": "Q"}),
    ("Q4, rest, 5 modes", {"reference": "rest", "modes": 5, "formulation": "Q4"}),
    ("P, rest, 5 modes", {"reference": "rest", "modes": 5, "formulation": "P"}),
    ("L, rest, 5 modes", {"reference": "rest", "modes": 5, "formulation": "L"}),
    ("Q, rest, 8 modes", {"reference": "rest", "modes": 8, "formulation": "Q"}),
    ("rigid", {"reference": "rest", "modes": 5, "formulation": "rigid"}),
)


def headline(run) -> dict:
    """End-of-run cone angle (deg), spin rate (Hz), dissipated energy (J), completion."""
    start = time.perf_counter()
    r = simulate.simulate(run)
    d = r.diagnostics
    return {
        "cone_deg": float(np.degrees(d.cone_angle[-1])),
        "spin_hz": float(d.spin_rate[-1] / (2 * np.pi)),
        "dissipated_J": float(d.E_d[-1]) if hasattr(d, "E_d") else float("nan"),
        "complete": bool(r.complete),
        "t_end": float(r.solution.t[-1]),
        "wall_s": time.perf_counter() - start,
        "modes": int(r.system.n_modes),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="paper-41hz,paper-0.5hz")
    args = ap.parse_args()
    for name in args.cases.split(","):
        base = load_run_case(name)
        print(f"\n{name}: {base.integration.duration:g} s, dt {base.integration.dt * 1e3:g} ms; "
              f"default: {base.reduced.formulation}, reference {base.reduced.reference}, "
              f"{base.reduced.modes} modes")  # fmt: skip
        print("| model | N | cone angle end (deg) | spin rate end (Hz) | dissipated energy (J) | "
              "wall (s) |\n|---|---|---|---|---|---|")  # fmt: skip
        for label, update in VARIANTS:
            run = base if update is None else base.model_copy(
                update={"reduced": base.reduced.model_copy(update=update)})  # fmt: skip
            h = headline(run)
            end = "" if h["complete"] else f" (stopped at {h['t_end']:.3g} s)"
            print(f"| {label}{end} | {h['modes']} | {h['cone_deg']:.4f} | {h['spin_hz']:.5f} | "
                  f"{h['dissipated_J']:.4f} | {h['wall_s']:.1f} |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
