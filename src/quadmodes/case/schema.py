"""Case files: validated, frozen pydantic models read from TOML.

Dimensional values are written in TOML as quantity strings ("0.3 psi", "60 in") and stored
in the models as SI floats (m, kg, Pa, kg/m^3, kg m^2, m^2, m^4). :func:`case_to_toml` writes a
case back in SI units with the original-style units as comments; the text loads back to an
equal case. Every problem is reported as a :class:`CaseError` with a one-line message that
names the field path and the fix.
"""

import difflib
import functools
import json
import math
import os
import re
import tomllib
import typing
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal, Self

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from quadmodes.case.units import QuantityError, format_quantity, parse_quantity, si_unit

__all__ = [
    "Beam",
    "Case",
    "CaseError",
    "EndBody",
    "Geometry",
    "Material",
    "Mesh",
    "Modes",
    "Pressure",
    "RunCase",
    "RunSpinup",
    "RunInitial",
    "RunIntegration",
    "RunReduced",
    "builtin_case_names",
    "builtin_run_case_names",
    "builtin_case_text",
    "case_from_dict",
    "case_from_toml",
    "case_to_toml",
    "load_case",
    "load_run_case",
    "run_case_from_dict",
    "run_case_from_toml",
]


class CaseError(ValueError):
    """An invalid case: ``str(exc)`` is one line naming the source, field path and fix."""

    def __init__(self, message: str, *, source: str | None = None, field: str | None = None):
        self.source = source
        self.field = field
        self.detail = message
        super().__init__(f"{source}: {message}" if source else message)


# --------------------------------------------------------------------------------------------
# field helpers


@dataclass(frozen=True)
class _Meta:
    """Per-field metadata: TOML example, unit dimension (None if not a quantity), display unit."""

    example: str
    dimension: str | None = None
    display: str | None = None


