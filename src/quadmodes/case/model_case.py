"""A model case: the top level of a membrane or beam case file, and its TOML text.

A membrane case (``kind = "membrane"``) has ``[geometry]``, ``[mesh]``, ``[material]``,
``[pressure]`` and any ``[[end_body]]`` tables (a flat ``disc``, ``annulus`` or ``square`` has
``[spin]`` instead of ``[pressure]``, the last two a ``[hub]`` and a square ``[[tip_mass]]``
tables); a beam case (``kind = "beam"``) has ``[beam]``;
a spacecraft case (``kind = "spacecraft"``) has ``[hub]`` and ``[[boom]]`` tables; all may have
``[modes]``. :func:`case_to_toml` writes a case in SI units; the text loads back
to an equal case.
"""

from __future__ import annotations

from typing import Self

from pydantic import Field, field_validator, model_validator

from quadmodes.case.fields import Section, choice, field_error, inch, text, toml_value, valid_name
from quadmodes.case.model_sections import (
    FLAT_SHAPES,
    HUB_SHAPES,
    Beam,
    Boom,
    EndBody,
    Geometry,
    Hub,
    Material,
    Mesh,
    Modes,
    Pressure,
    Spin,
    TipMass,
)
from quadmodes.case.toml_writing import section_lines, toml_document

_MEMBRANE_SECTIONS = ("geometry", "mesh", "material", "pressure")


