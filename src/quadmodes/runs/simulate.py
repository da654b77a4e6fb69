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

import dataclasses
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadmodes import __version__
from quadmodes.case import Case, CaseError, Modes, RunCase
from quadmodes.rom import artifact, integrators
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import reduced as red
from quadmodes.rom.diagnostics import Diagnostics, diagnostics
from quadmodes.rom.integrators import Solution
from quadmodes.structure import pipeline

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
    package version and the artifact format version, so that files of another format are not
    cache hits)."""
    return artifact.content_key(
        case.to_toml()
        + f"\n# reduced.modes = {int(n_modes)}\n"
        + f"# artifact.format_version = {artifact.FORMAT_VERSION}\n"
    )


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
    modes, and :func:`quadmodes.rom.reduced.reduce` with the case's damping ratio and provenance.

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
    velocity of :func:`quadmodes.rom.dynamics.coning_omega` for J̃(s0): spin ``initial.spin_rate``
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
# validity of the reduced model at the run's spin
# ---------------------------------------------------------------------------------------------

#: Spin rates scanned (uniformly from 0 to the run's spin) by :func:`rotating_validity`.
VALIDITY_SCAN = 64


@dataclass(frozen=True)
class Validity:
    """Whether the rotating-frame stiffness K(ω) = Λ − ωᵀJ2ω of the reduced model stays
    positive definite for every spin rate from 0 up to the run's (ω scaled along its direction).

    min_eigenvalue (1/s²): smallest eigenvalue of K at the run's ω (mass-normalised modal
    coordinates, so the square of a rotating-frame frequency); spin_rate (rad/s): |ω|;
    lost_at (rad/s): the spin rate at which K stops being positive definite (None if it does
    not); valid: ``lost_at is None``."""

    formulation: str
    spin_rate: float
    min_eigenvalue: float
    lost_at: float | None
    modal_energy: float = 0.0
    barrier_energy: float = math.inf

    @property
    def beyond_barrier(self) -> bool:
        """Q4 only: the initial modal energy exceeds the quartic potential's lowest barrier."""
        return self.modal_energy > self.barrier_energy

    @property
    def valid(self) -> bool:
        return self.lost_at is None and not self.beyond_barrier

    def message(self) -> str:
        """One line for a warning ("" when valid)."""
        if self.valid:
            return ""
        if self.lost_at is None:
            return (
                f"formulation {self.formulation} is outside its validity: the initial modal energy "
                f"{self.modal_energy:.4g} J exceeds the lowest barrier {self.barrier_energy:.4g} J "
                "of its truncated quartic potential, so the motion may leave the range where Q4 "
                "means anything; use Q, or a smaller initial deformation"
            )
        return (
            f"formulation {self.formulation} is outside its validity: the rotating-frame "
            f"stiffness Λ − ωᵀJ2ω is not positive definite above a spin rate of "
            f"{self.lost_at:.4g} rad/s ({self.lost_at / (2 * math.pi):.4g} Hz); the run's spin "
            f"is {self.spin_rate:.4g} rad/s (smallest eigenvalue {self.min_eigenvalue:.4g} s⁻²)"
        )

    def as_dict(self) -> dict:
        return {
            "valid": self.valid,
            "formulation": self.formulation,
            "rotating_stiffness_min_eigenvalue": float(self.min_eigenvalue),
            "rotating_stiffness_min_eigenvalue_units": "s-2",
            "spin_rate_rad_s": float(self.spin_rate),
            "lost_at_spin_rate_rad_s": None if self.lost_at is None else float(self.lost_at),
            "initial_modal_energy_J": float(self.modal_energy),
            "potential_barrier_J": None if math.isinf(self.barrier_energy)
            else float(self.barrier_energy),
            "message": self.message(),
        }


def _min_stiffness(system: dyn.ReducedSystem, omega: np.ndarray) -> float:
    k = dyn.rotating_frame_matrices(system, omega)[2]
    return float(np.linalg.eigvalsh(k).min()) if k.shape[0] else math.inf


def rotating_validity(
    system: dyn.ReducedSystem, omega, formulation: str, n_scan: int = VALIDITY_SCAN
) -> Validity:
    """:class:`Validity` of ``system`` (its formulation's J2) spinning at ``omega`` (3,) rad/s:
    the smallest eigenvalue of Λ − ωᵀJ2ω on a scan of ``n_scan`` spin rates α·ω (0 < α ≤ 1),
    the first loss of definiteness refined by bisection."""
    from scipy.optimize import brentq

    omega = np.asarray(omega, float)
    rate = float(np.linalg.norm(omega))
    if system.n_modes == 0 or rate == 0.0:
        return Validity(formulation, rate, math.inf if system.n_modes == 0 else
                        _min_stiffness(system, omega), None)  # fmt: skip
    alphas = np.linspace(0.0, 1.0, n_scan + 1)
    values = [_min_stiffness(system, a * omega) for a in alphas]
    lost = None
    for k in range(1, len(alphas)):
        if values[k] <= 0.0:
            if values[k - 1] > 0.0:
                a = brentq(lambda x: _min_stiffness(system, x * omega), alphas[k - 1], alphas[k])
            else:
                a = alphas[k - 1]
            lost = float(a * rate)
            break
    return Validity(formulation, rate, values[-1], lost)


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
    validity: Validity | None = None


