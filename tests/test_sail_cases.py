"""Issue 26, remaining pieces on spin-stiffened bodies: the CLI's Campbell diagram of a body
with no stiffness at rest (about its spinning state, the library's rule)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import quadmodes as qm
from quadmodes.case import load_case

BUILTIN = Path(qm.__file__).parent / "case" / "builtin"


@pytest.fixture(scope="module")
def coarse_rotor(tmp_path_factory) -> Path:
    """string-blade-rotor with 12 elements per blade (a TOML file, as a user's case)."""
    text = (BUILTIN / "string-blade-rotor.toml").read_text()
    text = text.replace("elements = 40", "elements = 12")
    text = text.replace('name = "string-blade-rotor"', 'name = "rotor-12"')
    path = tmp_path_factory.mktemp("rotor") / "rotor-12.toml"
    path.write_text(text)
    return path


def test_cli_campbell_of_a_body_without_stiffness_at_rest_is_the_librarys(coarse_rotor):
    """`quadmodes campbell` on a rotor whose blades have no stiffness at rest (and no [spin]
    table) expands its model about the spinning state at the sweep's top spin about the major
    axis, as the library does with that model: the same spins (from 5 % of it) and the same
    frequencies; the nutation is at the rigid body's ω/Ω ≈ 1 at every spin and the ratios are
    the same at the two upper spins (ω ∝ Ω), which the model about rest does not give."""
    from typer.testing import CliRunner

    from quadmodes.cli.app import app

    result = CliRunner().invoke(app, ["campbell", str(coarse_rotor), "--spin-max", "2 rad/s",
                                      "-n", "3", "--json", "-q"])  # fmt: skip
    assert result.exit_code == 0, result.output
    cli = json.loads(result.stdout.strip().splitlines()[-1])
    model = qm.reduced_model(load_case(coarse_rotor), 9, spin="2 rad/s", spin_axis="major")
    lib = qm.campbell(model, 0, "2 rad/s", 3)
    by_name = qm.campbell(coarse_rotor, 0, "2 rad/s", 3)  # the library with the case itself
    np.testing.assert_allclose(cli["spin_rate_rad_s"], [0.1, 1.05, 2.0])
    np.testing.assert_allclose(cli["spin_rate_rad_s"], lib.spin)
    assert cli["branches"] == list(lib.labels) == list(by_name.labels)
    np.testing.assert_allclose(np.array(cli["frequency_rad_s"], float), lib.frequency, rtol=1e-9)
    np.testing.assert_allclose(by_name.frequency, lib.frequency, rtol=1e-9)
    np.testing.assert_allclose(cli["axis"], [0.0, 0.0, 1.0], atol=1e-12)
    ratio = lib.ratio
    np.testing.assert_allclose(ratio[:, lib.branch("nutation")], 1.0, rtol=2e-4)
    np.testing.assert_allclose(ratio[1], ratio[2], rtol=2e-3)
