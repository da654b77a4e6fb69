"""The box at the top of a run's ``report.html``: the answer a user came for (is the spin
stable, how fast does the cone grow, in how long) and the checks that say whether to trust it
(the model valid at the start and along the path, the run complete, the convergence verdicts),
from the run's summary dict (``summary.json``; docs/outputs.md, "The answer").

The colour of the box is the stability verdict (green stable, red unstable, grey neutral or
unknown; the style sheet of :mod:`quadmodes.io.report`); a failed check is written in red
inside it whatever the verdict.
"""

from __future__ import annotations

import html

from quadmodes.io.report import Section, format_value

__all__ = ["compare_verdict", "run_verdict", "verdict_box"]

def verdict_box(headline: str, rows, kind: str = "") -> str:
    """The box: ``headline`` (plain text) above a table of ``rows`` (label, text, ok) where
    ``ok`` False writes the text in red and True in green (None: plain); ``kind`` the CSS
    class ("stable", "unstable", other: grey)."""
    body = []
    for label, text, ok in rows:
        css = "" if ok is None else (' class="ok"' if ok else ' class="bad"')
        body.append(f"<tr><th>{html.escape(label)}</th><td{css}>{html.escape(text)}</td></tr>")
    return (f'<div class="verdict {html.escape(kind)}"><p class="headline">{html.escape(headline)}'
            f"</p><table><tbody>{''.join(body)}</tbody></table></div>")  # fmt: skip


def _num(value, fmt: str = ".4g") -> str:
    return format_value(value, fmt)


def _coning_rows(s: dict) -> list[tuple[str, str, bool | None]]:
    rows = []
    rate = s.get("cone_growth_rate_deg_per_s")
    if rate is not None:
        span = f"t = {_num(s.get('cone_growth_fit_start_s'))}–{_num(s.get('cone_growth_fit_end_s'))} s"
        sig = ("" if s.get("cone_growth_significant") else
               "; not significant: within 2 standard errors of 0, too short a run to see it")  # fmt: skip
        rows.append(("coning rate (secular growth of the cone angle)",
                     f"{_num(rate)} ± {_num(s.get('cone_growth_rate_se_deg_per_s'), '.2g')} deg/s, "
                     f"straight-line fit over the quasi-steady part ({span}){sig}", None))  # fmt: skip
    tau = s.get("coning_time_constant_s")
    if "coning_time_constant_s" in s:
        own = s.get("simulated_coning_time_constant_s")
        text = (f"{_num(tau)} s: the e-folding time of the cone angle by the energy-sink law at "
                f"the start; this run's own (θ̄/θ̇): {_num(own)} s" if own is not None else
                f"{_num(tau)} s: the e-folding time of the cone angle by the energy-sink law at "
                "the start (this run is too short to measure its own)")  # fmt: skip
        rows.append(("coning time constant", text, None))
    if s.get("dissipated_power_W") is not None:
        rows.append(("dissipated power",
                     f"{_num(s['dissipated_power_W'])} ± {_num(s.get('dissipated_power_se_W'), '.2g')} W "
                     f"in this run; energy-sink estimate {_num(s.get('energy_sink_power_W'))} W",
                     None))  # fmt: skip
    if s.get("log_decrement") is not None:
        rows.append(("bending log decrement (free decay)", _num(s["log_decrement"]), None))
    return rows


def _start_row(s: dict) -> tuple[str, str, bool | None]:
    v = s.get("validity") or {}
    if not v:
        return ("valid at the start", "not checked", None)
    ok = bool(v.get("valid"))
    if not ok:
        return ("valid at the start", f"NO: {v.get('message', '')}", False)
    low = v.get("rotating_stiffness_min_eigenvalue")
    text = ("yes: the rotating-frame stiffness is positive definite at the spin (smallest "
            f"eigenvalue {_num(low)} s⁻²)" if low is not None else "yes (no elastic modes)")  # fmt: skip
    deformation = s.get("valid_initial_deformation")
    if deformation is None:
        text += "; no initial deformation to check"
    elif deformation:
        text += "; the initial deformation is within the reduced potential's range"
    else:
        return ("valid at the start", text + "; NOT the initial deformation (its energy differs "
                "from the FE model's by more than 2 %)", False)  # fmt: skip
    return ("valid at the start", text, True)


