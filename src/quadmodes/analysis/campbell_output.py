"""Campbell output: the figure, the xarray dataset with units, the CSV table and the files
written by ``quadmodes campbell`` (all through :mod:`quadmodes.io.atomic`), and the CLI entry
(:func:`campbell_main`: reduced model of a case from :mod:`quadmodes.models.build`, sweep,
write)."""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np

from quadmodes.analysis.campbell import CampbellResult, campbell
from quadmodes.analysis.full_order_markers import (
    FullOrderMarkers,
    draw_markers,
    full_order_markers,
    marker_attrs,
    marker_variables,
    relabel,
)
from quadmodes.io import cf
from quadmodes.io.atomic import atomic_path
from quadmodes.io.outputs import write_netcdf
from quadmodes.limits import CAMPBELL_POINTS, check_count
from quadmodes.rom.reduced import ReducedModel


def plot_campbell(result: CampbellResult, path=None, orders=(1, 2), title: str | None = None,
                  markers: FullOrderMarkers | None = None):  # fmt: skip
    """Campbell figure (matplotlib Figure, Agg canvas): frequency (rad/s) of each branch vs spin
    rate, engine-order lines f = kΩ for k in ``orders`` and unstable roots marked (×, with
    their growth rate on a second panel when there are any); the full-order roots of
    ``markers`` as diamonds in the colour of the branch they matched. Saved to ``path`` if
    given."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    unstable = result.unstable
    panels = 2 if unstable.any() else 1
    fig = Figure(figsize=(7.5, 5.0 + 2.0 * (panels - 1)))
    FigureCanvasAgg(fig)
    axs = fig.subplots(panels, 1, sharex=True, squeeze=False)[:, 0]
    ax = axs[0]
    colours = {}
    past = _past_divergence(result)
    for b, lab in enumerate(result.labels):
        # branches that start beyond a divergence: dotted, out of the legend (an unstable
        # equilibrium of another family, not a continuation of the branches before it)
        beyond = bool(past[_starts(result)[b]])
        (line,) = ax.plot(result.spin, result.frequency[:, b], ".:" if beyond else "-",
                          lw=1.0 if beyond else 1.5, ms=3,
                          label="_nolegend_" if beyond else lab)  # fmt: skip
        colours.setdefault(lab, line.get_color())
        bad = unstable[:, b]
        if bad.any():
            ax.plot(result.spin[bad], result.frequency[bad, b], "x", color=line.get_color())
            axs[1].plot(result.spin, result.growth[:, b], "-", color=line.get_color(), label=lab)
    top = max(float(np.nanmax(result.frequency, initial=0.0)) * 1.05, 1e-9)
    if markers is not None:
        draw_markers(ax, markers, colours)
        top = max(top, float(np.nanmax(markers.frequency, initial=0.0)) * 1.05)
    for k in orders:
        ax.plot(result.spin, k * result.spin, "k:", lw=0.8)
        j = np.searchsorted(k * result.spin, top) - 1
        if 0 <= j < result.spin.size and k * result.spin[j] > 0:
            ax.annotate(f"{k}Ω", (result.spin[j], k * result.spin[j]), fontsize=8)
    for k, w in enumerate(result.divergence):  # every branch ends here (CampbellResult)
        if result.spin.size and np.any(result.spin > w):
            nxt = result.divergence[k + 1] if k + 1 < result.divergence.size else result.spin.max()
            if past[np.searchsorted(result.spin, w)]:
                ax.axvspan(w, nxt, color="0.5", alpha=0.12, lw=0)
        for a in axs:
            a.axvline(w, color="tab:red", ls="--", lw=1.0,
                      label=f"divergence {w:.4g} rad/s" if (a is ax and k == 0) else None)  # fmt: skip
        ax.annotate("divergence", (w, 0.97 * top), color="tab:red", fontsize=8, rotation=90,
                    ha="right", va="top")  # fmt: skip
    ax.set_ylim(0.0, top)
    ax.set_ylabel("rotating-frame frequency (rad/s)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    kind = "free body" if result.free else "clamped to hub"
    ax.set_title(title or f"Campbell diagram ({kind}, formulation {result.formulation})")
    if panels == 2:
        axs[1].axhline(0.0, color="k", lw=0.6)
        axs[1].set_ylabel("growth rate Re λ (1/s)")
        axs[1].grid(True, alpha=0.3)
    axs[-1].set_xlabel("spin rate Ω (rad/s)")
    fig.tight_layout()
    if path is not None:
        with atomic_path(path) as tmp:
            fig.savefig(os.fspath(tmp), dpi=150)
    return fig


def _past_divergence(result: CampbellResult) -> np.ndarray:
    """(ns,) bool: spin rates beyond a divergence where the rotating stiffness is not positive
    definite (the shaded part of the figure)."""
    if result.divergence.size == 0:
        return np.zeros(result.spin.size, bool)
    return np.asarray(result.min_stiffness) <= 0.0


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
            "branch_start_spin": c("branch", result.spin[_starts(result)] if result.spin.size
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


def _starts(result: CampbellResult) -> np.ndarray:
    """Index of the first spin rate of each branch."""
    if result.start is not None:
        return np.asarray(result.start, int)
    return np.zeros(len(result.labels), int)


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
                   markers: FullOrderMarkers | None = None) -> dict[str, Path]:  # fmt: skip
    """Write ``campbell.png``, ``campbell.nc`` (NetCDF4, h5netcdf, units in attributes) and
    ``campbell.csv`` (one row per spin rate and branch) into ``directory``, each atomically;
    with ``markers`` the full-order roots on the figure and in the dataset. Returns the paths."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"png": out / f"{stem}.png", "nc": out / f"{stem}.nc", "csv": out / f"{stem}.csv"}
    plot_campbell(result, paths["png"], markers=markers)
    ds = to_dataset(result, markers)  # in memory first: a full disk is a clean OSError
    write_netcdf(ds, paths["nc"], encoding=cf.encoding(ds))
    write_csv(result, paths["csv"])
    return paths


