"""Full-order time stepping, old version against this one, side by side in one run.

For each run case (default ``paper-41hz-coarse``) the full-order setup (inflated structure,
reduced model, independent damping, initial state) is built once with this tree and pickled;
then two child processes integrate the same window from it, one importing this tree and one
importing an older source tree given by ``--old`` (e.g. a ``git worktree`` of main before
issue 10: ``git worktree add --detach /tmp/qm-old 55d0bce``). The runs alternate old/new
``--repeat`` times so that both see the same machine load. Each child first integrates one
step (printed: the one-off costs of a fresh process, e.g. loading the compiled kernels, about
1 s for the new version), then times the window. Printed per case: wall time per
simulated second (best of the repeats) and the ratio old/new, in wall and in CPU time (the
CPU time of the child, less disturbed by other jobs on a shared machine; and the CPU time of
its stepping thread alone, which is the wall time where the renewal thread has a core of its
own), Newton iterations and
factorisations per step, and how far the results differ: the |H| drift, the energy E and
the balance E + E_d relative to the kinetic energy, and the modal envelope (max |s_k| over the
window) relative to the largest. Nothing here asserts on timings. Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_fullorder_speed --old /tmp/qm-old/src
    python -m benchmarks.performance.bench_fullorder_speed --old /tmp/qm-old/src --cases paper-41hz \\
        --window 0.05 --repeat 1
    python -m benchmarks.performance.bench_fullorder_speed --old /tmp/qm-old/src --offline "1 in,0.39 in"

``--old fixed`` runs this tree twice instead: the old side with
``FullOrderOptions(newton_policy="fixed")`` (the Newton rules before issue 27), the new side with
the default ``"adaptive"`` (issue 27 item 4; docs/performance.md)::

    python -m benchmarks.performance.bench_fullorder_speed --old fixed --cases paper-41hz \
        --window 0.05 --repeat 2

``--old one-thread`` runs this tree twice: the old side with ``QUADMODES_THREADS=1`` (the
preconditioner renewed on the stepping thread), the new side with the environment's
``QUADMODES_THREADS`` (set it to 2 for the renewal on a second thread; the default is one
thread since session 14; issue 27 item 4, docs/performance.md)::

    QUADMODES_THREADS=2 python -m benchmarks.performance.bench_fullorder_speed --old one-thread \
        --cases paper-41hz --window 0.05 --repeat 2

``--offline`` times the offline build instead (mesh + structure, inflation, 10 modes of
``paper-membrane`` at the given mesh edges), old and new, with the differences of the inflated
state and the frequencies.
"""

from __future__ import annotations

import argparse
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

NEW_SRC = Path(__file__).resolve().parents[2] / "src"
SERIES = ("t", "H_norm", "H_discrete", "E", "E_d", "T", "modal_coordinates")


def child(setup_file: str, window: float, dt: float, out: str) -> None:
    """Integrate the pickled setup over [0, window] with whatever quadmodes is importable
    (``$QM_NEWTON_POLICY``: the Newton policy, if set)."""
    from quadmodes.fullorder.integrator import integrate_full_order

    with open(setup_file, "rb") as fh:
        st = pickle.load(fh)
    save_every = max(1, int(round(st.sample_interval / dt)))

    options = dict(model=st.model, damping=st.integrator_damping(), save_every=save_every,
                   hub=st.hub, spin_axis=st.spin_axis)  # fmt: skip
    if os.environ.get("QM_NEWTON_POLICY"):
        options["newton_policy"] = os.environ["QM_NEWTON_POLICY"]
    try:  # an options object since issue 23; an older tree takes them as keywords
        from quadmodes.fullorder.options import FullOrderOptions
    except ImportError:
        FullOrderOptions = None  # noqa: N806

    def run(span: float):
        if FullOrderOptions is None:
            return integrate_full_order(st.structure, st.x_ref, st.x0, st.v0, (0.0, span), dt,
                                        **options)  # fmt: skip
        return integrate_full_order(st.structure, st.x_ref, st.x0, st.v0, (0.0, span), dt,
                                    FullOrderOptions(**options))  # fmt: skip

    start = time.perf_counter()
    run(dt)  # one step: the one-off costs of a process (first calls, compiled kernels)
    first = time.perf_counter() - start
    load = os.getloadavg()[0]
    start, cpu, main = time.perf_counter(), time.process_time(), time.thread_time()
    sol = run(window)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    main = time.thread_time() - main  # the stepping thread's: wall time on free cores
    arrays = {k: np.asarray(getattr(sol, k)) for k in SERIES}
    np.savez(out, wall=wall, cpu=cpu, main=main, first=first,
             load=(load + os.getloadavg()[0]) / 2, n_steps=sol.stats["n_steps"], n_newton=sol.stats["n_newton"],
             n_factor=sol.stats["n_factor"], **arrays)  # fmt: skip