def _toml_value(value: object) -> str:
    """A scalar as TOML source text (also used to echo inputs in error messages)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    return str(value)


def _error(kind: str, detail: str, sub: str | None = None) -> PydanticCustomError:
    ctx: dict[str, Any] = {"detail": detail}
    if sub is not None:
        ctx["sub"] = sub
    return PydanticCustomError(kind, "{detail}", ctx)


_Check = Callable[[float], str | None]


def _positive(x: float) -> str | None:
    return None if x > 0 else "must be positive"


def _nonnegative(x: float) -> str | None:
    return None if x >= 0 else "must not be negative"


def _ratio(x: float) -> str | None:
    return None if 0 <= x < 1 else "must satisfy 0 <= ratio < 1"


def _poisson(nu: float) -> str | None:
    if nu >= 0.5:
        return "must be below 0.5 for an isotropic membrane"
    if nu <= -1:
        return "must be above -1 for an isotropic membrane"
    return None


def _quantity(
    dimension: str,
    example: str,
    check: _Check | None = None,
    display: str | None = None,
    optional: bool = False,
) -> Any:
    """Annotated float field read from a quantity string and stored in SI."""
    dimensionless = dimension == "dimensionless"
    shown = example if dimensionless else f'"{example}"'

    def validate(value: Any, info: ValidationInfo) -> float | None:
        if value is None and optional:
            return None
        try:
            si = parse_quantity(value, dimension, info.field_name or "", example)
        except QuantityError as exc:
            raise _error("quantity", exc.detail) from None
        problem = check(si) if check else None
        if problem:
            raise _error("case_value", f"{problem}; use e.g. {shown}")
        return si

    meta = _Meta(shown, dimension, display)
    if optional:
        return Annotated[float | None, BeforeValidator(validate), meta]
    return Annotated[float, BeforeValidator(validate), meta]


def _integer(example: int, minimum: int) -> Any:
    """Annotated whole-number field (no booleans, no fractions)."""

    def validate(value: Any) -> int:
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise _error("case_value", f"must be a whole number; use e.g. {example}")
        if value < minimum:
            raise _error("case_value", f"must be at least {minimum}; use e.g. {example}")
        return value

    return Annotated[int, BeforeValidator(validate), _Meta(str(example))]


def _text(example: str) -> Any:
    return Annotated[str, _Meta(_toml_value(example))]


def _choice(*options: str) -> Any:
    return Annotated[Literal[options], _Meta(_toml_value(options[0]))]  # type: ignore[valid-type]


class _Section(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


# --------------------------------------------------------------------------------------------
# sections

_CAP_FIELDS = ("length", "front_cap_diameter", "rear_cap_diameter", "diameter", "file")
_SHAPE_FIELDS: dict[str, tuple[str, ...]] = {
    "sphere-cone": ("length", "front_cap_diameter", "rear_cap_diameter"),
    "sphere": ("diameter",),
    "capsule": ("length", "diameter"),
    "flat-cylinder": ("length", "diameter"),
    "file": ("file",),
}


class Geometry(_Section):
    """Membrane surface of revolution about the x axis; lengths in m.

    ``length`` is the overall pole-to-pole length. A sphere-cone is two spherical caps joined
    by a tangent cone; a capsule is a cylinder with hemispherical ends; a flat-cylinder has
    flat end discs; ``file`` is a mesh file (relative paths are taken from the case file).
    """

    shape: _choice("sphere-cone", "sphere", "capsule", "flat-cylinder", "file")
    length: _quantity("length", "60 in", _positive, "in", optional=True) = None
    front_cap_diameter: _quantity("length", "5 in", _positive, "in", optional=True) = None
    rear_cap_diameter: _quantity("length", "20 in", _positive, "in", optional=True) = None
    diameter: _quantity("length", "20 in", _positive, "in", optional=True) = None
    file: Annotated[str | None, _Meta('"body.vtu"')] = None

    @field_validator("file")
    @classmethod
    def resolve_file(cls, value: str | None, info: ValidationInfo) -> str | None:
        if value is None:
            return None
        if not value.strip():
            raise _error("case_value", 'must name a mesh file; use e.g. "body.vtu"')
        base = (info.context or {}).get("base_dir")
        path = Path(value).expanduser()
        if base is not None and not path.is_absolute():
            path = Path(base) / path
        return str(path) if base is not None else value

    @model_validator(mode="after")
    def check_shape(self) -> Self:
        needed = _SHAPE_FIELDS[self.shape]
        for name in _CAP_FIELDS:
            given = getattr(self, name) is not None
            if name in needed and not given:
                example = _field_meta(Geometry, name).example
                raise _error(
                    "case_rule",
                    f'missing; shape = "{self.shape}" needs it, e.g. {name} = {example}',
                    name,
                )
            if given and name not in needed:
                raise _error(
                    "case_rule",
                    f'not used for shape = "{self.shape}"; remove it '
                    f'(shape "{self.shape}" takes {", ".join(needed)})',
                    name,
                )
        if self.shape == "sphere-cone":
            assert self.length and self.front_cap_diameter and self.rear_cap_diameter
            widest = max(self.front_cap_diameter, self.rear_cap_diameter)
            if self.length <= widest:
                raise _error(
                    "case_rule",
                    f"{_inch(self.length)} must exceed the larger cap diameter "
                    f"{_inch(widest)}; lengthen the body or shrink the caps",
                    "length",
                )
        if self.shape == "capsule":
            assert self.length and self.diameter
            if self.length <= self.diameter:
                raise _error(
                    "case_rule",
                    f"{_inch(self.length)} must exceed the diameter {_inch(self.diameter)}; "
                    'for a ball use shape = "sphere"',
                    "length",
                )
        return self

    def cap_radius(self, pole: str) -> float | None:
        """Radius (m) of the sphere or end disc at ``pole`` ("front"/"rear"); None for a file."""
        if self.shape == "file":
            return None
        if self.shape == "sphere-cone":
            cap = self.front_cap_diameter if pole == "front" else self.rear_cap_diameter
            return (cap or 0.0) / 2
        return (self.diameter or 0.0) / 2


def _inch(si: float) -> str:
    return format_quantity(si, "in")


class Mesh(_Section):
    """Triangulation settings: target edge length (m), optional grading (at least
    ``elements_per_radius`` edges per hoop radius of curvature, e.g. on a small cap; edges of
    ``attach_radius / elements_per_attach_radius`` at the rim of each end body's rigid patch,
    growing away from it), and the mass matrix kind."""

    edge_length: _quantity("length", "1 in", _positive, "in")
    elements_per_radius: _quantity(
        "dimensionless",
        "6",
        lambda v: None if v >= 1 else "must be at least 1",
        optional=True,
    ) = None
    elements_per_attach_radius: _quantity(
        "dimensionless",
        "8",
        lambda v: None if v >= 1 else "must be at least 1",
        optional=True,
    ) = None
    mass_matrix: _choice("consistent", "lumped") = "consistent"


class Material(_Section):
    """Isotropic membrane: density kg/m^3, Young's modulus Pa, thickness m, ratios plain."""

    density: _quantity("density", "0.0335 lb/in^3", _positive, "lb/in^3")
    youngs_modulus: _quantity("pressure", "0.05 Mpsi", _positive, "Mpsi")
    poisson_ratio: _quantity("dimensionless", "0.3", _poisson)
    thickness: _quantity("length", "0.0045 in", _positive, "in")
    damping_ratio: _quantity("dimensionless", "0.02", _ratio) = 0.0


