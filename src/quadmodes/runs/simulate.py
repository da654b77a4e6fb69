"""Run cases: prepare a free-body run (reduced model, system, initial state, validity),
integrate it in chunks, refine its step, and run a hub-driven spin-up.

Stages::

    Case ──models.build.reduced_model_for──▶ ReducedModel (cached)
    RunCase + ReducedModel ──prepare──▶ RunSetup ──execute──▶ RunResult (Solution + Diagnostics)
    RunSetup ──dt_convergence──▶ one row per step dt, dt/2, dt/4
    RunCase [spinup] ──simulate_spinup──▶ SpinupRun (:mod:`quadmodes.runs.spinup`)

The pieces: :mod:`quadmodes.models.build` (the reduced model of a case),
:mod:`quadmodes.runs.initial` (the initial state), :mod:`quadmodes.runs.validity` (the rotating
stiffness and Q4 barrier checks) and :mod:`quadmodes.runs.chunked` (chunked integration with
progress, checkpoints and early stops: an integrator failure or a non-finite state ends the run
early, what was computed is kept and the result is marked incomplete with a reason; Ctrl-C
raises :class:`~quadmodes.runs.chunked.Interrupted` carrying that partial result).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadmodes.case import Case, CaseError, RunCase
from quadmodes.models.build import reduced_model_for
from quadmodes.rom import reduced as red
from quadmodes.rom import system as rsys
from quadmodes.rom.diagnostics import Diagnostics, diagnostics
from quadmodes.rom.solution import Solution
from quadmodes.runs.chunked import (
    MAX_CHUNKS,
    Checkpointer,
    ChunkProgress,
    Interrupted,
)
from quadmodes.runs.deformation_check import with_deformation_check
from quadmodes.runs.events import EventHit, run_event
from quadmodes.runs.initial import InitialState, initial_state
from quadmodes.runs.manifold_system import run_system
from quadmodes.runs.mode_choice import ModeChoice, resolve_modes
from quadmodes.runs.path_validity import PathValidity, run_path_validity
from quadmodes.runs.resources import check_output_size
from quadmodes.runs.run_checks import check_model_case, check_run_step
from quadmodes.runs.step_chunks import integrate_run
from quadmodes.runs.validity import Validity, initial_validity, rotating_validity
from quadmodes.structure import pipeline

Progress = Callable[[str, float], None]
log = logging.getLogger(__name__)

PAPER_RUN_CASES = ("paper-0.5hz", "paper-41hz")


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
    system: rsys.ReducedSystem
    initial: InitialState
    solution: Solution
    diagnostics: Diagnostics
    complete: bool
    reason: str
    wall_s: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    validity: Validity | None = None
    mode_choice: ModeChoice | None = None
    # the linear answer at the spin (quadmodes.analysis.run_answer.LinearAnswer: energy-sink
    # time constant, stability), attached by the caller (a layer above the runs); None if not
    linear: object | None = None
    event: EventHit | None = None
    path: PathValidity | None = None
    # figures analyses above runs/ add: (file name, draw(path)) pairs, drawn with the run's
    # (quadmodes.analysis.run_campbell: the Campbell diagram of the run's model)
    figures: tuple = ()
    # the switches of a reduced.path_model = "spin-family" run (quadmodes.runs.spin_family)
    family: tuple = ()


@dataclass(frozen=True, eq=False)
class RunSetup:
    """Everything a run needs before integrating: the run case (with a whole number of modes:
    ``"auto"`` resolved), its model case, the reduced model (restricted to the run's modes),
    the system of the run's formulation, the initial state, the
    :class:`~quadmodes.runs.validity.Validity` of the formulation at the initial angular
    velocity and the :class:`~quadmodes.runs.mode_choice.ModeChoice` of the modes."""

    run: RunCase
    model_case: Case
    model: red.ReducedModel
    system: rsys.ReducedSystem
    initial: InitialState
    validity: Validity | None = None
    mode_choice: ModeChoice | None = None
    fe_checks: bool = False  # the FE model checks the path's modal amplitudes (as quadmodes run)


def _model_for_run(run: RunCase, model: red.ReducedModel) -> red.ReducedModel:
    """``model`` restricted to the run's ``reduced.modes``; raises :class:`CaseError` for a
    hub-clamped model or one with too few modes."""
    if not model.free:
        raise CaseError(
            f'model = "{run.model_name}": clamped to a hub; a run needs a free-floating body',
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
    return model


def prepare(
    run: RunCase,
    model: red.ReducedModel | None = None,
    progress: Progress | None = None,
    *,
    model_case: Case | None = None,
    check_deformation: bool = False,
    allow_coarse_step: bool = False,
) -> RunSetup:
    """Reduced model (from the cache unless ``model`` is given: it must have been built from
    the run's model case), system and initial state of ``run``; raises :class:`CaseError` for
    inputs that cannot be run, among them a time step that does not resolve the spin or the
    highest retained mode (:mod:`quadmodes.runs.run_checks`; unless ``allow_coarse_step``,
    then noted). ``check_deformation``: set an initial modal deformation beside the FE model's
    condensed energy (:mod:`quadmodes.runs.deformation_check`; one static solve on the FE
    model, what ``quadmodes run`` does), recorded in the validity."""
    if run.spinup is not None:
        raise CaseError(
            "[spinup]: a hub-driven spin-up, not a free-body run; use simulate_spinup",
            field="spinup",
        )
    if model_case is not None:  # record the model it runs (results' case_toml replays it)
        run = run.with_model(model_case)
    else:
        model_case = run.model_case()
    run, choice = resolve_modes(run, model_case, progress)
    check_output_size(run)  # before the model is built: a results file too large to write
    if model is None:
        model = reduced_model_for(model_case, run.reduced.modes, progress, spin=run.reference_spin,
                                  axis=run.reference_axis)  # fmt: skip
    else:
        check_model_case(model, model_case)
    model = _model_for_run(run, model)
    freqs = () if run.reduced.formulation == "rigid" else model.frequencies_hz
    coarse = check_run_step(run, freqs, allow_coarse=allow_coarse_step)
    system = run_system(run, model, model_case)  # "QM" from the case's structure
    init = initial_state(system, model, run)
    if coarse:
        init = dataclasses.replace(init, notes=(*init.notes, coarse))
    validity = initial_validity(system, init.y0, run.reduced.formulation)
    run_event(system, init, run)  # a run that starts on its until level: refused here
    setup = RunSetup(run, model_case, model, system, init, validity, choice)
    return with_deformation_check(setup, progress) if check_deformation else setup


def _result(setup: RunSetup, chunks) -> RunResult:
    """The :class:`RunResult` of ``setup`` integrated to ``chunks`` (a ChunkedRun), with the
    model's validity checked along the path (:mod:`quadmodes.runs.path_validity`)."""
    run, system, init = setup.run, setup.system, setup.initial
    diag = diagnostics(system, chunks.solution, spin_axis=init.spin_axis)
    return RunResult(
        run=run,
        model_case=setup.model_case,
        model=setup.model,
        system=system,
        initial=init,
        solution=chunks.solution,
        diagnostics=diag,
        complete=not chunks.reason,
        reason=chunks.reason,
        wall_s=chunks.wall_s,
        notes=init.notes,
        validity=setup.validity,
        mode_choice=setup.mode_choice,
        event=chunks.event,
        path=run_path_validity(setup, chunks.solution, diag),
    )


def _family_result(setup: RunSetup, fam) -> RunResult:
    """The :class:`RunResult` of a spin-family run (:class:`~quadmodes.runs.spin_family.
    FamilyRun`): ``model``/``system`` the first member's, the samples each in its member's."""
    return RunResult(setup.run, setup.model_case, setup.model, setup.system, setup.initial,
                     fam.solution, fam.diagnostics, not fam.last.reason, fam.last.reason,
                     fam.wall_s, (*setup.initial.notes, *fam.notes), setup.validity,
                     setup.mode_choice, event=fam.last.event, path=fam.path,
                     family=fam.switches)  # fmt: skip


_KERNEL_READY: list[bool] = []  # [True] once the compiled kernel is loaded in this process


def warm_up_kernel(run: RunCase, progress: Progress | None = None) -> float | None:
    """Compile (or load from numba's on-disk cache) the compiled midpoint kernel a free-body
    ``run`` will use, as the stage "compile" of ``progress``, so that its first call (about
    8 s) is not counted in the run's wall time; returns the seconds it took, None if the run
    does not use the kernel, numba is not installed or the kernel is already loaded."""
    from quadmodes.rom.integrators import numba_kernel

    if run.integration is None or run.integration.method != "midpoint" or _KERNEL_READY:
        return None
    kernel = numba_kernel()
    if kernel is None:  # numba cannot be imported here: the numpy steppers
        return None
    if progress:
        progress("compile", 0.0)
    seconds = kernel.warm_up()
    if run.reduced.formulation == "QM":  # its own compiled loop (rom.manifold_kernel)
        from quadmodes.rom import manifold_kernel

        seconds += manifold_kernel.warm_up()
    _KERNEL_READY.append(True)
    if progress:
        progress("compile", 1.0)
    log.info("compiled midpoint kernel ready in %.1f s", seconds)
    return seconds


def execute(
    setup: RunSetup,
    progress: Progress | None = None,
    max_chunks: int | None = None,
    *,
    checkpoint: Checkpointer | None = None,
    resume: tuple[ChunkProgress, float] | None = None,
):
    """Integrate a prepared run in chunks; returns a :class:`RunResult`.

    ``progress(stage, fraction)`` is called with stage = the run name between chunks (with an
    ``until`` event: "NAME (to EVENT or T s)", the fraction the larger of t/T and the distance
    to the event, :func:`quadmodes.runs.events.progress_fraction`). An
    integrator failure or a non-finite state ends the run early with ``complete`` False and a
    one-line ``reason``; it is not raised (see
    :func:`quadmodes.runs.chunked.integrate_in_chunks`, also for ``checkpoint`` and
    ``resume``). Ctrl-C raises :class:`~quadmodes.runs.chunked.Interrupted` whose ``partial``
    is the :class:`RunResult` up to the last whole chunk (``complete`` False)."""
    run, system, init = setup.run, setup.system, setup.initial
    warm_up_kernel(run, progress)  # the compile step is not part of the run's wall time
    if run.reduced.path_model == "spin-family":  # a family of models along the path
        from quadmodes.runs import spin_family

        spin_family.check_family_run(run)
        try:
            return _family_result(setup, spin_family.run_family(  # its switches: per chunk
                setup, progress, MAX_CHUNKS if max_chunks is None else max_chunks,
                checkpoint=checkpoint, resume=resume))
        except Interrupted as stop:
            raise Interrupted(_family_result(setup, stop.partial), stop.saved, stop.reason) from None
    try:
        chunks = integrate_run(  # the fixed step, or a controlled one (runs.step_chunks)
            system, init.y0, run.integration, progress, run.name, max_chunks,
            checkpoint=checkpoint, resume=resume, event=run_event(system, init, run),
        )  # fmt: skip
    except Interrupted as stop:  # no FE check of the path on the way out
        partial = _result(dataclasses.replace(setup, fe_checks=False), stop.partial)
        raise Interrupted(partial, stop.saved, stop.reason) from None
    return _result(setup, chunks)


def simulate(
    run: RunCase,
    model: red.ReducedModel | None = None,
    progress: Progress | None = None,
    *,
    model_case: Case | None = None,
    max_chunks: int | None = None,
    check_deformation: bool = False,
    allow_coarse_step: bool = False,
) -> RunResult:
    """:func:`prepare` (with ``check_deformation``, as ``quadmodes run``, and
    ``allow_coarse_step``) and :func:`execute` ``run`` (reduced model from the cache unless
    ``model`` is given). Raises :class:`CaseError` for bad inputs only; an integrator failure
    gives a result with ``complete`` False; Ctrl-C raises
    :class:`~quadmodes.runs.chunked.Interrupted`."""
    setup = prepare(run, model, progress, model_case=model_case,
                    check_deformation=check_deformation, allow_coarse_step=allow_coarse_step)  # fmt: skip
    return execute(setup, progress, max_chunks)


def _spinup_overrides(method, dt, duration, formulation, save_every, spin_rate,
                      until=None, step_tolerance=None) -> list:  # fmt: skip
    """The (field, value) changes of command-line overrides to a spin-up run (``[spinup]``)."""
    for option, value in (("method", method), ("dt", dt), ("save_every", save_every),
                          ("until", until), ("step_tolerance", step_tolerance)):  # fmt: skip
        if value is not None:
            raise CaseError(
                f"--{option.replace('_', '-')}: not used by a hub-driven spin-up ([spinup] "
                "is integrated by DOP853 with its own step control)",
                field=f"spinup.{option}",
            )
    return [("spinup.duration", duration), ("spinup.omega_s", spin_rate),
            ("reduced.formulation", formulation)]  # fmt: skip


def _free_body_overrides(method, dt, duration, formulation, save_every, spin_rate,
                         until=None, step_tolerance=None) -> list:  # fmt: skip
    """The (field, value) changes of command-line overrides to a free-body run."""
    return [("integration.until", until), ("integration.step_tolerance", step_tolerance),
            ("initial.spin_rate", spin_rate), ("integration.method", method),
            ("integration.dt", dt), ("integration.duration", duration),
            ("integration.save_every", save_every), ("reduced.formulation", formulation)]  # fmt: skip


def _modes_value(modes):
    """``--modes`` as a whole number or "auto" (validated by the case)."""
    if isinstance(modes, str):
        text = modes.strip()
        try:
            return int(text)
        except ValueError:
            return text
    return modes


def apply_overrides(
    run: RunCase,
    *,
    method: str | None = None,
    dt: str | None = None,
    duration: str | None = None,
    formulation: str | None = None,
    save_every: int | None = None,
    spin_rate: str | None = None,
    modes: int | str | None = None,
    axis: str | None = None,
    until: str | None = None,
    step_tolerance: str | float | None = None,
) -> RunCase:
    """``run`` with command-line overrides (quantity strings such as ``"0.25 ms"``), validated
    like the case file (:func:`quadmodes.case.editing.edit`); raises :class:`CaseError` naming
    the field.

    ``spin_rate`` sets ``initial.spin_rate`` (free-body run) or ``spinup.omega_s`` (spin-up);
    ``duration`` sets ``integration.duration`` or ``spinup.duration``; ``modes`` (a whole
    number, or "auto" for a free-body run) sets ``reduced.modes`` (a whole number drops
    ``reduced.mode_margin``); ``axis`` (a name or "a,b,c") sets ``initial.spin_axis`` of a
    free-body run; ``until`` (e.g. "cone 60 deg") sets ``integration.until``;
    ``step_tolerance`` (e.g. "1e-4") sets ``integration.step_tolerance`` (a controlled step)."""
    from quadmodes.case.editing import edit

    values = (method, dt, duration, formulation, save_every, spin_rate, until, step_tolerance)
    if all(v is None for v in values) and modes is None and axis is None:
        return run
    if axis is not None and run.spinup is not None:
        raise CaseError("--axis: a hub-driven spin-up turns about its hub's axis; drop --axis",
                        field="initial.spin_axis")  # fmt: skip
    changes = (_spinup_overrides if run.spinup is not None else _free_body_overrides)(*values)
    changes.append(("reduced.modes", None if modes is None else _modes_value(modes)))
    changes.append(("initial.spin_axis", axis))
    return edit(run, [(k, v) for k, v in changes if v is not None], "command line")


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
# hub-driven spin-up (clamped beam)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SpinupRun:
    """A hub-driven spin-up run: the run case, its (beam) model case, the
    :class:`quadmodes.runs.spinup.SpinupResult`, the :class:`~quadmodes.runs.validity.Validity`
    of the formulation at the final hub rate (about the hub z axis), and the wall time (s); a
    spin change of a free body on a hub (:mod:`quadmodes.runs.spin_change`) also its path's
    :class:`~quadmodes.runs.path_validity.PathValidity`."""

    run: RunCase
    model_case: Case
    result: object
    validity: Validity
    wall_s: float
    path: PathValidity | None = None

    @property
    def complete(self) -> bool:
        return self.result.status == "ok"

    @property
    def reason(self) -> str:
        return "" if self.complete else self.result.message


def spinup_model(run: RunCase, model_case: Case | None = None) -> red.ReducedModel:
    """Reduced model of a spin-up: :func:`quadmodes.models.beam.kane_model` of the run's clamped beam
    case with ``reduced.modes`` in-plane bending modes."""
    from quadmodes.models.beam import kane_model

    case = model_case if model_case is not None else run.model_case()
    if case.kind != "beam" or case.beam.support != "clamped":
        raise CaseError(
            f'model = "{run.model_name}": a [spinup] run needs a beam clamped to the hub '
            '(kind = "beam", support = "clamped"), e.g. "kane-beam"',
            field="model",
        )
    if run.reduced.formulation in ("rigid", "QM"):
        raise CaseError(
            f'reduced.formulation = "{run.reduced.formulation}": a spin-up takes Q, P, L or Q4',
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
    if model_case is not None:  # record the model it runs (results' case_toml replays it)
        run = run.with_model(model_case)
    else:
        model_case = run.model_case()
    if run.spinup.omega_0 > 0.0:  # a spin change of a free body on a hub
        from quadmodes.runs.spin_change import simulate_spin_change

        return simulate_spin_change(run, model_case, model, SpinupRun)
    if model is None:
        model = spinup_model(run, model_case)
    sp = run.spinup
    system = rsys.reduced_system(model, run.reduced.formulation)
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
