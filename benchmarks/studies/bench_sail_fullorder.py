"""The nutation decay of a membrane on a hub, reduced against the full order with its
independent damping, and the speed of both per simulated second, side by side (issue 26;
docs/sails.md, "Full-order comparisons in time on the hub-mounted bodies").

Writes copies of a run case (default ``ikaros-sail-nutation``) and of its model case with the
cone ``--cone`` (deg) and the mesh edges ``--edges`` (m; the first is the comparison's) into a
scratch folder and runs ``quadmodes compare`` (Q, the run's own mode rule: every mode up to its
margin) on each. For the first it prints the comparison's envelope, cone and dissipated-power
figures and the **nutation decay rate** of each model, fitted two ways: the slope of ln(cone) over
the whole window (least squares), and the quasi-steady cone growth of ``compare``. For every
mesh it prints the wall time of each model per simulated second and their ratio, measured in
the same process one after the other: the integration of each (the full order's as
``compare`` times it; the reduced one's also as the median of five repeats, the figure that
counts: a run of milliseconds is at the mercy of one time slice on a shared machine), and the
reduced run's whole work once its model is loaded (integration, diagnostics and the path's FE
checks, as ``quadmodes run`` does them: ``simulate.execute`` of a run prepared with the
deformation check; median of five). The full order keeps its own step ``--full-dt``
(default :data:`FULL_ORDER_DT`: 0.2 s for the sail, else the run case's), whatever the reduced
run's (``--dt``, default the run case's). Nothing is
asserted. Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_sail_fullorder            # ~3 min
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_sail_fullorder \\
        --case spinning-annulus-nutation --cone 0.1 --window 600 --edges 0.5
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_sail_fullorder \\
        --window 60 --edges 0.7,0.5,0.35                                                # speed
    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_sail_fullorder \\
        --window 600 --speed-window 600 --edges 0.7,0.5                         # 600 s windows

The cone must be small enough for the membrane to stay taut (docs: 0.05° for the sail, 0.1°
for the annulus); at the run cases' 5° the full order stops, naming the loss of tension. The
reduced run's own membrane is checked first (the FE membrane at the manifold point of its path:
``--reduced-only --cone 5 --window 60`` shows the 5° runs' compression).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import quadmodes as qm  # noqa: E402
from quadmodes.case import load_run_case  # noqa: E402
from quadmodes.case.editing import edit  # noqa: E402

#: The full order's own step (s) where it is not the run case's: the sail's comparisons were
#: established with the full order at 0.2 s, the case's step until its reduced run went to 0.4 s
#: (docs/sails.md, "Speed per simulated second"; the full order costs the same per simulated
#: second at both). Other cases: the run case's step.
FULL_ORDER_DT = {"ikaros-sail-nutation": 0.2}


def write_cases(folder: Path, run_name: str, cone_deg: float, edge_m: float,
                duration: float, dt: float | None = None) -> Path:  # fmt: skip
    """The model case with ``mesh.edge_length`` and the run case with the cone, ``duration``
    (s) and, if given, the step ``dt`` (s), in folder."""
    run = load_run_case(run_name)
    model = edit(run.model_case(), {"mesh.edge_length": f"{edge_m} m"}, "--edges")
    model_name = f"{model.name}-{edge_m}m"
    text = model.to_toml().replace(f'name = "{model.name}"', f'name = "{model_name}"', 1)
    (folder / f"{model_name}.toml").write_text(text, encoding="utf-8")
    changes = {"initial.cone_angle": f"{cone_deg} deg", "integration.duration": f"{duration} s"}
    if dt is not None:
        changes["integration.dt"] = f"{dt} s"
    run = edit(run, changes, "--cone")
    lines = run.to_toml().splitlines()
    for i, line in enumerate(lines):
        if line.startswith("model = "):
            lines[i] = f'model = "{model_name}.toml"'
        elif line.startswith("name = "):
            lines[i] = f'name = "{run.name}-{cone_deg}deg-{edge_m}m"'
    path = folder / f"{run.name}-{edge_m}.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def reduced_tension(run_path: Path, every: int = 10) -> tuple[float, float, float, float]:
    """The reduced run's own membrane state: the FE membrane at its manifold point
    ``X + Φs + Σ s_m s_n g^{mn}`` every ``every`` samples. Returns (the reference's not-taut
    fraction, the largest not-taut fraction along the run, the least minor resultant N/m, the
    time s of the largest)."""
    from quadmodes.runs.simulate import simulate
    from quadmodes.structure.membrane_tension import tension_state
    from quadmodes.structure.pipeline import structure_for_case

    r = simulate(load_run_case(str(run_path)))
    m, st = r.model, structure_for_case(r.model_case)
    s = r.solution.y[:, 7 : 7 + m.n_modes]
    worst, least, when = 0.0, np.inf, 0.0
    for k in range(0, len(r.solution.t), every):
        x = m.X + np.einsum("k,knj->nj", s[k], m.Phi) + np.einsum("k,l,klnj->nj", s[k], s[k], m.G)
        ts = tension_state(st, x)
        least = min(least, ts.least_resultant)
        if ts.not_taut_fraction > worst:
            worst, when = ts.not_taut_fraction, float(r.solution.t[k])
    return tension_state(st, m.X).not_taut_fraction, worst, least, when


def log_slope(t: np.ndarray, cone: np.ndarray) -> float:
    """Least-squares slope (1/s) of ln(cone) over the whole window."""
    return float(np.polyfit(t, np.log(cone), 1)[0])


def compare_one(folder: Path, args, edge: float, window: float) -> tuple[dict, Path, int]:
    """``quadmodes compare`` (Q) of the case copy at ``edge``: its JSON, output folder and
    the structure's number of vector DOFs."""
    from quadmodes.structure.pipeline import structure_for_case

    run = write_cases(folder, args.case, args.cone, edge, window, args.dt)
    out = folder / f"out-{edge}"
    cpu = []  # (simulated s, process CPU s) at the full order's progress reports

    def progress(stage: str, fraction: float) -> None:
        if stage == "full order":
            cpu.append((fraction * window, time.process_time()))

    qm.compare(str(run), f"{window} s", formulations=("Q",), output_dir=out, plots=False,
               full_order_dt=f"{args.full_dt} s", progress=progress)  # fmt: skip
    n = structure_for_case(load_run_case(str(run)).model_case()).n
    summary = json.loads((out / "comparison.json").read_text())
    summary["integration_wall_s"], summary["run_wall_s"], summary["integration_cpu_s"] = \
        reduced_run_wall(run)  # fmt: skip
    (t0, c0), (t1, c1) = cpu[0], cpu[-1]
    summary["full_cpu_per_s"] = (c1 - c0) / (t1 - t0) if t1 > t0 else float("nan")
    return summary, out, n


