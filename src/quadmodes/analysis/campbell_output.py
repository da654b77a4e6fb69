"""Campbell output: the xarray dataset with units (SI), the CSV table and the files written by
``quadmodes campbell`` (the figure from :mod:`quadmodes.analysis.campbell_figure`; all through
:mod:`quadmodes.io.atomic`), and the CLI entry
(:func:`campbell_main`: reduced model of a case from :mod:`quadmodes.models.build`, sweep,
write)."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np

from quadmodes.analysis.campbell import CampbellResult, campbell, stiffless_at_rest
from quadmodes.analysis.campbell_figure import branch_starts, plot_campbell
from quadmodes.analysis.campbell_table import campbell_table
from quadmodes.analysis.full_order_markers import (
    FullOrderMarkers,
    full_order_markers,
    marker_attrs,
    marker_variables,
    markers_from_dataset,
    relabel,
)
from quadmodes.io import cf
from quadmodes.io.atomic import atomic_path
from quadmodes.io.outputs import write_netcdf
from quadmodes.limits import CAMPBELL_POINTS, check_count
from quadmodes.rom.reduced import ReducedModel

__all__ = ["campbell_main", "campbell_with_full_order", "from_dataset", "model_for_case",
           "plot_campbell", "sweep_spins", "to_dataset", "write_campbell", "write_csv"]  # fmt: skip

#: A body without stiffness at rest swept from spin 0 starts at this fraction of its reference
#: spin (its frequencies, all ∝ Ω, vanish at 0, where its modal stiffness is round-off).
SPIN_START_FRACTION = 0.05


def sweep_spins(model: ReducedModel, spin_min: float, spin_max: float, n: int):
    """``(spin rates (n,) rad/s, notes)``: ``n`` evenly spaced from ``spin_min`` to ``spin_max``;
    for a body without stiffness at rest (:func:`stiffless_at_rest`) a start at 0 is moved to
    :data:`SPIN_START_FRACTION` × its reference spin (at most the first step); such a body
    always gets a note (ω/Ω is its spin-free answer)."""
    spins = np.linspace(spin_min, spin_max, n)
    if not stiffless_at_rest(model):
        return spins, ()
    ref = abs(float(model.reference_spin))
    what = (f"no stiffness at rest (modes from the spinning state at {ref:.4g} rad/s): every "
            "frequency scales with the spin, ω/Ω does not depend on it")  # fmt: skip
    if spin_min > 0.0:
        return spins, (what,)
    if spin_max <= 0.0:
        raise ValueError(f"spin_max: this body has no stiffness at rest (its modes come from its "
                         f"spinning state at {ref:.4g} rad/s): give a spin rate above 0")  # fmt: skip
    start = min(SPIN_START_FRACTION * ref, spin_max / max(n - 1, 1))
    spins = np.linspace(start, spin_max, n) if n > 1 else np.array([spin_max])
    note = f"{what}; the sweep starts at {spins[0]:.4g} rad/s instead of 0 (no frequency there)"
    return spins, (note,)


def to_dataset(result: CampbellResult, markers: FullOrderMarkers | None = None):
    """xarray Dataset of a Campbell result with units (CF-style ``units`` attributes); with
    ``markers`` also the full-order roots (``full_order_*`` over full_order_spin,
    full_order_root, :func:`~quadmodes.analysis.full_order_markers.marker_variables`)."""
    import xarray as xr

    c = cf.coordinate
    ds = xr.Dataset(
        {
            "frequency": cf.variable(("spin", "branch"), result.frequency, "rad/s",
                                     "branch frequency |Im lambda|, rotating frame"),
            "frequency_hz": cf.variable(("spin", "branch"), result.frequency_hz, "Hz",
                                        "branch frequency, rotating frame"),
            "growth_rate": cf.variable(("spin", "branch"), result.growth, "1/s",
                                       "growth rate Re lambda (> 0: unstable)"),
            "mac_previous": cf.variable(("spin", "branch"), result.mac, "1",
                                        "MAC with the branch at the previous spin rate"),
            "min_rotating_stiffness": cf.variable(("spin",), result.min_stiffness, "1/s^2",
                                                  "smallest eigenvalue of the rotating stiffness"),
            "equilibrium_modal_coordinates": cf.modal_variable(
                ("spin", "mode"), result.s_eq, "m", "kg^0.5 m",
                "modal coordinates of the relative equilibrium (modes normalised to 1 kg)"),
            "equilibrium_spin_axis": cf.variable(("spin", "xyz"), result.spin_axis, "1",
                                                 "spin axis of the relative equilibrium, body frame"),
            "divergence_spin": cf.variable(("divergence",), result.divergence, "rad/s",
                                           "spin rate where the rotating stiffness changes "
                                           "definiteness (every branch ends there)"),
        },
        coords={
            "spin": c("spin", result.spin, "rad/s", "spin rate"),
            "branch": c("branch", np.arange(1, len(result.labels) + 1), "1",
                        "branch number (from 1, as the CSV)"),
            "branch_label": c("branch", np.array(result.labels, dtype=object), "1", "branch label"),
            "branch_start_spin": c("branch", result.spin[branch_starts(result)] if result.spin.size
                                   else np.zeros(len(result.labels)), "rad/s",
                                   "spin rate where the branch starts"),
            "mode": c("mode", np.arange(1, result.s_eq.shape[1] + 1), "1",
                      "retained mode number (from 1, as results.nc)"),
            **cf.label_coordinate("xyz", ["x", "y", "z"], "Cartesian axis"),
        },
        attrs={
            **cf.provenance("Campbell diagram of a quadmodes reduced model"),
            "formulation": result.formulation,
            "body": "free" if result.free else "clamped to hub",
            "spin_axis_x": float(result.axis[0]),
            "spin_axis_y": float(result.axis[1]),
            "spin_axis_z": float(result.axis[2]),
            "mode_labels": "; ".join(result.mode_labels),
            "tracking": "MAC of state eigenvectors (energy inner product), optimal assignment; "
                        "degenerate roots by span; a branch with MAC < 0.8 ends (NaN after)",
            "modal_normalisation": cf.MODAL_NORMALISATION,
        },
    )  # fmt: skip
    if markers is not None:
        ds = ds.assign(marker_variables(markers))
        ds.attrs.update(marker_attrs(markers))
    return ds


def from_dataset(ds) -> tuple[CampbellResult, FullOrderMarkers | None]:
    """The :class:`CampbellResult` (without its eigenvectors) and the full-order markers (None
    if absent) of a dataset written by :func:`to_dataset` (``campbell.nc``): the same numbers,
    so :func:`plot_campbell` draws the figure ``quadmodes campbell`` wrote."""
    spin = np.asarray(ds["spin"].values, float)
    starts = np.asarray(ds["branch_start_spin"].values, float)
    axis = np.array([float(ds.attrs[f"spin_axis_{c}"]) for c in "xyz"])
    mode_labels = str(ds.attrs.get("mode_labels", ""))
    result = CampbellResult(
        spin=spin, axis=axis, formulation=str(ds.attrs.get("formulation", "")),
        free=ds.attrs.get("body") == "free",
        labels=tuple(str(v) for v in ds["branch_label"].values),
        frequency=np.asarray(ds["frequency"].values, float),
        growth=np.asarray(ds["growth_rate"].values, float),
        mac=np.asarray(ds["mac_previous"].values, float),
        min_stiffness=np.asarray(ds["min_rotating_stiffness"].values, float),
        s_eq=np.asarray(ds["equilibrium_modal_coordinates"].values, float),
        spin_axis=np.asarray(ds["equilibrium_spin_axis"].values, float),
        vectors=np.zeros((spin.size, starts.size, 0), complex),
        mode_labels=tuple(mode_labels.split("; ")) if mode_labels else (),
        start=np.searchsorted(spin, starts) if spin.size else np.zeros(starts.size, int),
        divergence=np.asarray(ds["divergence_spin"].values, float),
    )  # fmt: skip
    markers = markers_from_dataset(ds) if "full_order_frequency" in ds else None
    return result, markers


#: Columns of ``campbell.csv``.
CSV_COLUMNS = (
    "spin_rad_s",
    "branch",
    "label",
    "frequency_rad_s",
    "frequency_hz",
    "growth_1_s",
    "mac",
)


def write_csv(result: CampbellResult, path) -> Path:
    """Write the Campbell table to ``path`` (CSV, one row per spin rate and branch where the
    branch exists; atomic)."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(list(CSV_COLUMNS))
        for i, om in enumerate(result.spin):
            for b, lab in enumerate(result.labels):
                if not np.isfinite(result.frequency[i, b]):
                    continue  # the branch has ended or not started yet
                w.writerow(
                    [
                        f"{om:.10g}",
                        b + 1,
                        lab,
                        f"{result.frequency[i, b]:.10g}",
                        f"{result.frequency_hz[i, b]:.10g}",
                        f"{result.growth[i, b]:.10g}",
                        f"{result.mac[i, b]:.6f}",
                    ]
                )
    return Path(path)


