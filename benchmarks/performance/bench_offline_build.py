"""Offline build of the rim model ``paper-membrane-rim`` (mesh, inflation, 10 modes, labels),
old tree against this one, stage by stage, side by side in one run.

The rim model is what ``paper-membrane`` was before issue 14 (the old tree has only that name;
the recorded figures of docs/performance.md are of it).

Each build runs in a child process with its own ``PYTHONPATH`` (the old tree is a separate
checkout, e.g. ``git worktree add --detach /tmp/qm-old fecf956``, the version before issue 10).
The child times the stages of ``quadmodes modes`` (what ``pipeline.build_modal_model`` does) and
counts the SuperLU factorisations of each stage and their time (a wrapper around
``scipy.sparse.linalg.splu``). ``--backends pardiso`` adds a build of this tree with
``QUADMODES_LINALG=pardiso`` (reported as not installed, and skipped, without pypardiso), on one
core (``MKL_NUM_THREADS=1`` unless set). ``--keep DIR`` keeps each build's state, frequencies
and times.

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_offline_build --old /tmp/qm-old/src \\
        --edges "0.39 in" --repeat 2
    OPENBLAS_NUM_THREADS=1 nice -n 5 python -m benchmarks.performance.bench_offline_build \\
        --old /tmp/qm-old/src --edges "0.195 in"

Prints one table per mesh: stage times (best of ``--repeat``, old and new alternating), their
ratio, the factorisations, and how far the results differ (inflated state, frequencies).
"""

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

NEW_SRC = Path(__file__).resolve().parents[2] / "src"
STAGES = ("mesh", "inflation", "modes", "labels")


def _rim_case(load_case):
    """The rim model the recorded figures are of: ``paper-membrane-rim`` in this tree, which is
    what ``paper-membrane`` was before issue 14 (the old tree has only that name)."""
    try:
        return load_case("paper-membrane-rim")
    except Exception:  # noqa: BLE001 - the old tree: no such case
        return load_case("paper-membrane")


def child(edge: str, n_modes: int, out: str) -> None:
    """The offline build at mesh edge ``edge`` with whatever quadmodes is importable."""
    import scipy.sparse.linalg as spla

    from quadmodes.case import load_case, parse_quantity
    from quadmodes.structure import modes as qmodes
    from quadmodes.structure import pipeline
    from quadmodes.structure.labels import label_modes

    splu, tally = spla.splu, {"n": 0, "t": 0.0}

    def timed_splu(*args, **kwargs):
        start = time.perf_counter()
        try:
            return splu(*args, **kwargs)
        finally:
            tally["n"] += 1
            tally["t"] += time.perf_counter() - start

    spla.splu = timed_splu  # every factorisation of both trees goes through spla.splu
    base = _rim_case(load_case)
    h = parse_quantity(edge, "length", "--edges")
    case = base.model_copy(update={"mesh": base.mesh.model_copy(update={"edge_length": h})})
    times, counts = {}, {}

    def stage(name, start, before):
        times[name] = time.perf_counter() - start
        counts[name] = (tally["n"] - before[0], tally["t"] - before[1])
        return time.perf_counter(), (tally["n"], tally["t"])

    t, mark = time.perf_counter(), (0, 0.0)
    structure = pipeline.structure_for_case(case)
    t, mark = stage("mesh", t, mark)
    x, state = pipeline.reference_state(case, structure)
    t, mark = stage("inflation", t, mark)
    loaded = pipeline.with_gas_law(case, structure, x)
    result = qmodes.compute_modes(loaded, x, n_modes)
    t, mark = stage("modes", t, mark)
    label_modes(loaded, x, result.shapes)
    stage("labels", t, mark)
    np.savez(out, x=x, f=np.asarray(result.frequencies_hz), its=state.iterations,
             **{f"t_{k}": v for k, v in times.items()},
             **{f"n_{k}": v[0] for k, v in counts.items()},
             **{f"lu_{k}": v[1] for k, v in counts.items()})  # fmt: skip


def run(src: Path, edge: str, n_modes: int, out: Path, backend: str | None) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src), OPENBLAS_NUM_THREADS="1")
    env.setdefault("MKL_NUM_THREADS", "1")  # PARDISO on one core, as SuperLU
    env.pop("QUADMODES_LINALG", None)
    if backend:
        env["QUADMODES_LINALG"] = backend
    cmd = [sys.executable, __file__, "--child", edge, str(n_modes), str(out)]
    subprocess.run(cmd, env=env, check=True)
    with np.load(out) as z:
        return {k: z[k] for k in z.files}


