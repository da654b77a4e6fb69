"""Computations from Python, each delegating to the stage that does it: the modal model
(inflation and modes), the reduced model, a run, its results file, the Campbell diagram, the
rotating-frame comparison, the comparison with the full order, the end-mass calibration.

Inputs are SI inside; every dimensional argument here also takes a quantity string or a pint
quantity (:func:`quadmodes.api.quantities.si`). Cases may be given as objects, built-in names or
TOML paths.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from quadmodes.api.cases import load
from quadmodes.api.quantities import QuantityLike, si
from quadmodes.case import Case, CaseError, RunCase

#: ``progress(stage, fraction)``: a stage name and its completed fraction in [0, 1].
Progress = Callable[[str, float], None]


def _model(case: Case | str | os.PathLike[str]) -> Case:
    """A model case from a case object, a name or a path (a run case gives its model)."""
    if isinstance(case, Case):
        return case
    loaded = case if isinstance(case, RunCase) else load(case)
    return loaded.model_case() if isinstance(loaded, RunCase) else loaded


def _run(run: RunCase | str | os.PathLike[str]) -> RunCase:
    loaded = run if isinstance(run, RunCase) else load(run)
    if not isinstance(loaded, RunCase):
        raise CaseError(f"{loaded.name} is a model case; give a run case (kind = \"run\")")
    return loaded


def modal_model(case, progress: Progress | None = None, *,
                output_dir: str | os.PathLike[str] | None = None):  # fmt: skip
    """Mesh, finite-element structure, inflated (prestressed) state and free-free modes.

    Parameters
    ----------
    case : Case, str or path
        Model case (or a run case: its model).
    output_dir
        Also write what ``quadmodes modes -o DIR`` writes there, all or nothing: ``mesh.vtu``,
        ``modes/`` (a PVD series per mode, ParaView), PNG pictures of the mesh, the prestress and every mode, and
        ``modes.json`` (:func:`modes_summary`).

    Returns
    -------
    quadmodes.structure.pipeline.ModalModel
        ``structure``; ``x`` (n, 3) m, the inflated positions; ``modes.frequencies_hz`` (N,) Hz
        and ``modes.shapes`` (N, n, 3) mass-normalised (kg^-0.5); ``labels`` (N,).
        :func:`modes_summary` gives what ``quadmodes modes`` prints.
    """
    from quadmodes.io.staging import staged_output
    from quadmodes.structure.modal_files import write_modal_outputs
    from quadmodes.structure.pipeline import build_modal_model

    model = build_modal_model(_model(case), progress)
    if output_dir is not None:
        with staged_output(Path(output_dir)) as scratch:
            write_modal_outputs(model, scratch)
    return model


def modes_summary(modal) -> dict:
    """What ``quadmodes modes --json`` prints for a :func:`modal_model`: ``frequencies_hz``
    (Hz), ``labels``, ``mass_kg`` (kg), ``inertia_kg_m2`` (3, 3) kg m^2, ``pressure_pa`` (Pa),
    prestress figures (N/m)."""
    from quadmodes.structure.pipeline import modes_summary as summary

    return summary(modal)


def reduced_model(
    case, n_modes: int = 5, *, spin: QuantityLike = 0.0, spin_axis=None,
    progress: Progress | None = None, cache: bool = True,
):  # fmt: skip
    """The reduced model (quadratic modes, floating-frame arrays) of a model case, from the
    model cache ($QUADMODES_CACHE) unless ``cache`` is False.

    Parameters
    ----------
    n_modes
        Elastic modes kept (1).
    spin
        Angular rate of the state the model is expanded about: 0 (at rest) or e.g. "41 Hz";
        a bare float is rad/s.
    spin_axis
        The body axis of that spinning state, as ``initial.spin_axis`` ("x" … "major", or three
        numbers); None: the minor axis (a flat membrane: its normal).

    Returns
    -------
    quadmodes.rom.reduced.ReducedModel
        ``frequencies_hz`` (N,) Hz, ``labels``, ``mass`` kg, ``J0`` (3, 3) kg m^2, ...
    """
    from quadmodes.models.build import reduced_model_for

    rate = si(spin, "angular_rate", "spin")
    axis = spin_axis  # a name, or three numbers in the text form the case and cache key use
    if axis is not None and not isinstance(axis, str):
        axis = ",".join(f"{float(v)!r}" for v in axis)
    return reduced_model_for(_model(case), int(n_modes), progress, use_cache=cache, spin=rate,
                             axis=axis)  # fmt: skip


def simulate(run, *, model_case: Case | None = None, model=None, progress: Progress | None = None,
             check_deformation: bool = True, checkpoint: str | os.PathLike[str] | None = None,
             resume: bool = False, checkpoint_every: QuantityLike = "10 s",
             allow_coarse_step: bool = False, until: str | None = None):  # fmt: skip
    """Integrate a run case: a free-body run (``[initial]``, ``[integration]``) or a hub-driven
    spin-up (``[spinup]``).

    Parameters
    ----------
    run : RunCase, str or path
        The run (:func:`quadmodes.run_case`); times in s, rates in rad/s inside.
    model_case
        Run this model instead of the one the run names; it is recorded in the result's run case
        (``result.run.model``), so its TOML (``case_toml`` of ``results.nc``) replays it.
    model
        An already reduced model to use (else from the cache); one built from another case
        than the run's model case is refused (``CaseError`` naming ``model``).
    until
        End the run on an event before its duration (``integration.until``): "cone 60 deg",
        "spin 30 Hz", "time 10 s" or "flat spin"; located to the step, in ``result.event``
        (None if not reached), the summary's ``until`` and ``results.nc``.
    allow_coarse_step
        Run a time step of fewer than 2 steps per period of the spin or of the highest
        retained mode (refused otherwise, as ``quadmodes run`` without ``--yes``); under 10
        steps a period the run's notes say so.
    check_deformation
        As ``quadmodes run``: set an initial modal deformation beside the FE model's condensed
        energy before integrating (one static solve on the FE model; stage "initial deformation
        vs the FE model"), recorded in ``result.validity`` (2 % tolerance) and the summary.
    checkpoint, resume, checkpoint_every
        A free-body run is checkpointed into ``checkpoint`` (.npz) after the chunk that ends
        ``checkpoint_every`` of wall time (a time, e.g. "10 s"; 0: every chunk) and on Ctrl-C,
        as ``quadmodes run``; with ``resume`` it continues from it, bit for bit the
        uninterrupted run (a checkpoint of another run is refused). Without ``resume`` an
        existing checkpoint is discarded; a finished run removes it. Ctrl-C (or a ``progress``
        callback raising KeyboardInterrupt) raises :class:`quadmodes.runs.chunked.Interrupted`
        (a KeyboardInterrupt) whose ``partial`` is the result so far (``complete`` False).

    Returns
    -------
    quadmodes.runs.simulate.RunResult or SpinupRun
        ``solution`` (t (nt,) s, y (nt, 7 + 2N)), ``diagnostics`` (angular momentum kg m^2/s,
        energies J, spin rate rad/s, cone angle rad), ``complete``, ``reason``, ``validity``
        (at the start), ``path`` (the model's validity along the path), ``event``;
        :func:`summary` gives what ``quadmodes run`` prints.
    """
    from quadmodes.analysis.run_answer import with_linear_answer
    from quadmodes.runs import simulate as sim

    run = _run(run)
    if until is not None:
        from quadmodes.case.editing import edit

        run = edit(run, [("integration.until", until)], "until")
    if run.spinup is not None:
        return sim.simulate_spinup(run, model, model_case=model_case)
    if checkpoint is None:
        result = sim.simulate(run, model, progress, model_case=model_case,
                              check_deformation=check_deformation,
                              allow_coarse_step=allow_coarse_step)  # fmt: skip
    else:
        result = _checkpointed(run, model, progress, model_case, check_deformation,
                               Path(checkpoint), resume,
                               si(checkpoint_every, "time", "checkpoint_every"), allow_coarse_step)  # fmt: skip
    return with_linear_answer(result)  # energy-sink time constant, stability


def _checkpointed(run, model, progress, model_case, check_deformation, path: Path, resume: bool,
                  every_s: float, allow_coarse_step: bool = False):  # fmt: skip
    """:func:`simulate` of a free-body run checkpointed into ``path`` (see there)."""
    from quadmodes.runs import simulate as sim
    from quadmodes.runs.run_checkpoint import CheckpointError, RunCheckpoint

    if resume and not path.is_file():
        raise CheckpointError(f"resume: no checkpoint at {path}; run without resume")
    if not resume:
        path.unlink(missing_ok=True)  # a fresh run: never continue an old checkpoint unasked
    setup = sim.prepare(run, model, progress, model_case=model_case,
                        check_deformation=check_deformation,
                        allow_coarse_step=allow_coarse_step)  # fmt: skip
    start = RunCheckpoint(path, setup).load() if resume else None
    result = sim.execute(setup, progress, checkpoint=RunCheckpoint(path, setup, every_s),
                         resume=start)  # fmt: skip
    path.unlink(missing_ok=True)  # finished: nothing left to resume
    return result


def results_dataset(result):
    """The ``results.nc`` dataset (xarray, CF attributes: ``long_name``, ``units``) of a
    :func:`simulate` result; time in s, angles in rad, rates in rad/s, modal coordinates in
    m for modes normalised to 1 kg (the numbers of kg^0.5 m; ``mass_normalised_units``)."""
    from quadmodes.runs import results

    if hasattr(result, "diagnostics"):
        return results.to_dataset(result)
    return results.spinup_dataset(result)


def summary(result) -> dict:
    """The run summary (``summary.json``, the table ``quadmodes run`` prints) of a
    :func:`simulate` result; keys carry their units: ``_hz`` (Hz), ``_deg`` (deg), ``_J`` (J),
    ``_s`` (s)."""
    from quadmodes.runs import results

    ds = results_dataset(result)
    return results.summary(ds) if hasattr(result, "diagnostics") else results.spinup_summary(ds)


def write_results(result, folder: str | os.PathLike[str], plots: bool = True, *,
                  extra: dict | None = None, animate: int | None = None,
                  animate_frame: str = "inertial", note=None) -> dict:  # fmt: skip
    """Write what ``quadmodes run`` writes for a :func:`simulate` result into ``folder``
    (created): ``results.nc`` (CF: every variable with ``long_name`` and SI ``units``: s, rad,
    rad/s, J, kg m^2/s, m: :mod:`quadmodes.io.cf`) and ``summary.json``, all or nothing (staged in a hidden
    folder beside ``folder``, then moved in; figures an earlier run wrote there are removed,
    never a file quadmodes did not write, which is refused with ``OutputPathError``), then
    (if ``plots``) the PNG figures, with ``animate`` frames the motion (``motion.xdmf`` +
    ``motion.h5`` in the ``animate_frame``: "inertial" or "body"), and ``report.html``.

    ``extra``: summary keys to add (e.g. ``{"dt_convergence": dt_convergence(run)}``);
    ``note(text)``: receives the one-line notes (default: the ``logging`` module).
    Returns the summary (:func:`summary`, with ``extra``)."""
    from quadmodes.io.outputs import check_output_path, check_replaceable
    from quadmodes.runs.run_folder import DATA_FILES, EXTRA_FILES, Animation, write_run_outputs

    check_output_path(Path(folder), "folder")  # a link, a dangling link, too long: refused
    check_replaceable(Path(folder), (*DATA_FILES, *EXTRA_FILES), "folder")  # the user's files
    animation = None if animate is None else Animation(animate_frame, int(animate))
    return write_run_outputs(result, Path(folder), extra=extra, plots=plots, animation=animation,
                             note=note)  # fmt: skip


def campbell(
    case, spin_min: QuantityLike = 0.0, spin_max: QuantityLike = "10 rad/s", points: int = 41,
    *, formulation: str = "Q", axis=None, full_order: Sequence[QuantityLike] = (),
    output_dir: str | os.PathLike[str] | None = None, progress: Progress | None = None,
    units: str = "Hz",
):  # fmt: skip
    """Frequencies of the reduced model linearised about steady spin at ``points`` spin rates
    from ``spin_min`` to ``spin_max`` (quantities, e.g. "20 Hz"; bare floats are rad/s),
    tracked by MAC (what ``quadmodes campbell`` prints).

    ``case``: a case (name, path, object) or a reduced model (e.g. ``qm.reduced_model(case, 9,
    spin="1 rad/s", spin_axis="major")``: a body stiffened by its spin alone, swept from 0 from
    5 % of that spin). ``axis``: the body-frame spin axis, as ``--axis``: None (a model about a
    spinning state: that state's axis; a free body: its symmetry axis; a clamped body: z), a
    name ("x", "minor" ...), a principal index 0-2 or a vector (3,).
    ``full_order``: spin rates (quantities; bare floats rad/s) at which the full-order model is
    linearised about its spinning equilibrium, its roots drawn as markers (``--full-order``).
    ``units`` ("Hz", "rpm", "rad/s"; ``--units``): the unit of the result's ``table`` (the
    table ``quadmodes campbell`` prints, by the same function) and of campbell.png.

    Returns
    -------
    quadmodes.analysis.campbell.CampbellResult
        ``spin`` (ns,) rad/s, ``labels`` (nb,), ``frequency`` (ns, nb) rad/s (rotating frame),
        ``growth`` (ns, nb) 1/s, ``min_stiffness`` (ns,) 1/s^2 (SI whatever ``units``);
        ``table`` (:class:`~quadmodes.analysis.campbell_table.CampbellTable`): spin and
        frequencies in ``units``, critical speeds, ``to_text()``. With ``output_dir``
        campbell.png/.nc/.csv are written there (all or nothing), as ``campbell -o``.
    """
    from quadmodes.analysis.campbell_output import campbell_with_full_order
    from quadmodes.io.display_units import frequency_unit
    from quadmodes.io.staging import staged_output
    from quadmodes.rom.reduced import ReducedModel

    lo = si(spin_min, "angular_rate", "spin_min")
    hi = si(spin_max, "angular_rate", "spin_max")
    spins = [si(v, "angular_rate", "full_order") for v in full_order]
    unit = frequency_unit(units, "units")
    folder = None if output_dir is None else Path(output_dir)
    with staged_output(folder) as scratch:
        result, _, _ = campbell_with_full_order(
            case if isinstance(case, ReducedModel) else _model(case), lo, hi, int(points),
            axis=axis, formulation=formulation,
            output_dir=scratch, progress=progress, full_order_spins=spins, unit=unit,
        )  # fmt: skip
    return result


def rotating(
    case, spins: Sequence[QuantityLike] = ("0 Hz", "20 Hz", "41 Hz"), n_modes: int = 5,
    formulations: Sequence[str] = ("Q", "L"), *, progress: Progress | None = None,
):  # fmt: skip
    """Rotating-frame frequencies of the full-order model about its spinning equilibrium
    against the reduced model's, branch by branch (what ``quadmodes rotating`` prints).

    ``spins``: spin rates (quantities, e.g. "20 Hz"; bare floats are Hz). Returns a
    :class:`quadmodes.analysis.rotating_comparison.ComparisonTable` (frequencies in Hz,
    rotating frame); ``table.to_text()`` is the printed table."""
    from quadmodes.analysis.rotating_comparison import rotating_frequency_comparison

    hz = tuple(si(v, "frequency", "spins") for v in spins)
    return rotating_frequency_comparison(_model(case), hz, int(n_modes), tuple(formulations),
                                         progress=progress)  # fmt: skip


def _compare_checkpoint(checkpoint, resume: bool) -> Path | None:
    """The full order's checkpoint path of :func:`compare`: checked readable with ``resume``,
    removed without (a fresh run never continues an old checkpoint unasked)."""
    from quadmodes.analysis import comparison_run as runner

    path = None if checkpoint is None else Path(checkpoint)
    if resume and (path is None or not path.is_file()):
        raise runner.CheckpointError(f"resume: no checkpoint at {path}; run without resume")
    if resume:
        runner.check_checkpoint_readable(path, option="resume", fix="start again without resume")
    if path is not None and not resume:
        path.unlink(missing_ok=True)
    return path


def compare(
    run, window: QuantityLike = "1 s", *, formulations: Sequence[str] | None = None,
    full_order_dt: QuantityLike | None = None, damping_cutoff: QuantityLike | None = None,
    checkpoint: str | os.PathLike[str] | None = None, resume: bool = False,
    checkpoint_every: int | None = None, output_dir: str | os.PathLike[str] | None = None, plots: bool = True,
    progress: Progress | None = None, at: str | None = None,
    results: str | os.PathLike[str] | None = None,
):  # fmt: skip
    """Reduced formulations against the full-order finite-element transient over
    ``[0, window]`` (a time; bare floats are s), as ``quadmodes compare``. Expensive: the full
    order of the paper model takes minutes per simulated second.

    Parameters
    ----------
    formulations
        The reduced formulations compared (default, as the CLI's: rigid, L, P, Q, Q4 and the run
        case's own formulation, e.g. QM, :func:`quadmodes.analysis.compare.default_formulations`).
    at, results
        Start both sides at this point of the run's reduced path instead of t = 0 (an event:
        "cone 10 deg", "time 100 s", as ``compare --at``): the reduced run integrated to it, or
        its samples read from ``results`` (a results.nc of the same run); the full order from
        the reduced state there with the part outside the retained modes relaxed
        (:mod:`quadmodes.analysis.path_point`, docs/path-validity.md). A run with
        ``reduced.path_model = "spin-family"``: both windows with the member at the point
        (:mod:`quadmodes.analysis.family_point`; ``start["member_spin_hz"]``).
    damping_cutoff
        The full order's damping: every FE mode below this frequency (e.g. "150 Hz"; bare
        floats are Hz; default 3 × max(spin, highest retained mode)).
    checkpoint, resume, checkpoint_every
        The full-order run is checkpointed into ``checkpoint`` (.npz) every
        ``checkpoint_every`` steps (default
        ``quadmodes.analysis.comparison_run.FULL_ORDER_CHECKPOINT_EVERY``, 500, as the CLI);
        with ``resume`` it continues from it (bit for bit the uninterrupted run, with the same
        ``checkpoint_every``). Without ``resume`` an existing checkpoint is discarded; a
        complete comparison removes it.
    output_dir
        Also write ``comparison.nc``, ``.json``, ``.csv``, the overlay PNGs (``plots``) and
        ``report.html`` there (all or nothing for the data); the checkpoint is removed once
        they are written.

    Returns
    -------
    quadmodes.analysis.compare.Comparison
        ``table``: per formulation the relative errors (1), wall time (s), speed-up (1) and the
        secular rates; ``as_json()`` is ``comparison.json``.

    Raises
    ------
    quadmodes.analysis.comparison_run.FullOrderIncomplete
        The full order did not reach the end of the window (``interrupted``: Ctrl-C, e.g. a
        ``progress`` callback raising KeyboardInterrupt; its ``checkpoint`` continues it with
        ``resume=True``): it is never scored.
    """
    from quadmodes.analysis import compare as cmp
    from quadmodes.analysis import comparison_run as runner

    span = si(window, "time", "window")
    dt = None if full_order_dt is None else si(full_order_dt, "time", "full_order_dt")
    cutoff = None if damping_cutoff is None else si(damping_cutoff, "frequency", "damping_cutoff")
    if output_dir is not None:  # before any work, as ``compare -o``: no link, no user file
        runner.check_comparison_folder(Path(output_dir), "output_dir")
    path = _compare_checkpoint(checkpoint, resume)
    every = runner.FULL_ORDER_CHECKPOINT_EVERY if checkpoint_every is None else int(checkpoint_every)
    run = _run(run)
    names = cmp.default_formulations(run) if formulations is None else tuple(formulations)
    if at is None:
        resolved, setup = runner.prepare_comparison(run, span, cutoff, progress)
        point = None
    else:
        resolved, setup, point = runner.prepare_path_comparison(
            run, span, at, results=results, damping_cutoff=cutoff, progress=progress)
    result = runner.run_comparison(resolved, span, formulations=names,
                                   full_order_dt=dt, setup=setup, checkpoint=path, resume=resume,
                                   checkpoint_every=every, progress=progress, start=point)  # fmt: skip
    if output_dir is not None:  # the checkpoint is removed once the data are written
        runner.write_comparison_outputs(result, Path(output_dir), plots=plots, setup=setup,
                                        checkpoint=path)  # fmt: skip
    elif path is not None:  # complete: nothing left to resume
        path.unlink(missing_ok=True)
    return result


def calibrate(
    case, rocking: QuantityLike = "31.2 Hz", bending: QuantityLike = "38 Hz",
    axial: QuantityLike | None = None, *, progress: Progress | None = None,
) -> Any:  # fmt: skip
    """Fit the end-body masses (and the rear inertia when ``axial`` is given) so that the rear
    rocking pair, the bending pair (and the rear axial mode) are at the target frequencies
    (quantities, e.g. "31.2 Hz"; bare floats are Hz).

    Returns
    -------
    quadmodes.structure.calibrate.CalibrationResult
        ``case`` (the calibrated :class:`~quadmodes.case.Case`), ``masses_kg`` (kg),
        ``frequencies_hz`` (N,) Hz, ``labels``.
    """
    from quadmodes.structure.calibrate import calibrate_end_masses

    target = None if axial is None else si(axial, "frequency", "axial")
    return calibrate_end_masses(
        _model(case), rocking_hz=si(rocking, "frequency", "rocking"),
        bending_hz=si(bending, "frequency", "bending"), axial_hz=target, progress=progress,
    )  # fmt: skip


def dt_convergence(run, *, progress: Progress | None = None) -> dict:
    """The run at its step dt, dt/2 and dt/4 (fixed-step methods), as ``run --dt-convergence``:
    ``rows`` (one per step: ``dt_s`` (s), ``steps``, the secular ``cone_growth_rate_deg_per_s``
    (deg/s) with its standard error, ``cone_angle_change_deg`` (deg), the final
    ``cone_angle_deg`` (deg), ``spin_rate_hz`` (Hz), ``dissipated_energy_J`` (J) and their
    relative changes (1)) and the verdict on the cone growth (``converged``, ``judged``,
    ``text``; 1 %: :mod:`quadmodes.runs.dt_convergence`)."""
    from quadmodes.runs import simulate as sim
    from quadmodes.runs.dt_convergence import dt_convergence as convergence

    return convergence(sim.prepare(_run(run), progress=progress), progress=progress)


def mode_convergence(run, *, progress: Progress | None = None) -> dict:
    """The run with its N modes and the next two pair-whole mode counts above N:
    ``{"rows": [...], "converged", "text", ...}`` with the headline numbers (deg, Hz, J, their
    units in the keys) and their relative changes (1), as ``run --mode-convergence``."""
    from quadmodes.runs import simulate as sim
    from quadmodes.runs.mode_convergence import mode_convergence as convergence

    return convergence(sim.prepare(_run(run), progress=progress), progress=progress)


def sweep(
    run, params: dict[str, str] | Sequence[str], *, zipped: bool = False,
    output_dir: str | os.PathLike[str] = "sweep-out", workers: int | None = None,
    scheduler: str | None = None, time_run: bool = True, plots: bool = True,
):  # fmt: skip
    """Sweep a run case over case fields on dask.distributed (what ``quadmodes sweep`` does).

    Parameters
    ----------
    run : RunCase, str or path
        The run case swept.
    params : dict or sequence of str
        ``{"initial.spin_rate": "10 Hz:40 Hz:4"}`` (TOML path → values: a comma list of
        quantities or ``start:stop:count`` with units), or ``"PATH=VALUES"`` texts.
    zipped : bool
        Zip equal-length lists instead of taking their cartesian product.
    output_dir : path
        Folder of ``sweep.nc``, ``sweep.json``, the figures, ``report.html`` and the per-point
        files (``points/``; a rerun skips the points done).
    workers, scheduler
        Local worker processes (default one per core) or the address of a running scheduler.
    time_run : bool
        Integrate every point (else linearisation and energy-sink estimate only).

    Returns
    -------
    xarray.Dataset
        One dimension per swept parameter (SI coordinates with units); headline scalars per
        point (``cone_growth_rate`` rad/s, dissipated power W, spin change rad/s),
        rotating-frame frequencies (Hz), the energy-sink estimate and ``critical_speed`` (rad/s).
    """
    from quadmodes.sweeps.run import plan_from_texts, run_sweep

    texts = [f"{k}={v}" for k, v in params.items()] if isinstance(params, dict) else list(params)
    plan = plan_from_texts(_run(run), texts, zipped, time_run)
    ds, _, _ = run_sweep(plan, Path(output_dir), workers=workers, scheduler=scheduler,
                         command=f"quadmodes.sweep({texts!r})", plots=plots)  # fmt: skip
    return ds