class Pressure(_Section):
    """Inflation pressure (Pa, gauge) and polytropic gas-law exponent (0 = constant)."""

    value: _quantity(
        "pressure",
        "0.3 psi",
        lambda p: None if p > 0 else "must be positive for a membrane",
        "psi",
    )
    gas_law_exponent: _quantity("dimensionless", "0", _nonnegative) = 0.0


class EndBody(_Section):
    """Rigid body at a pole: mass kg, lengths m, inertias kg m^2 about its own centre.

    Its rotary inertia is given either directly (``inertia_axial``, ``inertia_transverse``) or as
    the shape of a uniform solid cylinder (``radius``, ``height``; axis along the body axis), in
    which case the inertias scale with the mass (the calibration fits masses with the shape
    fixed). Membrane nodes on that cap within ``attach_radius`` of the axis are tied to it; its
    centre of mass lies ``offset`` outside the pole on the axis; ``arm`` is the half-size of the
    point-mass cluster that carries the inertia (default: 1.25 × the smallest that works).
    """

    name: _text("rear")
    pole: _choice("front", "rear")
    mass: _quantity("mass", "0.1 kg", _positive, "kg")
    inertia_axial: _quantity("inertia", "1e-5 kg m^2", _nonnegative, "kg*m^2", optional=True) = None
    inertia_transverse: _quantity(
        "inertia", "1e-5 kg m^2", _nonnegative, "kg*m^2", optional=True
    ) = None
    radius: _quantity("length", "2 in", _positive, "in", optional=True) = None
    height: _quantity("length", "1 in", _nonnegative, "in", optional=True) = None
    attach_radius: _quantity("length", "1.5 in", _positive, "in")
    offset: _quantity("length", "0.5 in", _nonnegative, "in")
    arm: _quantity("length", "1 in", _positive, "in", optional=True) = None

    @field_validator("name")
    @classmethod
    def check_name(cls, value: str) -> str:
        if not value.strip():
            raise _error("case_value", 'must not be empty; use e.g. "rear"')
        return value

    @model_validator(mode="after")
    def check_inertia(self) -> Self:
        direct = (self.inertia_axial is not None, self.inertia_transverse is not None)
        shape = (self.radius is not None, self.height is not None)
        if any(direct) and any(shape):
            raise _error(
                "case_rule",
                "give either inertia_axial and inertia_transverse, or radius and height, not both",
                "radius" if shape[0] else "height",
            )
        if not (all(direct) or all(shape)):
            missing = "inertia_transverse" if direct[0] else "inertia_axial"
            if any(shape):
                missing = "height" if shape[0] else "radius"
            raise _error(
                "case_rule",
                "missing; give inertia_axial and inertia_transverse, or radius and height "
                '(a uniform solid cylinder), e.g. radius = "2 in"',
                missing,
            )
        return self

    def inertias(self) -> tuple[float, float]:
        """Axial and transverse moments of inertia (kg m²) about the body's own centre."""
        if self.radius is not None:
            r, h = self.radius, self.height or 0.0
            return 0.5 * self.mass * r * r, self.mass * (3.0 * r * r + h * h) / 12.0
        return self.inertia_axial, self.inertia_transverse

    def cluster_arm(self) -> float:
        """Half-size (m) of the point-mass cluster: ``arm`` or 1.25 × the smallest feasible."""
        if self.arm is not None:
            return self.arm
        i_ax, i_tr = self.inertias()
        return 1.25 * max((i_ax + 2.0 * i_tr) / (2.0 * self.mass), 1e-12) ** 0.5


class Beam(_Section):
    """Euler-Bernoulli beam along x: length m, area m^2, second moment m^4, E Pa, kg/m^3."""

    length: _quantity("length", "10 m", _positive, "m")
    elements: _integer(20, 1)
    area: _quantity("area", "4e-4 m^2", _positive, "m^2")
    second_moment: _quantity("second_moment", "2e-7 m^4", _positive, "m^4")
    youngs_modulus: _quantity("pressure", "7e10 Pa", _positive, "Pa")
    density: _quantity("density", "3000 kg/m^3", _positive, "kg/m^3")
    support: _choice("clamped", "free") = "clamped"
    damping_ratio: _quantity("dimensionless", "0.02", _ratio) = 0.0


class Modes(_Section):
    """Number of elastic modes to compute."""

    count: _integer(10, 1) = 10


_MEMBRANE_SECTIONS = ("geometry", "mesh", "material", "pressure")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


