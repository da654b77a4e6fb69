"""The rows of a run's summary table about its path (the model's validity along it, the
``--until`` event, the times to cone angles) and the ``--until`` and ``--step-tolerance``
options of ``quadmodes run``."""

from __future__ import annotations

from typing import Annotated

import typer

UntilOption = Annotated[
    str | None,
    typer.Option(
        "--until",
        help='end the run on an event: "cone 60 deg", "spin 30 Hz", "time 10 s" or "flat spin" '
        "(located to the step; --duration stays the longest it may run)",
    ),
]
StepToleranceOption = Annotated[
    str | None,
    typer.Option(
        "--step-tolerance",
        help='a step controlled between chunks to this relative error, e.g. "1e-4" (midpoint; '
        "sets integration.step_tolerance, --dt the first step; docs/long-paths.md)",
    ),
]


def _path_valid(summary: dict) -> str | None:
    path = summary.get("path_validity")
    if path is None:
        return None
    if path["valid"]:
        return "True (" + ", ".join(path["checked"]) + " checked)"
    return "False: " + (path.get("message") or "")


def _left(summary: dict) -> str | None:
    path = summary.get("path_validity")
    if path is None:
        return None
    if path.get("left_range_at_s") is None:
        return "not within the run"
    return (f"t = {path['left_range_at_s']:.6g} s (spin {path['left_range_spin_hz']:.5g} Hz, cone "
            f"{path['left_range_cone_deg']:.4g} deg)")  # fmt: skip


def _spin_range(summary: dict) -> str | None:
    rng = (summary.get("path_validity") or {}).get("spin_range_hz") or [None, None]
    if None in rng:
        return None
    return f"{rng[0]:.5g} – {rng[1]:.5g}"


def _taut(summary: dict) -> str | None:
    """Whether the membrane stays taut along the path (exact strain of the manifold
    displacement; runs.taut_path): None without the check."""
    path = summary.get("path_validity") or {}
    least = path.get("least_tension_n_per_m")
    rest = path.get("reference_slack_area_fraction")
    if least is None and path.get("taut") is None:
        return None
    apart = f"; {100 * rest:.2g} % slack at the reference, not judged" if rest else ""
    if least is None:
        return f"True (no deformation above round-off){apart}"
    verdict = {True: "True", False: "False",  # None: a pressurised membrane (its energy check judges)
               None: "recorded, not judged for a pressurised membrane"}[path.get("taut")]
    where = f" {path['slack_where']}" if path.get("slack_where") else ""
    return (f"{verdict}: least tension {least:.3g} N/m, {100 * path['slack_area_fraction']:.3g} % "
            f"of the taut area slack{where}; the largest |s| is "
            f"{_times(path.get('slack_onset_fraction_of_peak'))} the onset{apart}")  # fmt: skip


def _times(fraction) -> str:
    return "< 1/4 ×" if fraction is None else f"{1 / fraction:.3g} ×"


def _until(summary: dict) -> str | None:
    ev = summary.get("until")
    if ev is None:
        return None
    if not ev["reached"]:
        return f"{ev['event']}: not reached"
    return (f"{ev['event']}: t = {ev['time_s']:.6g} s (step {ev['step']}; cone "
            f"{ev['cone_angle_deg']:.4g} deg, spin {ev['spin_rate_hz']:.5g} Hz)")  # fmt: skip


def _cone_times(summary: dict) -> str | None:
    times = summary.get("time_to_cone_s")
    if not times:
        return None
    return ", ".join(f"{m}°: {'—' if v is None else f'{v:.4g}'}" for m, v in times.items())


def _sink(summary: dict) -> str | None:
    sink = summary.get("energy_sink_consistency")
    if not sink:
        return None
    if summary.get("cone_growth_significant") is False:  # window slopes of a wobbling cone
        return "— (the run does not resolve a cone growth: its secular fit is within 2 standard errors of 0)"
    if sink.get("ratio_min") is None:
        return "— (the cone's growth is within 2 standard errors of 0 in every window)"
    resolved = sink.get("windows_resolved", sink["windows"])
    return (f"{sink['ratio_min']:.5f} – {sink['ratio_max']:.5f} over {resolved} of "
            f"{sink['windows']} windows from t = {sink['window_start_s'][0]:.4g} s")  # fmt: skip


#: (label, function of the summary, "") rows of the free-body run summary.
PATH_ROWS = [
    ("reduced model valid along the path", _path_valid, ""),
    ("path leaves the model's range at", _left, ""),
    ("membrane taut along the path (where taut at the reference)", _taut, ""),
    ("model's spin range (centrifugal load, Hz)", _spin_range, ""),
    ("until", _until, ""),
    ("time to cone angle (s)", _cone_times, ""),
    ("cone growth: run / energy-sink law", _sink, ""),
]


def format_row(summary: dict, key, fmt: str, plain) -> str:
    """A row's cell: ``key(summary)`` for the rows above ("—" when None), else
    ``plain(summary, key, fmt)``."""
    if callable(key):
        value = key(summary)
        return "—" if value is None else value
    return plain(summary, key, fmt)
