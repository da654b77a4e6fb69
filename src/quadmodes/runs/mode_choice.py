"""Which elastic modes a run keeps: a fixed number (``reduced.modes = N``) or the modes the spin
can couple to (``reduced.modes = "auto"``), and the larger pair-whole counts that
``run --mode-convergence`` compares with.

Stages::

    RunCase ──resolve_modes──▶ (RunCase with a whole number of modes, ModeChoice)
    Spectrum (frequencies, labels) ──auto_mode_count──▶ N (pure)
    Spectrum, N ──pair_whole_counts──▶ [N₁, N₂, …] > N (pure)

The rule of ``"auto"``: every elastic mode whose non-spinning frequency is at most
``mode_margin`` × the initial spin frequency (``reduced.mode_margin``, default 2.5: the centrifugal load, quadratic in ω, forces a coning
body up to about twice the spin frequency), then the
cut moved up until no degenerate pair is split (the pair test of
:func:`quadmodes.models.build.splits_pair`), and never below the first bending pair
(:func:`quadmodes.runs.initial.bending_pair`). About the spinning state (``reference =
"spinning"``) the frequencies are those of the rotating-frame stiffness's own modes, the default
margin is 3.2 and the cutoff is at least :data:`SPINNING_FLOOR` × the lowest of them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from quadmodes.case import Case, CaseError, RunCase
from quadmodes.models.build import Spectrum, mode_spectrum, splits_pair
from quadmodes.runs.initial import bending_pair

Progress = Callable[[str, float], None]

#: About the spinning state the ``"auto"`` cutoff is at least this many times the lowest mode of
#: the rotating-frame stiffness: at low spin the coning load drives every mode quasi-statically,
#: and the 10 Hz case (cutoff 32 Hz: 5 modes) dissipates × 0.874 of the full order's power, with
#: the modes up to 2 × 31 Hz (8) × 0.998.
SPINNING_FLOOR = 2.0
#: ``"auto"`` gives up (one-line error) if more modes than this lie below the cutoff.
MAX_AUTO_MODES = 160


@dataclass(frozen=True)
class ModeChoice:
    """The modes of a run: ``n_modes``; ``requested`` ("auto" or the whole number asked for);
    ``rule`` (one line for the summary). With "auto": ``margin`` (1), ``spin_hz`` (Hz),
    ``cutoff_hz`` = margin × spin (Hz), ``below_cutoff`` (modes at or below it) and
    ``next_hz`` (the first mode left out, Hz; None if unknown)."""

    n_modes: int
    requested: int | str
    rule: str
    margin: float | None = None
    spin_hz: float | None = None
    cutoff_hz: float | None = None
    below_cutoff: int | None = None
    next_hz: float | None = None

    def summary(self) -> dict:
        """JSON-ready fields (None values left out)."""
        keys = ("n_modes", "requested", "rule", "margin", "spin_hz", "cutoff_hz",
                "below_cutoff", "next_hz")  # fmt: skip
        return {k: getattr(self, k) for k in keys if getattr(self, k) is not None}


def pair_whole_counts(
    labels: Sequence[str], freqs_hz: Sequence[float], above: int, count: int
) -> list[int]:
    """The first ``count`` mode counts N > ``above`` that keep every degenerate pair whole,
    among the modes known (N < len(freqs_hz): one mode beyond the cut must be known to test
    it); fewer if the spectrum ends."""
    found: list[int] = []
    for n in range(int(above) + 1, len(freqs_hz)):
        if len(found) == count:
            break
        if not splits_pair(labels, freqs_hz, n):
            found.append(n)
    return found


def next_counts(
    case: Case, n_modes: int, steps: int, progress: Progress | None = None
) -> list[int]:
    """The next ``steps`` pair-whole mode counts above ``n_modes`` of ``case``
    (:func:`pair_whole_counts` on its cached spectrum, lengthened as needed up to
    :data:`MAX_AUTO_MODES`); fewer only if the model has no more modes."""
    count = max(case.modes.count, int(n_modes) + steps + 1)
    while True:
        spec = mode_spectrum(case, count, progress)
        found = pair_whole_counts(spec.labels, spec.frequencies_hz, n_modes, steps)
        if len(found) == steps or len(spec.frequencies_hz) < count or count > MAX_AUTO_MODES:
            return found
        count = 2 * count


def auto_mode_count(
    labels: Sequence[str], freqs_hz: Sequence[float], cutoff_hz: float
) -> tuple[int | None, int]:
    """``(N, below)`` of the ``"auto"`` rule: ``below`` modes have f ≤ ``cutoff_hz``; N ≥ below
    also takes the first bending pair and the partner of a pair cut at N (at least 1). N is None
    if the spectrum ends before the cut can be tested (more modes are needed)."""
    freqs = [float(f) for f in freqs_hz]
    below = sum(1 for f in freqs if f <= cutoff_hz)
    n = max(below, 1)
    pair = bending_pair(labels, freqs)
    if pair:
        n = max(n, max(pair) + 1)
    while n < len(freqs) and splits_pair(labels, freqs, n):
        n += 1
    return (n if n < len(freqs) else None), below


def covering_spectrum(
    case: Case, cutoff_hz: float, progress: Progress | None = None, spin: float = 0.0,
    axis: str | None = None,
) -> tuple[Spectrum, int, int]:  # fmt: skip
    """Spectrum of ``case`` long enough for the ``"auto"`` rule at ``cutoff_hz`` and its
    ``(spectrum, N, below)``; the mode count doubles until a mode above the cut is known.
    Raises :class:`CaseError` (``reduced.modes``) beyond :data:`MAX_AUTO_MODES`."""
    count = case.modes.count
    while True:
        spec = mode_spectrum(case, count, progress, spin=spin, axis=axis)
        n, below = auto_mode_count(spec.labels, spec.frequencies_hz, cutoff_hz)
        if n is not None:
            return spec, n, below
        if count > MAX_AUTO_MODES:
            raise CaseError(
                f'reduced.modes = "auto": more than {MAX_AUTO_MODES} modes lie below '
                f"{cutoff_hz:.4g} Hz; lower reduced.mode_margin or give a whole number",
                field="reduced.modes",
            )
        count = 2 * count


def with_modes(run: RunCase, n_modes: int) -> RunCase:
    """``run`` with ``reduced.modes = n_modes`` (and no ``mode_margin``)."""
    reduced = run.reduced.model_copy(update={"modes": int(n_modes), "mode_margin": None})
    return run.model_copy(update={"reduced": reduced})


def resolve_modes(
    run: RunCase, model_case: Case | None = None, progress: Progress | None = None
) -> tuple[RunCase, ModeChoice]:
    """``run`` with a whole number of modes and the :class:`ModeChoice` that gave it. A whole
    ``reduced.modes`` is kept as it is; ``"auto"`` reads the spectrum of the model (cached)."""
    requested = run.reduced.modes
    if requested != "auto":
        rule = f"reduced.modes = {requested}: the lowest {requested} elastic modes"
        return run, ModeChoice(int(requested), int(requested), rule)
    if run.initial is None:
        raise CaseError('reduced.modes = "auto": needs [initial] spin_rate', field="reduced.modes")
    case = model_case if model_case is not None else run.model_case()
    margin = run.reduced.margin
    spin_hz = float(run.initial.spin_rate) / (2.0 * math.pi)
    cutoff = margin * spin_hz
    spin = run.reference_spin
    floor = ""
    if spin:  # about the spinning state: never below twice its lowest mode (see the module)
        lowest = mode_spectrum(case, case.modes.count, progress, spin=spin,
                               axis=run.reference_axis)  # fmt: skip
        f_low = float(lowest.frequencies_hz[0]) if lowest.frequencies_hz else 0.0
        if SPINNING_FLOOR * f_low > cutoff:
            cutoff = SPINNING_FLOOR * f_low
            floor = f" (raised to {SPINNING_FLOOR:g} × the lowest mode, {f_low:.4g} Hz)"
    spec, n, below = covering_spectrum(case, cutoff, progress, spin, run.reference_axis)
    extra = n - below
    kind = "mode of the rotating-frame stiffness" if spin else "elastic mode"
    rule = (
        f'reduced.modes = "auto": every {kind} with f ≤ {margin:g} × {spin_hz:.4g} Hz '
        f"(spin){floor} = {cutoff:.4g} Hz: {below} modes"
        + (f", {extra} more for a whole pair / the first bending pair" if extra else "")
        + f", next mode at {spec.frequencies_hz[n]:.4g} Hz: N = {n}"
    )
    choice = ModeChoice(n, "auto", rule, margin, spin_hz, cutoff, below, spec.frequencies_hz[n])
    return with_modes(run, n), choice