def write_campbell(result: CampbellResult, directory, stem: str = "campbell",
                   markers: FullOrderMarkers | None = None, unit="Hz") -> dict[str, Path]:  # fmt: skip
    """Write ``campbell.png`` (in ``unit``: "Hz", "rpm" or "rad/s"), ``campbell.nc`` (NetCDF4,
    h5netcdf, SI with units in attributes) and ``campbell.csv`` (one row per spin rate and
    branch, rad/s and Hz) into ``directory``, each atomically; with ``markers`` the full-order
    roots on the figure and in the dataset. Returns the paths."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"png": out / f"{stem}.png", "nc": out / f"{stem}.nc", "csv": out / f"{stem}.csv"}
    plot_campbell(result, paths["png"], markers=markers, unit=unit)
    ds = to_dataset(result, markers)  # in memory first: a full disk is a clean OSError
    write_netcdf(ds, paths["nc"], encoding=cf.encoding(ds))
    write_csv(result, paths["csv"])
    return paths


def model_for_case(case, progress=None, spin_max: float = 0.0, axis=None) -> ReducedModel:
    """Reduced model of a case (name, path or :class:`~quadmodes.case.Case`) with its modes and
    damping ratio (:func:`quadmodes.models.build.case_modes_model`: degenerate y/z pairs of a
    straight beam are split into pure planes; a membrane with a ``[spin]``: about that spin).

    A structure with no stiffness at rest and no ``[spin]`` (a spin-stiffened blade: lowest
    elastic frequency at rest below :data:`~quadmodes.structure.damping.STIFFLESS_RATIO` × the
    sweep's top spin ``spin_max`` rad/s) has no useful model about rest: it is expanded about its
    spinning state at ``spin_max`` about the sweep's ``axis`` request (None: the major axis, the
    only one a spin can stiffen a flat rotor about), :func:`spinning_reference_for`."""
    from quadmodes.case import Case, load_case
    from quadmodes.models.build import case_modes_model

    if not isinstance(case, Case):
        case = load_case(case)
    spinning = spinning_reference_for(case, spin_max, axis, progress)
    return spinning if spinning is not None else case_modes_model(case, progress)


def _axis_text(axis) -> str:
    """An axis request (:func:`~quadmodes.rom.spin_axis.parse_axis`) as the text a model's
    spinning reference takes (``initial.spin_axis``): None → "major"."""
    if axis is None:
        return "major"
    if isinstance(axis, str):
        return axis
    if isinstance(axis, int | np.integer):
        return ("minor", "intermediate", "major")[int(axis)]
    return ",".join(repr(float(v)) for v in np.asarray(axis, float).ravel())


def spinning_reference_for(case, spin_max: float, axis=None, progress=None):
    """The reduced model of ``case`` (``modes.count`` modes) about its spinning state at
    ``spin_max`` (rad/s) about ``axis`` (:func:`_axis_text`) when the case is a structure with
    no stiffness at rest and no ``[spin]`` table of its own; None otherwise (and for
    ``spin_max`` ≤ 0)."""
    from quadmodes.case import CaseError
    from quadmodes.models.build import modal_model_for, reduced_model_for
    from quadmodes.structure.damping import STIFFLESS_RATIO

    if spin_max <= 0.0 or getattr(case, "spin", None) is not None:
        return None
    modal = modal_model_for(case, 1, progress)
    lowest = np.asarray(modal.modes.frequencies_hz, float)
    if modal.spinning is not None or not lowest.size:
        return None
    if 2.0 * np.pi * lowest[0] >= STIFFLESS_RATIO * spin_max:
        return None
    try:
        return reduced_model_for(case, case.modes.count, progress, spin=float(spin_max),
                                 axis=_axis_text(axis))  # fmt: skip
    except CaseError as exc:
        raise ValueError(f"no stiffness at rest, so the model is expanded about its spinning "
                         f"state at {spin_max:.4g} rad/s: {exc}") from None  # fmt: skip


def campbell_main(
    case_or_model,
    spin_min: float,
    spin_max: float,
    n: int = 41,
    axis=None,
    formulation: str = "Q",
    output_dir=None,
    damped: bool = False,
    progress=None,
    axis_option: str = "axis",
) -> tuple[CampbellResult, dict[str, Path]]:
    """Convenience entry for the CLI: build (or take) the reduced model, sweep ``n`` spin rates
    from ``spin_min`` to ``spin_max`` (rad/s), and write the outputs to ``output_dir`` (if given).

    ``case_or_model``: a :class:`ReducedModel`, a case name / TOML path or a Case. ``axis``: the
    spin-axis request of :func:`~quadmodes.analysis.campbell.campbell` (``axis_option`` names it
    in errors). With full-order markers: :func:`campbell_with_full_order`."""
    result, _, paths = campbell_with_full_order(case_or_model, spin_min, spin_max, n, axis,
                                                formulation, output_dir, damped, progress,
                                                axis_option)  # fmt: skip
    return result, paths


def campbell_with_full_order(
    case_or_model,
    spin_min: float,
    spin_max: float,
    n: int = 41,
    axis=None,
    formulation: str = "Q",
    output_dir=None,
    damped: bool = False,
    progress=None,
    axis_option: str = "axis",
    full_order_spins=(),
    unit="Hz",
) -> tuple[CampbellResult, FullOrderMarkers | None, dict[str, Path]]:
    """:func:`campbell_main` and, at ``full_order_spins`` (rad/s; a free-body case, not a bare
    model), the full-order model linearised about its spinning equilibrium about the diagram's
    axis, its roots matched to the branches (:mod:`quadmodes.analysis.full_order_markers`),
    drawn on ``campbell.png`` and stored in ``campbell.nc``; ``unit`` that of the figure and of
    the result's ``table`` ("Hz", "rpm", "rad/s"; :mod:`quadmodes.analysis.campbell_table`).
    Returns ``(result, markers or None, paths)``."""
    if n < 1:
        raise ValueError("n: give at least one spin rate")
    check_count(CAMPBELL_POINTS, n, "points (--points)", "use fewer spin rates (41 by default)")
    if spin_max < spin_min:
        raise ValueError("spin_max: must not be below spin_min")
    spins = [float(s) for s in (full_order_spins or ())]
    if spins and isinstance(case_or_model, ReducedModel):
        raise ValueError("full_order_spins: give the case, not a reduced model")
    model = (
        case_or_model
        if isinstance(case_or_model, ReducedModel)
        else model_for_case(case_or_model, progress, spin_max, axis)
    )
    if spins and not model.free:
        raise ValueError("full_order_spins: the full-order rotating-frame analysis is for free "
                         "bodies; this case is clamped to a hub")  # fmt: skip
    sweep, notes = sweep_spins(model, spin_min, spin_max, n)
    result = campbell(model, sweep, axis, formulation, damped, axis_option=axis_option)
    result = replace(result, notes=(*result.notes, *notes))
    name = case_or_model if isinstance(case_or_model, str) else getattr(case_or_model, "name", "")
    result = replace(result, table=campbell_table(result, unit, str(name)))
    markers = (full_order_markers(case_or_model, model, spins, result.axis, formulation,
                                  progress, axis_option) if spins else None)  # fmt: skip
    if markers is not None:  # the figure's branch names
        markers = relabel(markers, result.spin, result.frequency, result.labels)
    paths = ({} if output_dir is None
             else write_campbell(result, output_dir, markers=markers, unit=unit))  # fmt: skip
    return result, markers, paths
