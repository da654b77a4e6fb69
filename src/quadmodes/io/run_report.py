"""The ``report.html`` of ``run`` and ``compare`` (:mod:`quadmodes.io.report`): first the answer
and the checks in a box (:mod:`quadmodes.io.verdict`), then the figures the command wrote
(embedded, each once, captions that stand alone), the model (mesh picture, modes table, mass,
inertia), the validity and convergence checks in detail, the case and the headline numbers. Modes are numbered from 1, as in results.nc, the
CLI tables, the mode pictures and the mode files.

Inputs are the objects the commands already hold: the run's summary dict and
:class:`~quadmodes.runs.simulate.RunResult`, or the comparison payload (``comparison.json``), the
plan and the full-order setup. Values are SI unless the label says otherwise.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from quadmodes.io.path_report import path_parts
from quadmodes.io.plots import early_window
from quadmodes.io.report import (
    Section,
    figure,
    figures,
    format_value,
    key_values,
    paragraph,
    preformatted,
    table,
    write_report,
)
from quadmodes.io.verdict import compare_verdict, run_verdict

__all__ = ["CAMPBELL_PICTURE", "COMPARE_FIGURES", "MODEL_PICTURE", "RUN_FIGURES", "write_compare_report", "write_run_report"]

#: (file, caption) of the run figures shown in its report, in report order: each once
#: (``summary.png`` gathers the same panels on one page and stays beside the report), with
#: captions that read without the rest of the page.
RUN_FIGURES = (
    ("cone_angle.png", "Cone angle (deg): the angle between the angular momentum H and the body's "
     "spin axis, against time. Its secular growth is the coning rate of the answer above."),
    ("spin_rate.png", "Spin rate (Hz) of the body about its spin axis, against time: energy "
     "dissipated at constant angular momentum moves the spin from the axis of least inertia."),
    ("energy.png", "Total energy E = T + V (J) and E plus the energy dissipated by structural "
     "damping (dashed): the dashed line stays flat when the energy balance closes; the fall of "
     "E is what drives the coning."),
    ("angular_momentum.png", "Magnitude of the angular momentum |H| about the centre of mass "
     "(top, kg m²/s) and its relative change (bottom): no external torque acts, so the bottom "
     "panel shows the integrator's round-off."),
    ("bending_mode.png", "First bending coefficient s_b1 (the modal coordinate of the lowest "
     "bending mode, kg^0.5 m; right axis: the largest nodal displacement it causes, mm) against "
     "time; a run of many periods is drawn as its envelope (max and min per time bin)."),
    ("bending_mode_early.png", "The first bending coefficient over the start of the run (the "
     "first 0.5 s, or 1 % of a long run): the response to the initial cone and deformation."),
    ("tip_deflection.png", "Spin-up of a hub-clamped body: in-plane and axial tip displacement "
     "(m) and the hub's spin rate (rad/s), against time."),
)  # fmt: skip
#: (file, caption) of the comparison figures.
COMPARE_FIGURES = tuple(
    (f"compare_{stem}.png", f"{what} against time: each reduced formulation (coloured) over the "
     "full-order finite-element solution (black) of the same run case")
    for stem, what in (("modal_amplitude", "modal amplitude"), ("cone_angle", "cone angle"),
                       ("spin_rate", "spin rate"), ("angular_momentum", "|H| drift"),
                       ("energy", "total energy"))
)  # fmt: skip


#: The picture of the model in a report folder (the inflated mesh, two views).
MODEL_PICTURE = "model.png"


#: The Campbell diagram of the run's model in a report folder, when the run drew one.
CAMPBELL_PICTURE = "campbell.png"


def model_section(model, picture: str | Path | None = None,
                  campbell: str | Path | None = None) -> Section:  # fmt: skip
    """Mass, inertia about the centre of mass (and its principal moments), the picture of the
    mesh (``picture``, a PNG, if it exists), the retained modes of a
    :class:`~quadmodes.rom.reduced.ReducedModel` and its Campbell diagram (``campbell``, a
    PNG, if it exists)."""
    j0 = np.asarray(model.J0, float)
    principal = np.linalg.eigvalsh(0.5 * (j0 + j0.T))
    spin = float(getattr(model, "reference_spin", 0.0))
    about = f"spinning at {spin / (2 * math.pi):.4g} Hz" if spin else "at rest"
    facts = key_values([
        ("mass (kg)", float(model.mass)),
        ("principal moments of inertia (kg m²)", ", ".join(f"{v:.6g}" for v in principal)),
        ("reference state of the modes", about),
        ("retained elastic modes N", int(model.n_modes)),
    ])  # fmt: skip
    inertia = table(("", "x", "y", "z"), [(a, *map(float, row)) for a, row in zip("xyz", j0, strict=True)],
                    "inertia J0 about the centre of mass (kg m²), body frame")  # fmt: skip
    rows = [(k + 1, float(f), str(lab), float(z)) for k, (f, lab, z) in enumerate(
        zip(model.frequencies_hz, model.labels, model.damping_ratio, strict=True))]  # fmt: skip
    modes = table(("mode", "frequency (Hz)", "label", "damping ratio ζ"), rows,
                  "retained modes (numbered from 1)") if rows else paragraph("no elastic modes (rigid body)")  # fmt: skip
    mesh = figure(picture, "The model: the inflated finite-element mesh (side view and a rotated "
                  "view; red: the ties of the rigid end bodies)") if picture is not None else ""  # fmt: skip
    diagram = figure(campbell, "Campbell diagram of the run's model: the frequency of every "
                     "branch in the rotating frame against the spin rate, from rest to 1.25 × "
                     "the run's spin (undamped, about the spinning relative equilibrium); "
                     "the lines f = kΩ and the critical speeds where a branch meets them") \
        if campbell is not None else ""  # fmt: skip
    return Section("model", facts + mesh + modes + diagram + inertia)


def _case_section(run, model_case, extra: list[tuple[str, object]]) -> Section:
    """Run name, description, model case and the case TOML (folded)."""
    pairs = [("run case", run.name), ("description", run.description or "—"),
             ("model case", model_case.name), ("formulation", run.reduced.formulation), *extra]  # fmt: skip
    toml = preformatted(run.to_toml(), "run case TOML") + preformatted(
        model_case.to_toml(), "model case TOML")
    return Section("case", key_values(pairs) + toml)


#: (label, summary key or keys, format) of a run's answer (docs/outputs.md, "The answer"):
#: shared by the report's headline table and the table ``quadmodes run`` prints.
ANSWER_ROWS = (
    ("secular cone-growth rate (deg/s), quasi-steady fit",
     ("cone_growth_rate_deg_per_s", "cone_growth_rate_se_deg_per_s", "cone_growth_fit_start_s",
      "cone_growth_fit_end_s"), "{:.4g} ± {:.2g} (t = {:.4g}–{:.4g} s)"),
    ("dissipated power (W): run | energy sink at the fit's state",
     ("dissipated_power_W", "energy_sink_power_at_fit_state_W"),
     "{:.4g} | {:.4g}"),
    ("coning time constant (s): energy sink at the start (as sweep)", "coning_time_constant_s",
     "{:.4g}"),
    ("coning time constant (s): energy sink at the fit's spin, cone",
     "coning_time_constant_at_fit_state_s", "{:.4g}"),
    ("coning time constant (s): this run (θ̄/θ̇)", "simulated_coning_time_constant_s", "{:.4g}"),
)

#: (label, summary key or keys, format) of the run headline table.
_HEADLINES = (
    ("status", "status", "{}"),
    ("steps", "steps", "{}"),
    ("integration wall time (s, without writing)", "wall_s", "{:.3g}"),
    ("max |H(t) − H0| / |H0|", "H_relative_drift", "{:.2e}"),
    ("energy start → end (J)", ("energy_start_J", "energy_end_J"), "{:.6g} → {:.6g}"),
    ("dissipated energy (J)", "dissipated_energy_J", "{:.4g}"),
    ("spin rate start → end (Hz)", ("spin_rate_start_hz", "spin_rate_end_hz"), "{:.6g} → {:.6g}"),
    ("cone angle start → end (deg)", ("cone_angle_start_deg", "cone_angle_end_deg"), "{:.5g} → {:.5g}"),
    ("cone angle max (deg)", "cone_angle_max_deg", "{:.5g}"),
    ("spin", "spin_verdict", "{}"),
    *ANSWER_ROWS,
    ("stability rule", "stability_rule", "{}"),
    ("bending log decrement (free decay only)", "log_decrement", "{:.4g}"),
    ("retained modes N", "n_modes", "{}"),
    ("mode choice", "mode_rule", "{}"),
    ("final hub rate Ωs (rad/s)", "omega_s_rad_s", "{:.4g}"),
    ("peak in-plane tip deflection (m)", "peak_tip_deflection_m", "{:.4g}"),
)


def _headline_rows(summary: dict) -> list[tuple[str, str]]:
    rows = []
    for label, key, fmt in _HEADLINES:
        keys = key if isinstance(key, tuple) else (key,)
        values = [summary.get(k) for k in keys]
        if all(k in summary for k in keys):
            rows.append((label, "—" if None in values else fmt.format(*values)))
    return rows


def _checks_section(summary: dict) -> Section:
    """Validity of the formulation at the run's spin, and the convergence tables if run."""
    parts = []
    validity = summary.get("validity") or {}
    if validity:
        ok = bool(validity.get("valid"))
        low = format_value(validity.get("rotating_stiffness_min_eigenvalue"), ".4g")
        text = ("valid: the rotating-frame stiffness is positive definite up to the run's spin "
                f"(min eigenvalue {low} s⁻²)" if ok else f"NOT valid: {validity.get('message', '')}")  # fmt: skip
        if ok and low == "—":
            text = "valid (no elastic modes: nothing to check)"
        deformation = summary.get("valid_initial_deformation")
        if ok and deformation is not None:  # the second check: the initial deformation
            text += ("; the initial deformation is within the reduced potential's range (its energy "
                     "within 2 % of the FE model's condensed energy)")  # fmt: skip
        parts.append(paragraph(text, "ok" if ok else "bad"))
    parts += path_parts(summary)  # the model along the path, the until event, cone times
    dt_conv = summary.get("dt_convergence")
    if dt_conv:
        rows = [(1e3 * r["dt_s"], r["steps"], r["cone_growth_rate_deg_per_s"],
                 r["rel_change_cone_growth_rate_deg_per_s"], r["cone_angle_deg"],
                 r["rel_change_cone_angle_deg"]) for r in dt_conv["rows"]]  # fmt: skip
        parts.append(table(("dt (ms)", "steps", "cone-growth rate (deg/s)", "rel. change",
                            "cone angle end (deg)", "rel. change"), rows, "time-step convergence"))  # fmt: skip
        parts.append(paragraph(f"verdict: {dt_conv.get('text', '')}"))
    conv = summary.get("mode_convergence")
    if conv:
        rows = [(r["n_modes"], r["steps"], r["wall_s"]) for r in conv["rows"]]
        parts.append(table(("N", "steps", "wall time (s)"), rows, "mode convergence runs"))
        parts.append(paragraph(f"verdict: {conv.get('text', '')}"))
    if not parts:
        parts.append(paragraph("no validity information; run with --dt-convergence or "
                               "--mode-convergence for convergence checks"))  # fmt: skip
    return Section("validity and convergence checks", "".join(parts))


