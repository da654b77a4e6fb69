"""The tables of a model case: ``[geometry]``, ``[mesh]``, ``[material]``, ``[pressure]``,
``[[end_body]]``, ``[spin]`` (membrane cases), ``[beam]`` (beam cases) and ``[modes]``.

Quantities are stored in SI units: m, kg, Pa, kg/m^3, kg m^2, m^2, m^4, rad/s.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Self

import numpy as np
from pydantic import ValidationInfo, field_validator, model_validator

from quadmodes.case.fields import (
    FieldMeta,
    Section,
    at_least_one,
    choice,
    field_error,
    field_meta,
    inch,
    integer,
    nonnegative,
    poisson,
    positive,
    quantity,
    ratio,
    text,
)
from quadmodes.case.units import QuantityError, parse_quantity
from quadmodes.limits import INFLATION_STEPS, MODE_COUNT

_CAP_FIELDS = (
    "length", "front_cap_diameter", "rear_cap_diameter", "diameter", "inner_diameter",
    "side_length", "width", "blades", "file",
)  # fmt: skip
_SHAPE_FIELDS: dict[str, tuple[str, ...]] = {
    "sphere-cone": ("length", "front_cap_diameter", "rear_cap_diameter"),
    "sphere": ("diameter",),
    "capsule": ("length", "diameter"),
    "flat-cylinder": ("length", "diameter"),
    "disc": ("diameter",),
    "annulus": ("diameter", "inner_diameter"),
    "square": ("side_length", "inner_diameter"),
    "strip": ("length", "width", "inner_diameter"),
    "file": ("file",),
}
#: Flat open membranes: no pressure, held taut by their spin (``[spin]``); those with a central
#: hole are clamped on its edge to a rigid hub (``[hub]``).
FLAT_SHAPES = ("disc", "annulus", "square", "strip")
HUB_SHAPES = ("annulus", "square", "strip")
#: Fields a shape may take besides its own: a mesh file on a hub names the hub's diameter.
_OPTIONAL_SHAPE_FIELDS: dict[str, tuple[str, ...]] = {
    "file": ("inner_diameter",), "strip": ("blades",),
}  # fmt: skip


class Geometry(Section):
    """Membrane surface of revolution about the x axis; lengths in m.

    ``length`` is the overall pole-to-pole length. A sphere-cone is two spherical caps joined
    by a tangent cone; a capsule is a cylinder with hemispherical ends; a flat-cylinder has
    flat end discs; ``file`` is a mesh file (relative paths are taken from the case file).
    A ``disc`` is an open flat membrane in the plane normal to the axis (no pressure: it is
    held taut by its spin, ``[spin]``); an ``annulus`` (outer ``diameter``) and a ``square``
    sail (``side_length``) are flat too, with a central hole of ``inner_diameter`` whose edge
    is clamped to a rigid hub (``[hub]``); a ``strip`` is ``blades`` (default 4) radial
    membrane strips of ``length`` × ``width`` (heliogyro blades) whose root edges, at
    ``inner_diameter`` / 2 from the axis, are clamped to the hub.
    """

    shape: choice(
        "sphere-cone", "sphere", "capsule", "flat-cylinder", "disc", "annulus", "square", "strip",
        "file",
    )
    length: quantity("length", "60 in", positive, "in", optional=True) = None
    front_cap_diameter: quantity("length", "5 in", positive, "in", optional=True) = None
    rear_cap_diameter: quantity("length", "20 in", positive, "in", optional=True) = None
    diameter: quantity("length", "20 in", positive, "in", optional=True) = None
    inner_diameter: quantity("length", "1.6 m", positive, "m", optional=True) = None
    side_length: quantity("length", "14 m", positive, "m", optional=True) = None
    width: quantity("length", "0.5 m", positive, "m", optional=True) = None
    blades: integer(4, 1, optional=True) = None
    file: Annotated[str | None, FieldMeta('"body.vtu"')] = None
    #: the length unit of the mesh file's coordinates (default metres), e.g. "mm", "in"
    file_unit: Annotated[str | None, FieldMeta('"mm"')] = None

    @field_validator("file")
    @classmethod
    def resolve_file(cls, value: str | None, info: ValidationInfo) -> str | None:
        if value is None:
            return None
        if not value.strip():
            raise field_error("case_value", 'must name a mesh file; use e.g. "body.vtu"')
        base = (info.context or {}).get("base_dir")
        path = Path(value).expanduser()
        if base is not None and not path.is_absolute():
            path = Path(base) / path
        return str(path) if base is not None else value

    @field_validator("file_unit")
    @classmethod
    def check_file_unit(cls, value: str | None) -> str | None:
        if value is not None:
            length_unit_scale(value)
        return value

    def file_scale(self) -> float:
        """Metres per coordinate unit of the mesh file (``file_unit``; 1 if not given)."""
        return 1.0 if self.file_unit is None else length_unit_scale(self.file_unit)

    @model_validator(mode="after")
    def check_shape(self) -> Self:
        needed = _SHAPE_FIELDS[self.shape]
        for name in _CAP_FIELDS:
            given = getattr(self, name) is not None
            if name in needed and not given:
                example = field_meta(Geometry, name).example
                raise field_error(
                    "case_rule",
                    f'missing; shape = "{self.shape}" needs it, e.g. {name} = {example}',
                    name,
                )
            if given and name not in needed + _OPTIONAL_SHAPE_FIELDS.get(self.shape, ()):
                raise field_error(
                    "case_rule",
                    f'not used for shape = "{self.shape}"; remove it '
                    f'(shape "{self.shape}" takes {", ".join(needed)})',
                    name,
                )
        if self.shape == "sphere-cone":
            assert self.length and self.front_cap_diameter and self.rear_cap_diameter
            widest = max(self.front_cap_diameter, self.rear_cap_diameter)
            if self.length <= widest:
                raise field_error(
                    "case_rule",
                    f"{inch(self.length)} must exceed the larger cap diameter "
                    f"{inch(widest)}; lengthen the body or shrink the caps",
                    "length",
                )
        if self.shape == "capsule":
            assert self.length and self.diameter
            if self.length <= self.diameter:
                raise field_error(
                    "case_rule",
                    f"{inch(self.length)} must exceed the diameter {inch(self.diameter)}; "
                    'for a ball use shape = "sphere"',
                    "length",
                )
        outer = self.side_length if self.shape == "square" else self.diameter
        if self.shape == "strip":
            self._check_strip()
        elif self.shape != "file" and self.inner_diameter is not None and (
            self.inner_diameter >= 0.9 * outer
        ):
            raise field_error(
                "case_rule",
                f"{self.inner_diameter:.4g} m must be below 0.9 × the outer size {outer:.4g} m; "
                "use a smaller hub",
                "inner_diameter",
            )
        if self.file_unit is not None and self.shape != "file":
            raise field_error(
                "case_rule", 'only used with shape = "file" (a mesh file); remove it', "file_unit"
            )
        return self

    def _check_strip(self) -> None:
        """The blades' roots must not overlap at the hub."""
        count = self.blades or 4
        half = 0.5 * self.inner_diameter * np.sin(np.pi / count) if count > 1 else np.inf
        if 0.5 * self.width >= half:
            raise field_error(
                "case_rule",
                f"{self.width:.4g} m is too wide for {count} blades on a hub of "
                f"{self.inner_diameter:.4g} m (their roots would overlap); use a width below "
                f"{2 * half:.4g} m",
                "width",
            )

    def cap_radius(self, pole: str) -> float | None:
        """Radius (m) of the sphere or end disc at ``pole`` ("front"/"rear"); None for a file."""
        if self.shape == "file":
            return None
        if self.shape == "square":
            return (self.side_length or 0.0) / 2
        if self.shape == "strip":
            return 0.5 * (self.width or 0.0) * 4.0  # edges across a blade: at least 2
        if self.shape == "sphere-cone":
            cap = self.front_cap_diameter if pole == "front" else self.rear_cap_diameter
            return (cap or 0.0) / 2
        return (self.diameter or 0.0) / 2