def _chunk_steps(n_steps: int, save_every: int, max_chunks: int = MAX_CHUNKS) -> int:
    per = max(1, math.ceil(n_steps / save_every / max_chunks))
    return save_every * per


def _first_bad_row(y: np.ndarray) -> int | None:
    bad = ~np.all(np.isfinite(y), axis=1)
    return int(np.argmax(bad)) if bad.any() else None


@dataclass(frozen=True, eq=False)
class RunSetup:
    """Everything a run needs before integrating: the run case, its model case, the reduced
    model (restricted to the run's modes), the system of the run's formulation, the initial
    state and the :class:`Validity` of the formulation at the initial angular velocity."""

    run: RunCase
    model_case: Case
    model: red.ReducedModel
    system: dyn.ReducedSystem
    initial: InitialState
    validity: Validity | None = None


def prepare(
    run: RunCase,
    model: red.ReducedModel | None = None,
    progress: Progress | None = None,
    *,
    model_case: Case | None = None,
) -> RunSetup:
    """Reduced model (from the cache unless ``model`` is given), system and initial state of
    ``run``; raises :class:`CaseError` for inputs that cannot be run."""
    if run.spinup is not None:
        raise CaseError(
            "[spinup]: a hub-driven spin-up, not a free-body run; use simulate_spinup",
            field="spinup",
        )
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
    init = initial_state(system, model, run)
    omega0 = dyn.split_state(system, init.y0)[1]
    validity = rotating_validity(system, omega0, run.reduced.formulation)
    if system.quartic:
        _, _, s0, sd0 = dyn.split_state(system, init.y0)
        e_modal = float(0.5 * sd0 @ system.mu @ sd0 + dyn.potential_energy(system, init.y0))
        validity = dataclasses.replace(
            validity, modal_energy=e_modal, barrier_energy=dyn.potential_barrier(system)[0]
        )
    return RunSetup(run, model_case, model, system, init, validity)


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
        validity=setup.validity,
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
    spin_rate: str | None = None,
) -> RunCase:
    """``run`` with command-line overrides (quantity strings such as ``"0.25 ms"``), validated
    like the case file; raises :class:`CaseError` naming the field.

    ``spin_rate`` sets ``initial.spin_rate`` (free-body run) or ``spinup.omega_s`` (spin-up);
    ``duration`` sets ``integration.duration`` or ``spinup.duration``."""
    import tomllib

    from quadmodes.case import run_case_from_dict

    if all(v is None for v in (method, dt, duration, formulation, save_every, spin_rate)):
        return run
    data = tomllib.loads(run.to_toml())
    if run.spinup is not None:
        for option, value in (("method", method), ("dt", dt), ("save_every", save_every)):
            if value is not None:
                raise CaseError(
                    f"--{option.replace('_', '-')}: not used by a hub-driven spin-up ([spinup] "
                    "is integrated by DOP853 with its own step control)",
                    field=f"spinup.{option}",
                )
        if duration is not None:
            data["spinup"]["duration"] = duration
        if spin_rate is not None:
            data["spinup"]["omega_s"] = spin_rate
        if formulation is not None:
            data.setdefault("reduced", {})["formulation"] = formulation
        return run_case_from_dict(data, source="command line")
    if spin_rate is not None:
        data.setdefault("initial", {})["spin_rate"] = spin_rate
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

    from quadmodes.case import builtin_run_case_names

    if name_or_path in builtin_run_case_names(None):
        return True
    path = Path(name_or_path).expanduser()
    if path.suffix != ".toml" or not path.is_file():
        return False
    try:
        return tomllib.loads(path.read_text(encoding="utf-8")).get("kind") == "run"
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False  # let the loader report it


# ---------------------------------------------------------------------------------------------
# time-step convergence
# ---------------------------------------------------------------------------------------------

#: Step refinements of :func:`dt_convergence`: dt, dt/2, dt/4.
DT_FACTORS = (1, 2, 4)


def _rel(new: float, old: float) -> float | None:
    if not (math.isfinite(new) and math.isfinite(old)) or old == 0.0:
        return None
    return abs(new - old) / abs(old)