def write_run_report(folder: str | Path, summary: dict, result) -> Path:
    """``folder/report.html`` of a run: the answer and the checks in a box at the top
    (:func:`~quadmodes.io.verdict.run_verdict`), the figures in ``folder``
    (:data:`RUN_FIGURES`, each once), the model (:data:`MODEL_PICTURE` if in ``folder``, modes,
    inertia), the checks in detail, the case and every headline number."""
    folder = Path(folder)
    run = result.run
    extra = []
    if run.initial is not None:
        extra += [("initial spin rate (Hz)", run.initial.spin_rate / (2 * math.pi)),
                  ("initial cone angle (deg)", math.degrees(run.initial.cone_angle))]  # fmt: skip
    if run.integration is not None:
        extra += [("method", run.integration.method), ("dt (ms)", 1e3 * run.integration.dt),
                  ("duration (s)", run.integration.duration)]  # fmt: skip
        if getattr(run.integration, "step_tolerance", None) is not None:  # a controlled step
            extra += [("step tolerance", run.integration.step_tolerance),
                      ("step taken (ms)", f"{1e3 * summary.get('dt_min_s', math.nan):.4g} – "
                                          f"{1e3 * summary.get('dt_max_s', math.nan):.4g}")]  # fmt: skip
    span = float(summary.get("t_end_s") or 0.0)
    shown = [f for f in RUN_FIGURES  # the early times of a short run are the whole run
             if f[0] != "bending_mode_early.png" or early_window(span) < span]  # fmt: skip
    sections = [run_verdict(summary), _figures_section(folder, shown)]
    if getattr(result, "model", None) is not None and hasattr(result.model, "J0"):
        sections.append(model_section(result.model, folder / MODEL_PICTURE,
                                      folder / CAMPBELL_PICTURE))  # fmt: skip
    sections += [
        _checks_section(summary),
        _case_section(run, result.model_case, extra),
        Section("all headline numbers", key_values(_headline_rows(summary))),
    ]
    return write_report(folder, f"quadmodes run: {run.name}", sections, summary.get("status", ""))