def reduced_run_wall(run_path: Path, repeats: int = 5) -> tuple[float, float, float]:
    """The reduced run's (integration, whole work) wall times (s) once its model is loaded,
    each the median of ``repeats``: its chunked integration alone (``integrate_run``, what
    ``compare`` times once) and ``simulate.execute`` of the run prepared as ``quadmodes run``
    prepares it (integration, diagnostics and the path's FE checks). The median, because a
    run of a few milliseconds on a shared machine is often preempted for a time slice. Third:
    the integration's process CPU time (s, median), what contention does not inflate."""
    from quadmodes.runs import simulate
    from quadmodes.runs.step_chunks import integrate_run

    setup = simulate.prepare(load_run_case(str(run_path)), check_deformation=True)
    simulate.warm_up_kernel(setup.run)
    integration, whole, cpu = [], [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        integrate_run(setup.system, setup.initial.y0, setup.run.integration)
        integration.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
        start = time.perf_counter()
        simulate.execute(setup)
        whole.append(time.perf_counter() - start)
    return float(np.median(integration)), float(np.median(whole)), float(np.median(cpu))


def print_decay(summary: dict, out: Path) -> None:
    """The comparison's figures and the decay rates of both models."""
    import xarray as xr

    q, full = summary["formulations"]["Q"], summary["full_order"]
    with xr.open_dataset(out / "comparison.nc") as ds:
        t, cone = ds.time.values, ds.cone_angle.values
        e_d = ds.dissipated_energy.values[:, -1]
    rates = [-log_slope(t, c) for c in cone]
    print(f"cone {full['cone_angle_start_deg']:.4g} deg -> full {np.degrees(cone[0, -1]):.5g}, "
          f"reduced {np.degrees(cone[1, -1]):.5g} deg over {t[-1]:.0f} s")  # fmt: skip
    print(f"envelope error {_g(q['envelope_error'])}, cone angle error {_g(q['cone_angle_error'])}")
    print(f"nutation decay rate, ln(cone) fit over the window: full {rates[0]:.5g} 1/s, reduced "
          f"{rates[1]:.5g} 1/s, ratio {rates[1] / rates[0]:.4f}")  # fmt: skip
    qs = summary["quasi_steady"]
    print(f"quasi-steady ({qs['start_s']:.0f}–{qs['end_s']:.0f} s) cone growth ratio {q['cone_growth_ratio']}, dissipated power "
          f"ratio {q['dissipated_power_ratio']}")  # fmt: skip
    print(f"dissipated energy over the window: full {e_d[0]:.5g} J, reduced {e_d[1]:.5g} J, "
          f"ratio {e_d[1] / e_d[0]:.4f}; full-order |H| drift {full['H_relative_drift']:.2g}")  # fmt: skip


def _g(value) -> str:
    """A figure to 3 digits, "—" for None (a comparison not scored)."""
    return "—" if value is None else f"{value:.3g}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="ikaros-sail-nutation", help="run case")
    ap.add_argument("--cone", type=float, default=0.05, help="initial cone (deg)")
    ap.add_argument("--window", type=float, default=600.0, help="simulated window (s)")
    ap.add_argument("--edges", default="0.7", help="mesh edge lengths (m), comma-separated")
    ap.add_argument("--reduced-only", action="store_true",
                    help="only the reduced run's own tension check (any cone, e.g. 5)")  # fmt: skip
    ap.add_argument("--speed-window", type=float, default=60.0,
                    help="window (s) of the meshes after the first (speed only)")  # fmt: skip
    ap.add_argument("--dt", type=float, default=None,
                    help="the reduced run's step (s); default: the run case's")  # fmt: skip
    ap.add_argument("--full-dt", type=float, default=None,
                    help="the full order's step (s); default: its own (FULL_ORDER_DT)")  # fmt: skip
    args = ap.parse_args()
    if args.full_dt is None:
        args.full_dt = FULL_ORDER_DT.get(args.case, load_run_case(args.case).integration.dt)
    edges = [float(e) for e in args.edges.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        run = write_cases(Path(tmp), args.case, args.cone, edges[0], args.window, args.dt)
        ref, worst, least, when = reduced_tension(run)
        print(f"reduced run's membrane (FE at its manifold point): not taut on {100 * ref:.1f} % "
              f"at the reference, at most {100 * worst:.1f} % (t = {when:.1f} s); least minor "
              f"resultant {least:.3g} N/m")  # fmt: skip
        if args.reduced_only:
            return
        for i, edge in enumerate(edges):
            window = args.window if i == 0 else args.speed_window
            summary, out, n = compare_one(Path(tmp), args, edge, window)
            if i == 0:
                print_decay(summary, out)
            full, q = summary["full_order"], summary["formulations"]["Q"]
            rows.append((edge, n, summary["reduced_model"]["modes"], window, full, q,
                         (summary["integration_wall_s"], summary["run_wall_s"]),
                         (summary["full_cpu_per_s"], summary["integration_cpu_s"])))  # fmt: skip
    print("\nwall time per simulated second (same process, one after the other; integration: "
          "what compare times; run: integration, diagnostics and the path's FE checks):")
    print("| edge (m) | DOFs | modes | window (s) | full order (s/s) | reduced integration, "
          "median of 5 (s/s) | ratio | (compare's single, ratio) | reduced run (s/s) | ratio | "
          "envelope error | cone error |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for edge, n_dofs, modes, window, full, q, (integration, run_wall), _ in rows:
        fw = full["wall_s"]
        print(f"| {edge} | {n_dofs} | {modes} | {window:.0f} | {fw / window:.4g} | "
              f"{integration / window:.3g} | {fw / integration:.0f} | "
              f"{q['wall_s'] / window:.3g}, {fw / q['wall_s']:.0f} | "
              f"{run_wall / window:.3g} | {fw / run_wall:.0f} | "
              f"{_g(q['envelope_error'])} | {_g(q['cone_angle_error'])} |")  # fmt: skip
    print("\nprocess CPU time per simulated second (contention does not inflate it; the full "
          "order's between its first and last progress report, its set-up excluded):")
    print("| edge (m) | window (s) | full order (CPU s/s) | reduced integration (CPU s/s) | ratio |")
    print("|---|---|---|---|---|")
    for edge, _, _, window, _, _, _, (full_cpu, red_cpu) in rows:
        print(f"| {edge} | {window:.0f} | {full_cpu:.4g} | {red_cpu / window:.3g} | "
              f"{full_cpu * window / red_cpu:.0f} |")  # fmt: skip
    for edge, _, _, _, full, _, _, _ in rows:
        if not full["complete"]:
            print(f"  full order at {edge} m incomplete: {full['reason']}")


if __name__ == "__main__":
    main()
