"""The CLI's plain log handler writes to the stderr of the moment, not the one it was
configured with (a caller that swaps and closes stderr must not get "--- Logging error ---")."""

import io
import logging
import sys

from quadmodes.cli import verbosity


def test_log_lines_follow_a_swapped_stderr(monkeypatch):
    first = io.StringIO()
    monkeypatch.setattr(sys, "stderr", first)
    verbosity.configure()
    first.close()  # the stream of configure time is gone, as after a captured CLI call
    second = io.StringIO()
    monkeypatch.setattr(sys, "stderr", second)
    logging.getLogger("quadmodes.test").warning("cone angle out of range")
    assert second.getvalue() == "WARNING quadmodes.test: cone angle out of range\n"
