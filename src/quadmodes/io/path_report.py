"""The part of a run's ``report.html`` about its path (:mod:`quadmodes.io.run_report` calls
:func:`path_parts`): the reduced model's validity along the path and where the path leaves its
range, the ``until`` event and the times to given cone angles, from the run's summary dict."""

from __future__ import annotations

from quadmodes.io.report import format_value, key_values, paragraph, table


def _validity(path: dict) -> list[str]:
    ok = bool(path.get("valid"))
    checked = ", ".join(path.get("checked") or []) or "nothing"
    text = (f"valid along the path ({checked} checked)" if ok
            else f"NOT valid along the path: {path.get('message', '')}")  # fmt: skip
    rng = path.get("spin_range_hz") or [None, None]
    rows = [
        ("checked", checked),
        ("not checked", ", ".join(path.get("unchecked") or []) or "—"),
        ("leaves the model's range at t (s)", format_value(path.get("left_range_at_s"))),
        ("spin there (Hz)", format_value(path.get("left_range_spin_hz"), ".5g")),
        ("cone angle there (deg)", format_value(path.get("left_range_cone_deg"), ".4g")),
        ("largest departure of the centrifugal load", format_value(path.get("centrifugal_departure_max"), ".3g")),
        ("its limit", format_value(path.get("centrifugal_departure_limit"), ".3g")),
        ("spin range of the model (Hz)", "—" if None in rng else f"{rng[0]:.5g} – {rng[1]:.5g}"),
        ("model rebuilt at (Hz)", format_value(path.get("centrifugal_measured_at_spin_hz"), ".5g")),
        ("its rotating-frame frequency difference", format_value(path.get("centrifugal_measured_frequency_error"), ".2e")),
        ("largest modal amplitude |s| (kg^0.5 m)", format_value(path.get("modal_amplitude_peak_m"), ".4g")),
        ("reduced potential error there", format_value(path.get("modal_amplitude_error"), ".3g")),
        ("membrane taut (where taut at the reference)", {True: "yes", False: "no"}.get(
            path.get("taut"), "—")),
        ("least tension (N/m)", format_value(path.get("least_tension_n_per_m"), ".3g")),
        ("taut area slack (largest fraction)", format_value(path.get("slack_area_fraction"), ".3g")),
        ("where it is slack", path.get("slack_where") or "—"),
        ("area slack at the reference (not judged)",
         format_value(path.get("reference_slack_area_fraction"), ".3g")),
    ]  # fmt: skip
    return [paragraph(text, "ok" if ok else "bad"), key_values(rows, "the model along the path")]


def path_parts(summary: dict) -> list[str]:
    """HTML parts (paragraphs, tables) about the path of a free-body run (none for a spin-up)."""
    parts: list[str] = []
    if summary.get("path_validity"):
        parts += _validity(summary["path_validity"])
    ev = summary.get("until")
    if ev:
        text = (f"until {ev['event']}: reached at t = {format_value(ev.get('time_s'))} s (step "
                f"{ev.get('step')}, cone {format_value(ev.get('cone_angle_deg'), '.4g')} deg, spin "
                f"{format_value(ev.get('spin_rate_hz'), '.5g')} Hz; located to the "
                f"{ev.get('located', 'step')})" if ev.get("reached")
                else f"until {ev['event']}: not reached within the run's duration")  # fmt: skip
        parts.append(paragraph(text))
    times = summary.get("time_to_cone_s")
    if times:
        rows = [(f"{mark} deg", format_value(t)) for mark, t in times.items()]
        parts.append(table(("cone angle", "first reached at t (s)"), rows,
                           "times to cone angles (interpolated between saved samples)"))  # fmt: skip
    return parts + sink_parts(summary.get("energy_sink_consistency"),
                              summary.get("cone_growth_significant") is not False)


def sink_parts(sink: dict | None, resolved: bool = True) -> list[str]:
    """The energy-sink law against the run along its path (``energy_sink_consistency`` of the
    summary, :mod:`quadmodes.runs.sink_consistency`): one row a window; a paragraph only when
    the run does not resolve a cone growth (``resolved`` False: its secular fit is within 2
    standard errors of 0, so window ratios are ratios of noise)."""
    if not sink or not sink.get("windows"):
        return []
    if not resolved:
        return [paragraph("energy-sink consistency along the path: not judged — the run does "
                          "not resolve a cone growth (its secular fit is within 2 standard "
                          "errors of 0)")]  # fmt: skip
    rows = [(format_value(a, ".5g"), format_value(b, ".5g"), format_value(r, ".5g"),
             format_value(se, ".2g"))
            for a, b, r, se in zip(sink["window_start_s"], sink["window_end_s"], sink["ratio"],
                                   sink["ratio_se"], strict=True)]  # fmt: skip
    return [table(("window from (s)", "to (s)", "cone growth: run / energy-sink law",
                   "standard error"), rows,
                  "energy-sink consistency along the path: the law applied to the run's own "
                  "dissipated power against its cone growth"),
            paragraph(f"rule: {sink.get('rule', '')}"
                      + ("; in no window is the cone's growth more than 2 standard errors from "
                         "0, so these ratios are noise" if sink.get("windows_resolved") == 0
                         else ""))]  # fmt: skip
