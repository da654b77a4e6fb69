"""Sparse direct solvers for the full order's Newton matrix on ``paper-41hz`` (issue 27, item 4):
measured, not adopted (docs/performance.md, "Supernodal direct solvers for the Krylov path").

The Krylov path (:mod:`quadmodes.fullorder.krylov`) preconditions GMRES on the Newton matrix
``A = M + (Δt²/2) J`` (18,255 free DOFs on the flange-bonded default) with a kept float32
SuperLU factorisation. This script asks whether a supernodal solver makes the step ≥ 3× cheaper
than main before issue 27 (f590acd); three subcommands, all on the benchmark's pickled setup
(``bench_fullorder_speed --setups``):

``isolated``: capture the Newton systems of some steps of a one-thread run, then on those
matrices: the symmetry of A and the inertia of its symmetric part (negative pivots of an
unpivoted SuperLU of ``(A + Aᵀ)/2``, i.e. of its LDLᵀ); factorisation and solve times, one
thread, of SuperLU float32/float64, CHOLMOD (``scikit-sparse`` if importable: supernodal LLᵀ on
the symmetric part shifted to be definite, for the times only, and simplicial LDLᵀ of the true
symmetric part) and MKL PARDISO (``--mkl-rt``, float32/float64, 1 and 2 threads); and the
preconditioner solves per Newton solve of the run's GMRES with each preconditioner factorised
(a) once per step, (b) at every Newton iterate, (c) kept as the run keeps it.

``breakdown``: a one-thread (or ``QUADMODES_THREADS=2``) run with timers on its parts (per step,
the calling thread's CPU time); ``--pardiso``: the preconditioner factorised by PARDISO float32
(``--cost``: :data:`~quadmodes.fullorder.krylov.FACTOR_COST`, ``--fused``: the compiled
membrane blocks on the stepping thread too, ``--every-step``: renewed at every step).

``side-by-side``: :mod:`benchmarks.performance.bench_fullorder_speed` with ``--old`` against
this tree with the PARDISO overlay (a temporary source folder whose ``sitecustomize`` installs
it; measurement only, nothing in the package changes). Usage::

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.performance.bench_fullorder_solvers \\
        --setup /tmp/setups/paper-41hz.pkl --mkl-rt /path/libmkl_rt.so.3 isolated
    python -m benchmarks.performance.bench_fullorder_solvers --setup ... breakdown --pardiso \\
        --cost 12 --fused --steps 80
    python -m benchmarks.performance.bench_fullorder_solvers --setup ... --mkl-rt ... \\
        side-by-side --old /tmp/old/src --window 0.05 --repeat 2
"""

from __future__ import annotations

import argparse
import ctypes
import os
import pickle
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[2]
DT = 2.5e-4

# ---------------------------------------------------------------------------------------------
# PARDISO (MKL) through ctypes: a float32 LU of the permuted Newton matrix
# ---------------------------------------------------------------------------------------------

_MKL = None


def mkl(path: str | None = None):
    """The MKL runtime library (``path``, else ``$QM_MKL_RT``, else found by name)."""
    global _MKL
    if _MKL is None:
        from ctypes.util import find_library

        name = path or os.environ.get("QM_MKL_RT") or find_library("mkl_rt")
        if not name:
            raise SystemExit("PARDISO: libmkl_rt not found; pip install mkl, then --mkl-rt PATH")
        _MKL = ctypes.CDLL(name)
        _MKL.MKL_Set_Num_Threads(1)
    return _MKL


