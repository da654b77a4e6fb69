"""A spin-family run through the library is the command line's (the brief's rule: library =
CLI): ``qm.simulate`` + ``qm.write_results`` and ``quadmodes run`` on the small capsule's family
(members 1e-6 apart in spin: several switches in 0.04 s), each in a fresh cache (each builds its
members), write the same summary.json and the same results.nc, bit for bit but the wall time."""

from __future__ import annotations

import json

import numpy as np
from test_family_prefetch import _family_case
from typer.testing import CliRunner

import quadmodes as qm
from quadmodes.cli.app import app
from quadmodes.runs import results as res


def test_family_run_by_the_library_is_the_run_command(tmp_path, monkeypatch):
    case = _family_case(tmp_path)
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache-cli"))
    cli = CliRunner().invoke(app, ["run", str(case), "-o", str(tmp_path / "cli"), "--json", "--no-plots"])
    assert cli.exit_code == 0, cli.output
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache-api"))
    result = qm.simulate(case)
    assert len(result.family) >= 2
    summary = qm.write_results(result, tmp_path / "api", plots=False)
    by_cli, by_api = tmp_path / "cli" / "small-run", tmp_path / "api"
    a = json.loads((by_cli / "summary.json").read_text())
    assert {k: v for k, v in a.items() if k != "wall_s"} == {k: v for k, v in summary.items() if k != "wall_s"}
    ds_a, ds_b = res.load_results(by_cli / "results.nc"), res.load_results(by_api / "results.nc")
    assert set(ds_a.variables) == set(ds_b.variables)
    for name in ds_a.variables:
        assert np.array_equal(ds_a[name].values, ds_b[name].values, equal_nan=ds_a[name].dtype.kind == "f"), name
    assert {k for k in ds_a.attrs if str(ds_a.attrs[k]) != str(ds_b.attrs.get(k))} <= {"wall_s", "history",
                                                                                        "date_created"}  # fmt: skip