class Case(Section):
    """A complete case. Membrane cases use geometry/mesh/material/pressure/end_body; beam
    cases use beam; the other sections are None (or empty)."""

    name: text("my-case")
    description: text("what this case is for") = ""
    kind: choice("membrane", "beam", "spacecraft")
    geometry: Geometry | None = None
    mesh: Mesh | None = None
    material: Material | None = None
    pressure: Pressure | None = None
    end_body: tuple[EndBody, ...] = ()
    spin: Spin | None = None
    beam: Beam | None = None
    hub: Hub | None = None
    boom: tuple[Boom, ...] = ()
    tip_mass: tuple[TipMass, ...] = ()
    modes: Modes = Field(default_factory=Modes)

    @field_validator("name")
    @classmethod
    def check_name(cls, value: str) -> str:
        return valid_name(value, "my-case")

    @model_validator(mode="after")
    def check_kind(self) -> Self:
        if self.kind == "membrane":
            self._check_membrane_tables()
            self._check_end_bodies()
            self._check_mesh_resolution()
        elif self.kind == "beam":
            self._check_beam_tables()
        else:
            self._check_spacecraft_tables()
        self._check_spin_table()
        self._check_hub_membrane()
        if self.kind != "spacecraft":
            for section in ("hub", "boom"):
                if section == "hub" and self._hub_shape:
                    continue  # checked by _check_hub_membrane
                if getattr(self, section):
                    raise field_error(
                        "case_rule",
                        'only used when kind = "spacecraft"; remove it or set that kind',
                        section,
                    )
        return self

    def _check_spacecraft_tables(self) -> None:
        if self.hub is None or not self.boom:
            missing = "hub" if self.hub is None else "boom"
            raise field_error(
                "case_rule",
                'missing; kind = "spacecraft" needs a [hub] table and [[boom]] tables (see '
                '"quadmodes show-case hub-booms")',
                missing,
            )
        for section in (*_MEMBRANE_SECTIONS, "end_body", "beam", "spin"):
            if getattr(self, section):
                raise field_error(
                    "case_rule",
                    'not used when kind = "spacecraft"; remove it or change the kind',
                    section,
                )
        names = [b.name for b in self.boom]
        for i, name in enumerate(names):
            if name in names[:i]:
                raise field_error(
                    "case_rule",
                    f"{toml_value(name)} is used twice; give each boom its own name",
                    f"boom[{i}].name",
                )

    @property
    def _flat(self) -> bool:
        """A flat membrane without pressure: a disc, an annulus, a square, or a mesh file with
        a ``[spin]`` table."""
        if self.kind != "membrane" or self.geometry is None:
            return False
        shape = self.geometry.shape
        return shape in FLAT_SHAPES or (shape == "file" and self.spin is not None)

    @property
    def _hub_shape(self) -> bool:
        """A flat membrane clamped to a rigid hub (an annulus, a square sail, or a flat mesh
        file with a ``[hub]``)."""
        if self.kind != "membrane" or self.geometry is None:
            return False
        return self.geometry.shape in HUB_SHAPES or (
            self.geometry.shape == "file" and self.hub is not None
        )

    def _check_spin_table(self) -> None:
        """A flat membrane (disc, annulus, square) has no stiffness at rest: no ``[pressure]``
        (it is open), a ``[spin]`` table and no end bodies (yet); every other body has no
        ``[spin]`` table."""
        if not self._flat:
            if self.spin is not None:
                raise field_error(
                    "case_rule",
                    "only used for a membrane without pressure (geometry.shape = \"disc\", "
                    '"annulus" or "square"); remove it',
                    "spin",
                )
            return
        shape = self.geometry.shape
        see = 'see "quadmodes show-case spinning-disc"'
        if self.pressure is not None:
            raise field_error(
                "case_rule",
                f'not used for shape = "{shape}": an open membrane holds no pressure; remove '
                f"the [pressure] table ({see})",
                "pressure",
            )
        if self.spin is None:
            raise field_error(
                "case_rule",
                f'missing; shape = "{shape}" has no stiffness at rest and needs a [spin] '
                f'table, e.g. rate = "1 rad/s" ({see})',
                "spin",
            )
        if self.end_body:
            raise field_error(
                "case_rule",
                f'not supported for shape = "{shape}" yet; remove the [[end_body]] tables',
                "end_body",
            )

    def _check_hub_membrane(self) -> None:
        """An annulus or a square sail needs a ``[hub]`` (its inner edge is clamped to it),
        whose damping is the membrane's (``material.damping_ratio``); ``[[tip_mass]]`` tables
        only on a square sail, one per corner."""
        see = 'see "quadmodes show-case spinning-annulus"'
        file = self.kind == "membrane" and self.geometry.shape == "file"
        if file and (self.hub is not None) != (self.geometry.inner_diameter is not None):
            missing = "geometry.inner_diameter" if self.hub is not None else "hub"
            raise field_error(
                "case_rule",
                "a mesh file on a hub needs both [hub] and geometry.inner_diameter (its boundary "
                "nodes within that diameter of the z axis are clamped to the hub); give both",
                missing,
            )
        if file and self.hub is not None and self.spin is None:
            raise field_error(
                "case_rule",
                "a mesh file on a hub is a flat membrane without pressure: give a [spin] table "
                'instead of [pressure], e.g. rate = "1 rad/s"',
                "spin",
            )
        if self._hub_shape:
            if self.hub is None:
                raise field_error(
                    "case_rule",
                    f'missing; shape = "{self.geometry.shape}" is clamped to a rigid hub at '
                    f"its inner edge and needs a [hub] table with mass and inertias ({see})",
                    "hub",
                )
            if self.hub.damping_ratio:
                raise field_error(
                    "case_rule",
                    "not used for a membrane on a hub (the structure's damping is "
                    "material.damping_ratio); remove it",
                    "hub.damping_ratio",
                )
        square = self.kind == "membrane" and self.geometry.shape == "square"
        if self.tip_mass and not square:
            raise field_error(
                "case_rule", 'only used with geometry.shape = "square"; remove it', "tip_mass"
            )
        corners = [t.corner for t in self.tip_mass]
        names = [t.name for t in self.tip_mass]
        for i, tip in enumerate(self.tip_mass):
            for field, values in (("corner", corners), ("name", names)):
                if values[i] in values[:i]:
                    raise field_error(
                        "case_rule",
                        f"{toml_value(values[i])} is used twice; one tip mass per {field}",
                        f"tip_mass[{i}].{field}",
                    )
            if tip.patch >= 0.25 * self.geometry.side_length:
                raise field_error(
                    "case_rule",
                    f"{tip.patch:.4g} m must be below a quarter of the side; use a smaller patch",
                    f"tip_mass[{i}].patch",
                )

    def _check_membrane_tables(self) -> None:
        see = 'see "quadmodes show-case paper-membrane"'
        for section in _MEMBRANE_SECTIONS:
            if section == "pressure" and self._flat:
                continue  # checked by _check_spin_table
            if getattr(self, section) is None:
                raise field_error(
                    "case_rule",
                    f'missing; kind = "membrane" needs a [{section}] table ({see})',
                    section,
                )
        if self.beam is not None:
            raise field_error(
                "case_rule",
                'not used when kind = "membrane"; remove the [beam] table or set kind = "beam"',
                "beam",
            )

    def _check_beam_tables(self) -> None:
        if self.beam is None:
            raise field_error(
                "case_rule",
                'missing; kind = "beam" needs a [beam] table (see "quadmodes show-case kane-beam")',
                "beam",
            )
        for section in (*_MEMBRANE_SECTIONS, "end_body", "spin"):
            if getattr(self, section):
                table = "[[end_body]] tables" if section == "end_body" else f"[{section}] table"
                raise field_error(
                    "case_rule",
                    f'not used when kind = "beam"; remove the {table} or set kind = "membrane"',
                    section,
                )

    def _check_end_bodies(self) -> None:
        names: set[str] = set()
        poles: dict[str, str] = {}
        for i, body in enumerate(self.end_body):
            if body.name in names:
                raise field_error(
                    "case_rule",
                    f"{toml_value(body.name)} is used twice; give each end body its own name",
                    f"end_body[{i}].name",
                )
            if body.pole in poles:
                raise field_error(
                    "case_rule",
                    f"{toml_value(body.pole)} already carries end body "
                    f"{toml_value(poles[body.pole])}; use at most one end body per pole",
                    f"end_body[{i}].pole",
                )
            names.add(body.name)
            poles[body.pole] = body.name
            radius = self.geometry.cap_radius(body.pole) if self.geometry else None
            if radius is not None and body.attach_radius >= radius:
                raise field_error(
                    "case_rule",
                    f"{inch(body.attach_radius)} must be smaller than the {body.pole} cap "
                    f"radius {inch(radius)}; use a smaller attach_radius",
                    f"end_body[{i}].attach_radius",
                )
            if radius is not None and body.flange_radius and body.flange_radius >= radius:
                raise field_error(
                    "case_rule",
                    f"{inch(body.flange_radius)} must be smaller than the {body.pole} cap "
                    f"radius {inch(radius)}; use a smaller flange_radius",
                    f"end_body[{i}].flange_radius",
                )

    def _check_mesh_resolution(self) -> None:
        """The mesh edge must be at most half the body's largest radius (at least ~12 edges
        around its widest ring); a coarser mesh cannot represent the body or its modes."""
        g = self.geometry
        if g.shape == "file":
            return
        radius = max(g.cap_radius("front") or 0.0, g.cap_radius("rear") or 0.0)
        edge = self.mesh.edge_length
        if radius > 0.0 and edge > radius / 2:
            raise field_error(
                "case_rule",
                f"{inch(edge)} is too long for a body of largest radius {inch(radius)} (fewer "
                f"than 12 edges around it); use at most {inch(radius / 2)}, e.g. "
                f"{inch(radius / 10)}",
                "mesh.edge_length",
            )

    @property
    def damping_ratio(self) -> float:
        """Modal damping ratio of the structure (material, beam or hub table)."""
        section = {"membrane": self.material, "beam": self.beam, "spacecraft": self.hub}[self.kind]
        return float(section.damping_ratio) if section is not None else 0.0

    def to_toml(self) -> str:
        """This case as TOML text in SI units (see :func:`case_to_toml`)."""
        return case_to_toml(self)