class Pardiso:
    """One PARDISO handle (one factorisation) of a square matrix given as CSC (indptr, indices):
    the CSC arrays are passed as the CSR of Aᵀ and the transposed solve asked (``iparm[11]``).
    Real unsymmetric (``mtype`` 11), METIS ordering, no scaling or matching (the unpivoted
    SuperLU factorises the same matrix without pivoting), 1e-13 pivot perturbation."""

    def __init__(self, indptr, indices, single: bool = True, threads: int = 1,
                 parallel_solve: bool = False):  # fmt: skip
        self.pt, ip = np.zeros(64, np.int64), np.zeros(64, np.int32)
        ip[[0, 1, 9, 11, 34]] = (1, 2, 13, 2, 1)  # own iparm, METIS, 1e-13, transposed, 0-based
        ip[27] = 1 if single else 0  # float32 factors and solves
        ip[23], ip[24] = (1, 2) if parallel_solve else (0, 0)
        ip[17] = -1  # report the factors' nonzeros
        self.iparm, self.threads = ip, threads
        self.dtype = np.float32 if single else np.float64
        self.n = indptr.size - 1
        self.ia, self.ja = indptr.astype(np.int32), indices.astype(np.int32)
        self.perm = np.zeros(self.n, np.int32)
        self.a = np.ones(indices.size, self.dtype)
        self.analysed = False

    def _call(self, phase: int, b: np.ndarray) -> np.ndarray:
        lib, ptr, i32 = mkl(), ctypes.POINTER, ctypes.c_int32
        lib.MKL_Set_Num_Threads(self.threads)
        x, err = np.zeros_like(b), i32(0)
        ref = ctypes.byref
        lib.pardiso(self.pt.ctypes.data_as(ptr(ctypes.c_int64)), ref(i32(1)), ref(i32(1)),
                    ref(i32(11)), ref(i32(phase)), ref(i32(self.n)),
                    self.a.ctypes.data_as(ctypes.c_void_p), self.ia.ctypes.data_as(ptr(i32)),
                    self.ja.ctypes.data_as(ptr(i32)), self.perm.ctypes.data_as(ptr(i32)),
                    ref(i32(1)), self.iparm.ctypes.data_as(ptr(i32)), ref(i32(0)),
                    b.ctypes.data_as(ctypes.c_void_p), x.ctypes.data_as(ctypes.c_void_p),
                    ref(err))  # fmt: skip
        if err.value:
            raise RuntimeError(f"PARDISO error {err.value} in phase {phase}")
        return x

    def factor(self, data: np.ndarray) -> Pardiso:
        """Numerical factorisation of the matrix with these CSC data (analysis once)."""
        self.a = np.ascontiguousarray(data, self.dtype)
        if not self.analysed:
            self._call(11, np.zeros(self.n, self.dtype))
            self.analysed = True
        self._call(22, np.zeros(self.n, self.dtype))
        return self

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._call(33, np.ascontiguousarray(b, self.dtype))


class PardisoFactor:
    """``A⁻¹`` of the unpermuted matrix from PARDISO factors of ``A[order][:, order]`` (the
    interface of :func:`quadmodes.linalg.factor.single_permuted`)."""

    backend = "pardiso"

    def __init__(self, handle: Pardiso, order: np.ndarray):
        self.handle, self.order = handle, order

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        rhs = np.asarray(rhs)
        out = np.empty(rhs.shape)
        cols = rhs.reshape(rhs.shape[0], -1)
        view = out.reshape(out.shape[0], -1)
        for j in range(cols.shape[1]):
            view[self.order, j] = self.handle.solve(cols[self.order, j])
        return out


class _Handles:
    """Rotating PARDISO handles: a renewal pipeline keeps up to three factorisations alive."""

    def __init__(self, size: int, threads: int = 1):
        self.size, self.handles, self.k, self.lock = size, [], 0, threading.Lock()
        self.threads = threads

    def factor(self, a: sp.csc_matrix, order: np.ndarray) -> PardisoFactor:
        with self.lock:
            if len(self.handles) < self.size:
                self.handles.append(Pardiso(a.indptr, a.indices, True, self.threads,
                                            self.threads > 1))  # fmt: skip
            handle = self.handles[self.k % len(self.handles)]
            self.k += 1
        return PardisoFactor(handle.factor(a.data), order)


def install_pardiso(cost: float | None, fused: bool, every_step: bool = False,
                    threads: int = 1) -> None:  # fmt: skip
    """Patch this process's quadmodes: the Krylov preconditioner factorised by PARDISO float32;
    ``cost``: ``krylov.FACTOR_COST``; ``fused``: the compiled membrane blocks on the stepping
    thread; ``every_step``: renewed before every step (one thread); ``threads``: PARDISO's
    own threads (factorisation and solve; with 2, its parallel solve)."""
    import quadmodes.fullorder.krylov as krylov
    import quadmodes.fullorder.newton as newton
    import quadmodes.fullorder.preconditioner as pre

    handles = _Handles(1 if os.environ.get("QUADMODES_THREADS", "1") == "1" else 4, threads)
    pre.single_permuted = handles.factor
    if cost is not None:
        krylov.FACTOR_COST = cost
    if every_step:
        krylov.KrylovNewtonMatrix.worn = property(lambda self: self.renewal is None)
    if fused:
        kept = newton._kept
        newton._kept = lambda p, o, perm, z0, z1, fused=False: kept(p, o, perm, z0, z1, True)