def _figures_section(folder: Path, items) -> Section:
    body = figures(folder, items)
    body = f'<div class="grid">{body}</div>' if body else body
    files = [n for n in ("motion.xdmf",) if (folder / n).is_file()]
    if files:
        body += paragraph("animation: motion.xdmf (+ motion.h5) beside this page; open it in "
                          "ParaView, Warp By Vector (displacement, scale 1), colour by "
                          "elastic_displacement_magnitude (docs/outputs.md)")  # fmt: skip
    return Section("figures", body or paragraph("no figures (--no-plots)"))


def _compare_rows(payload: dict) -> list[tuple]:
    rows = []
    fo = payload["full_order"]
    rows.append(("full order", None, None, None, None, fo.get("wall_s"), 1.0))
    for name, row in payload["formulations"].items():
        rows.append((name, row.get("envelope_error"), row.get("cone_angle_error"),
                     row.get("spin_rate_error"), row.get("cone_growth_ratio"), row.get("wall_s"),
                     row.get("speedup")))  # fmt: skip
    return rows


def write_compare_report(folder: str | Path, payload: dict, run, model_case, model) -> Path:
    """``folder/report.html`` of a comparison: the errors of each formulation against the full
    order (``payload`` = comparison.json), the case, the model (None: left out), notes and the
    overlay plots."""
    folder = Path(folder)
    fo = payload["full_order"]
    head = table(("model", "envelope error", "cone angle error", "spin rate error",
                  "cone growth reduced / full", "wall (s)", "speed-up"), _compare_rows(payload),
                 f"{payload['case']}: {payload['window_s']:g} s window, errors relative to the full order")  # fmt: skip
    facts = key_values([("full-order step (ms)", 1e3 * fo["dt_s"]), ("full-order steps", fo["steps"]),
                        ("full-order |H| drift", fo.get("H_relative_drift")),
                        ("full order complete", bool(fo.get("complete")))])  # fmt: skip
    notes = "".join(paragraph(f"note: {n}") for n in payload.get("notes", []))
    sections = [
        compare_verdict(payload),
        _figures_section(folder, COMPARE_FIGURES),
        Section("headline numbers", head + facts + notes),
        *([model_section(model, folder / MODEL_PICTURE)] if model is not None else []),
        _case_section(run, model_case, [("window (s)", payload["window_s"])]),
    ]
    return write_report(folder, f"quadmodes compare: {payload['case']}", sections)
