"""Case input: the TOML schema (validated, SI floats inside), quantities with units, and the
built-in case files in ``builtin/``.

Dimensional values are written in TOML as quantity strings ("0.3 psi", "60 in") and stored in
the models as SI floats (m, kg, Pa, kg/m^3, kg m^2, m^2, m^4). :func:`case_to_toml` writes a
case back in SI units with the original-style units as comments; the text loads back to an
equal case. Every problem is reported as a :class:`CaseError` with a one-line message that
names the field path and the fix.

Modules: ``fields`` (quantity-typed field annotations and checks), ``errors`` (:class:`CaseError`
and messages), ``model_sections`` / ``model_case`` (a model case and its tables),
``run_sections`` / ``run_case`` (a run case and its tables), ``builtin`` (the shipped cases),
``toml_reading`` / ``model_loading`` / ``run_loading`` (loading), ``toml_writing`` (SI text),
``units`` (quantity strings).
"""

from quadmodes.case.builtin import builtin_case_names, builtin_case_text, builtin_run_case_names
from quadmodes.case.errors import CaseError
from quadmodes.case.model_case import Case, case_to_toml
from quadmodes.case.model_loading import case_from_dict, case_from_toml, load_case
from quadmodes.case.model_sections import Beam, EndBody, Geometry, Material, Mesh, Modes, Pressure
from quadmodes.case.run_case import RunCase, run_case_to_toml
from quadmodes.case.run_loading import load_run_case, run_case_from_dict, run_case_from_toml
from quadmodes.case.run_sections import RunInitial, RunIntegration, RunReduced, RunSpinup
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
    "QuantityError",
    "RunCase",
    "RunInitial",
    "RunIntegration",
    "RunReduced",
    "RunSpinup",
    "builtin_case_names",
    "builtin_case_text",
    "builtin_run_case_names",
    "case_from_dict",
    "case_from_toml",
    "case_to_toml",
    "format_quantity",
    "load_case",
    "load_run_case",
    "parse_quantity",
    "run_case_from_dict",
    "run_case_from_toml",
    "run_case_to_toml",
    "si_unit",
]
