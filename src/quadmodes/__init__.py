"""quadmodes: spinning flexible bodies by the method of quadratic modes.

Pipeline (one module per stage, see docs/architecture.md):
geometry/mesh -> finite elements -> prestress -> modes -> quadratic modes -> reduced model
-> time integration -> diagnostics -> results.
"""

__version__ = "0.1.0"