class Case(_Section):
    """A complete case. Membrane cases use geometry/mesh/material/pressure/end_body; beam
    cases use beam; the other sections are None (or empty)."""

    name: _text("my-case")
    description: _text("what this case is for") = ""
    kind: _choice("membrane", "beam")
    geometry: Geometry | None = None
    mesh: Mesh | None = None
    material: Material | None = None
    pressure: Pressure | None = None
    end_body: tuple[EndBody, ...] = ()
    beam: Beam | None = None
    modes: Modes = Field(default_factory=Modes)

    @field_validator("name")
    @classmethod
    def check_name(cls, value: str) -> str:
        if not _NAME.match(value):
            raise _error("case_value", 'use letters, digits, ".", "_" or "-" only; e.g. "my-case"')
        return value

    @model_validator(mode="after")
    def check_kind(self) -> Self:
        see = 'see "quadmodes show-case paper-membrane"'
        if self.kind == "membrane":
            for section in _MEMBRANE_SECTIONS:
                if getattr(self, section) is None:
                    raise _error(
                        "case_rule",
                        f'missing; kind = "membrane" needs a [{section}] table ({see})',
                        section,
                    )
            if self.beam is not None:
                raise _error(
                    "case_rule",
                    'not used when kind = "membrane"; remove the [beam] table or set kind = "beam"',
                    "beam",
                )
            self._check_end_bodies()
        else:
            if self.beam is None:
                raise _error(
                    "case_rule",
                    'missing; kind = "beam" needs a [beam] table '
                    '(see "quadmodes show-case kane-beam")',
                    "beam",
                )
            for section in (*_MEMBRANE_SECTIONS, "end_body"):
                if getattr(self, section):
                    table = "[[end_body]] tables" if section == "end_body" else f"[{section}] table"
                    raise _error(
                        "case_rule",
                        f'not used when kind = "beam"; remove the {table} or set kind = "membrane"',
                        section,
                    )
        return self

    def _check_end_bodies(self) -> None:
        names: set[str] = set()
        poles: dict[str, str] = {}
        for i, body in enumerate(self.end_body):
            if body.name in names:
                raise _error(
                    "case_rule",
                    f"{_toml_value(body.name)} is used twice; give each end body its own name",
                    f"end_body[{i}].name",
                )
            if body.pole in poles:
                raise _error(
                    "case_rule",
                    f"{_toml_value(body.pole)} already carries end body "
                    f"{_toml_value(poles[body.pole])}; use at most one end body per pole",
                    f"end_body[{i}].pole",
                )
            names.add(body.name)
            poles[body.pole] = body.name
            radius = self.geometry.cap_radius(body.pole) if self.geometry else None
            if radius is not None and body.attach_radius >= radius:
                raise _error(
                    "case_rule",
                    f"{_inch(body.attach_radius)} must be smaller than the {body.pole} cap "
                    f"radius {_inch(radius)}; use a smaller attach_radius",
                    f"end_body[{i}].attach_radius",
                )

    def to_toml(self) -> str:
        """This case as TOML text in SI units (see :func:`case_to_toml`)."""
        return case_to_toml(self)


# --------------------------------------------------------------------------------------------
# run cases: a model (built-in name or case file) + initial conditions + integration settings


def _cone(theta: float) -> str | None:
    return None if 0.0 <= theta < 0.5 * math.pi else "must satisfy 0 deg <= cone_angle < 90 deg"


def _rtol(x: float) -> str | None:
    return None if 0.0 < x < 1.0 else "must satisfy 0 < rtol < 1"


class RunReduced(_Section):
    """Reduced model of a run: the lowest ``modes`` elastic modes of the model and the
    formulation of the equations ("Q" quadratic modes, "P" the seed's printed equations, "L"
    linear modes, "rigid" no elastic modes, "Q4" quadratic modes with the quartic manifold
    potential)."""

    modes: _integer(5, 1) = 5
    formulation: _choice("Q", "P", "L", "rigid", "Q4") = "Q"


class RunInitial(_Section):
    """Initial state: spin rate (rad/s) about the minor principal axis of the (deformed)
    inertia, cone angle (rad) between the angular momentum and that axis, and an initial
    deformation in the first bending mode whose largest nodal displacement is
    ``bending_amplitude`` (m; 0 = undeformed). Modal velocities start at zero."""

    spin_rate: _quantity("angular_rate", "41 Hz", _positive)
    cone_angle: _quantity("angle", "6 deg", _cone, "deg") = 0.0
    bending_amplitude: _quantity("length", "0.5 in", _nonnegative, "in") = 0.0


