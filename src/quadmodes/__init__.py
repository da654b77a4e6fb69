"""quadmodes: spinning flexible bodies by the method of quadratic modes.

Pipeline, one subpackage per stage (see docs/architecture.md):
``case`` (TOML, units) -> ``mesh`` -> ``fe`` (elements, structure) -> ``structure`` (prestress,
modes, calibration) -> ``rom`` (quadratic modes, reduced model artifact, equations of motion,
integrators, diagnostics) -> ``runs`` (run cases, results) -> ``io`` (files, pictures).
On top: ``analysis`` (Campbell, rotating frame, comparison), ``validation``, ``cli``; beside:
``fullorder`` (the nonlinear finite-element reference).
"""

__version__ = "0.1.0"