def offline_child(case_name: str, edge: str, n_modes: int, out: str) -> None:
    """Offline build (mesh + structure, inflation, modes) of ``case_name`` at mesh edge
    ``edge`` with whatever quadmodes is importable: stage times and results to ``out``."""
    from quadmodes.case import load_case, parse_quantity
    from quadmodes.structure import modes as qmodes
    from quadmodes.structure import pipeline

    base = load_case(case_name)
    h = parse_quantity(edge, "length", "--offline")
    case = base.model_copy(update={"mesh": base.mesh.model_copy(update={"edge_length": h})})
    t0 = time.perf_counter()
    structure = pipeline.structure_for_case(case)
    t1 = time.perf_counter()
    x, _ = pipeline.reference_state(case, structure)
    t2 = time.perf_counter()
    freqs = qmodes.compute_modes(pipeline.with_gas_law(case, structure, x), x, n_modes)
    t3 = time.perf_counter()
    np.savez(out, x=x, f=np.asarray(freqs.frequencies_hz), mesh=t1 - t0, inflate=t2 - t1,
             modes=t3 - t2)  # fmt: skip


def offline(old_src: Path, edges: str, n_modes: int, tmp: Path) -> None:
    """Print old/new stage times of the offline build of paper-membrane per mesh edge."""
    print("\n| edge | nodes | stage | old (s) | new (s) | old / new |\n|---|---|---|---|---|---|")
    for edge in (e.strip() for e in edges.split(",")):
        res = {}
        for label, src in (("old", old_src), ("new", NEW_SRC)):
            out = tmp / f"offline-{label}.npz"
            env = dict(os.environ, PYTHONPATH=str(src), OPENBLAS_NUM_THREADS="1")
            cmd = [sys.executable, __file__, "--offline-child", "paper-membrane", edge,
                   str(n_modes), str(out)]  # fmt: skip
            subprocess.run(cmd, env=env, check=True)
            with np.load(out) as z:
                res[label] = {k: z[k] for k in z.files}
        old, new = res["old"], res["new"]
        for stage in ("mesh", "inflate", "modes"):
            a, b = float(old[stage]), float(new[stage])
            print(f"| {edge} | {old['x'].shape[0]} | {stage} | {a:.2f} | {b:.2f} | {a / b:.2f} |")
        df = float(np.max(np.abs(new["f"] - old["f"]) / old["f"]))
        dx = float(np.abs(new["x"] - old["x"]).max() / np.ptp(old["x"], axis=0).max())
        print(f"| {edge} | | max Δf/f {df:.1e}, max Δx/extent {dx:.1e} | | | |", flush=True)


def build_setup(case: str, folder: Path) -> Path:
    """Pickle the full-order setup of ``case`` (a run case name or .toml file, e.g.
    ``benchmarks/cases/paper-20hz.toml``; this tree) into ``folder`` (kept if there)."""
    from quadmodes.analysis.full_order_runs import setup_for_run

    path = folder / f"{Path(case).stem if case.endswith('.toml') else case}.pkl"
    if path.is_file():
        return path
    st = setup_for_run(case)
    st.structure.pattern_cache.clear()  # plain arrays only: both trees unpickle it
    with open(path, "wb") as fh:
        pickle.dump(st, fh)
    return path