def _path_row(s: dict) -> tuple[str, str, bool | None] | None:
    p = s.get("path_validity")
    if not p:
        return None
    checked = ", ".join(p.get("checked") or []) or "nothing"
    if p.get("valid"):
        return ("valid along the path", f"yes ({checked} checked)", True)
    where = p.get("left_range_at_s")
    at = f"; leaves the model's range at t = {_num(where)} s" if where is not None else ""
    return ("valid along the path", f"NO: {p.get('message', '')}{at}", False)


def _run_row(s: dict) -> tuple[str, str, bool | None]:
    complete = bool(s.get("complete", s.get("status") == "complete"))
    text = (f"{s.get('status', '?')}: {s.get('steps', '?')} steps of {_num(1e3 * s['dt_s'], '.3g')} ms "
            f"to t = {_num(s.get('t_end_s'))} s; |H| drift {_num(s.get('H_relative_drift'), '.2e')}, "
            f"energy balance error {_num(s.get('energy_balance_relative_error'), '.2e')}"
            if "dt_s" in s else str(s.get("status", "?")))  # fmt: skip
    return ("the run", text, complete)


def _convergence_rows(s: dict) -> list[tuple[str, str, bool | None]]:
    rows = []
    for key, label in (("dt_convergence", "time-step convergence"),
                       ("mode_convergence", "mode convergence")):  # fmt: skip
        conv = s.get(key)
        if conv:
            rows.append((label, str(conv.get("text", "")), conv.get("converged")))
    ev = s.get("until")
    if ev:
        rows.append((f"until {ev['event']}",
                     f"reached at t = {_num(ev.get('time_s'))} s" if ev.get("reached")
                     else "not reached within the run's duration", None))  # fmt: skip
    return rows


def run_verdict(summary: dict) -> Section:
    """The answer and the checks of a free-body run (its summary dict), as the first section
    of its report; a spin-up (no cone) gets its peak tip deflection and hub rate."""
    s = summary
    stability = str(s.get("spin_stability", ""))
    if "spin_verdict" in s:
        headline = f"Spin {s['spin_verdict']}"
    elif "peak_tip_deflection_m" in s:
        headline = (f"Spin-up: peak in-plane tip deflection {_num(s['peak_tip_deflection_m'])} m, "
                    f"final hub rate {_num(s.get('omega_s_rad_s'))} rad/s")  # fmt: skip
    else:
        headline = "no stability verdict (no elastic modes or no energy-sink estimate)"
    rows = _coning_rows(s)
    rows.append(_start_row(s))
    path = _path_row(s)
    if path is not None:
        rows.append(path)
    rows.append(_run_row(s))
    rows += _convergence_rows(s)
    if s.get("stability_rule"):
        rows.append(("stability rule", str(s["stability_rule"]), None))
    return Section("the answer", verdict_box(headline, rows, stability))


def _pct(value) -> str:
    return "—" if value is None else f"{100 * float(value):.3g} %"


def compare_verdict(payload: dict) -> Section:
    """The answer of a comparison (its ``comparison.json`` payload): for each reduced
    formulation its errors against the full order and its speed-up, the full order's state."""
    fo = payload["full_order"]
    complete = bool(fo.get("complete"))
    rows = []
    for name, row in payload["formulations"].items():
        ratio = row.get("cone_growth_ratio")
        rows.append((f"formulation {name}",
                     f"envelope error {_pct(row.get('envelope_error'))}, cone angle error "
                     f"{_pct(row.get('cone_angle_error'))}, spin rate error {_pct(row.get('spin_rate_error'))}; "
                     f"cone growth reduced / full {_num(ratio)}; {_num(row.get('speedup'), '.3g')}× faster",
                     None))  # fmt: skip
    rows.append(("full order", f"{'complete' if complete else 'INCOMPLETE'}: {fo.get('steps')} steps "
                 f"of {_num(1e3 * fo['dt_s'], '.3g')} ms, |H| drift {_num(fo.get('H_relative_drift'), '.2e')}",
                 complete))  # fmt: skip
    headline = (f"{payload['case']}: the reduced formulations against the full-order finite-element "
                f"solution over {payload['window_s']:g} s (errors relative to the full order)")  # fmt: skip
    return Section("the answer", verdict_box(headline, rows, "stable" if complete else "unstable"))
