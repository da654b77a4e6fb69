"""Project metadata agrees with itself: the licence pyproject names is the LICENSE file's, and
CITATION.cff cites the package's own version."""

import re
import tomllib
from pathlib import Path

from quadmodes._version import __version__

ROOT = Path(__file__).resolve().parents[1]


def test_licence_file_matches_pyproject():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert meta["license"] == "MIT"  # an SPDX expression (PEP 639; the table form is deprecated)
    assert (ROOT / "LICENSE").read_text(encoding="utf-8").startswith("MIT License")


def test_citation_cites_this_version():
    text = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert re.search(r"^cff-version: 1\.2\.0$", text, re.M)
    assert re.search(r"^license: MIT$", text, re.M)
    assert re.search(rf'^version: "{re.escape(__version__)}"$', text, re.M)
