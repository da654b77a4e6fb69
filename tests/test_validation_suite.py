"""The fast subset of the validation suite (``quadmodes validate --quick``) passes: each row
compares a measured number with a published or analytic reference within its tolerance."""

import pytest

from quadmodes.validation import dynamics_checks as vdyn
from quadmodes.validation.report import Row, format_rows, validation_markdown


@pytest.mark.parametrize("name", vdyn.FAST)
def test_fast_dynamics_checks_pass(name):
    rows = vdyn.ROM_CHECKS[name]()
    assert rows
    failed = [f"{r.check}: {r.measured} vs {r.reference}" for r in rows if not r.passed]
    assert not failed, failed


def test_report_only_rows_and_markdown_escaping():
    rows = [
        Row("|H| drift", 1e-14, 0.0, 1e-10, absolute=True),
        Row("speed-up", 50.0, 1e4, 0.0, report_only=True),
        Row("failing", 2.0, 1.0, 0.1),
    ]
    assert rows[0].passed and rows[1].passed and not rows[2].passed
    text = format_rows(rows)
    assert "\\|H\\| drift" in text and "reported" in text and "**NO**" in text
    page = validation_markdown([], [], {"Reduced dynamics": rows})
    assert "## Reduced dynamics" in page
