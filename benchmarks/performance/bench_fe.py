"""Finite-element performance benchmark for quadmodes (a plain script, not a test).

Two parts:

1. Element kernel throughput of the paper-membrane case's membrane set (``MembraneSet.force``,
   ``MembraneSet.stiffness``) at the case's default mesh and a finer one, plus global assembly
   (``quadmodes.fe.model.internal_force`` / ``tangent_stiffness``) calls per second.
2. The whole modal build of the paper model (mesh + structure, inflation, 10 modes) at about 5k,
   20k and 80k nodes, with the growth exponent between sizes, a breakdown of where the time goes
   (tangent assembly, residual assembly, SuperLU factorisation, triangular solves, Lanczos) and the
   first five elastic frequencies (a mesh-convergence record).

Usage::

    python -m benchmarks.performance.bench_fe                        # kernels + 5k, 20k, 80k
    python -m benchmarks.performance.bench_fe --sizes 5k,20k --markdown /tmp/bench.md
    python -m benchmarks.performance.bench_fe --skip-kernels --sizes 80k
    python -m benchmarks.performance.bench_fe --skip-kernels --one-step --sizes 5k,20k,80k

Threads are left at their defaults (``OPENBLAS_NUM_THREADS`` etc. are not touched); the script
prints ``os.cpu_count()`` and the numpy BLAS configuration. Nothing here asserts on timings.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import math
import os
import platform
import resource
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy
import scipy.sparse.linalg as spla

import quadmodes.structure.modes as qmodes
import quadmodes.structure.prestress as qprestress
from quadmodes.case import Case, load_case
from quadmodes.fe.membrane import MembraneSet
from quadmodes.fe.model import Structure, internal_force, tangent_stiffness, with_load_factor
from quadmodes.structure import pipeline

T0 = time.perf_counter()


def log(message: str) -> None:
    """A progress line with the elapsed wall time, flushed at once."""
    print(f"[{time.perf_counter() - T0:8.1f} s] {message}", flush=True)


# --------------------------------------------------------------------------------------------
# Tables (plain text for the terminal, Markdown for --markdown)


@dataclass
class Table:
    title: str
    header: list[str]
    rows: list[list[str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def add(self, *cells: object) -> None:
        self.rows.append([str(c) for c in cells])

    def text(self) -> str:
        widths = [
            max(len(r[i]) for r in [self.header, *self.rows]) for i in range(len(self.header))
        ]
        line = "  ".join("-" * w for w in widths)
        out = [
            self.title,
            line,
            "  ".join(h.rjust(w) for h, w in zip(self.header, widths, strict=True)),
        ]
        out.append(line)
        out += ["  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in self.rows]
        out += [line, *self.notes]
        return "\n".join(out)

    def markdown(self) -> str:
        out = [f"### {self.title}", "", "| " + " | ".join(self.header) + " |"]
        out.append("|" + "|".join("---:" for _ in self.header) + "|")
        out += ["| " + " | ".join(r) + " |" for r in self.rows]
        if self.notes:
            out += ["", *self.notes]
        return "\n".join(out)


def fmt_rate(x: float) -> str:
    return f"{x / 1e6:.2f} M" if x >= 1e6 else f"{x / 1e3:.1f} k"


def fmt_s(x: float) -> str:
    return f"{x:.2f}" if x < 100 else f"{x:.0f}"


# --------------------------------------------------------------------------------------------
# Environment


def blas_description() -> str:
    try:
        blas = np.show_config(mode="dicts")["Build Dependencies"]["blas"]
        text = f"{blas.get('name', '?')} {blas.get('version', '')}".strip()
    except Exception:  # older numpy without mode="dicts"
        text = "unknown"
    try:
        from threadpoolctl import threadpool_info

        pools = [
            f"{p.get('internal_api')} {p.get('version')} ({p.get('num_threads')} threads)"
            for p in threadpool_info()
        ]
        if pools:
            text += "; threadpoolctl: " + ", ".join(pools)
    except ImportError:
        text += "; threadpoolctl not installed (thread counts at library defaults)"
    return text


def environment_lines() -> list[str]:
    threads = {
        k: os.environ[k]
        for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
        if k in os.environ
    }
    return [
        f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}",
        f"BLAS: {blas_description()}",
        f"os.cpu_count() = {os.cpu_count()}; thread variables: {threads or 'none set'}",
        f"machine: {platform.machine()} {platform.processor() or ''} {platform.system()}".rstrip(),
    ]


def peak_rss_gb() -> float:
    """Peak resident set size of this process so far (GB; Linux reports kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


# --------------------------------------------------------------------------------------------
# Helpers


def with_edge_length(case: Case, h: float) -> Case:
    return case.model_copy(update={"mesh": case.mesh.model_copy(update={"edge_length": h})})


def parse_size(token: str) -> int:
    """``"5k"`` -> 5000, ``"1.5k"`` -> 1500, ``"80000"`` -> 80000."""
    t = token.strip().lower()
    scale = 1000 if t.endswith("k") else 1
    return int(round(float(t.rstrip("k")) * scale))


def edge_for_nodes(case: Case, target: int, rtol: float = 0.03, max_meshes: int = 8) -> float:
    """Edge length giving about ``target`` nodes. The mesher refines at caps and end-body rims,
    so nodes are not exactly ∝ 1/h²: secant iteration on log n(log h), starting from slope −2."""
    h = case.mesh.edge_length
    log_h, log_n = [], []
    for _ in range(max_meshes):
        n = pipeline.structure_for_case(with_edge_length(case, h)).n
        log_h.append(math.log(h))
        log_n.append(math.log(n))
        if abs(n / target - 1.0) <= rtol:
            break
        slope = -2.0
        if len(log_h) > 1 and log_h[-1] != log_h[-2]:
            secant = (log_n[-1] - log_n[-2]) / (log_h[-1] - log_h[-2])
            slope = min(max(secant, -3.0), -0.5)
        h = math.exp(log_h[-1] + (math.log(target) - log_n[-1]) / slope)
    best = min(range(len(log_n)), key=lambda i: abs(log_n[i] - math.log(target)))
    return math.exp(log_h[best])


def repeat_rate(fn: Callable[[], object], min_time: float) -> tuple[float, int]:
    """Mean seconds per call of ``fn`` over doubling batches run for ≥ ``min_time`` in total."""
    fn()  # warm-up
    calls, elapsed, batch = 0, 0.0, 1
    while elapsed < min_time:
        t = time.perf_counter()
        for _ in range(batch):
            fn()
        elapsed += time.perf_counter() - t
        calls += batch
        batch *= 2
    return elapsed / calls, calls


def membrane_of(structure: Structure) -> MembraneSet:
    sets = [e for e in structure.elements if isinstance(e, MembraneSet)]
    if not sets:
        raise SystemExit("the case has no membrane element set")
    return sets[0]


# --------------------------------------------------------------------------------------------
# Part 1: element kernels and global assembly


def bench_kernels(case: Case, fine_factor: float, min_time: float) -> Table:
    h0 = case.mesh.edge_length
    table = Table(
        "Element kernels and global assembly (paper-membrane)",
        [
            "mesh",
            "h (mm)",
            "nodes",
            "membrane elems",
            "force (elem/s)",
            "stiffness (elem/s)",
            "force+stiffness (elem/s)",
            "internal_force (calls/s)",
            "tangent_stiffness (calls/s)",
        ],
        notes=[
            f"Each figure is the mean over repeated calls for ≥ {min_time:g} s. The state is the "
            "stress-free reference plus a 0.1 mm random perturbation (the kernels' cost does not "
            "depend on the state). Global assembly covers all element sets (membrane, pressure, "
            "end-body ties) and the sparse COO→CSR scatter."
        ],
    )
    rng = np.random.default_rng(0)
    for label, h in (("default", h0), (f"fine (h/{fine_factor:g})", h0 / fine_factor)):
        structure = pipeline.structure_for_case(with_edge_length(case, h))
        x = structure.reference + 1e-4 * rng.standard_normal(structure.reference.shape)
        mem = membrane_of(structure)
        ne = mem.conn.shape[0]
        t_f, _ = repeat_rate(lambda mem=mem, x=x: mem.force(x), min_time)
        t_k, _ = repeat_rate(lambda mem=mem, x=x: mem.stiffness(x), min_time)
        t_fk, _ = repeat_rate(lambda mem=mem, x=x: (mem.force(x), mem.stiffness(x)), min_time)
        t_if, _ = repeat_rate(lambda s=structure, x=x: internal_force(s, x), min_time)
        t_ts, _ = repeat_rate(lambda s=structure, x=x: tangent_stiffness(s, x), min_time)
        table.add(
            label,
            f"{1e3 * h:.2f}",
            structure.n,
            ne,
            fmt_rate(ne / t_f),
            fmt_rate(ne / t_k),
            fmt_rate(ne / t_fk),
            f"{1 / t_if:.1f}",
            f"{1 / t_ts:.2f}",
        )
        log(
            f"kernels {label}: {ne} elements; force {1e3 * t_f:.2f} ms, stiffness "
            f"{1e3 * t_k:.2f} ms, internal_force {1e3 * t_if:.2f} ms, "
            f"tangent_stiffness {1e3 * t_ts:.1f} ms per call"
        )
    return table


# --------------------------------------------------------------------------------------------
# Part 2: whole build, with timing wrappers that attribute time to the expensive calls

Accumulator = defaultdict[str, list[float]]  # key -> [seconds, calls]


def _add(acc: Accumulator, key: str, dt: float) -> None:
    acc[key][0] += dt
    acc[key][1] += 1


class _TimedLU:
    """Proxy of a SuperLU object that times ``solve``."""

    def __init__(self, lu, acc: Accumulator) -> None:
        self._lu, self._acc = lu, acc

    def solve(self, *args, **kwargs):
        t = time.perf_counter()
        try:
            return self._lu.solve(*args, **kwargs)
        finally:
            _add(self._acc, "solve", time.perf_counter() - t)

    def __getattr__(self, name: str):
        return getattr(self._lu, name)


@contextlib.contextmanager
def instrumented(acc: Accumulator, history: list[float] | None = None) -> Iterator[None]:
    """Temporarily wrap splu (factorisation; its solves), eigsh, and the assembly functions as
    seen by quadmodes.structure.prestress and quadmodes.structure.modes, accumulating (seconds, calls) in ``acc``.
    With ``history``, the norm over free DOFs of every internal-force evaluation (Newton iterates
    and line-search trials) is appended to it, outside the timed region. Names that no longer
    exist are skipped, so the benchmark survives refactoring."""
    patches: list[tuple[object, str, object]] = []

    def timed(key: str, fn: Callable) -> Callable:
        @functools.wraps(fn)
        def wrapper(*args, **kwargs):
            t = time.perf_counter()
            try:
                out = fn(*args, **kwargs)
            finally:
                _add(acc, key, time.perf_counter() - t)
            if key == "residual" and history is not None and args:
                history.append(float(np.linalg.norm(out.ravel()[args[0].free_dofs])))
            return out

        return wrapper

    def patch(owner: object, name: str, key: str) -> None:
        if hasattr(owner, name):
            original = getattr(owner, name)
            patches.append((owner, name, original))
            setattr(owner, name, timed(key, original))

    original_splu = spla.splu

    def splu(*args, **kwargs):
        t = time.perf_counter()
        lu = original_splu(*args, **kwargs)
        _add(acc, "splu", time.perf_counter() - t)
        acc["lu_nnz"][0] = float(lu.nnz)
        acc["lu_nnz"][1] = float(args[0].shape[0]) if args else 0.0
        return _TimedLU(lu, acc)

    patches.append((spla, "splu", original_splu))
    spla.splu = splu
    patch(spla, "eigsh", "eigsh")
    for module in (qprestress, qmodes):
        patch(module, "tangent_stiffness", "tangent")
        patch(module, "internal_force", "residual")
    try:
        yield
    finally:
        for owner, name, original in reversed(patches):
            setattr(owner, name, original)


@dataclass
class BuildResult:
    target: int
    h: float
    nodes: int
    dofs: int
    t_structure: float
    t_inflate: float
    iterations: int
    residual: float
    residual_history: list[float]
    t_modes: float
    frequencies: np.ndarray
    breakdown: dict[str, Accumulator]
    rss_gb: float

    @property
    def total(self) -> float:
        return self.t_structure + self.t_inflate + self.t_modes


def bench_build(case: Case, target: int, h: float, n_modes: int) -> BuildResult:
    c = with_edge_length(case, h)
    log(f"build ~{target} nodes: h = {1e3 * h:.3f} mm")
    t = time.perf_counter()
    structure = pipeline.structure_for_case(c)
    t_structure = time.perf_counter() - t
    log(
        f"  mesh+structure {t_structure:.2f} s: {structure.n} nodes, "
        f"{structure.free_dofs.size} DOFs"
    )

    def progress(stage: str, fraction: float) -> None:
        log(f"  {stage} load factor {fraction:.3f} reached ({time.perf_counter() - t:.1f} s)")

    breakdown: dict[str, Accumulator] = {}
    breakdown["inflation"] = defaultdict(lambda: [0.0, 0])
    history: list[float] = []
    t = time.perf_counter()
    with instrumented(breakdown["inflation"], history):
        x, state = pipeline.reference_state(c, structure, progress)
    t_inflate = time.perf_counter() - t
    iterations = state.iterations if state is not None else 0
    residual = state.residual_norm if state is not None else 0.0
    log(
        f"  inflation {t_inflate:.2f} s, {iterations} Newton iterations, final relative "
        f"residual {residual:.2e}"
    )
    if history:
        log(
            "  residual norms over free DOFs / first (every force evaluation): "
            + " ".join(f"{v / history[0]:.1e}" for v in history)
        )

    breakdown["modes"] = defaultdict(lambda: [0.0, 0])
    t = time.perf_counter()
    with instrumented(breakdown["modes"]):
        result = qmodes.compute_modes(structure, x, n_modes)
    t_modes = time.perf_counter() - t
    freqs = np.asarray(result.frequencies_hz)
    log(
        f"  modes {t_modes:.2f} s; first elastic frequencies (Hz): "
        + ", ".join(f"{f:.3f}" for f in freqs[:5])
    )
    res = BuildResult(
        target,
        h,
        structure.n,
        int(structure.free_dofs.size),
        t_structure,
        t_inflate,
        iterations,
        residual,
        [v / history[0] for v in history] if history else [],
        t_modes,
        freqs,
        breakdown,
        peak_rss_gb(),
    )
    log(f"  total {res.total:.2f} s; peak RSS so far {res.rss_gb:.2f} GB")
    return res


def build_tables(results: Sequence[BuildResult], n_modes: int) -> list[Table]:
    sizes = Table(
        f"Whole build of paper-membrane (mesh + structure, inflation, {n_modes} modes)",
        [
            "target",
            "h (mm)",
            "nodes",
            "DOFs",
            "mesh+structure (s)",
            "inflation (s)",
            "Newton its",
            "final rel. residual",
            "modes (s)",
            "total (s)",
            "peak RSS (GB)",
        ],
        notes=[
            "Peak RSS is the process high-water mark so far (sizes run in ascending order). "
            "Newton its is PrestressedState.iterations; the final relative residual is "
            "PrestressedState.residual_norm (solve_static's own scaling)."
        ],
    )
    for r in results:
        sizes.add(
            f"{r.target / 1000:g}k",
            f"{1e3 * r.h:.2f}",
            r.nodes,
            r.dofs,
            fmt_s(r.t_structure),
            fmt_s(r.t_inflate),
            r.iterations,
            f"{r.residual:.1e}",
            fmt_s(r.t_modes),
            fmt_s(r.total),
            f"{r.rss_gb:.2f}",
        )
    tables = [sizes]

    if len(results) > 1:
        growth = Table(
            "Growth exponents  p = log(t2/t1) / log(n2/n1)  (time ∝ nodes^p)",
            ["from → to", "node ratio", "mesh+structure", "inflation", "modes", "total"],
        )
        for a, b in zip(results[:-1], results[1:], strict=True):
            ln = math.log(b.nodes / a.nodes)

            def p(ta: float, tb: float, ln: float = ln) -> str:
                return f"{math.log(tb / ta) / ln:.2f}"

            growth.add(
                f"{a.nodes} → {b.nodes}",
                f"{b.nodes / a.nodes:.2f}",
                p(a.t_structure, b.t_structure),
                p(a.t_inflate, b.t_inflate),
                p(a.t_modes, b.t_modes),
                p(a.total, b.total),
            )
        tables.append(growth)

    where = Table(
        "Where the time goes (seconds, calls in parentheses)",
        [
            "nodes",
            "stage",
            "stage (s)",
            "tangent assembly",
            "residual assembly",
            "SuperLU factorisation",
            "LU solves",
            "eigsh (incl. its solves)",
            "other",
            "LU nnz / n",
        ],
        notes=[
            "Measured by timing wrappers around scipy.sparse.linalg.splu (factorisation and the "
            "SuperLU.solve calls), scipy.sparse.linalg.eigsh and the tangent_stiffness / "
            "internal_force used by quadmodes.structure.prestress and quadmodes.structure.modes. 'other' is the rest "
            "of the stage: sparse slicing [free][:, free], bordered-matrix construction, mass "
            "matrix, rigid-body projections, line-search bookkeeping, stress report. In the "
            "modes stage the eigsh column includes the shift-invert solves and ARPACK's own work. "
            "'LU nnz / n' is the fill of the last factorisation (nonzeros of L+U per matrix row)."
        ],
    )
    for r in results:
        for stage, t_stage in (("inflation", r.t_inflate), ("modes", r.t_modes)):
            acc = r.breakdown[stage]

            def cell(key: str, acc: Accumulator = acc) -> str:
                s, n = acc.get(key, (0.0, 0))
                return f"{s:.2f} ({int(n)})" if n else "-"

            accounted = sum(acc.get(k, (0.0, 0))[0] for k in ("tangent", "residual", "splu"))
            accounted += acc.get("eigsh", (0.0, 0))[0] or acc.get("solve", (0.0, 0))[0]
            nnz, rows = acc.get("lu_nnz", (0.0, 0.0))
            where.add(
                r.nodes,
                stage,
                fmt_s(t_stage),
                cell("tangent"),
                cell("residual"),
                cell("splu"),
                cell("solve"),
                cell("eigsh"),
                f"{t_stage - accounted:.2f}",
                f"{nnz / rows:.0f}" if rows else "-",
            )
    tables.append(where)

    freq = Table(
        "First five elastic frequencies (Hz) — mesh-convergence record",
        ["nodes", "h (mm)", "f1", "f2", "f3", "f4", "f5"],
    )
    for r in results:
        fs = [f"{f:.3f}" for f in r.frequencies[:5]]
        freq.add(r.nodes, f"{1e3 * r.h:.2f}", *(fs + ["-"] * (5 - len(fs))))
    tables.append(freq)
    return tables


def bench_one_step(case: Case, targets: Sequence[int]) -> Table:
    """One full-load Newton step of ``solve_static`` from the stress-free shape per size: the unit
    of work the inflation repeats, for sizes too large (or too slow) for the whole build."""
    table = Table(
        "One Newton step of the inflation (full load, from the stress-free shape)",
        [
            "nodes",
            "DOFs",
            "step (s)",
            "tangent assembly (s)",
            "SuperLU factorisation (s)",
            "LU solves (s)",
            "residual evaluations (s)",
            "LU nnz / n",
            "peak RSS (GB)",
        ],
        notes=[
            "solve_static(..., max_iterations=1) run through its first iteration (tangent, "
            "bordered factorisation, solve, line search); the ConvergenceError it then raises is "
            "expected. Multiply by the Newton iteration count for an inflation estimate."
        ],
    )
    for target in targets:
        h = edge_for_nodes(case, target)
        structure = pipeline.structure_for_case(with_edge_length(case, h))
        loaded = with_load_factor(structure, 1.0)
        acc: Accumulator = defaultdict(lambda: [0.0, 0])
        t = time.perf_counter()
        with instrumented(acc), contextlib.suppress(qprestress.ConvergenceError):
            qprestress.solve_static(loaded, structure.reference, max_iterations=1)
        dt = time.perf_counter() - t
        nnz, rows = acc.get("lu_nnz", (0.0, 0.0))
        table.add(
            structure.n,
            structure.free_dofs.size,
            fmt_s(dt),
            f"{acc['tangent'][0]:.2f}",
            f"{acc['splu'][0]:.2f}",
            f"{acc['solve'][0]:.2f}",
            f"{acc['residual'][0]:.2f} ({int(acc['residual'][1])})",
            f"{nnz / rows:.0f}" if rows else "-",
            f"{peak_rss_gb():.2f}",
        )
        log(
            f"one step ~{target} nodes ({structure.n}): {dt:.2f} s, factorisation "
            f"{acc['splu'][0]:.2f} s, tangent {acc['tangent'][0]:.2f} s"
        )
    return table


# --------------------------------------------------------------------------------------------


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", default="paper-membrane", help="case name or TOML path")
    parser.add_argument(
        "--sizes",
        default="5k,20k,80k",
        help="comma-separated target node counts for the whole build, e.g. 5k,20k (default: "
        "%(default)s); 'none' skips the build part",
    )
    parser.add_argument("--modes", type=int, default=10, help="elastic modes (default 10)")
    parser.add_argument("--min-time", type=float, default=1.0, help="seconds per kernel timing")
    parser.add_argument(
        "--fine-factor", type=float, default=2.0, help="finer kernel mesh: h / this (default 2)"
    )
    parser.add_argument("--skip-kernels", action="store_true", help="skip the kernel part")
    parser.add_argument(
        "--one-step",
        action="store_true",
        help="instead of the whole build, time one inflation Newton step per size",
    )
    parser.add_argument("--markdown", metavar="FILE", help="also write the tables as Markdown")
    args = parser.parse_args(argv)

    case = load_case(args.case)
    if case.kind != "membrane":
        parser.error(f"{args.case} is not a membrane case")
    targets = (
        []
        if args.sizes.strip().lower() == "none"
        else sorted({parse_size(s) for s in args.sizes.split(",") if s.strip()})
    )

    env = environment_lines()
    print("\n".join(env), flush=True)
    command = "python " + " ".join([os.path.relpath(sys.argv[0]), *sys.argv[1:]])
    tables: list[Table] = []

    if not args.skip_kernels:
        log("part 1: element kernels")
        tables.append(bench_kernels(case, args.fine_factor, args.min_time))
        print("\n" + tables[-1].text() + "\n", flush=True)

    results: list[BuildResult] = []
    if targets:
        h0 = case.mesh.edge_length
        n0 = pipeline.structure_for_case(case).n
        log(f"part 2 at {targets} nodes (default mesh: {n0} nodes at h = {h0} m)")
        if args.one_step:
            tables.append(bench_one_step(case, targets))
            targets = []
        for target in targets:
            h = edge_for_nodes(case, target)  # meshing for the search is not timed
            results.append(bench_build(case, target, h, args.modes))
            if args.markdown:  # keep what finished if a later, larger size is interrupted
                partial = tables + build_tables(results, args.modes)
                write_markdown(args.markdown, command, env, partial)
        if results:
            tables += build_tables(results, args.modes)

    for t in tables[0 if args.skip_kernels or not tables else 1 :]:
        print("\n" + t.text(), flush=True)
    for r in results:
        if 15_000 <= r.nodes <= 25_000:
            verdict = "met" if r.t_inflate + r.t_modes <= 60.0 else "NOT met"
            print(
                f"\ntarget '20k nodes inflate + {args.modes} modes <= 60 s': {verdict} "
                f"({r.nodes} nodes: inflate + modes {r.t_inflate + r.t_modes:.1f} s, "
                f"total with meshing {r.total:.1f} s)",
                flush=True,
            )
    if args.markdown:
        write_markdown(args.markdown, command, env, tables)
        log(f"wrote {args.markdown}")
    return 0


def write_markdown(path: str, command: str, env: list[str], tables: Sequence[Table]) -> None:
    lines = [f"Command: `{command}`", "", *[f"- {e}" for e in env], ""]
    for t in tables:
        lines += [t.markdown(), ""]
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
