"""The box at the top of report.html (``io/verdict.py``): the verdict, the answer's numbers and
the checks, a failed check in red whatever the verdict (issue 28, item 5)."""

from __future__ import annotations

import html
import re

from quadmodes.io.verdict import run_verdict

SUMMARY = {
    "status": "complete", "complete": True, "steps": 400, "dt_s": 5e-4, "t_end_s": 0.2,
    "H_relative_drift": 3.3e-15, "energy_balance_relative_error": 1.2e-11,
    "spin_stability": "unstable",
    "spin_verdict": "unstable: the cone grows, e-folding time 564.8 s (energy sink)",
    "cone_growth_rate_deg_per_s": 0.0484, "cone_growth_rate_se_deg_per_s": 0.0282,
    "cone_growth_significant": False, "cone_growth_fit_start_s": 0.15, "cone_growth_fit_end_s": 0.2,
    "coning_time_constant_s": 564.8, "simulated_coning_time_constant_s": None,
    "dissipated_power_W": 0.00904, "dissipated_power_se_W": 0.00276, "energy_sink_power_W": 0.01066,
    "validity": {"valid": True, "rotating_stiffness_min_eigenvalue": 3278.4},
    "valid_initial_deformation": None,
    "path_validity": {"valid": True, "checked": ["centrifugal load", "modal amplitudes"]},
    "stability_rule": "unstable if ...",
}  # fmt: skip


def _rows(body: str) -> dict[str, tuple[str, str]]:
    """label -> (css class of the value or "", its text) of the box's table."""
    found = re.findall(r"<tr><th>([^<]*)</th><td( class=\"(\w+)\")?>([^<]*)</td></tr>", body)
    return {html.unescape(k): (css, html.unescape(v)) for k, _, css, v in found}


def test_the_box_says_the_verdict_and_the_numbers_first():
    section = run_verdict(SUMMARY)
    assert section.title == "the answer" and 'class="verdict unstable"' in section.body
    assert "Spin unstable: the cone grows, e-folding time 564.8 s" in html.unescape(section.body)
    rows = _rows(section.body)
    assert list(rows)[:3] == ["coning rate (secular growth of the cone angle)",
                              "coning time constant", "dissipated power"]  # fmt: skip
    assert rows["coning rate (secular growth of the cone angle)"][1].startswith(
        "0.0484 ± 0.028 deg/s")  # fmt: skip
    assert "not significant" in rows["coning rate (secular growth of the cone angle)"][1]
    assert rows["coning time constant"][1].startswith("564.8 s")
    assert rows["valid at the start"][0] == "ok" and "3278" in rows["valid at the start"][1]
    assert rows["valid along the path"] == ("ok", "yes (centrifugal load, modal amplitudes checked)")
    assert rows["the run"][0] == "ok" and "400 steps of 0.5 ms" in rows["the run"][1]


def test_a_failed_check_is_red_in_a_stable_box():
    bad = {**SUMMARY, "spin_stability": "stable", "spin_verdict": "stable: the cone shrinks",
           "path_validity": {"valid": False, "message": "the spin left the model's range",
                             "left_range_at_s": 439.0},
           "valid_initial_deformation": False, "status": "interrupted", "complete": False}  # fmt: skip
    rows = _rows(run_verdict(bad).body)
    assert 'class="verdict stable"' in run_verdict(bad).body
    assert rows["valid along the path"][0] == "bad"
    assert rows["valid along the path"][1] == ("NO: the spin left the model's range; leaves the "
                                               "model's range at t = 439 s")  # fmt: skip
    assert rows["valid at the start"][0] == "bad" and "NOT the initial deformation" in rows["valid at the start"][1]
    assert rows["the run"][0] == "bad"