def length_unit_scale(unit: str) -> float:
    """Metres per ``unit`` (a length unit such as "mm", "in", "m"); a ``case_value`` error
    naming the fix otherwise."""
    try:
        return parse_quantity(f"1 {unit}", "length", "file_unit", "1 mm")
    except QuantityError:
        raise field_error(
            "case_value", 'must be a length unit such as "mm", "cm", "m" or "in"'
        ) from None


class Mesh(Section):
    """Triangulation settings: target edge length (m), optional grading (at least
    ``elements_per_radius`` edges per hoop radius of curvature, e.g. on a small cap; edges of
    ``attach_radius / elements_per_attach_radius`` at the rim of each end body's rigid patch,
    growing away from it), and the mass matrix kind."""

    edge_length: quantity("length", "1 in", positive, "in")
    elements_per_radius: quantity("dimensionless", "6", at_least_one, optional=True) = None
    elements_per_attach_radius: quantity("dimensionless", "8", at_least_one, optional=True) = None
    mass_matrix: choice("consistent", "lumped") = "consistent"


class Material(Section):
    """Isotropic membrane: density kg/m^3, Young's modulus Pa, thickness m, ratios plain;
    wrinkling model."""

    density: quantity("density", "0.0335 lb/in^3", positive, "lb/in^3")
    youngs_modulus: quantity("pressure", "0.05 Mpsi", positive, "Mpsi")
    poisson_ratio: quantity("dimensionless", "0.3", poisson)
    thickness: quantity("length", "0.0045 in", positive, "in")
    damping_ratio: quantity("dimensionless", "0.02", ratio) = 0.0
    #: "tension-field": the membrane wrinkles instead of carrying compression (fe/wrinkling.py);
    #: "none": St Venant–Kirchhoff in compression too (a membrane without bending stiffness).
    wrinkling: choice("none", "tension-field") = "none"


