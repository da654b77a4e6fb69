"""Run cases: the (cached) reduced model of a case, the initial state of a run, and the chunked
time integration with progress reporting and early-stop handling.

Stages::

    Case ──reduced_model_for──▶ ReducedModel (cache: $QUADMODES_CACHE or ~/.cache/quadmodes)
    RunCase + ReducedModel ──simulate──▶ RunResult (merged Solution + Diagnostics)

The run is integrated in chunks of whole steps (a multiple of ``save_every``), so progress can
be reported between chunks; each chunk starts from the last state of the previous one on the
same fixed-step grid (t = i·Δt), so the chunked trajectory is the single-run trajectory up to
the Newton tolerance of the first step of each chunk (its predictor has no previous step to
extrapolate from). The dissipated energy is accumulated across chunks.

An integrator failure (``Solution.status != 0``), a non-finite state or an interrupt (Ctrl-C)
ends the run early: what was computed is kept and the result is marked incomplete with a reason.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadmodes import __version__, artifact, integrators, pipeline
from quadmodes import dynamics as dyn
from quadmodes import reduced as red
from quadmodes.config import Case, CaseError, Modes, RunCase
from quadmodes.diagnostics import Diagnostics, diagnostics
from quadmodes.integrators import Solution

Progress = Callable[[str, float], None]

PAPER_RUN_CASES = ("paper-0.5hz", "paper-41hz")
DEFAULT_MODES = 5
#: Two modes with the same label within this relative frequency gap form a (degenerate) pair.
PAIR_TOLERANCE = 0.05
#: Modes this close in frequency (relative) are degenerate, whatever their labels.
DEGENERATE_TOLERANCE = 1e-3
#: The run is split into at most this many chunks (progress is reported between chunks).
MAX_CHUNKS = 200


# ---------------------------------------------------------------------------------------------
# reduced model (cached)
# ---------------------------------------------------------------------------------------------


def cache_dir() -> Path:
    """Folder of cached reduced models: ``$QUADMODES_CACHE`` or ``~/.cache/quadmodes``."""
    env = os.environ.get("QUADMODES_CACHE")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "quadmodes"


def damping_ratio_of(case: Case) -> float:
    """Modal damping ratio of a case (``material.damping_ratio`` or ``beam.damping_ratio``)."""
    section = case.material if case.kind == "membrane" else case.beam
    return float(section.damping_ratio) if section is not None else 0.0


def reduced_key(case: Case, n_modes: int) -> str:
    """Content key of the reduced model of ``case`` with ``n_modes`` modes (includes the
    package version)."""
    return artifact.content_key(case.to_toml() + f"\n# reduced.modes = {int(n_modes)}\n")


def cache_path(case: Case, n_modes: int) -> Path:
    """Cache file of the reduced model of ``case`` with ``n_modes`` modes."""
    return cache_dir() / f"{case.name}-N{int(n_modes)}-{reduced_key(case, n_modes)}.nc"


def _check_pair_not_split(labels, freqs, n_modes: int) -> None:
    if len(freqs) <= n_modes:
        return
    a, b = n_modes - 1, n_modes
    gap = abs(freqs[b] - freqs[a])
    same_label = labels[a] == labels[b] and gap <= PAIR_TOLERANCE * freqs[a]
    if same_label or gap <= DEGENERATE_TOLERANCE * freqs[a]:
        raise CaseError(
            f"reduced.modes = {n_modes} splits the pair {labels[a]} / {labels[b]} at "
            f"{freqs[a]:.2f}/{freqs[b]:.2f} Hz (modes {a + 1} and {b + 1}); keep pairs whole: "
            f"use {n_modes - 1} or {n_modes + 1}",
            field="reduced.modes",
        )


def build_reduced_model(
    case: Case, n_modes: int = DEFAULT_MODES, progress: Progress | None = None
) -> red.ReducedModel:
    """Modal model of ``case`` (``pipeline.build_modal_model``), its lowest ``n_modes`` elastic
    modes, and :func:`quadmodes.reduced.reduce` with the case's damping ratio and provenance.

    Raises :class:`CaseError` (field ``reduced.modes``) if the model has fewer modes or the cut
    splits a degenerate pair."""
    n_modes = int(n_modes)
    if n_modes < 1:
        raise CaseError(f"reduced.modes = {n_modes}: must be at least 1", field="reduced.modes")
    count = max(case.modes.count, n_modes + 1)  # one more, to see whether a pair is split
    work = (
        case if count == case.modes.count else case.model_copy(update={"modes": Modes(count=count)})
    )
    modal = pipeline.build_modal_model(work, progress)
    freqs = np.asarray(modal.modes.frequencies_hz, float)
    labels = list(modal.labels)
    if len(freqs) < n_modes:
        raise CaseError(
            f"reduced.modes = {n_modes}: the model has only {len(freqs)} elastic modes; "
            f"use at most {len(freqs)}",
            field="reduced.modes",
        )
    _check_pair_not_split(labels, freqs, n_modes)
    key = reduced_key(case, n_modes)
    provenance = {
        "case": case.name,
        "case_toml": case.to_toml(),
        "n_nodes": int(modal.structure.n),
        "n_modes": n_modes,
        "quadmodes_version": __version__,
        "content_key": key,
    }
    return red.reduce(
        modal.structure,
        modal.x,
        freqs[:n_modes],
        modal.modes.shapes[:n_modes],
        labels[:n_modes],
        damping_ratio_of(case),
        progress,
        provenance,
    )


def reduced_model_for(
    case: Case,
    n_modes: int = DEFAULT_MODES,
    progress: Progress | None = None,
    *,
    use_cache: bool = True,
    info: dict | None = None,
) -> red.ReducedModel:
    """The reduced model of ``case`` with ``n_modes`` modes, from the cache if present.

    The cache file is keyed by ``artifact.content_key(case TOML + n_modes)``; a missing, corrupt
    or mismatching file is (re)built and saved. ``info`` (optional dict) receives ``cache``
    ("hit", "miss", "rebuilt" or "off") and ``path``."""
    info = {} if info is None else info
    path = cache_path(case, n_modes)
    info["path"] = str(path)
    info["cache"] = "off" if not use_cache else "miss"
    if use_cache and path.is_file():
        try:
            model = artifact.load_reduced_model(path)
        except artifact.ArtifactError:
            info["cache"] = "rebuilt"
        else:
            if (
                model.provenance.get("content_key") == reduced_key(case, n_modes)
                and model.n_modes == n_modes
            ):
                info["cache"] = "hit"
                return model
            info["cache"] = "rebuilt"
    model = build_reduced_model(case, n_modes, progress)
    if use_cache:
        try:
            artifact.save_reduced_model(model, path)
        except OSError as exc:  # a read-only cache is not an error: the run goes on
            info["cache"] = f"not saved ({exc.strerror or type(exc).__name__})"
    return model


# ---------------------------------------------------------------------------------------------
# initial state
# ---------------------------------------------------------------------------------------------


def bending_pair(labels, frequencies_hz) -> tuple[int, ...]:
    """Indices of the first bending mode and its partner (same label, frequency within
    :data:`PAIR_TOLERANCE`); ``()`` if no retained mode is labelled bending."""
    labels = list(labels)
    found = [k for k, lab in enumerate(labels) if "bending" in str(lab).lower()]
    if not found:
        return ()
    first = found[0]
    pair = [first]
    nxt = first + 1
    f = np.asarray(frequencies_hz, float)
    if nxt < len(labels) and labels[nxt] == labels[first]:
        if abs(f[nxt] - f[first]) <= PAIR_TOLERANCE * f[first]:
            pair.append(nxt)
    return tuple(pair)


def largest_nodal_displacement(model: red.ReducedModel, mode: int) -> float:
    """Largest nodal displacement (m) of mode ``mode`` per unit modal coordinate (√kg·m)."""
    u = np.asarray(model.Phi[mode])[np.asarray(model.translational, bool)]
    return float(np.max(np.linalg.norm(u, axis=1)))


@dataclass(frozen=True, eq=False)
class InitialState:
    """Initial state of a run.

    y0 (7+2N,): [q, ω, s, ṡ]. spin_axis (3,): body-frame minor principal axis of J̃(s0) (sign:
    largest component positive). inertia (3,3) kg m²: J̃(s0). bending_modes: indices of the
    first bending pair (may be empty). notes: remarks (e.g. an ignored deformation)."""

    y0: np.ndarray
    spin_axis: np.ndarray
    inertia: np.ndarray
    bending_modes: tuple[int, ...]
    notes: tuple[str, ...] = ()


def initial_state(system: dyn.ReducedSystem, model: red.ReducedModel, run: RunCase) -> InitialState:
    """Initial state of ``run``: modal displacement s0 in the first bending mode (largest nodal
    displacement = ``initial.bending_amplitude``), ṡ0 = 0, q0 = identity, and the body angular
    velocity of :func:`quadmodes.dynamics.coning_omega` for J̃(s0): spin ``initial.spin_rate``
    about the minor principal axis of J̃(s0), cone angle ``initial.cone_angle`` between
    H = J̃(s0) ω and that axis."""
    n = system.n_modes
    notes: list[str] = []
    pair = bending_pair(model.labels, model.frequencies_hz) if n else ()
    s0 = np.zeros(n)
    amp = run.initial.bending_amplitude
    if amp > 0.0:
        if n == 0:
            notes.append("initial.bending_amplitude ignored: no elastic modes (rigid)")
        elif not pair:
            labels = ", ".join(model.labels)
            raise CaseError(
                "initial.bending_amplitude: no retained mode is a bending mode "
                f'(labels: {labels}); set it to "0 in" or '
                "keep more modes in [reduced]",
                field="initial.bending_amplitude",
            )
        else:
            s0[pair[0]] = amp / largest_nodal_displacement(model, pair[0])
    jt = dyn.inertia_tensor(system, s0, "rot")
    jt = 0.5 * (jt + jt.T)
    omega = dyn.coning_omega(jt, run.initial.spin_rate, run.initial.cone_angle)
    lam, vec = np.linalg.eigh(jt)
    axis = vec[:, 0] * np.sign(vec[np.argmax(np.abs(vec[:, 0])), 0])
    y0 = dyn.pack_state(system, omega=omega, s=s0)
    return InitialState(y0, axis, jt, pair, tuple(notes))


# ---------------------------------------------------------------------------------------------
# the run
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RunResult:
    """A finished (or stopped) run: inputs, the merged solution and its diagnostics.

    complete: False if the integrator stopped early, the state became non-finite or the run was
    interrupted; reason: one line (empty when complete). wall_s: integration wall time (s)."""

    run: RunCase
    model_case: Case
    model: red.ReducedModel
    system: dyn.ReducedSystem
    initial: InitialState
    solution: Solution
    diagnostics: Diagnostics
    complete: bool
    reason: str
    wall_s: float
    notes: tuple[str, ...] = field(default_factory=tuple)


def _chunk_steps(n_steps: int, save_every: int, max_chunks: int = MAX_CHUNKS) -> int:
    per = max(1, math.ceil(n_steps / save_every / max_chunks))
    return save_every * per


def _first_bad_row(y: np.ndarray) -> int | None:
    bad = ~np.all(np.isfinite(y), axis=1)
    return int(np.argmax(bad)) if bad.any() else None


@dataclass(frozen=True, eq=False)
class RunSetup:
    """Everything a run needs before integrating: the run case, its model case, the reduced
    model (restricted to the run's modes), the system of the run's formulation and the initial
    state."""

    run: RunCase
    model_case: Case
    model: red.ReducedModel
    system: dyn.ReducedSystem
    initial: InitialState


def prepare(
    run: RunCase,
    model: red.ReducedModel | None = None,
    progress: Progress | None = None,
    *,
    model_case: Case | None = None,
) -> RunSetup:
    """Reduced model (from the cache unless ``model`` is given), system and initial state of
    ``run``; raises :class:`CaseError` for inputs that cannot be run."""
    model_case = model_case if model_case is not None else run.model_case()
    if model is None:
        model = reduced_model_for(model_case, run.reduced.modes, progress)
    if not model.free:
        raise CaseError(
            f'model = "{run.model}": clamped to a hub; a run needs a free-floating body',
            field="model",
        )
    if run.reduced.formulation != "rigid":
        if model.n_modes < run.reduced.modes:
            raise CaseError(
                f"reduced.modes = {run.reduced.modes}: the reduced model has only "
                f"{model.n_modes} modes",
                field="reduced.modes",
            )
        if model.n_modes > run.reduced.modes:
            model = model.select(np.arange(run.reduced.modes))
    system = dyn.reduced_system(model, run.reduced.formulation)
    return RunSetup(run, model_case, model, system, initial_state(system, model, run))


def execute(setup: RunSetup, progress: Progress | None = None, max_chunks: int = MAX_CHUNKS):
    """Integrate a prepared run in chunks; returns a :class:`RunResult`.

    ``progress(stage, fraction)`` is called with stage = the run name between chunks. An
    integrator failure, a non-finite state or Ctrl-C ends the run early with ``complete`` False
    and a one-line ``reason``; it is not raised."""
    run, system, init = setup.run, setup.system, setup.initial
    integ = run.integration
    n_total = integ.n_steps
    h = integ.duration / n_total
    se = integ.save_every
    chunk = _chunk_steps(n_total, se, max_chunks)
    adaptive = integ.method == "adaptive"

    ts: list[np.ndarray] = []
    ys: list[np.ndarray] = []
    eds: list[np.ndarray] = []
    stats = {"n_steps": 0, "n_rhs": 0, "n_newton": 0, "n_jac": 0}
    y = init.y0.copy()
    ed_offset = 0.0
    reason = ""
    status, message = 0, "ok"
    k0 = 0
    start = time.perf_counter()
    if progress:
        progress(run.name, 0.0)
    try:
        while k0 < n_total:
            k1 = min(k0 + chunk, n_total)
            ta, tb = k0 * h, k1 * h
            try:
                with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                    sol = integrators.integrate(
                        system, y, (ta, tb), integ.method, dt=h, rtol=integ.rtol, save_every=se
                    )
            except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
                # a numerical breakdown inside the integrator (e.g. a non-finite Newton iterate
                # reaching a math function): keep the samples up to the start of this chunk
                detail = " ".join(str(exc).split()) or type(exc).__name__
                reason = (
                    f"{integ.method}: {type(exc).__name__} ({detail}) between t = {ta:.6g} s "
                    f"and {tb:.6g} s"
                )
                status, message = 1, reason
                break
            for key in stats:
                stats[key] += int(sol.stats.get(key, 0))
            t_chunk = np.asarray(sol.t, float)
            if not adaptive and len(t_chunk):  # exact global grid times
                t_chunk = (k0 + np.rint((t_chunk - ta) / h)) * h
            y_chunk = np.asarray(sol.y, float)
            ed_chunk = ed_offset + np.asarray(sol.dissipated, float)
            first = 1 if ts else 0  # the first sample repeats the previous chunk's last
            bad = _first_bad_row(y_chunk)
            if bad is not None:
                reason = f"non-finite state at t = {t_chunk[bad]:.6g} s"
                status, message = 1, reason
                y_chunk, t_chunk, ed_chunk = y_chunk[:bad], t_chunk[:bad], ed_chunk[:bad]
            ts.append(t_chunk[first:])
            ys.append(y_chunk[first:])
            eds.append(ed_chunk[first:])
            if bad is not None:
                break
            if sol.status != 0:
                status, message = sol.status, sol.message
                reason = sol.message
                break
            y = y_chunk[-1].copy()
            ed_offset = float(ed_chunk[-1])
            k0 = k1
            if progress:
                progress(run.name, k1 / n_total)
    except KeyboardInterrupt:
        reason = f"interrupted at t = {k0 * h:.6g} s"
        status, message = 1, reason
    wall = time.perf_counter() - start
    stats["wall_s"] = wall
    t_all = np.concatenate(ts) if ts else np.zeros(0)
    y_all = np.concatenate(ys) if ys else np.zeros((0, system.n_state))
    ed_all = np.concatenate(eds) if eds else np.zeros(0)
    if len(t_all) == 0:  # nothing usable: keep the initial state
        t_all, y_all, ed_all = np.zeros(1), init.y0[None, :], np.zeros(1)
    merged = Solution(
        t_all, y_all, integ.method, stats, status, message, ed_all, None if adaptive else h
    )
    diag = diagnostics(system, merged, spin_axis=init.spin_axis)
    return RunResult(
        run=run,
        model_case=setup.model_case,
        model=setup.model,
        system=system,
        initial=init,
        solution=merged,
        diagnostics=diag,
        complete=not reason,
        reason=reason,
        wall_s=wall,
        notes=init.notes,
    )


def simulate(
    run: RunCase,
    model: red.ReducedModel | None = None,
    progress: Progress | None = None,
    *,
    model_case: Case | None = None,
    max_chunks: int = MAX_CHUNKS,
) -> RunResult:
    """:func:`prepare` and :func:`execute` ``run`` (reduced model from the cache unless
    ``model`` is given). Raises :class:`CaseError` for bad inputs only; an integrator failure
    gives a result with ``complete`` False."""
    setup = prepare(run, model, progress, model_case=model_case)
    return execute(setup, progress, max_chunks)


def apply_overrides(
    run: RunCase,
    *,
    method: str | None = None,
    dt: str | None = None,
    duration: str | None = None,
    formulation: str | None = None,
    save_every: int | None = None,
) -> RunCase:
    """``run`` with command-line overrides (quantity strings such as ``"0.25 ms"``), validated
    like the case file; raises :class:`CaseError` naming the field."""
    import tomllib

    from quadmodes.config import run_case_from_dict

    if all(v is None for v in (method, dt, duration, formulation, save_every)):
        return run
    data = tomllib.loads(run.to_toml())
    integ = data.setdefault("integration", {})
    if method is not None:
        integ["method"] = method
    if dt is not None:
        integ["dt"] = dt
    if duration is not None:
        integ["duration"] = duration
    if save_every is not None:
        integ["save_every"] = save_every
    if formulation is not None:
        data.setdefault("reduced", {})["formulation"] = formulation
    return run_case_from_dict(data, source="command line")


def is_run_case(name_or_path: str) -> bool:
    """True if ``name_or_path`` is a built-in run case or a TOML file with ``kind = "run"``."""
    import tomllib

    from quadmodes.config import builtin_run_case_names

    if name_or_path in builtin_run_case_names():
        return True
    path = Path(name_or_path).expanduser()
    if path.suffix != ".toml" or not path.is_file():
        return False
    try:
        return tomllib.loads(path.read_text(encoding="utf-8")).get("kind") == "run"
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False  # let the loader report it
