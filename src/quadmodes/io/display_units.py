"""Units a user chooses for frequencies and spin rates in tables and figures (issue 28 item 4):
Hz (the default: the unit the cases and options are given in), rpm or rad/s. Files stay SI
(rad/s with ``units`` attributes); only what is shown changes.

Also what every Campbell-type figure shares: the family of a branch (its label without the
"#k" of the second and later branches of one family) and a colour per family that never
repeats (tab10 up to 10 families, tab20 up to 20, then evenly spaced hues).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FrequencyUnit:
    """A unit of frequency or spin rate: its ``name`` as shown ("Hz", "rpm", "rad/s") and
    ``per_rad_s``, the value in this unit of 1 rad/s."""

    name: str
    per_rad_s: float

    def from_rad_s(self, value):
        """``value`` (rad/s; scalar or array) in this unit (a float for a scalar)."""
        v = np.asarray(value, float) * self.per_rad_s
        return float(v) if v.ndim == 0 else v

    def from_hz(self, value):
        """``value`` (Hz; scalar or array) in this unit (a float for a scalar)."""
        return self.from_rad_s(np.asarray(value, float) * (2.0 * math.pi))


HZ = FrequencyUnit("Hz", 1.0 / (2.0 * math.pi))
RPM = FrequencyUnit("rpm", 60.0 / (2.0 * math.pi))
RAD_S = FrequencyUnit("rad/s", 1.0)

#: The units ``--units`` accepts, by their name.
UNITS = {u.name: u for u in (HZ, RPM, RAD_S)}
_SPELLINGS = {"hz": HZ, "rpm": RPM, "rev/min": RPM, "rad/s": RAD_S, "rad_s": RAD_S,
              "rad s-1": RAD_S, "rad/sec": RAD_S}  # fmt: skip


def frequency_unit(text: str | FrequencyUnit, option: str = "--units") -> FrequencyUnit:
    """The :class:`FrequencyUnit` named ``text`` ("Hz", "rpm", "rad/s", any case); raises
    ValueError naming ``option`` otherwise."""
    if isinstance(text, FrequencyUnit):
        return text
    unit = _SPELLINGS.get(str(text).strip().lower())
    if unit is None:
        raise ValueError(f"{option}: {text!r} is not a unit of frequency shown here; use Hz, "
                         "rpm or rad/s")  # fmt: skip
    return unit


def family(label: str) -> str:
    """The family of a branch label: the label without its " #k" suffix (the second and later
    branches of one family, e.g. the two members of a pair)."""
    return str(label).split(" #")[0]


def family_colours(labels) -> dict[str, tuple[float, float, float, float] | str]:
    """A colour per family of ``labels`` (first appearance order): tab10 for up to 10 families,
    tab20 for up to 20, else evenly spaced hues of a cyclic map, so no two families share one."""
    from matplotlib import colormaps

    names = list(dict.fromkeys(family(lab) for lab in labels if str(lab)))
    if len(names) <= 10:
        return {n: f"C{i}" for i, n in enumerate(names)}
    if len(names) <= 20:
        cmap = colormaps["tab20"]
        return {n: cmap(i) for i, n in enumerate(names)}
    cmap = colormaps["hsv"]
    return {n: cmap(i / len(names)) for i, n in enumerate(names)}