class RunIntegration(_Section):
    """Time integration: method, step ``dt`` (s; the sampling step for "adaptive"), duration
    (s), keep every ``save_every``-th step, relative tolerance ``rtol`` ("adaptive" only)."""

    method: _choice("midpoint", "backward-euler", "adaptive") = "midpoint"
    dt: _quantity("time", "0.5 ms", _positive, "ms")
    duration: _quantity("time", "4 s", _positive, "s")
    save_every: _integer(4, 1) = 1
    rtol: _quantity("dimensionless", "1e-9", _rtol) = 1e-9

    @model_validator(mode="after")
    def check_span(self) -> Self:
        if self.dt > self.duration:
            raise _error(
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


class RunSpinup(_Section):
    """Hub-driven spin-up of a clamped beam (Kane, Ryan & Banerjee): the hub rate rises
    smoothly from 0 to ``omega_s`` (rad/s) in ``ramp_time`` (s) and is held until ``duration``
    (s); integrated with scipy's DOP853 (relative tolerance ``rtol``) by
    :func:`quadmodes.runs.spinup.kane_spinup`. Replaces ``[initial]`` and ``[integration]``."""

    omega_s: _quantity("angular_rate", "6 rad/s", _positive, "rad/s")
    ramp_time: _quantity("time", "15 s", _positive, "s") = 15.0
    duration: _quantity("time", "30 s", _positive, "s") = 30.0
    rtol: _quantity("dimensionless", "1e-9", _rtol) = 1e-9
    samples: _integer(3001, 2) = 3001


class RunCase(_Section):
    """A run: integrate a model's reduced equations from given initial conditions.

    ``model`` is a built-in case name or the path of a case file (relative paths are taken from
    the run-case file). A free-body run has ``[initial]`` and ``[integration]``; a hub-driven
    spin-up of a clamped beam has ``[spinup]`` instead."""

    name: _text("my-run")
    description: _text("what this run is for") = ""
    kind: _choice("run")
    model: Annotated[str, _Meta('"paper-membrane"')]
    reduced: RunReduced = Field(default_factory=RunReduced)
    initial: RunInitial | None = None
    integration: RunIntegration | None = None
    spinup: RunSpinup | None = None

    @model_validator(mode="after")
    def check_tables(self) -> Self:
        if self.spinup is not None:
            for table in ("initial", "integration"):
                if getattr(self, table) is not None:
                    raise _error(
                        "case_rule",
                        f"not used with [spinup] (hub-driven spin-up); remove the [{table}] "
                        "table or the [spinup] table",
                        table,
                    )
            return self
        for table in ("initial", "integration"):
            if getattr(self, table) is None:
                raise _error(
                    "case_rule",
                    "missing; a free-body run needs [initial] and [integration] tables "
                    "(or [spinup] for a hub-driven spin-up of a clamped beam)",
                    table,
                )
        return self

    @field_validator("name")
    @classmethod
    def check_name(cls, value: str) -> str:
        if not _NAME.match(value):
            raise _error("case_value", 'use letters, digits, ".", "_" or "-" only; e.g. "my-run"')
        return value

    @field_validator("model")
    @classmethod
    def resolve_model(cls, value: str, info: ValidationInfo) -> str:
        if not value.strip():
            raise _error("case_value", 'must name a model case; use e.g. "paper-membrane"')
        if value in builtin_case_names():
            return value
        base = (info.context or {}).get("base_dir")
        path = Path(value).expanduser()
        if base is not None and not path.is_absolute():
            return str(Path(base) / path)
        return value

    def model_case(self) -> Case:
        """The model (membrane or beam case); raises :class:`CaseError` naming ``model``."""
        try:
            return load_case(self.model)
        except CaseError as exc:
            raise CaseError(
                f"model = {_toml_value(self.model)}: {exc}", source=f"{self.name}", field="model"
            ) from None

    def to_toml(self) -> str:
        """This run case as TOML text in SI units (see :func:`run_case_to_toml`)."""
        return run_case_to_toml(self)


# --------------------------------------------------------------------------------------------
# error messages


def _unwrap_model(annotation: Any) -> type[BaseModel] | None:
    """The pydantic model inside an annotation such as ``Geometry | None`` or a tuple."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _unwrap_model(arg)
        if found is not None:
            return found
    return None


def _walk(
    loc: list[Any], root: type[BaseModel] | None = None
) -> tuple[type[BaseModel] | None, str | None]:
    """(model owning the last key of ``loc``, that key); ``root`` defaults to :class:`Case`."""
    model: type[BaseModel] | None = Case if root is None else root
    keys = [k for k in loc if isinstance(k, str)]
    for name in keys[:-1]:
        if model is None or name not in model.model_fields:
            return None, name
        model = _unwrap_model(model.model_fields[name].annotation)
    return model, keys[-1] if keys else None


def _field_meta(model: type[BaseModel], name: str) -> _Meta:
    for item in model.model_fields[name].metadata:
        if isinstance(item, _Meta):
            return item
    return _Meta('"..."')


def _path(loc: list[Any]) -> str:
    text = ""
    for key in loc:
        if isinstance(key, int):
            text += f"[{key}]"
        else:
            text += ("." if text else "") + str(key)
    return text


def _table_name(loc: list[Any]) -> str:
    keys = [k for k in loc if isinstance(k, str)]
    return ".".join(keys)


def _describe_error(error: Any, root: type[BaseModel] | None = None) -> tuple[str, str]:
    """(field path, one-line message) for one pydantic error dict (``root``: see _walk)."""
    loc = list(error["loc"])
    ctx = error.get("ctx") or {}
    if "sub" in ctx:
        loc += [int(k) if k.isdigit() else k for k in re.split(r"[.\[\]]+", ctx["sub"]) if k]
    path = _path(loc) or "(case)"
    kind = error["type"]
    value = error.get("input")
    scalar = isinstance(value, (str, int, float, bool))
    shown = f"{path} = {_toml_value(value)}" if scalar else path
    if kind in ("quantity", "case_rule"):
        return path, f"{path}: {ctx['detail']}"
    if kind == "case_value":
        return path, f"{shown}: {ctx['detail']}"
    if kind == "missing":
        model, key = _walk(loc, root)
        if model is not None and key in model.model_fields:
            example = _field_meta(model, key).example
            return path, f"{path}: missing; add e.g. {key} = {example}"
        return path, f"{path}: missing"
    if kind == "extra_forbidden":
        model, key = _walk(loc, root)
        if model is None:
            return path, f"{path}: unknown key; remove it"
        parent = _table_name(loc[:-1])
        allowed = list(model.model_fields)
        where = f"[{parent}]" if parent else "the top level"
        close = difflib.get_close_matches(str(key), allowed, n=1)
        hint = f'did you mean "{close[0]}"? ' if close else ""
        return path, f"{path}: unknown key; {hint}keys allowed in {where}: {', '.join(allowed)}"
    if kind == "literal_error":
        return path, f"{shown}: must be {ctx.get('expected', '').replace(chr(39), chr(34))}"
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return path, f"{shown}: must be a table; write it as [{_table_name(loc)}]"
    if kind in ("tuple_type", "list_type"):
        return path, f"{shown}: must be an array of tables; write each as [[{_table_name(loc)}]]"
    if kind == "string_type":
        key = path.split(".")[-1]
        return path, f'{shown}: must be a string in double quotes, e.g. {key} = "..."'
    message = " ".join(str(error.get("msg", "invalid value")).split())
    return path, f"{shown}: {message}"


def _case_error(
    exc: ValidationError, source: str | None, root: type[BaseModel] | None = None
) -> CaseError:
    # an unknown (misspelt) key explains the "missing" error that usually comes with it
    errors = sorted(exc.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden")
    path, message = _describe_error(errors[0], root)
    if len(errors) > 1:
        message += f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})"
    return CaseError(message, source=source, field=path)


# --------------------------------------------------------------------------------------------
# loading


def case_from_dict(
    data: dict[str, Any], source: str | None = None, base_dir: str | os.PathLike[str] | None = None
) -> Case:
    """Validate parsed TOML data into a :class:`Case`; raises :class:`CaseError`.

    ``base_dir`` anchors a relative ``geometry.file``; ``source`` prefixes error messages.
    """
    if not isinstance(data, dict):
        raise CaseError("a case must be a TOML table of keys", source=source)
    if data.get("kind") == "run":
        raise CaseError(
            'kind = "run": a run case, not a model; use it with `quadmodes run` or '
            "`quadmodes reduce`, or give its model case here",
            source=source,
            field="kind",
        )
    context = {"base_dir": os.fspath(base_dir) if base_dir is not None else None}
    try:
        return Case.model_validate(data, context=context)
    except ValidationError as exc:
        raise _case_error(exc, source) from None


_TOML_POSITION = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")


def case_from_toml(
    text: str, source: str = "<string>", base_dir: str | os.PathLike[str] | None = None
) -> Case:
    """Parse TOML text into a :class:`Case`; raises :class:`CaseError` (one line)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc).splitlines()[0] if str(exc) else "invalid TOML"
        match = _TOML_POSITION.search(message)
        if match:
            line, column = match.groups()
            message = message[: match.start()]
            raise CaseError(
                f"line {line}, column {column}: invalid TOML: {message}", source=source
            ) from None
        raise CaseError(f"invalid TOML: {message}", source=source) from None
    return case_from_dict(data, source=source, base_dir=base_dir)


