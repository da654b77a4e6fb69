"""The tables of a run case: ``[reduced]`` (which reduced model), ``[initial]`` (initial
conditions) and ``[integration]`` (time stepping) for a free-body run, or ``[spinup]`` for a
hub-driven spin-up of a clamped beam.

Quantities are stored in SI units: rad/s, rad, m, s.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Self

from pydantic import BeforeValidator, model_validator

from quadmodes.case.fields import (
    FieldMeta,
    Section,
    choice,
    field_error,
    integer,
    nonnegative,
    positive,
    quantity,
    whole_number,
)
from quadmodes.case.run_events import until_field
from quadmodes.case.units import format_quantity


def _cone(theta: float) -> str | None:
    """0 deg ≤ value < 90 deg"""
    return None if 0.0 <= theta < 0.5 * math.pi else "must satisfy 0 deg <= cone_angle < 90 deg"


def _rtol(x: float) -> str | None:
    """0 < value < 1"""
    return None if 0.0 < x < 1.0 else "must satisfy 0 < value < 1"


#: Default of ``reduced.mode_margin``: with ``modes = "auto"`` every elastic mode up to 2.5 times
#: the spin frequency is kept. The centrifugal load is quadratic in ω, so a coning body is forced
#: up to about twice the spin frequency; with 1.5, paper-41hz-coarse leaves out its axial mode
#: at 84.9 Hz (2.07 × spin), which changes the 120 s dissipated energy by 33 %; with 2.5 the
#: next larger basis changes it by 0.16 % (docs/paper-cases.md, "Mode convergence").
DEFAULT_MODE_MARGIN = 2.5
#: The same about the spinning state (``reference = "spinning"``), on the rotating-frame
#: stiffness's own modes: 3.2. The 41 Hz coning needs the second bending pair at 3.05 × the spin
#: (× 0.958 → × 0.975 of the full order's dissipated power, docs/full-order.md), 20 Hz the
#: front-mass rocking pair at 2.98 ×; both meshes of the paper model then keep 16 modes at 41 Hz.
DEFAULT_SPINNING_MODE_MARGIN = 3.2


def _modes(value: Any) -> int | str:
    """``reduced.modes``: a whole number of modes (at least 1) or ``"auto"``."""
    if isinstance(value, str) and value.strip().lower() == "auto":
        return "auto"
    value = whole_number(value)
    if value is None:
        raise field_error("case_value", 'must be a whole number of modes or "auto"; use e.g. 5')
    if value < 1:
        raise field_error("case_value", 'must be at least 1 (or "auto"); use e.g. 5')
    return value


def _margin(x: float) -> str | None:
    """≥ 1"""
    return None if x >= 1.0 else "must be at least 1 (modes up to mode_margin × spin frequency)"


def _switch(x: float) -> str | None:
    """in (0, 0.05]"""
    return None if 0.0 < x <= 0.05 else "must be in (0, 0.05] (a fraction of the spin, e.g. 0.0075)"


def _path_tolerance(x: float) -> str | None:
    """in (0, 0.02]"""
    return None if 0.0 < x <= 0.02 else "must be in (0, 0.02] (a fraction of the coning rate, e.g. 0.01)"


class RunReduced(Section):
    """Reduced model of a run: the lowest ``modes`` elastic modes of the model and the
    formulation of the equations ("Q" quadratic modes, "P" the seed's printed equations, "L"
    linear modes, "rigid" no elastic modes, "Q4" quadratic modes with the quartic manifold
    potential, "QM" the exact kinetic energy of the quadratic manifold with Q4's potential and
    the damping on the manifold velocity: docs/manifold-formulation.md; numpy midpoint only).

    ``modes = "auto"`` keeps every elastic mode whose (non-spinning) frequency is at most
    ``mode_margin`` × the initial spin frequency (default :data:`DEFAULT_MODE_MARGIN` = 2.5; about
    the spinning state the modes of its rotating-frame stiffness, default
    :data:`DEFAULT_SPINNING_MODE_MARGIN` = 3.2),
    degenerate pairs whole and at least the first bending pair
    (:func:`quadmodes.runs.mode_choice.auto_mode_count`); ``mode_margin`` is only read with
    ``"auto"`` (dimensionless).

    ``reference``: the state the model is expanded about. ``"rest"``: the prestressed (inflated)
    state at rest, as the seed does. ``"spinning"``: the finite-element model's own centrifugal
    relative equilibrium at the initial spin rate about ``initial.spin_axis`` (default the minor
    principal axis; a flat membrane: its normal), with the modes
    of its rotating-frame stiffness and the modal damping projected from the modes at rest
    (:mod:`quadmodes.rom.spinning_reduction`); the steady centrifugal stretch is then in the
    reference instead of in the modal coordinates.

    ``path_model``: ``"fixed"`` (default) integrates the whole path with the one model;
    ``"spin-family"`` (with ``reference = "spinning"``) integrates it by the models about the
    spins of a grid ``path_switch`` apart (a fraction, default 0.0075), switching to the one
    nearest the path's spin as it changes (:mod:`quadmodes.runs.spin_family`);
    ``path_tolerance`` instead chooses the members adaptively: each is used over the spins where
    its energy-sink coning rate is within that fraction of the rate of a member about the
    path's spin, measured between neighbours (:mod:`quadmodes.runs.family_spacing`)."""

    modes: Annotated[int | Literal["auto"], BeforeValidator(_modes),
                     FieldMeta("5", allowed='whole number ≥ 1, or "auto"')] = 5  # fmt: skip
    formulation: choice("Q", "P", "L", "rigid", "Q4", "QM") = "Q"
    mode_margin: quantity("dimensionless", "2.5", _margin, optional=True) = None
    reference: choice("rest", "spinning") = "rest"
    path_model: choice("fixed", "spin-family") = "fixed"
    path_switch: quantity("dimensionless", "0.0075", _switch, optional=True) = None
    path_tolerance: quantity("dimensionless", "0.01", _path_tolerance, optional=True) = None

    @model_validator(mode="after")
    def check_margin(self) -> Self:
        if self.mode_margin is not None and self.modes != "auto":
            raise field_error(
                "case_rule",
                f'is used only with modes = "auto" (modes = {self.modes}); remove it or set '
                'modes = "auto"',
                "mode_margin",
            )
        return self

    @model_validator(mode="after")
    def check_path_model(self) -> Self:
        if self.path_model == "spin-family" and (self.reference != "spinning"
                                                 or self.formulation not in ("Q", "P", "L", "QM")):  # fmt: skip
            raise field_error(
                "case_rule",
                'needs reference = "spinning" and formulation Q, P, L or QM (the members are '
                'expanded about spinning states); set them, or path_model = "fixed"',
                "path_model",
            )
        for name in ("path_switch", "path_tolerance"):
            if getattr(self, name) is not None and self.path_model != "spin-family":
                raise field_error(
                    "case_rule",
                    'is used only with path_model = "spin-family"; remove it or set that',
                    name,
                )
        if self.path_switch is not None and self.path_tolerance is not None:
            raise field_error(
                "case_rule",
                "sets the members' spacing that path_tolerance chooses adaptively; set one",
                "path_switch",
            )
        return self

    @property
    def margin(self) -> float:
        """``mode_margin``, or when not given :data:`DEFAULT_MODE_MARGIN` (about the state at
        rest) / :data:`DEFAULT_SPINNING_MODE_MARGIN` (about the spinning state)."""
        if self.mode_margin is not None:
            return float(self.mode_margin)
        return DEFAULT_SPINNING_MODE_MARGIN if self.reference == "spinning" else DEFAULT_MODE_MARGIN