def run_child(src: Path | str, setup: Path, window: float, dt: float, out: Path) -> dict:
    """One child on ``src`` (a src/ folder, or "fixed"/"adaptive": this tree, that policy, or
    "one-thread": this tree with ``QUADMODES_THREADS=1``)."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    env.pop("QM_NEWTON_POLICY", None)
    if str(src) == "one-thread":
        env["QUADMODES_THREADS"], src = "1", NEW_SRC
    if str(src) in ("fixed", "adaptive"):
        env["QM_NEWTON_POLICY"], src = str(src), NEW_SRC
    env["PYTHONPATH"] = str(src)
    cmd = [sys.executable, __file__, "--child", str(setup), str(window), str(dt), str(out)]
    subprocess.run(cmd, env=env, check=True)
    with np.load(out) as z:
        return {k: z[k] for k in z.files}


def differences(old: dict, new: dict) -> dict:
    """Result differences of two runs on the same samples (relative, see module docstring)."""
    if old["t"].shape != new["t"].shape or np.abs(old["t"] - new["t"]).max() > 1e-12:
        raise RuntimeError("the two runs sampled different times")
    drift = lambda r: r["H_norm"] / r["H_norm"][0] - 1.0  # noqa: E731
    t_scale = float(np.max(np.abs(old["T"])))
    env_old = np.abs(old["modal_coordinates"]).max(axis=0)
    env_new = np.abs(new["modal_coordinates"]).max(axis=0)
    return {
        "H_drift": float(np.max(np.abs(drift(new) - drift(old)))),
        "H_drift_old": float(np.max(np.abs(drift(old)))),
        "E": float(np.max(np.abs(new["E"] - old["E"]))) / t_scale,
        "E_balance": float(np.max(np.abs((new["E"] + new["E_d"]) - (old["E"] + old["E_d"]))))
        / t_scale,
        "envelope": float(np.max(np.abs(env_new - env_old)) / env_old.max()),
        "modal": float(np.max(np.abs(new["modal_coordinates"] - old["modal_coordinates"]))
                       / env_old.max()),  # fmt: skip
    }


def measure(case: str, old_src: Path, window: float, dt: float, repeat: int, tmp: Path,
            setups: Path) -> dict:  # fmt: skip
    setup = build_setup(case, setups)
    case = setup.stem  # a .toml file: its name
    runs = {"old": [], "new": []}
    for k in range(repeat):
        for label, src in (("old", old_src), ("new", NEW_SRC)):
            runs[label].append(run_child(src, setup, window, dt, tmp / f"{case}-{label}-{k}.npz"))
            last = runs[label][-1]
            print(f"  {case} {label} run {k + 1}: {float(last['wall']):.1f} s wall, "
                  f"{float(last['cpu']):.1f} s CPU, {float(last['main']):.1f} s CPU of the "
                  f"stepping thread, load {float(last['load']):.1f} (one step before it, in a "
                  f"fresh process: {float(last['first']):.2f} s)", flush=True)  # fmt: skip
    best = {label: min(float(r["wall"]) for r in rs) for label, rs in runs.items()}
    cpu = {label: min(float(r["cpu"]) for r in rs) for label, rs in runs.items()}
    main = {label: min(float(r["main"]) for r in rs) for label, rs in runs.items()}
    old, new = runs["old"][0], runs["new"][0]
    steps = int(new["n_steps"])
    return {
        "case": case, "window": window, "dt": dt, "steps": steps,
        "old_s": best["old"] / window, "new_s": best["new"] / window,
        "ratio": best["old"] / best["new"], "cpu_ratio": cpu["old"] / cpu["new"],
        "main_ratio": main["old"] / main["new"],
        "old_main_s": main["old"] / window, "new_main_s": main["new"] / window,
        "old_newton": int(old["n_newton"]) / steps, "new_newton": int(new["n_newton"]) / steps,
        "old_factor": int(old["n_factor"]) / steps, "new_factor": int(new["n_factor"]) / steps,
        "diff": differences(old, new),
    }  # fmt: skip


def report(rows: list[dict]) -> None:
    print("\n| case | window (s) | steps | old (s per sim. s) | new (s per sim. s) | old / new "
          "| CPU old / new | stepping thread's CPU s per sim. s, old → new | its old / new "
          "| Newton/step old → new | factorisations/step old → new |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {r['window']:g} | {r['steps']} | {r['old_s']:.1f} | "
              f"{r['new_s']:.1f} | **{r['ratio']:.2f}** | {r['cpu_ratio']:.2f} | "
              f"{r['old_main_s']:.1f} → {r['new_main_s']:.1f} | {r['main_ratio']:.2f} | "
              f"{r['old_newton']:.2f} → "
              f"{r['new_newton']:.2f} | {r['old_factor']:.3f} → {r['new_factor']:.4f} |")  # fmt: skip
    print("\n| case | Δ|H| drift | |H| drift (old) | ΔE / T | Δ(E + E_d) / T | Δ envelope "
          "| Δ modal coordinates |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        d = r["diff"]
        print(f"| {r['case']} | {d['H_drift']:.1e} | {d['H_drift_old']:.1e} | {d['E']:.1e} | "
              f"{d['E_balance']:.1e} | {d['envelope']:.1e} | {d['modal']:.1e} |")  # fmt: skip


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5])
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--offline-child":
        offline_child(sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5])
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old", required=True, type=Path,
                    help='src/ folder of the old version, or "fixed": this tree with the Newton '
                         'policy before issue 27, or "one-thread": this tree on one thread')  # fmt: skip
    ap.add_argument("--cases", default="paper-41hz-coarse", help="comma-separated run cases")
    ap.add_argument("--window", type=float, default=0.2, help="simulated window (s)")
    ap.add_argument("--dt", type=float, default=2.5e-4, help="full-order step (s)")
    ap.add_argument("--repeat", type=int, default=2, help="old/new pairs per case")
    ap.add_argument("--offline", default=None,
                    help='instead: the offline build of paper-membrane at these mesh edges, '
                         'e.g. "1 in,0.39 in" (inflation + 10 modes)')  # fmt: skip
    ap.add_argument("--setups", type=Path, default=None,
                    help="folder keeping the pickled setups between runs (default: temporary)")
    args = ap.parse_args()
    if str(args.old) in ("fixed", "one-thread"):
        args.old = str(args.old)
    elif not (args.old / "quadmodes" / "__init__.py").is_file():
        print(f"error: --old {args.old}: not a source folder with quadmodes/ in it; give the "
              "src/ of a checkout of the old version", file=sys.stderr)  # fmt: skip
        raise SystemExit(2)
    rows = []
    if args.offline:
        with tempfile.TemporaryDirectory() as tmp:
            offline(args.old, args.offline, 10, Path(tmp))
        return
    with tempfile.TemporaryDirectory() as tmp:
        for case in args.cases.split(","):
            setups = args.setups if args.setups is not None else Path(tmp)
            setups.mkdir(parents=True, exist_ok=True)
            rows.append(measure(case.strip(), args.old, args.window, args.dt, args.repeat,
                                Path(tmp), setups))  # fmt: skip
    report(rows)


if __name__ == "__main__":
    main()
