"""The Campbell figure and its critical speeds, in the unit a user chooses (issue 28 item 4).

The figure reads at a glance: one colour per mode family (the branches of one family, e.g. the
two members of a pair split by the gyroscopic coupling, share it and differ by line style),
colours that never repeat (:func:`quadmodes.io.display_units.family_colours`), the legend
outside the axes, the engine-order lines f = kΩ, the critical speeds where a branch meets
them, and the divergence where the rotating stiffness is lost.

Critical speeds (:func:`engine_order_crossings`): in the rotating frame a load fixed in space
(gravity, a side load, an imbalance of the support) excites the body at the spin rate Ω, and a
load twice per revolution at 2Ω; a branch whose rotating-frame frequency equals kΩ is in
resonance with it. The crossing is found where f_b(Ω) − kΩ changes sign between two points of
the diagram, by linear interpolation (exact for lines; second order in the spacing otherwise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.analysis.campbell import CampbellResult
from quadmodes.analysis.full_order_markers import FullOrderMarkers, draw_markers
from quadmodes.io.display_units import HZ, FrequencyUnit, family, family_colours, frequency_unit
from quadmodes.io.figures import new_figure, save_png

#: Line styles of the first, second, ... branch of one family.
_STYLES = ("-", "--", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 1)))


@dataclass(frozen=True)
class Crossing:
    """A critical speed: branch ``label`` meets the engine-order line f = ``order`` Ω at spin
    ``spin`` (rad/s), where its frequency is ``frequency`` (rad/s, = order × spin)."""

    spin: float
    frequency: float
    order: int
    label: str


def past_divergence(result: CampbellResult) -> np.ndarray:
    """(ns,) bool: spin rates beyond a divergence where the rotating stiffness is not positive
    definite (the shaded part of the figure)."""
    if result.divergence.size == 0:
        return np.zeros(result.spin.size, bool)
    return np.asarray(result.min_stiffness) <= 0.0


def branch_starts(result: CampbellResult) -> np.ndarray:
    """Index of the first spin rate of each branch."""
    if result.start is not None:
        return np.asarray(result.start, int)
    return np.zeros(len(result.labels), int)


def engine_order_crossings(result: CampbellResult, orders=(1, 2)) -> list[Crossing]:
    """Every crossing of a branch with f = kΩ (k in ``orders``) between two consecutive spin
    rates where the branch exists, on the side of the diagram where the rotating stiffness is
    positive definite (beyond a divergence the relative equilibrium is another, unstable one);
    sorted by spin. A branch that only touches the line (f − kΩ = 0 at a grid point without a
    change of sign, e.g. every branch at Ω = 0) gives none; a zero on a point counts once."""
    spin, freq = np.asarray(result.spin, float), np.asarray(result.frequency, float)
    past = past_divergence(result)
    found = []
    for k in orders:
        gap = freq - k * spin[:, None]  # (ns, nb)
        gap[past] = np.nan
        for b, label in enumerate(result.labels):
            for w in _sign_changes(spin, gap[:, b]):
                found.append(Crossing(float(w), float(k * w), int(k), str(label)))
    return sorted(found, key=lambda c: (c.spin, c.order))


def _sign_changes(x: np.ndarray, g: np.ndarray) -> list[float]:
    """Where ``g`` (sampled at ``x``; NaN where undefined) changes sign between neighbouring
    finite samples, by linear interpolation; a zero on a sample counts once, when the samples
    on its two sides have opposite signs."""
    found = []
    for i in range(x.size - 1):
        g0, g1 = g[i], g[i + 1]
        if not (np.isfinite(g0) and np.isfinite(g1)) or g0 == 0.0:
            continue
        if g0 * g1 < 0.0:
            found.append(x[i] + g0 / (g0 - g1) * (x[i + 1] - x[i]))
        elif g1 == 0.0 and i + 2 < x.size and np.isfinite(g[i + 2]) and g0 * g[i + 2] < 0.0:
            found.append(x[i + 1])
    return found


def _draw_branches(ax, result: CampbellResult, unit: FrequencyUnit, colours: dict) -> None:
    """Each branch in its family's colour (members by line style); branches beyond a
    divergence dotted and thin; unstable roots as ×. One legend entry per family, then one per
    line style used (grey)."""
    x = unit.from_rad_s(result.spin)
    past, starts = past_divergence(result), branch_starts(result)
    member: dict[str, int] = {}
    named: set[str] = set()
    for b, lab in enumerate(result.labels):
        fam = family(lab)
        beyond = bool(past[starts[b]]) if result.spin.size else False
        y = unit.from_rad_s(result.frequency[:, b])
        if beyond:
            ax.plot(x, y, ".:", lw=0.8, ms=2.5, color=colours[fam], label="_nolegend_")
        else:
            k = member.get(fam, 0)
            member[fam] = k + 1
            ax.plot(x, y, ls=_STYLES[k % len(_STYLES)], lw=1.5, color=colours[fam],
                    label=fam if fam not in named else "_nolegend_")  # fmt: skip
            named.add(fam)
        bad = result.unstable[:, b]
        if bad.any():
            ax.plot(x[bad], y[bad], "x", ms=5, color=colours[fam], label="_nolegend_")
    styles = max(member.values(), default=0)
    for k in range(styles if styles > 1 else 0):
        ax.plot([], [], ls=_STYLES[k % len(_STYLES)], lw=1.5, color="k",
                label=f"branch {k + 1} of a family" if k else "first branch of a family")  # fmt: skip
    if past.any():
        ax.plot([], [], ".:", lw=0.8, ms=2.5, color="k", label="beyond the divergence")


def _draw_orders(ax, result, unit: FrequencyUnit, orders, top: float) -> None:
    """The engine-order lines f = kΩ, named at their upper end."""
    x = unit.from_rad_s(result.spin)
    for k in orders:
        ax.plot(x, k * x, color="0.35", ls=":", lw=0.9, label="_nolegend_")
        j = np.searchsorted(k * x, top) - 1
        if 0 <= j < x.size and k * x[j] > 0:
            ax.annotate(f"{k}Ω", (x[j], k * x[j]), fontsize=8, color="0.25",
                        xytext=(2, 2), textcoords="offset points")  # fmt: skip


def _draw_crossings(ax, crossings: list[Crossing], unit: FrequencyUnit, span: float) -> None:
    """The critical speeds as open circles, each with its spin rate (below right; above left
    when the previous one is closer than 4 % of the ``span`` of spin rates shown)."""
    last, flip = -np.inf, False
    for n, c in enumerate(crossings):
        x, y = unit.from_rad_s(c.spin), unit.from_rad_s(c.frequency)
        flip = (not flip) if x - last < 0.04 * span else False
        last = x
        ax.plot(x, y, "o", ms=7, mfc="none", mec="k", mew=1.1,
                label="critical speed (branch = kΩ)" if n == 0 else "_nolegend_")  # fmt: skip
        ax.annotate(f"{x:.3g}", (x, y), fontsize=7, textcoords="offset points",
                    xytext=(-6, 5) if flip else (4, -9), ha="right" if flip else "left")  # fmt: skip


def _draw_divergence(axs, result, unit: FrequencyUnit, top: float) -> None:
    """Each divergence as a red dashed line (named with its spin rate), the part beyond it
    where the stiffness stays lost shaded."""
    ax, past = axs[0], past_divergence(result)
    for k, w in enumerate(result.divergence):
        if result.spin.size and np.any(result.spin > w):
            nxt = result.divergence[k + 1] if k + 1 < result.divergence.size else result.spin.max()
            if past[np.searchsorted(result.spin, w)]:
                ax.axvspan(unit.from_rad_s(w), unit.from_rad_s(nxt), color="0.5", alpha=0.12, lw=0)
        xw = unit.from_rad_s(w)
        for a in axs:
            a.axvline(xw, color="tab:red", ls="--", lw=1.0,
                      label=f"divergence {xw:.4g} {unit.name}" if a is ax else "_nolegend_")  # fmt: skip
        ax.annotate("divergence", (xw, 0.97 * top), color="tab:red", fontsize=8, rotation=90,
                    ha="right", va="top")  # fmt: skip


def plot_campbell(result: CampbellResult, path=None, orders=(1, 2), title: str | None = None,
                  markers: FullOrderMarkers | None = None, unit: str | FrequencyUnit = HZ):  # fmt: skip
    """Campbell figure (matplotlib Figure, Agg canvas) in ``unit`` (Hz by default; "rpm",
    "rad/s"): the frequency of each branch against the spin rate, one colour per family, the
    engine-order lines f = kΩ for k in ``orders`` and the critical speeds on them
    (:func:`engine_order_crossings`), unstable roots as × (with their growth rate, 1/s, on a
    second panel when there are any), the divergence; the full-order roots of ``markers`` as
    diamonds in the colour of the branch they matched; the legend outside the axes. Saved to
    ``path`` (PNG, cropped to its content) if given."""
    unit = frequency_unit(unit)
    panels = 2 if result.unstable.any() else 1
    fig = new_figure((8.5, 5.0 + 2.0 * (panels - 1)))
    axs = fig.subplots(panels, 1, sharex=True, squeeze=False)[:, 0]
    ax = axs[0]
    colours = family_colours(result.labels)
    _draw_branches(ax, result, unit, colours)
    top = max(float(np.nanmax(unit.from_rad_s(result.frequency), initial=0.0)) * 1.05, 1e-9)
    if markers is not None:
        draw_markers(ax, markers, colours, unit.per_rad_s)
        top = max(top, float(np.nanmax(unit.from_rad_s(markers.frequency), initial=0.0)) * 1.05)
    _draw_orders(ax, result, unit, orders, top)
    span = float(np.ptp(unit.from_rad_s(result.spin))) if result.spin.size else 1.0
    _draw_crossings(ax, engine_order_crossings(result, orders), unit, span)
    _draw_divergence(axs, result, unit, top)
    if panels == 2:
        for b, lab in enumerate(result.labels):
            if result.unstable[:, b].any():
                axs[1].plot(unit.from_rad_s(result.spin), result.growth[:, b], "-",
                            color=colours[family(lab)])  # fmt: skip
        axs[1].axhline(0.0, color="k", lw=0.6)
        axs[1].set_ylabel("growth rate Re λ (1/s)")
        axs[1].grid(True, alpha=0.3)
    ax.set_ylim(0.0, top)
    ax.set_ylabel(f"rotating-frame frequency ({unit.name})")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    kind = "free body" if result.free else "clamped to hub"
    ax.set_title(title or f"Campbell diagram ({kind}, formulation {result.formulation})")
    axs[-1].set_xlabel(f"spin rate Ω ({unit.name})")
    fig.tight_layout()
    if path is not None:
        save_png(fig, path)
    return fig