#: Names ``initial.spin_axis`` accepts (body axes, principal axes of the deformed inertia).
SPIN_AXIS_NAMES = ("x", "y", "z", "minor", "intermediate", "major")


def _spin_axis(value: Any) -> str | None:
    """``initial.spin_axis``: a name of :data:`SPIN_AXIS_NAMES` or three numbers (a TOML array
    or ``"0,0,1"``), stored as text (lower-case name or ``"a,b,c"``)."""
    if value is None:
        return None
    use = 'use "minor", "major", "x", "y", "z" or three numbers such as [0, 0, 1]'
    if isinstance(value, str) and value.strip().lower() in SPIN_AXIS_NAMES:
        return value.strip().lower()
    parts = value.replace(";", ",").split(",") if isinstance(value, str) else value
    try:
        nums = [float(v) for v in parts] if not isinstance(parts, bool) else []
    except (TypeError, ValueError):
        nums = []
    if len(nums) != 3 or not all(math.isfinite(v) for v in nums) or not any(nums):
        raise field_error("case_value", f"{value!r} is not an axis; {use}")
    return ",".join(repr(v) for v in nums)


class RunInitial(Section):
    """Initial state: spin rate (rad/s) about the minor principal axis of the (deformed)
    inertia, cone angle (rad) between the angular momentum and that axis, and an initial
    deformation in the first bending mode whose largest nodal displacement is
    ``bending_amplitude`` (m; 0 = undeformed). Modal velocities start at zero.

    ``spin_axis`` (optional, default the minor axis): the body-frame axis to spin about instead,
    "x", "y", "z", "minor", "intermediate", "major" or three numbers; it must be a principal
    axis of the deformed inertia (for equal moments exactly the axis given,
    :mod:`quadmodes.rom.spin_axis`)."""

    spin_rate: quantity("angular_rate", "41 Hz", positive)
    cone_angle: quantity("angle", "6 deg", _cone, "deg") = 0.0
    bending_amplitude: quantity("length", "0.5 in", nonnegative, "in") = 0.0
    spin_axis: Annotated[str | None, BeforeValidator(_spin_axis), FieldMeta('"minor"')] = None


