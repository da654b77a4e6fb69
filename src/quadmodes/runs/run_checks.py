"""Checks of a free-body run before it integrates: the reduced model given is the run's
(:func:`check_model_case`), and the time step against the fastest motion it has to resolve: the spin
(period 1/f_spin) and the highest retained mode (1/f_max, Hz).

The implicit midpoint rule is stable at any step, so a step longer than these periods still
"completes" — with the spin aliased and the modes' dissipation wrong by orders of magnitude
(``--dt "0.2 s"`` at 41 Hz is 8 turns a step). Fewer than :data:`STEPS_PER_PERIOD_WARN` steps
per period of the fastest motion is noted with the run (in its notes and the results); fewer
than :data:`STEPS_PER_PERIOD_MIN` is refused (:class:`~quadmodes.case.CaseError` naming
``integration.dt``) unless asked for (``--yes``, ``allow_coarse_step``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from quadmodes.case import Case, CaseError

#: Fewer steps than this per period of the spin or of the highest retained mode: a note.
STEPS_PER_PERIOD_WARN = 10.0
#: Fewer steps than this (the Nyquist limit): refused unless asked for.
STEPS_PER_PERIOD_MIN = 2.0


def fastest_motion(spin_rate: float, frequencies_hz: Sequence[float] = ()) -> tuple[float, str]:
    """(frequency Hz, what) of the fastest motion: the spin (``spin_rate`` rad/s) or the
    highest of ``frequencies_hz`` (the retained modes)."""
    spin_hz = abs(float(spin_rate)) / (2 * math.pi)
    top = max((abs(float(f)) for f in frequencies_hz), default=0.0)
    if top > spin_hz:
        return top, f"the highest retained mode ({top:.4g} Hz)"
    return spin_hz, f"the spin ({spin_hz:.4g} Hz)"


def check_time_step(dt: float, spin_rate: float, frequencies_hz: Sequence[float] = (), *,
                    allow_coarse: bool = False) -> str | None:  # fmt: skip
    """A note (None if the step resolves the fastest motion) for a step ``dt`` (s) against the
    spin ``spin_rate`` (rad/s) and the retained modes ``frequencies_hz``; raises
    :class:`CaseError` (``integration.dt``) below :data:`STEPS_PER_PERIOD_MIN` steps a period
    unless ``allow_coarse``."""
    f, what = fastest_motion(spin_rate, frequencies_hz)
    if not (f > 0 and dt > 0):
        return None
    per_period = 1.0 / (f * dt)
    if per_period >= STEPS_PER_PERIOD_WARN:
        return None
    suggested = 1.0 / (f * 20.0)
    text = (f"integration.dt = {dt:.4g} s is {per_period:.3g} steps per period of {what}; the "
            f"results are not resolved (at least {STEPS_PER_PERIOD_WARN:g} steps a period are "
            f"needed, e.g. --dt \"{suggested * 1e3:.2g} ms\")")  # fmt: skip
    if per_period < STEPS_PER_PERIOD_MIN and not allow_coarse:
        raise CaseError(text + ", or pass --yes to run it anyway", field="integration.dt")
    return text


def check_run_step(run, frequencies_hz: Sequence[float] = (), *,
                   allow_coarse: bool = False) -> str | None:  # fmt: skip
    """:func:`check_time_step` of the free-body run case ``run`` (its initial spin and step);
    None for a spin-up (its step follows the hub's own schedule)."""
    if getattr(run, "spinup", None) is not None:
        return None
    return check_time_step(run.integration.dt, run.initial.spin_rate, frequencies_hz,
                           allow_coarse=allow_coarse)  # fmt: skip


def check_model_case(model, model_case: Case) -> None:
    """Raise :class:`CaseError` (field ``model``) if the reduced ``model`` records the case it was built
    from (provenance ``case_toml``) and that is not ``model_case`` (a model without
    provenance is taken as given)."""
    from quadmodes.runs.run_checkpoint import differing_settings

    built_from = model.provenance.get("case_toml")
    if not built_from or built_from == model_case.to_toml():
        return
    differ = differing_settings(built_from, model_case.to_toml())
    raise CaseError(
        f'model: the reduced model given was built from case "{model.provenance.get("case")}", '
        f'not the run\'s model case "{model_case.name}" (they differ in '
        f"{', '.join(differ[:3]) or 'their text'}); pass the run's own model, or model_case= "
        "the case the model was built from",
        field="model",
    )