def _cases_dir() -> Any:
    return resources.files("quadmodes.case").joinpath("builtin")


@functools.cache
def _builtin_kinds() -> dict[str, str]:
    """``{name: kind}`` of the TOML files shipped in ``quadmodes/case/builtin``."""
    kinds = {}
    for entry in _cases_dir().iterdir():
        if entry.name.endswith(".toml") and entry.is_file():
            try:
                kind = tomllib.loads(entry.read_text(encoding="utf-8")).get("kind")
            except tomllib.TOMLDecodeError:
                kind = None
            kinds[entry.name[: -len(".toml")]] = str(kind)
    return kinds


def builtin_case_names() -> list[str]:
    """Names of the built-in model cases (membrane and beam TOML files shipped in
    ``quadmodes/case/builtin``), sorted; run cases are listed by :func:`builtin_run_case_names`."""
    return sorted(name for name, kind in _builtin_kinds().items() if kind != "run")


@functools.cache
def _builtin_spinups() -> frozenset[str]:
    """Names of the built-in run cases with a ``[spinup]`` table (hub-driven spin-ups)."""
    names = set()
    for entry in _cases_dir().iterdir():
        if entry.name.endswith(".toml") and entry.is_file():
            try:
                data = tomllib.loads(entry.read_text(encoding="utf-8"))
            except tomllib.TOMLDecodeError:
                continue
            if data.get("kind") == "run" and "spinup" in data:
                names.add(entry.name[: -len(".toml")])
    return frozenset(names)