def model_for_case(case, progress=None) -> ReducedModel:
    """Reduced model of a case (name, path or :class:`~quadmodes.case.Case`) with its modes and
    damping ratio (:func:`quadmodes.models.build.case_modes_model`: degenerate y/z pairs of a
    straight beam are split into pure planes)."""
    from quadmodes.case import Case, load_case
    from quadmodes.models.build import case_modes_model

    if not isinstance(case, Case):
        case = load_case(case)
    return case_modes_model(case, progress)


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
) -> tuple[CampbellResult, FullOrderMarkers | None, dict[str, Path]]:
    """:func:`campbell_main` and, at ``full_order_spins`` (rad/s; a free-body case, not a bare
    model), the full-order model linearised about its spinning equilibrium about the diagram's
    axis, its roots matched to the branches (:mod:`quadmodes.analysis.full_order_markers`),
    drawn on ``campbell.png`` and stored in ``campbell.nc``. Returns ``(result, markers or None,
    paths)``."""
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
        else model_for_case(case_or_model, progress)
    )
    if spins and not model.free:
        raise ValueError("full_order_spins: the full-order rotating-frame analysis is for free "
                         "bodies; this case is clamped to a hub")  # fmt: skip
    result = campbell(model, np.linspace(spin_min, spin_max, n), axis, formulation, damped,
                      axis_option=axis_option)  # fmt: skip
    markers = (full_order_markers(case_or_model, model, spins, result.axis, formulation,
                                  progress, axis_option) if spins else None)  # fmt: skip
    if markers is not None:  # the figure's branch names
        markers = relabel(markers, result.spin, result.frequency, result.labels)
    paths = write_campbell(result, output_dir, markers=markers) if output_dir is not None else {}
    return result, markers, paths