# ---------------------------------------------------------------------------------------------
# a run with timers, and the Newton systems of some of its steps
# ---------------------------------------------------------------------------------------------


def timed_run(setup_file: str, steps: int, capture: set[int]) -> dict:
    """Integrate ``steps`` steps of the pickled setup with timers (the calling thread's CPU)
    on the run's parts; the Newton systems solved in the steps ``capture`` are kept (pair,
    right-hand side, index of the preconditioner in use), with every renewal's pair."""
    import quadmodes.fullorder.integrator as integ
    import quadmodes.fullorder.krylov as krylov
    import quadmodes.fullorder.newton as newton
    import quadmodes.fullorder.preconditioner as pre
    import quadmodes.fullorder.step as step
    import quadmodes.linalg.factor as factor
    from quadmodes.fullorder.kernels import StepOperators
    from quadmodes.fullorder.options import FullOrderOptions

    cpu, calls = defaultdict(float), defaultdict(int)

    def timed(name, f):
        def wrapped(*a, **k):
            t = time.thread_time()
            out = f(*a, **k)
            cpu[name] += time.thread_time() - t
            calls[name] += 1
            return out

        return wrapped

    patches = [(factor.PermutedLU, "solve", "preconditioner solve"),
               (PardisoFactor, "solve", "preconditioner solve"),
               (pre, "single_permuted", "factorisation"),
               (pre.PermutedNewtonAssembly, "data", "assembly of the Newton matrix"),
               (step.StepResidual, "__call__", "residual"),
               (step, "step_damping", "  of which damping force"),
               (StepOperators, "step_force", "step force"),
               (integ, "_advance", "step")]  # fmt: skip
    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in patches]
    for obj, name, label in patches:
        setattr(obj, name, timed(label, getattr(obj, name)))
    captured, renewals = [], []
    plain_solve, plain_kept = krylov.KrylovNewtonMatrix.solve, newton._kept

    def solve_and_keep(self, rhs):
        x = plain_solve(self, rhs)
        if calls["step"] in capture:
            captured.append(dict(step=calls["step"], z0=self._z0.copy(), z1=self._z1.copy(),
                                 rhs=rhs.copy(), renewal=len(renewals) - 1))  # fmt: skip
        return x

    def kept_and_keep(problem, ops, permuted, z0, z1, fused=False):
        renewals.append((z0.copy(), z1.copy()))
        return plain_kept(problem, ops, permuted, z0, z1, fused)

    krylov.KrylovNewtonMatrix.solve, newton._kept = solve_and_keep, kept_and_keep
    try:
        with open(setup_file, "rb") as fh:
            st = pickle.load(fh)
        opts = FullOrderOptions(model=st.model, damping=st.integrator_damping(), save_every=40,
                                hub=st.hub, spin_axis=st.spin_axis)  # fmt: skip
        run = integ.integrate_full_order
        run(st.structure, st.x_ref, st.x0, st.v0, (0.0, DT), DT, opts)  # one-off costs
        cpu.clear(), calls.clear(), captured.clear(), renewals.clear()
        wall, main = time.perf_counter(), time.thread_time()
        sol = run(st.structure, st.x_ref, st.x0, st.v0, (0.0, steps * DT), DT, opts)
        wall, main = time.perf_counter() - wall, time.thread_time() - main
    finally:
        for obj, name, f in saved:
            setattr(obj, name, f)
        krylov.KrylovNewtonMatrix.solve, newton._kept = plain_solve, plain_kept
    return dict(stats=sol.stats, wall=wall, main=main, cpu=dict(cpu), calls=dict(calls),
                captured=captured, renewals=renewals)  # fmt: skip


def print_breakdown(res: dict) -> None:
    """Per step: the run's time and the timed parts (CPU of the thread that called them)."""
    n = res["stats"]["n_steps"]
    print(f"{n} steps: {1e3 * res['wall'] / n:.1f} ms wall and {1e3 * res['main'] / n:.1f} ms "
          f"CPU of the stepping thread per step; Newton {res['stats']['n_newton'] / n:.2f}, "
          f"factorisations {res['stats']['n_factor'] / n:.3f} per step; load "
          f"{os.getloadavg()[0]:.1f}")  # fmt: skip
    print("| part | ms per step | calls per step | ms per call |\n|---|---|---|---|")
    for name in sorted(res["cpu"], key=lambda k: -res["cpu"][k]):
        t, c = res["cpu"][name], res["calls"][name]
        print(f"| {name} | {1e3 * t / n:.2f} | {c / n:.2f} | {1e3 * t / c:.2f} |")