def builtin_run_case_names(spinup: bool | None = False) -> list[str]:
    """Names of the built-in run cases (``kind = "run"``), sorted.

    ``spinup``: False (default) the free-body runs (``[initial]`` + ``[integration]``, e.g. the
    paper cases), True the hub-driven spin-ups (``[spinup]``, e.g. ``kane-spinup``), None both.
    Name look-ups (:func:`load_run_case`, ``show-case``) accept both kinds."""
    runs = [name for name, kind in _builtin_kinds().items() if kind == "run"]
    if spinup is not None:
        runs = [name for name in runs if (name in _builtin_spinups()) == spinup]
    return sorted(runs)


def builtin_case_text(name: str) -> str:
    """TOML text of a built-in case (model or run); raises :class:`CaseError` for an unknown
    name."""
    if name not in builtin_case_names() and name not in builtin_run_case_names(None):
        raise CaseError(_unknown_case(name), field="case")
    return _cases_dir().joinpath(f"{name}.toml").read_text(encoding="utf-8")


def _unknown_case(name: str) -> str:
    names = builtin_case_names() + builtin_run_case_names(None)
    close = difflib.get_close_matches(name, names, n=1)
    hint = f'did you mean "{close[0]}"? ' if close else ""
    return (
        f'unknown case "{name}"; {hint}built-in cases are: {", ".join(names)} '
        "(or give the path of a .toml file)"
    )


def load_case(name_or_path: str | os.PathLike[str]) -> Case:
    """Load a built-in case by name or a case from a ``.toml`` file path.

    A string without a path separator or ``.toml`` suffix is looked up among the built-in
    cases first. Raises :class:`CaseError` with a one-line message.
    """
    text = os.fspath(name_or_path)
    looks_like_path = (
        not isinstance(name_or_path, str)
        or text.endswith(".toml")
        or os.sep in text
        or (os.altsep is not None and os.altsep in text)
    )
    if not looks_like_path and text in builtin_case_names():
        return case_from_toml(builtin_case_text(text), source=f"{text}.toml")
    if not looks_like_path and text in builtin_run_case_names(None):
        model = load_run_case(text).model
        raise CaseError(
            f'"{text}" is a run case (kind = "run"); use `quadmodes run {text}`, or its model '
            f'"{model}" here',
            field="case",
        )
    path = Path(text).expanduser()
    if not path.is_file():
        if looks_like_path:
            raise CaseError(f"case file not found: {text}", field="case")
        raise CaseError(_unknown_case(text), field="case")
    try:
        content = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise CaseError(f"cannot read case file: {reason}", source=text) from None
    return case_from_toml(content, source=text, base_dir=path.parent)


# --------------------------------------------------------------------------------------------
# writing


def _section_lines(section: BaseModel) -> list[str]:
    lines = []
    for name in type(section).model_fields:
        value = getattr(section, name)
        if value is None:
            continue
        meta = _field_meta(type(section), name)
        if meta.dimension is None or meta.dimension == "dimensionless":
            lines.append(f"{name} = {_toml_value(value)}")
            continue
        unit = si_unit(meta.dimension)
        line = f'{name} = "{value!r} {unit}"'
        if meta.display and meta.display != unit and math.isfinite(value):
            line += f"  # {format_quantity(value, meta.display)}"
        lines.append(line)
    return lines


def case_to_toml(case: Case) -> str:
    """TOML text for ``case`` with quantities in SI units (comments give familiar units).

    ``case_from_toml(case_to_toml(case)) == case`` holds exactly.
    """
    lines = [
        f"# quadmodes case {case.name!s}: quantities in SI units",
        f"name = {_toml_value(case.name)}",
        f"description = {_toml_value(case.description)}",
        f"kind = {_toml_value(case.kind)}",
    ]
    for name in ("geometry", "mesh", "material", "pressure", "beam", "modes"):
        section = getattr(case, name)
        if section is not None:
            lines += ["", f"[{name}]", *_section_lines(section)]
    for body in case.end_body:
        lines += ["", "[[end_body]]", *_section_lines(body)]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# run cases: loading and writing


