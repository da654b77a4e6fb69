"""The bounds on the work one input can ask for, in one place (docs/reliability.md).

Each bound is a :class:`Limit`: a named default and the environment variable that raises (or
lowers) it, e.g. ``QUADMODES_MAX_SWEEP_POINTS=50000 quadmodes sweep ...``. The checks of the
library read them through :meth:`Limit.value` at the moment they check, so a variable set in
the environment of a process (a cluster worker, a test) takes effect there. An input beyond a
bound is refused before any work with a :class:`LimitError`: one line naming the field or
option, the limit, the fix, and the variable that raises it.

This module is a leaf: it imports nothing from quadmodes.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from quadmodes.errors import QuadmodesError

__all__ = [
    "CAMPBELL_POINTS",
    "LIMITS",
    "MAX_MASS",
    "MAX_STRAIN",
    "MAX_VOLUME_CHANGE",
    "MIN_MASS",
    "MESH_FILE_BYTES",
    "MESH_NODES",
    "MODE_COUNT",
    "OUTPUT_BYTES",
    "REDUCED_MODES",
    "SWEEP_POINTS",
    "Limit",
    "LimitError",
]


class LimitError(QuadmodesError, ValueError):
    """An input beyond a bound of :mod:`quadmodes.limits`: ``str(exc)`` is one line naming the
    ``field`` (or option), the limit, the fix and the environment variable that raises it."""

    def __init__(self, message: str, *, field: str | None = None) -> None:
        self.field = field
        self.detail = message
        super().__init__(message)


@dataclass(frozen=True)
class Limit:
    """A bound: ``default`` (a count, or bytes), raised by the environment variable ``env``
    (a positive number, e.g. ``QUADMODES_MAX_SWEEP_POINTS=50000``; "1e6" is accepted);
    ``what`` says what it counts, for messages and the docs."""

    env: str
    default: float
    what: str

    def value(self) -> float:
        """The bound in force: ``$env`` when set to a positive number, else ``default``.
        A malformed variable raises :class:`LimitError` naming it (never silently ignored)."""
        text = os.environ.get(self.env, "").strip()
        if not text:
            return self.default
        try:
            number = float(text)
        except ValueError:
            number = float("nan")
        if not math.isfinite(number) or number <= 0:
            raise LimitError(
                f"{self.env}={text!r}: must be a positive number ({self.what}); e.g. "
                f"{self.env}={self.default:.0f}, or unset it for the default",
                field=self.env,
            )
        return number

    def raise_hint(self, needed: float | None = None) -> str:
        """``"raise the limit with QUADMODES_MAX_...=<needed>"`` for messages."""
        target = needed if needed is not None else 10 * self.value()
        shown = f"{target:.0f}" if 1 <= target < 1e12 else f"{target:.3g}"
        return f"or raise the limit with {self.env}={shown}"


#: Elastic modes a model case computes (``modes.count``): the eigensolver keeps count × 3n
#: numbers; the built-in cases use 6 to 40.
MODE_COUNT = Limit("QUADMODES_MAX_MODES", 500, "elastic modes")
#: First load steps of the inflation (``pressure.steps``): each step is at least one Newton
#: solve of the whole structure; the built-in cases use 1.
INFLATION_STEPS = Limit("QUADMODES_MAX_INFLATION_STEPS", 1000, "inflation load steps")
#: Elastic modes of a reduced model (``reduced.modes``, ``--modes``), a hard bound even with
#: ``--yes``: the quartic terms alone hold N⁴ numbers (150 modes: 4 GB); the paper cases use 5.
REDUCED_MODES = Limit("QUADMODES_MAX_REDUCED_MODES", 150, "modes of a reduced model")
#: Points of a sweep (the product of the ``--param`` grids, or one range's count).
SWEEP_POINTS = Limit("QUADMODES_MAX_SWEEP_POINTS", 10_000, "points of a sweep")
#: Spin rates of a Campbell diagram (``--points``); the default diagram has 41.
CAMPBELL_POINTS = Limit("QUADMODES_MAX_CAMPBELL_POINTS", 10_000, "spin rates of a Campbell diagram")
#: Bytes of a mesh file (``geometry.file``), checked on disk before reading: a surface of
#: MESH_NODES nodes is 20 to 100 MB in the common formats (binary STL ~100 B a node).
MESH_FILE_BYTES = Limit("QUADMODES_MAX_MESH_BYTES", 200e6, "bytes of a mesh file")
#: Nodes of a mesh file's surface (estimated from a binary STL's header before reading, else
#: counted after reading, before any model is built): 50,000 nodes take about 1.5 GB to build.
MESH_NODES = Limit("QUADMODES_MAX_MESH_NODES", 200_000, "nodes of a mesh file")
#: Bytes of a run's results.nc, estimated from the saved samples and the state size before the
#: run (2 million samples of a 5-mode run: ~650 MB on disk, ~3 GB in memory).
OUTPUT_BYTES = Limit("QUADMODES_MAX_OUTPUT_BYTES", 1e9, "bytes of results.nc")

# ---------------------------------------------------------------- physical plausibility (item 4)

#: Largest membrane strain scale p R / (E t) accepted (R: the largest cap radius, or for a mesh
#: file the radius of the sphere of its volume): beyond ~10 % the St Venant–Kirchhoff membrane
#: is far outside its range, and a thickness, modulus or mesh unit is usually off by a power of
#: ten (paper-membrane: 0.013). The lower bound is ``runs.resources.MIN_STRAIN``.
MAX_STRAIN = Limit("QUADMODES_MAX_STRAIN", 0.1, "membrane strain scale p R / (E t)")
#: Smallest and largest structural mass accepted (kg): density × thickness × area of a
#: membrane, density × area × length of a beam (paper-membrane: 0.13 kg; kane-beam: 12 kg).
MIN_MASS = Limit("QUADMODES_MIN_MASS", 1e-6, "kg of structural mass")
MAX_MASS = Limit("QUADMODES_MAX_MASS", 1e6, "kg of structural mass")
#: A warning (not a refusal) when inflation changes the enclosed volume by more than this
#: fraction (paper-membrane: 3 %): a mesh file in the wrong unit, or a far too soft membrane.
MAX_VOLUME_CHANGE = Limit("QUADMODES_MAX_VOLUME_CHANGE", 0.2, "fraction of volume change")

#: Every limit, for the docs and tests.
LIMITS: tuple[Limit, ...] = (
    MODE_COUNT,
    REDUCED_MODES,
    SWEEP_POINTS,
    CAMPBELL_POINTS,
    MESH_FILE_BYTES,
    MESH_NODES,
    OUTPUT_BYTES,
    MAX_STRAIN,
    MIN_MASS,
    MAX_MASS,
    MAX_VOLUME_CHANGE,
)


def check_count(limit: Limit, count: float, field: str, fix: str) -> None:
    """Raise :class:`LimitError` (one line: ``field``, the count, the limit, ``fix``, the
    variable) when ``count`` exceeds ``limit``."""
    bound = limit.value()
    if count > bound:
        raise LimitError(
            f"{field}: {count:,.0f} {limit.what} exceed the limit of {bound:,.0f}; {fix}, "
            f"{limit.raise_hint(count)}",
            field=field,
        )