# ---------------------------------------------------------------------------------------------
# the captured matrices in isolation
# ---------------------------------------------------------------------------------------------


def newton_operators(setup_file: str):
    """``(problem, ops, permuted)`` of the pickled setup's run (as the integrator builds them)."""
    from quadmodes.fullorder.kernels import StepOperators
    from quadmodes.fullorder.options import FullOrderOptions
    from quadmodes.fullorder.preconditioner import PermutedNewtonAssembly
    from quadmodes.fullorder.setup import setup_problem

    with open(setup_file, "rb") as fh:
        st = pickle.load(fh)
    o = FullOrderOptions(model=st.model, damping=st.integrator_damping(), hub=st.hub)
    problem = setup_problem(st.structure, st.x_ref, (0.0, 100 * DT), DT, model=o.model,
                            damping=o.damping, hub=o.hub, newton_tol=o.newton_tol,
                            energy_momentum=o.energy_momentum, rotation_map=o.rotation_map)  # fmt: skip
    ops = StepOperators.build(st.structure, problem.m_full, problem.free, o.energy_momentum)
    return problem, ops, PermutedNewtonAssembly.of(ops, problem.free)


def best_of(f, n: int) -> float:
    """The least wall time (ms) of n calls of f."""
    best = np.inf
    for _ in range(n):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return 1e3 * best