def dt_convergence(
    setup: RunSetup,
    first: RunResult | None = None,
    progress: Progress | None = None,
    factors: tuple[int, ...] = DT_FACTORS,
) -> list[dict]:
    """Run ``setup`` at dt/f for f in ``factors`` (fixed-step methods only; ``first``: the run
    at the case's dt, if already done) and return one row per step: ``dt_s``, ``steps``,
    ``complete``, ``t_end_s``, final ``cone_angle_deg``, ``spin_rate_hz`` and
    ``dissipated_energy_J``, and their relative changes from the previous row (``rel_change_*``,
    None for the first row or a zero reference). ``save_every`` scales with the refinement so
    the samples stay on the same times."""
    run = setup.run
    if run.integration.method == "adaptive":
        raise CaseError(
            "--dt-convergence: needs a fixed-step method (midpoint or backward-euler), not "
            '"adaptive"',
            field="integration.method",
        )
    rows: list[dict] = []
    keys = ("cone_angle_deg", "spin_rate_hz", "dissipated_energy_J")
    for f in factors:
        if f == 1 and first is not None:
            result = first
        else:
            integ = run.integration.model_copy(
                update={"dt": run.integration.dt / f, "save_every": run.integration.save_every * f}
            )
            sub = dataclasses.replace(setup, run=run.model_copy(update={"integration": integ}))
            result = execute(sub, progress)
        d = result.diagnostics
        row = {
            "dt_s": float(run.integration.dt / f),
            "steps": int(result.solution.stats.get("n_steps", 0)),
            "complete": bool(result.complete),
            "t_end_s": float(d.t[-1]),
            "cone_angle_deg": float(np.degrees(d.cone_angle[-1])),
            "spin_rate_hz": float(d.spin_rate[-1] / (2 * math.pi)),
            "dissipated_energy_J": float(d.E_d[-1]),
            "wall_s": float(result.wall_s),
        }
        for key in keys:
            row[f"rel_change_{key}"] = _rel(row[key], rows[-1][key]) if rows else None
        rows.append(row)
    return rows


# ---------------------------------------------------------------------------------------------
# hub-driven spin-up (clamped beam)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SpinupRun:
    """A hub-driven spin-up run: the run case, its (beam) model case, the
    :class:`quadmodes.runs.spinup.SpinupResult`, the :class:`Validity` of the formulation at the
    final hub rate (about the hub z axis), and the wall time (s)."""

    run: RunCase
    model_case: Case
    result: object
    validity: Validity
    wall_s: float

    @property
    def complete(self) -> bool:
        return self.result.status == "ok"

    @property
    def reason(self) -> str:
        return "" if self.complete else self.result.message


def spinup_model(run: RunCase, model_case: Case | None = None) -> red.ReducedModel:
    """Reduced model of a spin-up: :func:`quadmodes.runs.spinup.kane_model` of the run's clamped beam
    case with ``reduced.modes`` in-plane bending modes."""
    from quadmodes.runs.spinup import kane_model

    case = model_case if model_case is not None else run.model_case()
    if case.kind != "beam" or case.beam.support != "clamped":
        raise CaseError(
            f'model = "{run.model}": a [spinup] run needs a beam clamped to the hub '
            '(kind = "beam", support = "clamped"), e.g. "kane-beam"',
            field="model",
        )
    if run.reduced.formulation == "rigid":
        raise CaseError(
            'reduced.formulation = "rigid": a spin-up needs the elastic modes (Q, P or L)',
            field="reduced.formulation",
        )
    structure = pipeline.structure_for_case(case)
    try:
        return kane_model(
            run.reduced.modes,
            n_elements=case.beam.elements,
            damping_ratio=float(case.beam.damping_ratio),
            structure=structure,
        )
    except ValueError as exc:
        raise CaseError(
            f"reduced.modes = {run.reduced.modes}: {exc}", field="reduced.modes"
        ) from None


def simulate_spinup(
    run: RunCase, model: red.ReducedModel | None = None, *, model_case: Case | None = None
) -> SpinupRun:
    """Integrate the hub-driven spin-up of ``run`` (``[spinup]``) with
    :func:`quadmodes.runs.spinup.kane_spinup`; a diverged run is returned (status "diverged"), not
    raised."""
    from quadmodes.runs.spinup import kane_spinup

    if run.spinup is None:
        raise CaseError("not a spin-up run: it has no [spinup] table", field="spinup")
    model_case = model_case if model_case is not None else run.model_case()
    if model is None:
        model = spinup_model(run, model_case)
    sp = run.spinup
    system = dyn.reduced_system(model, run.reduced.formulation)
    validity = rotating_validity(system, np.array([0.0, 0.0, sp.omega_s]), run.reduced.formulation)
    start = time.perf_counter()
    result = kane_spinup(
        sp.omega_s,
        sp.ramp_time,
        sp.duration,
        formulation=run.reduced.formulation,
        model=model,
        rtol=sp.rtol,
        atol=sp.rtol * 1e-2,
        n_out=sp.samples,
    )
    return SpinupRun(run, model_case, result, validity, time.perf_counter() - start)
