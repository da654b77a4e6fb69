"""The modes of a run: ``run --modes N``, ``reduced.modes = "auto"`` (every mode up to
``mode_margin`` × the spin frequency, pairs whole, at least the first bending pair) and
``run --mode-convergence`` (the next pair-whole mode counts).

Fast: the small capsule of conftest (≈400 nodes). Its spectrum, computed here independently
(16 modes): an ovalling pair at 122.45 Hz, the bending pair at 148.0/148.2 Hz, axial at 164.9 Hz,
a shell pair at 198.70 Hz, an ovalling pair at 204.2/204.3 Hz. Runs are 0.01–0.02 s.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_run import run_toml, workdir  # noqa: F401  (fixture)
from typer.testing import CliRunner

from quadmodes.case import CaseError, load_case, run_case_from_toml
from quadmodes.case.run_sections import DEFAULT_MODE_MARGIN
from quadmodes.cli.app import app
from quadmodes.models import build as model_build
from quadmodes.runs import mode_choice
from quadmodes.runs import results as res
from quadmodes.structure import pipeline
from quadmodes.structure.labels import label_modes
from quadmodes.structure.modes import compute_modes

#: Two neighbouring modes this close (relative) are taken as one pair by the tests.
PAIR_GAP = 0.01


@pytest.fixture(scope="module")
def spectrum(small_modal_model):
    """(frequencies Hz (16,), labels) of the small capsule, computed here from its FE model."""
    m = small_modal_model
    modes = compute_modes(m.structure, m.x, 16)
    return np.asarray(modes.frequencies_hz), label_modes(m.structure, m.x, modes.shapes)


def _whole(freqs: np.ndarray, n: int) -> bool:
    """True if keeping the lowest ``n`` modes leaves every close pair (gap < PAIR_GAP) whole."""
    return bool(freqs[n] - freqs[n - 1] > PAIR_GAP * freqs[n - 1])


def _run(workdir, *args):  # noqa: F811
    return CliRunner().invoke(
        app, ["run", str(workdir / "small-run.toml"), "-o", str(workdir / "out"), *args]
    )


def _auto_run(tmp_path, spin_hz: float, margin: float | None):
    text = run_toml(spin=f'"{float(spin_hz)!r} Hz"').replace("modes = 5", 'modes = "auto"')
    if margin is not None:
        text = text.replace('modes = "auto"', f'modes = "auto"\nmode_margin = {float(margin)!r}')
    return run_case_from_toml(text, source="auto.toml", base_dir=tmp_path)


# ----------------------------------------------------------------------------- case schema


def test_auto_modes_round_trip_and_bad_values(workdir):  # noqa: F811
    run = _auto_run(workdir, 100.0, 2.0)
    assert run.reduced.modes == "auto" and run.reduced.margin == 2.0
    assert run_case_from_toml(run.to_toml(), base_dir=workdir) == run
    default = _auto_run(workdir, 100.0, None)
    assert default.reduced.mode_margin is None and default.reduced.margin == DEFAULT_MODE_MARGIN
    assert "mode_margin" not in default.to_toml()  # existing cases keep their TOML
    for bad, field in [
        ("modes = 0", "reduced.modes"),
        ('modes = "all"', "reduced.modes"),
        ("modes = 2.5", "reduced.modes"),
        ('modes = "auto"\nmode_margin = 0.5', "reduced.mode_margin"),
        ("modes = 5\nmode_margin = 2.0", "reduced.mode_margin"),
    ]:
        with pytest.raises(CaseError) as info:
            run_case_from_toml(run_toml().replace("modes = 5", bad), "bad.toml", workdir)
        assert info.value.field == field and "\n" not in str(info.value)


# ----------------------------------------------------------------------------- auto


def test_auto_takes_every_mode_below_the_margin_and_keeps_pairs(workdir, spectrum):  # noqa: F811
    freqs, labels = spectrum
    bending = [k for k, lab in enumerate(labels) if lab == "bending"][:2]
    # a cutoff in a wide gap above the bending pair: every mode below it, nothing more
    gaps = np.diff(freqs) / freqs[:-1]
    k = next(i for i in range(max(bending) + 1, len(freqs) - 1) if gaps[i] > 0.1)
    cutoff = 0.5 * (freqs[k] + freqs[k + 1])
    run, choice = mode_choice.resolve_modes(_auto_run(workdir, cutoff / DEFAULT_MODE_MARGIN, None))
    assert run.reduced.modes == choice.n_modes == int(np.sum(freqs <= cutoff)) == k + 1
    assert choice.cutoff_hz == pytest.approx(cutoff) and choice.margin == DEFAULT_MODE_MARGIN
    assert choice.next_hz == pytest.approx(freqs[k + 1], rel=1e-6)
    assert f"N = {k + 1}" in choice.rule and f"{DEFAULT_MODE_MARGIN:g} ×" in choice.rule
    # a cutoff inside a close pair: the partner above it is kept too
    p = next(i for i in range(k + 1, len(freqs) - 1) if gaps[i] < 1e-4)
    inside = 0.5 * (freqs[p] + freqs[p + 1])
    _, choice = mode_choice.resolve_modes(_auto_run(workdir, 100.0, inside / 100.0))
    assert int(np.sum(freqs <= inside)) == p + 1 and choice.n_modes == p + 2
    assert _whole(freqs, choice.n_modes) and choice.below_cutoff == p + 1
    # a slow spin (20 Hz: no mode below the cutoff) still keeps the first bending pair whole
    _, choice = mode_choice.resolve_modes(_auto_run(workdir, 20.0, None))
    assert choice.below_cutoff == 0 and choice.n_modes == max(bending) + 1


def test_auto_run_states_its_choice_and_has_n_modes(workdir, spectrum):  # noqa: F811
    freqs, _ = spectrum
    (workdir / "small-run.toml").write_text(
        run_toml(spin=f'"{180.0 / DEFAULT_MODE_MARGIN!r} Hz"', duration='"0.01 s"'),
        encoding="utf-8",
    )
    result = _run(workdir, "--modes", "auto", "--json", "--no-plots")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)["small-run"]  # run --json: {case name: summary}
    expected = int(np.sum(freqs <= 180.0))
    assert _whole(freqs, expected)
    assert summary["n_modes"] == expected and summary["modes_requested"] == "auto"
    assert (
        summary["mode_cutoff_hz"] == pytest.approx(180.0)
        and summary["mode_margin"] == DEFAULT_MODE_MARGIN
    )
    assert "auto" in summary["mode_rule"]
    ds = res.load_results(workdir / "out" / "small-run" / "results.nc")
    assert ds.sizes["mode"] == expected and ds["modal_coordinates"].shape[1] == expected
    assert np.allclose(ds["mode_frequency_hz"].values, freqs[:expected], rtol=1e-6)
    table = _run(workdir, "--modes", "auto", "--no-plots")
    assert table.exit_code == 0 and "mode choice" in table.stdout


# ----------------------------------------------------------------------------- --modes N


def test_modes_option_overrides_the_case(workdir, spectrum):  # noqa: F811
    freqs, _ = spectrum
    result = _run(workdir, "--modes", "4", "--duration", "0.01 s", "--json", "--no-plots")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)["small-run"]  # run --json: {case name: summary}
    assert summary["n_modes"] == 4 and summary["modes_requested"] == "4"
    ds = res.load_results(workdir / "out" / "small-run" / "results.nc")
    assert ds["modal_coordinates"].shape == (ds.sizes["time"], 4)
    assert np.allclose(ds["mode_frequency_hz"].values, freqs[:4], rtol=1e-6)
    # the angular momentum is conserved with the new basis too
    assert summary["H_relative_drift"] < 1e-10


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--modes", "0"], "reduced.modes"),
        (["--modes", "abc"], "reduced.modes"),
        (["--modes", "2.5"], "reduced.modes"),
        (["--modes", "3"], "splits the pair"),  # the bending pair is modes 3 and 4
        (["--formulation", "rigid", "--mode-convergence"], "--mode-convergence"),
    ],
)
def test_bad_modes_exit_2_with_one_line(workdir, args, needle):  # noqa: F811
    result = _run(workdir, *args, "--duration", "0.01 s")
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0]
    assert not (workdir / "out").exists()


def test_auto_is_refused_for_a_spinup():
    result = CliRunner().invoke(app, ["run", "kane-spinup", "--modes", "auto"])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "reduced.modes" in lines[0] and "spinup" in lines[0]


# ----------------------------------------------------------------------------- convergence


def test_mode_convergence_table_with_the_next_pair_whole_counts(workdir, spectrum):  # noqa: F811
    freqs, _ = spectrum
    expected = [n for n in range(5, len(freqs)) if _whole(freqs, n)][:2]  # above N = 4
    result = _run(workdir, "--modes", "4", "--duration", "0.01 s", "--mode-convergence",
                  "--no-plots")  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "mode convergence" in result.stdout and "verdict:" in result.stdout
    saved = json.loads((workdir / "out" / "small-run" / "summary.json").read_text())
    conv = saved["mode_convergence"]
    rows = conv["rows"]
    assert [r["n_modes"] for r in rows] == [4, *expected]
    assert rows[0]["cone_angle_end_deg"] == pytest.approx(saved["cone_angle_end_deg"], rel=1e-12)
    assert [m["mode"] for m in rows[1]["added_modes"]] == list(range(5, expected[0] + 1))
    for prev, row in zip(rows, rows[1:], strict=False):
        assert row["complete"] and row["H_relative_drift"] < 1e-10
        change = abs(row["dissipated_energy_J"] - prev["dissipated_energy_J"])
        assert row["rel_change_dissipated_energy_J"] == pytest.approx(
            change / prev["dissipated_energy_J"]
        )
    assert conv["tolerance"] == 0.01 and isinstance(conv["converged"], bool)
    worst = max(rows[1][f"rel_change_{k}"] for k in conv["judged"])
    assert conv["converged"] == (worst <= conv["tolerance"])


def test_a_larger_basis_reuses_the_inflated_state(tmp_path, monkeypatch, spectrum):
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    from conftest import SMALL_CAPSULE

    (tmp_path / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    case = load_case(tmp_path / "small.toml")
    calls = []
    real = pipeline.inflate

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(pipeline, "inflate", counting)
    monkeypatch.setattr(model_build, "_LAST_MODAL", [])
    small = model_build.reduced_model_for(case, 2)
    larger = model_build.reduced_model_for(case, 5)  # more modes than the case computes
    assert len(calls) == 1
    assert np.allclose(larger.frequencies_hz[:2], small.frequencies_hz, rtol=1e-8)
    assert np.allclose(larger.frequencies_hz, spectrum[0][:5], rtol=1e-8)
