"""`quadmodes run` warns on stderr, in one line, when a run's path leaves its reduced model's
range (the summary, the report and results.nc say where too), and says nothing when it does not."""

from __future__ import annotations

import math

from quadmodes.cli.run_commands import _warn_path
from quadmodes.runs.path_validity import PathValidity


def _path(left_at):
    return PathValidity(reference_spin=2 * math.pi * 41, centrifugal_max=0.15,
                        centrifugal_limit=0.02, spin_range=(250.0, 260.0), min_stiffness=3000.0,
                        amplitude_peak=6e-4, amplitude_peak_time=900.0, left_at=left_at,
                        left_spin=2 * math.pi * 40.24, left_cone=math.radians(12.6),
                        left_reason="modal amplitudes: the reduced potential is 8.5 % off",
                        checked=("centrifugal load", "modal amplitudes"))  # fmt: skip


def test_a_path_leaving_the_range_is_one_warning_line_on_stderr(capsys):
    _warn_path("paper-41hz-coarse", _path(439.0))
    got = capsys.readouterr()
    assert got.out == ""
    lines = [line for line in got.err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("warning: paper-41hz-coarse")
    assert "t = 439 s" in lines[0] and "40.24 Hz" in lines[0] and "12.6 deg" in lines[0]


def test_a_path_in_range_or_unchecked_is_no_warning(capsys):
    _warn_path("x", _path(None))
    _warn_path("x", None)
    assert capsys.readouterr().err == ""
