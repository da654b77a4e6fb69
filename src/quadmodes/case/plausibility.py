"""Physical plausibility of a case (issue 24 item 4, docs/reliability.md): the membrane strain
scale p R / (E t) and the structural mass, for every geometry.

The checks are pure functions of the case and a few numbers of its surface (the radius R and
the area, from the case's caps before meshing, or from a mesh file after reading), so they run
before any finite-element model is built. A value off by powers of ten (``thickness =
"1e-300 m"``, a modulus in Pa given as MPa, a mesh file in millimetres read as metres) is
refused with :class:`~quadmodes.case.CaseError`: one line naming the field most likely wrong
and the fix. The bounds are in :mod:`quadmodes.limits` (``MAX_STRAIN``, ``MIN_MASS``,
``MAX_MASS``; their variables raise them).
"""

from __future__ import annotations

import math

from quadmodes.case.errors import CaseError
from quadmodes.limits import MAX_MASS, MAX_STRAIN, MAX_VOLUME_CHANGE, MIN_MASS, Limit, LimitError

#: Below this membrane strain scale p R / (E t) inflation does not converge reliably:
#: paper-membrane-coarse fails at 1.3e-6 (3e-5 psi) and converges at 4.4e-6 (1e-4 psi).
MIN_STRAIN = 3e-6

#: Typical values (paper-membrane, kane-beam), to name the field farthest from them.
_TYPICAL = {
    "pressure.value": 2068.4,  # Pa (0.3 psi)
    "material.youngs_modulus": 3.45e8,  # Pa (0.05 Mpsi)
    "material.thickness": 1.143e-4,  # m (0.0045 in)
    "material.density": 927.0,  # kg/m^3 (0.0335 lb/in^3)
    "geometry.file_unit": 0.254,  # m, the radius of a body
    "beam.density": 3000.0,  # kg/m^3
    "beam.area": 4e-4,  # m^2
    "beam.length": 10.0,  # m
}
_FIX = {
    "pressure.value": "check its value and unit (e.g. \"0.3 psi\")",
    "material.youngs_modulus": "check its value and unit (e.g. \"0.05 Mpsi\")",
    "material.thickness": "check its value and unit (e.g. \"0.0045 in\")",
    "material.density": "check its value and unit (e.g. \"0.0335 lb/in^3\")",
    "geometry.file_unit": 'declare the unit of the mesh file\'s coordinates, e.g. file_unit = "mm"',
    "beam.density": "check its value and unit (e.g. \"3000 kg/m^3\")",
    "beam.area": "check its value and unit (e.g. \"4e-4 m^2\")",
    "beam.length": "check its value and unit (e.g. \"10 m\")",
}


def _bound(limit: Limit) -> float:
    try:
        return limit.value()
    except LimitError as exc:
        raise CaseError(exc.detail, field=exc.field) from None


def _suspect(values: dict[str, float]) -> str:
    """The field of ``values`` (SI) farthest, in powers of ten, from its typical value."""
    return max(values, key=lambda k: abs(math.log10(max(values[k], 1e-300) / _TYPICAL[k])))


def _shown(field: str, value: float, case) -> str:
    if field == "geometry.file_unit":
        return f'geometry.file_unit = "{case.geometry.file_unit or "m"}"'
    unit = {"pressure.value": "Pa", "material.youngs_modulus": "Pa", "material.density": "kg/m^3",
            "beam.density": "kg/m^3", "beam.area": "m^2"}.get(field, "m")  # fmt: skip
    return f'{field} = "{value:.4g} {unit}"'


def check_strain_scale(case, radius: float) -> None:
    """Raise :class:`CaseError` if the membrane case's strain scale p R / (E t) (``radius`` R in
    m) is below :data:`MIN_STRAIN` (too low to tension it: names ``pressure.value``) or above
    ``limits.MAX_STRAIN`` (names the field farthest from typical; for a mesh file possibly
    ``geometry.file_unit``)."""
    if case.kind != "membrane" or not radius > 0.0:
        return
    m, p = case.material, case.pressure.value
    strain = p * radius / (m.youngs_modulus * m.thickness)
    if strain < MIN_STRAIN:
        lowest = MIN_STRAIN * m.youngs_modulus * m.thickness / radius
        raise CaseError(
            f"pressure.value = {p:.3g} Pa ({p / 6894.757:.3g} psi) is too low to tension the "
            f"membrane reliably (strain scale p R / (E t) = {strain:.2g}, below {MIN_STRAIN:g}); "
            f"raise it to at least {lowest:.2g} Pa ({lowest / 6894.757:.2g} psi)",
            field="pressure.value",
        )
    bound = _bound(MAX_STRAIN)
    if strain > bound:
        values = {"pressure.value": p, "material.youngs_modulus": m.youngs_modulus,
                  "material.thickness": m.thickness}  # fmt: skip
        if case.geometry.shape == "file":
            values["geometry.file_unit"] = radius
        field = _suspect(values)
        raise CaseError(
            f"{_shown(field, values[field], case)}: the membrane strain scale p R / (E t) = "
            f"{strain:.3g} (R = {radius:.4g} m) is implausible (above {bound:g}: the membrane "
            f"would stretch by tens of percent or more); {_FIX[field]}, or set {MAX_STRAIN.env} "
            "to accept it",
            field=field,
        )


def volume_change_warning(volume_change: float) -> str | None:
    """A one-line warning when inflation changed the enclosed volume by more than
    ``limits.MAX_VOLUME_CHANGE`` (a fraction), else None."""
    bound = _bound(MAX_VOLUME_CHANGE)
    if abs(volume_change) <= bound:
        return None
    return (f"inflation changed the enclosed volume by {100 * volume_change:.3g} % (more than "
            f"{100 * bound:g} %): check the mesh file's unit (geometry.file_unit), the pressure, "
            "the modulus and the thickness")  # fmt: skip


def check_mass(case, area: float | None = None) -> None:
    """Raise :class:`CaseError` if the structural mass (kg) of ``case`` lies outside
    ``limits.MIN_MASS``..``MAX_MASS``: density × thickness × ``area`` (m², the membrane's
    surface; skipped when None) or density × area × length of a beam."""
    if case.kind == "membrane" and area is not None:
        m = case.material
        values = {"material.density": m.density, "material.thickness": m.thickness}
        mass = m.density * m.thickness * area
    elif case.kind == "beam":
        b = case.beam
        values = {"beam.density": b.density, "beam.area": b.area, "beam.length": b.length}
        mass = b.density * b.area * b.length
    else:
        return
    low, high = _bound(MIN_MASS), _bound(MAX_MASS)
    if low <= mass <= high:
        return
    field = _suspect(values)
    limit, side = (MIN_MASS, "below") if mass < low else (MAX_MASS, "above")
    raise CaseError(
        f"{_shown(field, values[field], case)}: the structure's mass would be {mass:.3g} kg, "
        f"implausibly {'light' if mass < low else 'heavy'} ({side} {limit.value():g} kg); "
        f"{_FIX[field]}, or set {limit.env} to accept it",
        field=field,
    )
