"""Progress a user sees in a log or a pipe: every model build of a command, labelled with the
model it belongs to and time-stamped (issue 25: the second build of a command was silent)."""

import re

from conftest import SMALL_CAPSULE

from quadmodes.case import case_from_toml
from quadmodes.cli import common
from quadmodes.models.build import reduced_model_for


def test_each_model_build_reports_its_own_stages():
    case = case_from_toml(SMALL_CAPSULE, source="small-capsule")
    seen: list[tuple[str, float]] = []
    for n in (2, 4):
        reduced_model_for(case, n, lambda stage, f: seen.append((stage, f)), use_cache=False)
    stages = {stage for stage, _ in seen}
    for n in (2, 4):
        assert any(s.startswith(f"small-capsule N={n}: quadratic modes") for s in stages), stages
        done = [f for s, f in seen if s == f"small-capsule N={n}: quadratic modes"]
        assert done[-1] == 1.0


def test_piped_lines_repeat_a_stage_that_runs_again(monkeypatch):
    printed: list[str] = []
    monkeypatch.setattr(common.err, "print", lambda text, **kw: printed.append(text))
    progress = common._text_progress()
    for _ in range(2):  # the same stage name twice (e.g. two inflations of one command)
        for f in (0.0, 0.5, 1.0):
            progress("inflation", f)
    assert [p.split(" ", 1)[1] for p in printed] == ["inflation: 0 %", "inflation: 50 %",
                                                      "inflation: 100 %"] * 2  # fmt: skip
    assert all(re.match(r"\d\d:\d\d:\d\d ", p) for p in printed)  # time-stamped