def structure_of(a: sp.csc_matrix, mass: sp.csc_matrix) -> None:
    """Print the symmetry of A and the inertia of its symmetric part."""
    sym, skew = ((a + a.T) * 0.5).tocsc(), (a - a.T) * 0.5
    print(f"n {a.shape[0]}, nnz {a.nnz}: ‖A − Aᵀ‖_F/‖A‖_F {spla.norm(a - a.T) / spla.norm(a):.2e}, "
          f"‖skew‖_F/‖A − M‖_F {spla.norm(skew) / spla.norm(a - mass):.2e}")  # fmt: skip
    opts = dict(permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
    for name, m in (("A", a), ("(A + Aᵀ)/2", sym)):
        u = spla.splu(m, **opts).U.diagonal()
        print(f"unpivoted LU of {name}: {int(np.sum(u < 0))} negative pivots of {u.size}")


def time_solvers(a: sp.csc_matrix, order: np.ndarray, with_pardiso: bool) -> None:
    """Factorisation and solve times (ms, best of repeats, one thread unless said)."""
    from quadmodes.linalg.factor import permuted_lu, single_permuted

    b = np.random.default_rng(0).standard_normal(a.shape[0])
    a32 = sp.csc_matrix((a.data.astype(np.float32), a.indices, a.indptr), shape=a.shape)
    rows = []
    lu = single_permuted(a32.copy(), order)
    rows.append(("SuperLU float32 (today's)", best_of(lambda: single_permuted(a32.copy(), order), 3),
                 best_of(lambda: lu.solve(b), 20), lu.lu.lu.L.nnz + lu.lu.lu.U.nnz))  # fmt: skip
    lu = permuted_lu(a.copy(), order)
    rows.append(("SuperLU float64", best_of(lambda: permuted_lu(a.copy(), order), 3),
                 best_of(lambda: lu.solve(b), 20), lu.lu.L.nnz + lu.lu.U.nnz))  # fmt: skip
    rows += _cholmod_rows(a, b)
    if with_pardiso:
        for single, threads, par in ((True, 1, False), (False, 1, False), (True, 2, False),
                                     (True, 2, True)):  # fmt: skip
            h = Pardiso(a.indptr, a.indices, single, threads, par).factor(a.data)
            name = (f"PARDISO float{32 if single else 64}, {threads} thread(s)"
                    + (", parallel solve" if par else ""))  # fmt: skip
            rows.append((name, best_of(lambda h=h: h.factor(a.data), 5),
                         best_of(lambda h=h: h.solve(b), 20), int(h.iparm[17])))  # fmt: skip
    print("| solver | factorisation (ms) | solve (ms) | factor entries |\n|---|---|---|---|")
    for name, tf, ts, nnz in rows:
        print(f"| {name} | {tf:.1f} | {ts:.2f} | {nnz:,} |")


def _cholmod_rows(a: sp.csc_matrix, b: np.ndarray) -> list:
    """CHOLMOD (scikit-sparse), if importable: supernodal LLᵀ of the symmetric part shifted by
    5 I (definite; the same pattern and work, for the times only) and simplicial LDLᵀ of the
    symmetric part itself."""
    try:
        from sksparse.cholmod import analyze
    except ImportError:
        print("CHOLMOD: not measured (pip install scikit-sparse, with SuiteSparse)")
        return []
    sym = ((a + a.T) * 0.5).tocsc()
    rows = []
    shifted = (sym + 5.0 * sp.identity(a.shape[0])).tocsc()
    for ordering in ("amd", "metis"):
        an = analyze(shifted, mode="supernodal", ordering_method=ordering)
        f = an.cholesky(shifted)
        rows.append((f"CHOLMOD supernodal LLᵀ, {ordering} (shifted)",
                     best_of(lambda an=an: an.cholesky(shifted), 3),
                     best_of(lambda f=f: f(b), 20), f.L().nnz))  # fmt: skip
    an = analyze(sym, mode="simplicial", ordering_method="amd")
    f = an.cholesky(sym)
    rows.append(("CHOLMOD simplicial LDLᵀ of (A + Aᵀ)/2, amd", best_of(lambda: an.cholesky(sym), 2),
                 best_of(lambda: f(b), 20), f.L_D()[0].nnz))  # fmt: skip
    return rows


def krylov_counts(problem, ops, permuted, res: dict) -> None:
    """Preconditioner solves per Newton solve of the run's GMRES on the captured systems, with
    the preconditioner (an exact LU of A in float32 or float64, or of its symmetric part)
    factorised (c) where the run had it, (a) at the step's first pair, (b) at each solve's."""
    import quadmodes.fullorder.krylov as krylov
    from quadmodes.fullorder.newton import NewtonMatrix
    from quadmodes.fullorder.preconditioner import low_rank_terms
    from quadmodes.linalg.factor import permuted_lu, single_permuted

    weight, order = 0.5 * DT * DT, permuted.order
    size = order.size

    def base(kind, z0, z1):
        a = sp.csc_matrix((permuted.data(ops, z0, z1, weight), permuted.indices.copy(),
                           permuted.indptr.copy()), shape=(size, size))  # fmt: skip
        if kind == "(A + Aᵀ)/2, float64":
            a = ((a + a.T) * 0.5).tocsc()
        if kind == "A, float32":
            a = a.astype(np.float32)
        lu = single_permuted(a, order) if a.dtype == np.float32 else permuted_lu(a, order)
        low = low_rank_terms(problem.structure, z0, z1)
        return NewtonMatrix(None, low, weight, problem.free, lu=lu)

    caps, first = res["captured"], {}
    for c in caps:
        first.setdefault(c["step"], c)
    krylov.KRYLOV_STEPS_ADAPTIVE, cap = 60, krylov.KRYLOV_STEPS_ADAPTIVE
    print(f"{len(caps)} Newton solves in {len(first)} steps (steps {sorted(first)})")
    print("| preconditioner | factorised | solves per Newton solve (max) | per step | not "
          "converged |\n|---|---|---|---|---|")  # fmt: skip
    for kind in ("A, float32", "A, float64", "(A + Aᵀ)/2, float64"):
        for when in ("kept (as the run)", "(a) every step", "(b) every iterate"):
            counts, unconverged, kept = [], 0, {}
            for c in caps:
                if when.startswith("kept"):
                    key, pair = ("r", c["renewal"]), res["renewals"][c["renewal"]]
                elif when.startswith("(a)"):
                    key, pair = ("s", c["step"]), (first[c["step"]]["z0"], first[c["step"]]["z1"])
                else:
                    key, pair = ("i", id(c)), (c["z0"], c["z1"])
                if key not in kept:
                    kept = {key: base(kind, *pair)}
                kn = krylov.KrylovNewtonMatrix(problem, ops, kept[key], "adaptive")
                kn.update(c["z0"], c["z1"])
                kn.solve(c["rhs"])
                counts.append(kn.krylov_steps)
                unconverged += kn.stale
            counts = np.array(counts)
            print(f"| {kind} | {when} | {counts.mean():.2f} ({counts.max()}) | "
                  f"{counts.sum() / len(first):.2f} | {unconverged} |", flush=True)  # fmt: skip
    krylov.KRYLOV_STEPS_ADAPTIVE = cap


# ---------------------------------------------------------------------------------------------
# side by side with bench_fullorder_speed (the PARDISO overlay as the new version)
# ---------------------------------------------------------------------------------------------

OVERLAY = '''"""Measurement only (benchmarks/performance/bench_fullorder_solvers.py)."""
import os, sys
sys.path.insert(0, {root!r})
os.environ["QM_MKL_RT"] = {mkl!r}
from benchmarks.performance.bench_fullorder_solvers import install_pardiso
install_pardiso({cost!r}, {fused!r}, threads={threads!r})
'''


def side_by_side(args) -> None:
    """bench_fullorder_speed's measure and report, new = this tree with the PARDISO overlay."""
    import benchmarks.performance.bench_fullorder_speed as bench

    with tempfile.TemporaryDirectory() as tmp:
        overlay = Path(tmp) / "src"
        overlay.mkdir()
        (overlay / "quadmodes").symlink_to(ROOT / "src" / "quadmodes")
        mkl_path = args.mkl_rt or os.environ.get("QM_MKL_RT", "")
        text = OVERLAY.format(root=str(ROOT), mkl=mkl_path, cost=args.cost, fused=args.fused,
                           threads=args.mkl_threads)  # fmt: skip
        (overlay / "sitecustomize.py").write_text(text)
        bench.NEW_SRC = overlay
        setups = Path(args.setup).parent
        row = bench.measure(Path(args.setup).stem, args.old, args.window, DT, args.repeat,
                            Path(tmp), setups)  # fmt: skip
        bench.report([row])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--setup", required=True, help="pickled setup (bench_fullorder_speed --setups)")
    ap.add_argument("--mkl-rt", default=None, help="path of libmkl_rt (PARDISO)")
    sub = ap.add_subparsers(dest="what", required=True)
    iso = sub.add_parser("isolated")
    iso.add_argument("--steps", default="40-47,60-63,70-76", help="steps whose systems to take")
    br = sub.add_parser("breakdown")
    br.add_argument("--steps", type=int, default=80)
    sbs = sub.add_parser("side-by-side")
    sbs.add_argument("--old", required=True, type=Path, help="src/ of the old version")
    sbs.add_argument("--window", type=float, default=0.05)
    sbs.add_argument("--repeat", type=int, default=2)
    for p in (br, sbs):
        p.add_argument("--pardiso", action="store_true", help="(breakdown) factorise by PARDISO")
        p.add_argument("--cost", type=float, default=None, help="krylov.FACTOR_COST")
        p.add_argument("--fused", action="store_true", help="compiled blocks, stepping thread")
        p.add_argument("--mkl-threads", type=int, default=1, help="PARDISO's own threads")
    br.add_argument("--every-step", action="store_true", help="renew before every step")
    args = ap.parse_args()
    if args.mkl_rt:
        os.environ["QM_MKL_RT"] = args.mkl_rt
    if args.what == "side-by-side":
        side_by_side(args)
        return
    if args.what == "breakdown":
        if args.pardiso:
            install_pardiso(args.cost, args.fused, args.every_step, args.mkl_threads)
        print_breakdown(timed_run(args.setup, args.steps, set()))
        return
    wanted = set()
    for part in args.steps.split(","):
        lo, _, hi = part.partition("-")
        wanted.update(range(int(lo), int(hi or lo) + 1))
    res = timed_run(args.setup, max(wanted) + 2, wanted)
    problem, ops, permuted = newton_operators(args.setup)
    c = res["captured"][0]
    size = permuted.order.size
    a = sp.csc_matrix((permuted.data(ops, c["z0"], c["z1"], 0.5 * DT * DT), permuted.indices,
                       permuted.indptr), shape=(size, size))  # fmt: skip
    mass = sp.csc_matrix((permuted.mass, permuted.indices, permuted.indptr), shape=a.shape)
    structure_of(a, mass)
    time_solvers(a, permuted.order, bool(args.mkl_rt or os.environ.get("QM_MKL_RT")))
    krylov_counts(problem, ops, permuted, res)


if __name__ == "__main__":
    main()
