"""quadmodes: spinning flexible bodies by the method of quadratic modes.

The public Python API (``quadmodes.__all__``, reference in docs/api.md)::

    import quadmodes as qm

    body = qm.model_case("paper-membrane-coarse", pressure={"value": "0.4 psi"})
    run = qm.run_case("paper-41hz", model=body, integration={"duration": "0.1 s"})
    result = qm.simulate(run)            # free-body run (or a [spinup])
    qm.write_results(result, "out/my-run")  # results.nc (CF), summary.json, PNGs, report.html
    qm.summary(result)["cone_angle_end_deg"]
    back = qm.open_results("out/my-run")  # results.nc: .data, .summary, .plot("cone_angle")

Quantities are accepted as strings ("0.3 psi"), pint quantities or SI floats; cases are
validated like case files. The names are loaded on first use (``import quadmodes`` stays
light).

Pipeline, one subpackage per stage and layer (see docs/architecture.md):
``case`` (TOML, units) -> ``mesh`` -> ``fe`` (elements, structure) -> ``structure`` (prestress,
modes, calibration) -> ``rom`` (quadratic modes, reduced model artifact, equations of motion,
integrators, diagnostics) -> ``models`` (the reduced model of a case: build and cache) ->
``runs`` (run cases, results), beside it ``fullorder`` (the nonlinear finite-element reference);
files through ``io`` (below the models). On top: ``analysis`` (Campbell, rotating frame,
comparison), ``sweeps``, ``validation``, ``api`` (this API), ``cli``.
"""

import importlib

from quadmodes._version import __version__

#: The public API: functions of :mod:`quadmodes.api`, the case types of :mod:`quadmodes.case`
#: and the exceptions the functions document (docs/api.md: what is public and stable). Every
#: problem a caller can fix is a :class:`QuadmodesError` (CaseError, QuantityError, InputError …
#: are its subclasses) whose message is the line the CLI prints.
__all__ = [
    "Case",
    "CaseError",
    "FullOrderIncomplete",
    "InputError",
    "QuadmodesError",
    "QuantityError",
    "RunCase",
    "__version__",
    "calibrate",
    "campbell",
    "case_to_toml",
    "cases",
    "changed",
    "compare",
    "dt_convergence",
    "format_quantity",
    "load",
    "modal_model",
    "mode_convergence",
    "model_case",
    "modes_summary",
    "open_results",
    "parse_quantity",
    "reduced_model",
    "results_dataset",
    "rotating",
    "run_case",
    "run_case_to_toml",
    "save_case",
    "si",
    "simulate",
    "summary",
    "sweep",
    "ureg",
    "write_results",
]

_FROM_CASE = {"Case", "CaseError", "QuantityError", "RunCase", "case_to_toml", "format_quantity",
              "parse_quantity", "run_case_to_toml"}  # fmt: skip
#: Exceptions of the API's functions, from the modules that raise them.
_ERRORS = {"FullOrderIncomplete": "quadmodes.analysis.comparison_run",
           "InputError": "quadmodes.errors", "QuadmodesError": "quadmodes.errors"}


def __getattr__(name: str):
    """Load a public name on first use (PEP 562): the API imports most of the package."""
    if name == "ureg":
        return importlib.import_module("quadmodes.case.units").ureg
    if name in _FROM_CASE:
        return getattr(importlib.import_module("quadmodes.case"), name)
    if name in _ERRORS:
        return getattr(importlib.import_module(_ERRORS[name]), name)
    if name in __all__:
        return getattr(importlib.import_module("quadmodes.api"), name)
    raise AttributeError(f"module 'quadmodes' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
