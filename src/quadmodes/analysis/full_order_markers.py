"""Full-order linearisation markers for a Campbell diagram (``--full-order`` of ``quadmodes
campbell`` and ``quadmodes sweep``).

At a few spin rates the full-order FE model is linearised about its own spinning relative
equilibrium and its rotating-frame roots near the reduced ones are found and matched to the
reduced branches by MAC (:func:`quadmodes.analysis.rotating_comparison.rotating_frequency_comparison`).
:class:`FullOrderMarkers` keeps those roots per spin in rad/s, each with the label of the reduced
branch it matched ("tilt" / "other" for roots in the searched band that no branch claimed), for
markers on the figure and for the variables ``full_order_*(full_order_spin, root)`` of
``campbell.nc`` / ``sweep.nc``.

Stages::

    case + ReducedModel + spins (rad/s) ──full_order_markers──▶ FullOrderMarkers
    FullOrderMarkers ──marker_variables──▶ xarray variables with units and long names
    FullOrderMarkers ──draw_markers──▶ markers on a matplotlib axes
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.analysis.rotating_comparison import ComparisonTable, rotating_frequency_comparison

TWO_PI = 2.0 * np.pi
#: Dimensions of the stored variables.
SPIN_DIM, ROOT_DIM = "full_order_spin", "full_order_root"


@dataclass(frozen=True)
class FullOrderMarkers:
    """Full-order rotating-frame roots at ``spin`` (k,) rad/s, padded per spin to r roots.

    frequency (k, r) rad/s: |Im λ| of the full-order root (NaN: padding). growth (k, r) 1/s:
    Re λ. label (k, r): the reduced branch the root matched, "tilt" (rigid attitude root) or
    "other" (elastic root outside the reduced basis) when no branch claimed it, "" padding.
    matched (k, r): the root was matched to a reduced branch. reduced_frequency (k, r) rad/s:
    that branch's reduced-model frequency at the same spin (NaN if unmatched). relative_error
    (k, r): (reduced − full)/full. captured (k, r): share of the root's kinetic energy in the
    reduced coordinates. axis (3,): body-frame spin axis. formulation: of the reduced roots.
    """

    spin: np.ndarray
    frequency: np.ndarray
    growth: np.ndarray
    label: np.ndarray
    matched: np.ndarray
    reduced_frequency: np.ndarray
    relative_error: np.ndarray
    captured: np.ndarray
    axis: np.ndarray
    formulation: str

    @property
    def count(self) -> int:
        return int(self.spin.size)


def _rows_per_spin(table: ComparisonTable, spins_hz: list[float], formulation: str) -> list[list]:
    """Per spin (Hz, in order) the tuples (label, full Hz, growth, matched, rom Hz, error,
    captured) of the matched rows and then the unclaimed roots."""
    per_spin: list[list] = [[] for _ in spins_hz]

    def slot(spin_hz: float) -> int:
        return int(np.argmin([abs(s - spin_hz) for s in spins_hz]))

    for r in table.rows:
        if np.isfinite(r.full_hz):
            per_spin[slot(r.spin_hz)].append((r.label, r.full_hz, r.full_growth, True,
                                              r.rom_hz[formulation], r.rel_error[formulation],
                                              r.captured))  # fmt: skip
    for r in table.extra:
        per_spin[slot(r.spin_hz)].append((r.label, r.full_hz, r.full_growth, False, np.nan,
                                          np.nan, r.captured))  # fmt: skip
    return per_spin


def markers_from_table(table: ComparisonTable, spins_hz, formulation: str) -> FullOrderMarkers:
    """:class:`FullOrderMarkers` of a comparison table computed at ``spins_hz`` (Hz)."""
    spins_hz = [float(s) for s in spins_hz]
    per_spin = _rows_per_spin(table, spins_hz, formulation)
    k, r = len(spins_hz), max((len(rows) for rows in per_spin), default=0)
    nan = np.full((k, r), np.nan)
    freq, growth, rom, err, cap = nan.copy(), nan.copy(), nan.copy(), nan.copy(), nan.copy()
    label = np.full((k, r), "", dtype=object)
    matched = np.zeros((k, r), bool)
    for i, rows in enumerate(per_spin):
        for j, (lab, f_hz, g, ok, rom_hz, e, c) in enumerate(sorted(rows, key=lambda t: t[1])):
            label[i, j], matched[i, j] = lab, ok
            freq[i, j], growth[i, j], cap[i, j] = TWO_PI * f_hz, g, c
            rom[i, j], err[i, j] = TWO_PI * rom_hz, e
    return FullOrderMarkers(TWO_PI * np.asarray(spins_hz), freq, growth, label.astype(str),
                            matched, rom, err, cap, np.asarray(table.axis, float),
                            formulation)  # fmt: skip


def full_order_markers(case, model, spins_rad_s, axis=None, formulation: str = "Q",
                       progress=None, axis_option: str = "axis") -> FullOrderMarkers:  # fmt: skip
    """The full-order roots of a free-body ``case`` (name, TOML path or Case) at ``spins_rad_s``
    (rad/s, continued in the given order from rest), matched to the branches of the reduced
    ``model`` of the same case; ``axis`` as in :func:`quadmodes.analysis.campbell.campbell`
    (a resolved unit vector keeps the diagram's axis)."""
    spins_hz = [float(s) / TWO_PI for s in np.asarray(spins_rad_s, float).ravel()]
    if not spins_hz:
        raise ValueError("spins_rad_s: give at least one spin rate")
    table = rotating_frequency_comparison(case, spins_hz, model.n_modes, (formulation,),
                                          axis=axis, model=model, progress=progress,
                                          axis_option=axis_option)  # fmt: skip
    return markers_from_table(table, spins_hz, formulation)


def marker_variables(m: FullOrderMarkers, spin_units: str = "rad/s") -> dict:
    """``{name: xarray.Variable}``: the coordinate ``full_order_spin`` (rad/s) and the
    variables ``full_order_*`` over (full_order_spin, full_order_root), each with ``units``
    and ``long_name``."""
    import xarray as xr

    d = (SPIN_DIM, ROOT_DIM)

    def var(dims, value, units, long_name):
        return xr.Variable(dims, np.asarray(value), {"units": units, "long_name": long_name})

    return {
        SPIN_DIM: var((SPIN_DIM,), m.spin, spin_units, "spin rate of the full-order "
                      "linearisation"),
        "full_order_frequency": var(d, m.frequency, "rad/s", "rotating-frame frequency |Im "
                                    "lambda| of the full-order model linearised about its "
                                    "spinning relative equilibrium"),
        "full_order_growth_rate": var(d, m.growth, "1/s", "real part of the full-order root "
                                      "(> 0: unstable)"),
        "full_order_branch_label": var(d, m.label, "1", "reduced branch the full-order root "
                                       "matched (tilt / other: no branch claimed it)"),
        "full_order_matched": var(d, m.matched.astype(np.int8), "1", "full-order root matched "
                                  "to a reduced branch by MAC (1) or not (0)"),
        "full_order_reduced_frequency": var(d, m.reduced_frequency, "rad/s", "frequency of the "
                                            "matched reduced branch at the same spin"),
        "full_order_relative_error": var(d, m.relative_error, "1", "(reduced - full order) / "
                                         "full order frequency of the matched branch"),
        "full_order_captured": var(d, m.captured, "1", "share of the full-order root's kinetic "
                                   "energy in the reduced coordinates"),
    }  # fmt: skip


def marker_attrs(m: FullOrderMarkers) -> dict:
    """Global attributes describing the markers (axis, formulation)."""
    return {"full_order_formulation": m.formulation,
            "full_order_axis": ",".join(f"{v:.12g}" for v in m.axis)}  # fmt: skip


def to_record(m: FullOrderMarkers) -> dict:
    """JSON-ready dict of ``m`` (NaN as None)."""

    def clean(a):
        return [[None if isinstance(v, float) and not np.isfinite(v) else v for v in row]
                for row in np.asarray(a).tolist()]  # fmt: skip

    return {"spin": m.spin.tolist(), "frequency": clean(m.frequency), "growth": clean(m.growth),
            "label": np.asarray(m.label).tolist(), "matched": np.asarray(m.matched).tolist(),
            "reduced_frequency": clean(m.reduced_frequency),
            "relative_error": clean(m.relative_error), "captured": clean(m.captured),
            "axis": m.axis.tolist(), "formulation": m.formulation}  # fmt: skip


def from_record(rec: dict) -> FullOrderMarkers:
    """Inverse of :func:`to_record`."""

    def arr(key):
        return np.array([[np.nan if v is None else v for v in row] for row in rec[key]], float)

    k = len(rec["spin"])
    shape = (k, len(rec["label"][0]) if k else 0)
    return FullOrderMarkers(
        np.asarray(rec["spin"], float), arr("frequency").reshape(shape),
        arr("growth").reshape(shape), np.array(rec["label"], dtype=str).reshape(shape),
        np.array(rec["matched"], bool).reshape(shape), arr("reduced_frequency").reshape(shape),
        arr("relative_error").reshape(shape), arr("captured").reshape(shape),
        np.asarray(rec["axis"], float), str(rec["formulation"]))  # fmt: skip


def combine(parts: list[FullOrderMarkers]) -> FullOrderMarkers:
    """One :class:`FullOrderMarkers` of several (one spin or more each), padded to the most
    roots; in the given order."""
    r = max((p.frequency.shape[1] for p in parts), default=0)

    def pad(a, fill):
        out = np.full((a.shape[0], r), fill, dtype=a.dtype if a.dtype != bool else bool)
        out[:, : a.shape[1]] = a
        return out

    def cat(name, fill):
        return np.concatenate([pad(np.asarray(getattr(p, name)), fill) for p in parts])

    return FullOrderMarkers(
        np.concatenate([p.spin for p in parts]), cat("frequency", np.nan), cat("growth", np.nan),
        np.concatenate([pad(np.asarray(p.label, dtype=object), "") for p in parts]).astype(str),
        cat("matched", False), cat("reduced_frequency", np.nan), cat("relative_error", np.nan),
        cat("captured", np.nan), parts[0].axis, parts[0].formulation)  # fmt: skip


def _colour(label: str, colours: dict) -> str:
    """The colour of the reduced branch ``label`` (or of its base name before " #"); grey."""
    return colours.get(label) or colours.get(label.split(" #")[0]) or "0.5"


def draw_markers(ax, m: FullOrderMarkers, colours: dict, scale: float = 1.0) -> None:
    """Markers of the full-order roots on ``ax``: spin and frequency times ``scale`` (1: rad/s,
    1/2π: Hz); a matched root in its branch's colour (``colours``: label → colour), an
    unclaimed root hollow grey. One legend entry for each kind present."""
    done = set()
    for i in range(m.count):
        for j in range(m.frequency.shape[1]):
            if not np.isfinite(m.frequency[i, j]):
                continue
            ok = bool(m.matched[i, j])
            name = "full order (matched)" if ok else "full order (no reduced branch)"
            colour = _colour(str(m.label[i, j]), colours) if ok else "0.5"
            ax.plot(scale * m.spin[i], scale * m.frequency[i, j], "D", ms=6, mec="k", mew=0.8,
                    mfc=colour if ok else "none", zorder=1.5,
                    label=None if name in done else name)  # fmt: skip
            done.add(name)


def markers_from_dataset(ds) -> FullOrderMarkers:
    """The :class:`FullOrderMarkers` stored in a dataset by :func:`marker_variables`."""
    axis = [float(v) for v in str(ds.attrs.get("full_order_axis", "0,0,1")).split(",")]
    return FullOrderMarkers(
        np.asarray(ds[SPIN_DIM].values, float), np.asarray(ds["full_order_frequency"].values),
        np.asarray(ds["full_order_growth_rate"].values),
        np.asarray(ds["full_order_branch_label"].values, dtype=str),
        np.asarray(ds["full_order_matched"].values) > 0,
        np.asarray(ds["full_order_reduced_frequency"].values),
        np.asarray(ds["full_order_relative_error"].values),
        np.asarray(ds["full_order_captured"].values), np.asarray(axis),
        str(ds.attrs.get("full_order_formulation", "")))  # fmt: skip


def relabel(m: FullOrderMarkers, spin: np.ndarray, frequency: np.ndarray, labels,
            rtol: float = 0.01) -> FullOrderMarkers:  # fmt: skip
    """``m`` with each matched root labelled by the branch of a Campbell diagram (``spin`` (ns,)
    rad/s, ``frequency`` (ns, nb) rad/s, ``labels`` (nb,)) whose frequency, interpolated to the
    marker's spin, is nearest to the matched reduced frequency (within ``rtol``; else the label
    is kept): the branch names of the figure instead of those of the comparison's own tracking."""
    spin, frequency = np.asarray(spin, float), np.asarray(frequency, float)
    label = np.array(m.label, dtype=object)
    for i, om in enumerate(m.spin):
        at = np.full(len(labels), np.nan)
        for b in range(len(labels)):
            ok = np.isfinite(frequency[:, b])
            if ok.any() and spin[ok].min() - 1e-9 <= om <= spin[ok].max() + 1e-9:
                at[b] = np.interp(om, spin[ok], frequency[ok, b])
        for j in np.flatnonzero(m.matched[i]):
            target = m.reduced_frequency[i, j]
            if not np.isfinite(target) or not np.isfinite(at).any():
                continue
            b = int(np.nanargmin(np.abs(at - target)))
            if abs(at[b] - target) <= rtol * max(abs(target), 1e-9):
                label[i, j] = labels[b]
    return FullOrderMarkers(m.spin, m.frequency, m.growth, label.astype(str), m.matched,
                            m.reduced_frequency, m.relative_error, m.captured, m.axis,
                            m.formulation)  # fmt: skip