class RunIntegration(Section):
    """Time integration: method, step ``dt`` (s; the sampling step for "adaptive"), duration
    (s), keep every ``save_every``-th step, relative tolerance ``rtol`` ("adaptive" only);
    ``until`` (optional): an event that ends the run before its duration, e.g. "cone 60 deg"
    (:mod:`quadmodes.case.run_events`); ``step_tolerance`` (optional, "midpoint" only): a step
    controlled between chunks to this relative error estimate, ``dt`` the first step
    (:mod:`quadmodes.rom.step_control`)."""

    method: choice("midpoint", "backward-euler", "adaptive") = "midpoint"
    dt: quantity("time", "0.5 ms", positive, "ms")
    duration: quantity("time", "4 s", positive, "s")
    save_every: integer(4, 1) = 1
    rtol: quantity("dimensionless", "1e-9", _rtol) = 1e-9
    until: Annotated[str | None, BeforeValidator(until_field), FieldMeta('"cone 60 deg"')] = None
    step_tolerance: quantity("dimensionless", "1e-3", _rtol, optional=True) = None

    @model_validator(mode="after")
    def check_span(self) -> Self:
        if self.step_tolerance is not None and self.method != "midpoint":
            raise field_error(
                "case_rule",
                f'a controlled step needs method "midpoint", not "{self.method}"; drop '
                "step_tolerance or use the midpoint",
                "step_tolerance",
            )
        if self.dt > self.duration:
            raise field_error(
                "case_rule",
                f"{format_quantity(self.dt, 'ms')} is longer than the duration "
                f"{format_quantity(self.duration, 's')}; use a smaller dt",
                "dt",
            )
        return self

    @property
    def n_steps(self) -> int:
        """Number of (fixed) steps: ``ceil(duration / dt)``."""
        return max(1, math.ceil(self.duration / self.dt - 1e-9))


class RunSpinup(Section):
    """Hub-driven spin-up of a clamped beam (Kane, Ryan & Banerjee): the hub rate rises
    smoothly from 0 to ``omega_s`` (rad/s) in ``ramp_time`` (s) and is held until ``duration``
    (s); integrated with scipy's DOP853 (relative tolerance ``rtol``) by
    :func:`quadmodes.runs.spinup.kane_spinup`. Replaces ``[initial]`` and ``[integration]``.

    ``omega_0`` > 0 (rad/s): a spin change of a free body on a hub (a model case with a
    ``[hub]``, e.g. heliogyro blades) from ``omega_0`` to ``omega_s`` by a torque on the hub,
    its reduced model expanded about the spinning state at ``omega_0`` (``reduced.reference =
    "spinning"``; :mod:`quadmodes.runs.spin_change`)."""

    omega_0: quantity("angular_rate", "1 rad/s", nonnegative, "rad/s") = 0.0
    omega_s: quantity("angular_rate", "6 rad/s", positive, "rad/s")
    ramp_time: quantity("time", "15 s", positive, "s") = 15.0
    duration: quantity("time", "30 s", positive, "s") = 30.0
    rtol: quantity("dimensionless", "1e-9", _rtol) = 1e-9
    samples: integer(3001, 2) = 3001