def run_case_from_dict(
    data: dict[str, Any], source: str | None = None, base_dir: str | os.PathLike[str] | None = None
) -> RunCase:
    """Validate parsed TOML data into a :class:`RunCase` and check that its model loads;
    raises :class:`CaseError` (one line naming the field). ``base_dir`` anchors a relative
    ``model`` path."""
    if not isinstance(data, dict):
        raise CaseError("a run case must be a TOML table of keys", source=source)
    kind = data.get("kind")
    if kind in ("membrane", "beam"):
        raise CaseError(
            f'kind = "{kind}": a model case, not a run case; a run case has kind = "run", '
            'model = "<this case>", [initial] and [integration] tables '
            "(see src/quadmodes/cases/paper-41hz.toml)",
            source=source,
            field="kind",
        )
    context = {"base_dir": os.fspath(base_dir) if base_dir is not None else None}
    try:
        run = RunCase.model_validate(data, context=context)
    except ValidationError as exc:
        raise _case_error(exc, source, RunCase) from None
    try:
        run.model_case()
    except CaseError as exc:
        raise CaseError(exc.detail, source=source, field="model") from None
    return run


def run_case_from_toml(
    text: str, source: str = "<string>", base_dir: str | os.PathLike[str] | None = None
) -> RunCase:
    """Parse TOML text into a :class:`RunCase`; raises :class:`CaseError` (one line)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc).splitlines()[0] if str(exc) else "invalid TOML"
        match = _TOML_POSITION.search(message)
        if match:
            line, column = match.groups()
            raise CaseError(
                f"line {line}, column {column}: invalid TOML: {message[: match.start()]}",
                source=source,
            ) from None
        raise CaseError(f"invalid TOML: {message}", source=source) from None
    return run_case_from_dict(data, source=source, base_dir=base_dir)


def load_run_case(name_or_path: str | os.PathLike[str]) -> RunCase:
    """Load a built-in run case by name or a run case from a ``.toml`` file path; raises
    :class:`CaseError` with a one-line message."""
    text = os.fspath(name_or_path)
    looks_like_path = (
        not isinstance(name_or_path, str)
        or text.endswith(".toml")
        or os.sep in text
        or (os.altsep is not None and os.altsep in text)
    )
    if not looks_like_path and text in builtin_run_case_names(None):
        return run_case_from_toml(builtin_case_text(text), source=f"{text}.toml")
    if not looks_like_path and text in builtin_case_names():
        runs = ", ".join(builtin_run_case_names(None))
        raise CaseError(
            f'"{text}" is a model case, not a run case; built-in run cases are: {runs} '
            f'(or write a run case with model = "{text}")',
            field="case",
        )
    path = Path(text).expanduser()
    if not path.is_file():
        if looks_like_path:
            raise CaseError(f"run case file not found: {text}", field="case")
        names = builtin_run_case_names(None)
        close = difflib.get_close_matches(text, names, n=1)
        hint = f'did you mean "{close[0]}"? ' if close else ""
        raise CaseError(
            f'unknown run case "{text}"; {hint}built-in run cases are: {", ".join(names)} '
            "(or give the path of a .toml file)",
            field="case",
        )
    try:
        content = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise CaseError(f"cannot read run case file: {reason}", source=text) from None
    return run_case_from_toml(content, source=text, base_dir=path.parent)


def run_case_to_toml(run: RunCase) -> str:
    """TOML text for ``run`` with quantities in SI units (comments give familiar units);
    ``run_case_from_toml(run_case_to_toml(run)) == run``."""
    lines = [
        f"# quadmodes run case {run.name!s}: quantities in SI units",
        f"name = {_toml_value(run.name)}",
        f"description = {_toml_value(run.description)}",
        f"kind = {_toml_value(run.kind)}",
        f"model = {_toml_value(run.model)}",
    ]
    for name in ("reduced", "initial", "integration", "spinup"):
        if getattr(run, name) is None:
            continue
        section_lines = _section_lines(getattr(run, name))
        if name == "initial":  # the spin rate in Hz as well
            hz = format_quantity(run.initial.spin_rate / (2.0 * math.pi), "Hz")
            section_lines = [
                f"{line}  # {hz}" if line.startswith("spin_rate") else line
                for line in section_lines
            ]
        lines += ["", f"[{name}]", *section_lines]
    return "\n".join(lines) + "\n"