def case_tables(case: Case, prefix: str = "") -> list[tuple[str, list[str]]]:
    """The ``(header, lines)`` tables of ``case`` for :func:`toml_document`; with ``prefix``
    (e.g. ``"model"``) the case is one table ``[prefix]`` with its name, description and kind,
    and its own tables below it (``[prefix.geometry]``, ``[[prefix.end_body]]``)."""
    head = f"{prefix}." if prefix else ""
    tables = []
    if prefix:
        top = {"name": case.name, "description": case.description, "kind": case.kind}
        tables.append((f"[{prefix}]", [f"{k} = {toml_value(v)}" for k, v in top.items()]))
    tables += [
        (f"[{head}{name}]", section_lines(getattr(case, name)))
        for name in ("geometry", "mesh", "material", "pressure", "spin", "beam", "hub", "modes")
        if getattr(case, name) is not None
    ]
    tables += [(f"[[{head}end_body]]", section_lines(body)) for body in case.end_body]
    tables += [(f"[[{head}boom]]", section_lines(boom)) for boom in case.boom]
    tables += [(f"[[{head}tip_mass]]", section_lines(tip)) for tip in case.tip_mass]
    return tables


def case_to_toml(case: Case) -> str:
    """TOML text for ``case`` with quantities in SI units (comments give familiar units).

    ``case_from_toml(case_to_toml(case)) == case`` holds exactly.
    """
    return toml_document(
        f"quadmodes case {case.name!s}: quantities in SI units",
        {"name": case.name, "description": case.description, "kind": case.kind},
        case_tables(case),
    )