class Pressure(Section):
    """Inflation pressure (Pa, gauge), polytropic gas-law exponent (0 = constant) and the
    load steps of the inflation.

    The inflation follows the pressure from zero in increments of ``value / steps`` at first;
    an increment whose equilibrium is not found is halved, one found quickly doubles the next
    (at most ``value / steps``), and where Newton fails, pseudo-transient continuation takes over
    (:func:`quadmodes.structure.prestress.inflate`). Raise ``steps`` (default 1) for a body that
    only inflates along a finely followed path."""

    value: quantity(
        "pressure",
        "0.3 psi",
        lambda p: None if p > 0 else "must be positive for a membrane",
        "psi",
        allowed="> 0",
    )
    gas_law_exponent: quantity("dimensionless", "0", nonnegative) = 0.0
    steps: integer(10, 1, INFLATION_STEPS, optional=True) = None


_INERTIA = quantity("inertia", "1e-5 kg m^2", nonnegative, "kg*m^2", optional=True)


class Spin(Section):
    """The spin of the reference state (rad/s) of a membrane without pressure (a disc, a sail):
    it has no stiffness out of its plane at rest, so its modes are those of the rotating-frame
    stiffness about the centrifugal relative equilibrium at this spin about its normal
    (:mod:`quadmodes.structure.flat_spin`)."""

    rate: quantity("angular_rate", "1 rad/s", positive)


class TipMass(Section):
    """A point mass (kg) at a corner of a square sail, bonded to the membrane within ``patch``
    (m) of the corner and spread over that patch (by area): its load converges as the mesh is
    refined (fe/hub_membrane.py)."""

    name: text("+x+y")
    corner: choice("+x+y", "-x+y", "-x-y", "+x-y")
    mass: quantity("mass", "0.5 kg", positive, "kg")
    patch: quantity("length", "0.3 m", positive, "m")


