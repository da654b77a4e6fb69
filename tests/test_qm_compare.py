"""A run case of formulation "QM" through ``quadmodes compare`` (its own formulation compared by
default) and ``compare --at`` (its path point integrated by QM, or read from its results.nc).

Fast: the small capsule of conftest (N = 5, K = 21 manifold fields) and windows of a few ms."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_sweep import RUN, folder, runner  # noqa: F401  (fixture)

from quadmodes.analysis import path_point as pp
from quadmodes.case import CaseError, load_run_case
from quadmodes.cli.app import app
from quadmodes.runs import results, simulate


def _case(folder, formulation="QM", name="qm-run"):  # noqa: F811
    text = RUN.replace("modes = 5", f'modes = 5\nformulation = "{formulation}"')
    text = text.replace('name = "small-run"', f'name = "{name}"')
    (folder / f"{name}.toml").write_text(text, encoding="utf-8")
    return load_run_case(folder / f"{name}.toml")


def test_qm_path_point_read_from_results_is_the_integrated_one(folder, monkeypatch):  # noqa: F811
    """The QM path's point at a time is the same state whether integrated to it or read from
    the run's results.nc (samples every 5 steps: the sample before, stepped on by QM); a cone
    event is located without integrating the path far past it (the path's chunks of QM steps
    are short); a Q run's results.nc is refused for a QM case (another path)."""
    run = _case(folder)
    res = simulate.simulate(run)
    path = results.write_dataset(results.to_dataset(res), folder / "results.nc")
    model = res.model
    read = pp.path_point(run, "time 0.0212 s", model=model, results=path)
    direct = pp.path_point(run, "time 0.0212 s", model=model)
    assert read.step == direct.step == 106
    assert np.max(np.abs(read.y - direct.y)) <= 1e-9 * np.max(np.abs(direct.y))
    assert read.dissipated == pytest.approx(direct.dissipated, rel=1e-6)

    reached = []
    execute = simulate.execute

    def spy(setup, *a, **k):
        out = execute(setup, *a, **k)
        reached.append(float(out.solution.t[-1]))
        return out

    monkeypatch.setattr(simulate, "execute", spy)
    # a level the path's first sample past t = 0 (at 0.05 s) is above: its event is found there
    cone = np.floor(np.degrees(res.diagnostics.cone_angle[-1]) * 1e6) / 1e6
    assert cone > np.degrees(res.diagnostics.cone_angle[0])
    point = pp.path_point(run, f"cone {cone:.6f} deg", model=model)
    assert point.time <= 0.05 and np.degrees(point.cone_angle) >= cone
    dt = float(run.integration.dt)
    assert reached[-1] <= point.time + pp.NUMPY_PATH_CHUNK * dt + 1e-12

    q = simulate.simulate(_case(folder, "Q", "q-run"))
    q_path = results.write_dataset(results.to_dataset(q), folder / "q-results.nc")
    with pytest.raises(CaseError, match="formulation Q, this run case's is QM"):
        pp.path_point(run, "time 0.02 s", model=model, results=q_path)


def test_compare_of_a_qm_run_case_compares_qm_by_default_and_at_a_point(folder):  # noqa: F811
    _case(folder)
    res = runner.invoke(app, ["run", "qm-run.toml", "-o", "runs", "--no-plots"])
    assert res.exit_code == 0, res.output
    for extra in ([], ["--at", "time 0.02 s", "--results", "runs/qm-run/results.nc"]):
        out = runner.invoke(app, ["compare", "qm-run.toml", "--window", "4 ms", "--no-plots",
                                  "-o", f"cmp{len(extra)}", "--json", *extra])  # fmt: skip
        assert out.exit_code == 0, out.output
        payload = json.loads((folder / f"cmp{len(extra)}" / "comparison.json").read_text())
        assert list(payload["formulations"]) == ["rigid", "L", "P", "Q", "Q4", "QM"]
        qm = payload["formulations"]["QM"]
        assert qm["cone_angle_error"] < 1e-2 and qm["spin_rate_error"] < 1e-3
    assert payload["start"]["step"] == 100 and payload["start"]["source"].endswith("results.nc")


def test_the_library_compares_what_the_cli_compares(monkeypatch):
    """``qm.compare`` without ``formulations`` compares the CLI's default list: rigid, L, P, Q,
    Q4 and the run case's own formulation (QM here): library = CLI."""
    import tomllib

    import quadmodes as qm
    from quadmodes.analysis import compare as cmp
    from quadmodes.analysis import comparison_run as runner
    from quadmodes.case import load_run_case, run_case_from_dict

    data = tomllib.loads(load_run_case("paper-41hz-coarse").to_toml())
    data["reduced"]["formulation"] = "QM"
    run = run_case_from_dict(data, source="test")
    seen = {}
    monkeypatch.setattr(runner, "prepare_comparison", lambda r, span, cutoff, progress: (r, None))
    monkeypatch.setattr(runner, "run_comparison",
                        lambda resolved, span, formulations, **kw: seen.setdefault("names", formulations))  # fmt: skip
    qm.compare(run, "0.1 s")
    assert seen["names"] == cmp.default_formulations(run) == ("rigid", "L", "P", "Q", "Q4", "QM")
