"""The long path of a run with a controlled step (issue 29 item 3): paper-41hz-coarse from 6° until
a 60° cone (or 3 h simulated), or the hub with booms to a flat spin, with its cost, conservation,
times to cone angles, validity along the path and convergence in the tolerance.

    OPENBLAS_NUM_THREADS=1 nice -n 5 python -m benchmarks.studies.bench_long_path \\
        [--case paper-41hz-coarse] [--tolerance 5e-3] [--until "cone 60 deg"] [--duration "3 h"] \\
        [--save-every 200] [--halve] [--fixed DT] [--no-fe-checks]

Prints per run: integration wall time (s), steps (run and probes), shortest and longest step,
|H| drift (largest |‖H‖ − ‖H₀‖| / ‖H₀‖ and of the inertial vector), the energy balance E + E_d
(largest change / E₀), the event, the times to 10/20/30/45/60/75°, the step along the path
(every tenth of the samples: t, cone, spin, step) and the path validity verdict (the FE checks
of ``quadmodes run`` unless ``--no-fe-checks``). ``--halve`` runs again at half the tolerance and
prints the relative change of every time to a cone angle (the path's convergence in the step);
``--fixed DT`` runs the fixed step DT instead of the controlled one (``--until`` as given), for
the secular answer side by side. A flat-spin event (``--until "flat spin"``) also prints the
final angle between H and the major principal axis and |ω| against H / I_major.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from quadmodes.case import load_run_case
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import system as rsys
from quadmodes.runs import simulate as sim
from quadmodes.runs.events import cone_times, state_measures


def _run_case(args, tolerance: float | None, fixed_dt: str | None):
    """The run case with the options applied (step_tolerance set unless ``fixed_dt``)."""
    run = sim.apply_overrides(load_run_case(args.case), duration=args.duration, until=args.until,
                              dt=fixed_dt, modes=args.modes)  # fmt: skip
    integ = run.integration.model_copy(update={
        "save_every": args.save_every, "step_tolerance": None if fixed_dt else tolerance})  # fmt: skip
    return run.model_copy(update={"integration": integ})


def _flat_spin_lines(result) -> list[str]:
    """The end state against a flat spin: angle between H and the major axis, |ω| / (|H| /
    I_major) − 1 (I_major of the deformed inertia J̃(s) there)."""
    y = np.asarray(result.solution.y[-1:], float)
    m = state_measures(result.system, y, np.asarray(result.initial.spin_axis, float))
    s = rsys.split_state(result.system, y)[2]
    i_major = float(np.linalg.eigvalsh(dyn.inertia_tensor(result.system, s, "rot")[0])[-1])
    h = float(np.linalg.norm(dyn.body_momentum(result.system, y)[0]))
    w = float(np.linalg.norm(y[0, 4:7]))
    return [f"  end: H to the major axis {math.degrees(float(m['flat spin'][0])):.4g} deg, "
            f"|omega| / (|H| / I_major) - 1 = {w / (h / i_major) - 1:.3e}"]  # fmt: skip


def _report(label: str, result, wall: float) -> dict:
    """Print the run's figures; return its times to cone angles."""
    d, st = result.diagnostics, result.solution.stats
    h_in = dyn.momentum_inertial(result.system, result.solution.y)
    h0 = float(np.linalg.norm(h_in[0]))
    e0 = float(d.E[0])
    bal = float(np.abs(d.E_balance - d.E_balance[0]).max() / e0)
    times = cone_times(d.t, d.cone_angle)
    print(f"\n== {label}, N = {result.model.n_modes}: "
          f"{'complete' if result.complete else 'INCOMPLETE ' + result.reason}")
    print(f"  integration wall {result.wall_s:.1f} s (all {wall:.1f} s); steps {st['n_steps']:,}"
          f" + probes {st.get('n_probe_steps', 0):,}; step {1e3 * st.get('dt_min_s', math.nan):.4g}"
          f" – {1e3 * st.get('dt_max_s', math.nan):.4g} ms")  # fmt: skip
    print(f"  |H| drift {np.abs(d.H_norm / d.H_norm[0] - 1).max():.2e}, inertial H "
          f"{np.linalg.norm(h_in - h_in[0], axis=1).max() / h0:.2e}; E + E_d {bal:.2e} of E0 "
          f"({e0:.2f} J; dissipated {float(d.E_d[-1]):.2f} J)")  # fmt: skip
    print(f"  end t = {d.t[-1]:.2f} s, cone {math.degrees(d.cone_angle[-1]):.3f} deg, spin "
          f"{d.spin_rate[-1] / (2 * math.pi):.4f} Hz; event: {result.event}")  # fmt: skip
    print("  times to cone (s): " + ", ".join(f"{k:g} deg {v:.2f}" for k, v in times.items()))
    t = np.asarray(d.t, float)
    step = np.diff(t) / result.run.integration.save_every
    for k in np.linspace(0, len(step) - 1, min(11, len(step))).astype(int):
        print(f"    t {t[k]:9.1f} s  cone {math.degrees(d.cone_angle[k]):6.2f} deg  spin "
              f"{d.spin_rate[k] / (2 * math.pi):7.3f} Hz  step {1e3 * step[k]:.4g} ms  "
              f"E + E_d {(d.E_balance[k] - d.E_balance[0]) / e0:+.2e}")  # fmt: skip
    path = result.path
    print(f"  path: {'valid' if path and path.valid else 'not valid'}: "
          f"{path.message() if path else 'not checked'}")  # fmt: skip
    if result.event is not None and result.event.kind == "flat spin":
        print("\n".join(_flat_spin_lines(result)))
    return times


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", default="paper-41hz-coarse")
    p.add_argument("--tolerance", type=float, default=5e-3)
    p.add_argument("--until", default="cone 60 deg")
    p.add_argument("--duration", default="3 h")
    p.add_argument("--save-every", type=int, default=200)
    p.add_argument("--modes", default=None)
    p.add_argument("--halve", action="store_true", help="also run at half the tolerance")
    p.add_argument("--fixed", default=None, help='a fixed step instead, e.g. "0.5 ms"')
    p.add_argument("--no-fe-checks", action="store_true")
    args = p.parse_args(argv)
    runs = [(args.fixed and f"fixed {args.fixed}") or f"tolerance {args.tolerance:g}"]
    found = {}
    for k, label in enumerate(runs + ([f"tolerance {args.tolerance / 2:g}"] if args.halve else [])):
        run = _run_case(args, args.tolerance / (2 if k else 1), args.fixed)
        start = time.perf_counter()
        result = sim.simulate(run, check_deformation=not (args.no_fe_checks or k),
                              allow_coarse_step=True)  # fmt: skip
        found[label] = _report(label, result, time.perf_counter() - start)
    if len(found) == 2:
        (a, ta), (b, tb) = found.items()
        print(f"\n== {a} -> {b}: relative change of the time to a cone angle")
        print("  " + ", ".join(f"{m:g} deg {tb[m] / ta[m] - 1:+.2e}" for m in ta
                               if m in tb and math.isfinite(ta[m]) and math.isfinite(tb[m])))  # fmt: skip


if __name__ == "__main__":
    main()