class EndBody(Section):
    """Rigid body at a pole: mass kg, lengths m, inertias kg m^2 about its own centre.

    Its rotary inertia is given either directly (``inertia_axial``, ``inertia_transverse``) or as
    the shape of a uniform solid cylinder (``radius``, ``height``; axis along the body axis), in
    which case the inertias scale with the mass (the calibration fits masses with the shape
    fixed). Membrane nodes on that cap within ``attach_radius`` of the axis are tied to it; its
    centre of mass lies ``offset`` outside the pole on the axis; ``arm`` is the half-size of the
    point-mass cluster that carries the inertia (default: 1.25 × the smallest that works).

    ``attachment`` says how the body is bonded to the membrane: ``"rim"`` (the rigid patch meets
    the bare membrane at a sharp rim), or ``"flange"`` (a bonded flange: between
    ``attach_radius`` and ``flange_radius`` the membrane is ``flange_thickness_factor`` times as
    thick, a doubler that carries the load from the rigid patch into the membrane; see
    docs/calibration.md "Mesh-objective end bodies").
    """

    name: text("rear")
    pole: choice("front", "rear")
    mass: quantity("mass", "0.1 kg", positive, "kg")
    inertia_axial: _INERTIA = None
    inertia_transverse: _INERTIA = None
    radius: quantity("length", "2 in", positive, "in", optional=True) = None
    height: quantity("length", "1 in", nonnegative, "in", optional=True) = None
    attach_radius: quantity("length", "1.5 in", positive, "in")
    offset: quantity("length", "0.5 in", nonnegative, "in")
    arm: quantity("length", "1 in", positive, "in", optional=True) = None
    attachment: choice("rim", "flange") = "rim"
    flange_radius: quantity("length", "2 in", positive, "in", optional=True) = None
    flange_thickness_factor: quantity("dimensionless", "4", at_least_one, optional=True) = None

    @field_validator("name")
    @classmethod
    def check_name(cls, value: str) -> str:
        if not value.strip():
            raise field_error("case_value", 'must not be empty; use e.g. "rear"')
        return value

    @model_validator(mode="after")
    def check_inertia(self) -> Self:
        direct = (self.inertia_axial is not None, self.inertia_transverse is not None)
        shape = (self.radius is not None, self.height is not None)
        if any(direct) and any(shape):
            raise field_error(
                "case_rule",
                "give either inertia_axial and inertia_transverse, or radius and height, not both",
                "radius" if shape[0] else "height",
            )
        if not (all(direct) or all(shape)):
            missing = "inertia_transverse" if direct[0] else "inertia_axial"
            if any(shape):
                missing = "height" if shape[0] else "radius"
            raise field_error(
                "case_rule",
                "missing; give inertia_axial and inertia_transverse, or radius and height "
                '(a uniform solid cylinder), e.g. radius = "2 in"',
                missing,
            )
        return self

    @model_validator(mode="after")
    def check_flange(self) -> Self:
        flange = ("flange_radius", "flange_thickness_factor")
        if self.attachment == "rim":
            for name in flange:
                if getattr(self, name) is not None:
                    raise field_error(
                        "case_rule", 'only used with attachment = "flange"; remove it', name
                    )
            return self
        for name in flange:
            if getattr(self, name) is None:
                example = field_meta(EndBody, name).example
                raise field_error(
                    "case_rule",
                    f'missing; attachment = "flange" needs it, e.g. {name} = {example}',
                    name,
                )
        if self.flange_radius <= self.attach_radius:
            raise field_error(
                "case_rule",
                f"{inch(self.flange_radius)} must exceed attach_radius "
                f"{inch(self.attach_radius)}; the flange surrounds the rigid patch",
                "flange_radius",
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


class Beam(Section):
    """Straight beam along x: length m, area m^2, second moment m^4 (both bending planes), E Pa,
    kg/m^3; shear modulus (default E/2.6) and torsion constant (default 2I, a circular section)
    of the 3-D beam."""

    length: quantity("length", "10 m", positive, "m")
    elements: integer(20, 1)
    area: quantity("area", "4e-4 m^2", positive, "m^2")
    second_moment: quantity("second_moment", "2e-7 m^4", positive, "m^4")
    youngs_modulus: quantity("pressure", "7e10 Pa", positive, "Pa")
    density: quantity("density", "3000 kg/m^3", positive, "kg/m^3")
    support: choice("clamped", "free") = "clamped"
    damping_ratio: quantity("dimensionless", "0.02", ratio) = 0.0
    # "beam3d": bending in both planes, extension, torsion and section rotary inertia (spins
    # free); "cable": the ANCF cable without torsion (Kane's Euler-Bernoulli benchmark)
    element: choice("beam3d", "cable") = "beam3d"
    shear_modulus: quantity("pressure", "2.7e10 Pa", positive, "Pa", optional=True) = None
    torsion_constant: quantity("second_moment", "4e-7 m^4", positive, "m^4", optional=True) = None


class Hub(Section):
    """Rigid hub of a spacecraft case: mass kg, principal moments of inertia about its centre
    along x, y, z (kg m^2), the modal damping ratio of the whole structure and the stiffness of
    the hub's rigid triad relative to the attached booms' stiffness on the hub axes at rest
    (dimensionless: the hub strains 1/rigidity as much as the boom roots under any load)."""

    mass: quantity("mass", "20 kg", positive, "kg")
    inertia_x: quantity("inertia", "1.0 kg*m^2", positive, "kg*m^2")
    inertia_y: quantity("inertia", "1.2 kg*m^2", positive, "kg*m^2")
    inertia_z: quantity("inertia", "0.8 kg*m^2", positive, "kg*m^2")
    damping_ratio: quantity("dimensionless", "0.02", ratio) = 0.0
    rigidity: quantity("dimensionless", "100", positive) = 1e2

    @model_validator(mode="after")
    def check_triangle(self) -> Self:
        i = (self.inertia_x, self.inertia_y, self.inertia_z)
        for name, value in zip(("inertia_x", "inertia_y", "inertia_z"), i, strict=True):
            if value > sum(i) - value + 1e-12 * sum(i):
                raise field_error(
                    "case_rule",
                    "must not exceed the sum of the other two moments (no physical body has "
                    "that); lower it or raise the others",
                    name,
                )
        return self


class Boom(Section):
    """A straight 3-D beam clamped to the hub, pointing along (azimuth in the hub's x-y plane
    from x, elevation above that plane), its root at root_radius along that direction from the
    hub axis and root_height along z; section as in [beam]."""

    name: text("boom-1")
    azimuth: quantity("angle", "0 deg", None, "deg") = 0.0
    elevation: quantity("angle", "0 deg", None, "deg") = 0.0
    root_radius: quantity("length", "0.3 m", nonnegative, "m") = 0.0
    root_height: quantity("length", "0 m", None, "m") = 0.0
    length: quantity("length", "2 m", positive, "m")
    elements: integer(10, 1)
    area: quantity("area", "7.85e-5 m^2", positive, "m^2")
    second_moment: quantity("second_moment", "4.9e-10 m^4", positive, "m^4")
    youngs_modulus: quantity("pressure", "7e10 Pa", positive, "Pa")
    density: quantity("density", "2700 kg/m^3", positive, "kg/m^3")
    shear_modulus: quantity("pressure", "2.7e10 Pa", positive, "Pa", optional=True) = None
    torsion_constant: quantity("second_moment", "1e-9 m^4", positive, "m^4", optional=True) = None


class Modes(Section):
    """Number of elastic modes to compute."""

    count: integer(10, 1, MODE_COUNT) = 10