def non_rigid(dx: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``dx`` ``(n, 3)`` less its least-squares rigid motion ``t + ω × (x − x̄)`` about ``x``: two
    inflations whose Newton paths differ end up turned against each other by ~1e-8 rad about
    the axis (the frame conditions hold to first order in each step), which is no deformation."""
    arm = x - x.mean(axis=0)
    cols = []
    for e in np.eye(3):
        cols += [np.tile(e, (len(x), 1)).ravel(), np.cross(e, arm).ravel()]
    basis = np.column_stack(cols)
    coef = np.linalg.lstsq(basis, dx.ravel(), rcond=None)[0]
    return (dx.ravel() - basis @ coef).reshape(dx.shape)


def report(edge: str, results: dict) -> None:
    """Print the stage table of one mesh; ``results``: label -> list of child results."""
    best = {label: {s: min(float(r[f"t_{s}"]) for r in rs) for s in STAGES}
            for label, rs in results.items()}  # fmt: skip
    first = {label: rs[0] for label, rs in results.items()}
    old = first["old"]
    labels = list(results)
    print(f"\n### edge {edge}: {old['x'].shape[0]} nodes, best of {len(results['old'])}\n")
    head = " | ".join(f"{lab} (s)" for lab in labels)
    ratios = " | ".join(f"old / {lab}" for lab in labels[1:])
    facts = " | ".join(f"LU {lab} (n, s)" for lab in labels)
    print(f"| stage | {head} | {ratios} | {facts} |")
    print("|---" * (1 + 2 * len(labels) + len(labels) - 1) + "|")
    for s in (*STAGES, "total"):
        t = {lab: (sum(best[lab].values()) if s == "total" else best[lab][s]) for lab in labels}
        lu = []
        for lab in labels:
            r = first[lab]
            n = sum(int(r[f"n_{k}"]) for k in STAGES) if s == "total" else int(r[f"n_{s}"])
            sec = sum(float(r[f"lu_{k}"]) for k in STAGES) if s == "total" else float(r[f"lu_{s}"])
            lu.append(f"{n}, {sec:.1f}")
        cells = " | ".join(f"{t[lab]:.2f}" for lab in labels)
        rat = " | ".join(f"**{t['old'] / t[lab]:.2f}**" if s == "total" else
                         f"{t['old'] / t[lab]:.2f}" for lab in labels[1:])  # fmt: skip
        print(f"| {s} | {cells} | {rat} | {' | '.join(lu)} |")
    extent = float(np.ptp(old["x"], axis=0).max())
    for lab in labels[1:]:
        r = first[lab]
        dx = float(np.abs(r["x"] - old["x"]).max()) / extent
        dx_elastic = float(np.abs(non_rigid(r["x"] - old["x"], old["x"])).max()) / extent
        df = float(np.max(np.abs(r["f"] - old["f"]) / old["f"]))
        print(f"\n{lab} against old: max Δx / extent {dx:.1e} ({dx_elastic:.1e} without the "
              f"rigid part), max Δf / f {df:.1e}; Newton iterations {int(old['its'])} → "
              f"{int(r['its'])}")  # fmt: skip
        each = " ".join(f"{v:.1e}" for v in np.abs(r["f"] - old["f"]) / old["f"])
        print(f"  Δf / f per mode ({' '.join(f'{f:.2f}' for f in old['f'])} Hz): {each}")
    print(flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, required=True, help="src/ folder of the old tree")
    ap.add_argument("--edges", default="0.39 in", help="mesh edge lengths (quantities)")
    ap.add_argument("--modes", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--backends", default="", help='extra back ends of this tree: "pardiso"')
    ap.add_argument("--keep", type=Path, help="folder to keep each build's results in (.npz)")
    args = ap.parse_args()
    backends = [b.strip() for b in args.backends.split(",") if b.strip()]
    if "pardiso" in backends and importlib.util.find_spec("pypardiso") is None:
        print("pardiso: pypardiso is not installed here; that column is skipped")
        backends.remove("pardiso")
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for edge in (e.strip() for e in args.edges.split(",")):
            results = {"old": [], "new": [], **{b: [] for b in backends}}
            for rep in range(args.repeat):
                for label in results:
                    src = args.old if label == "old" else NEW_SRC
                    backend = label if label not in ("old", "new") else None
                    out = folder / f"{label}-{edge.replace(' ', '')}-{rep}.npz"
                    results[label].append(run(src, edge, args.modes, out, backend))
            report(edge, results)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2], int(sys.argv[3]), sys.argv[4])
    else:
        main()
