"""The public Python API of quadmodes (re-exported by :mod:`quadmodes`): build or load cases
with quantities in any unit (:mod:`.cases`) and run every stage the command line runs
(:mod:`.compute`). Reference: docs/api.md."""

from quadmodes.api.cases import cases, changed, load, model_case, run_case, save_case
from quadmodes.api.compute import (
    calibrate,
    campbell,
    compare,
    dt_convergence,
    modal_model,
    mode_convergence,
    modes_summary,
    reduced_model,
    results_dataset,
    rotating,
    simulate,
    summary,
    sweep,
    write_results,
)
from quadmodes.api.quantities import si

__all__ = [
    "calibrate",
    "campbell",
    "cases",
    "changed",
    "compare",
    "dt_convergence",
    "load",
    "modal_model",
    "mode_convergence",
    "model_case",
    "modes_summary",
    "reduced_model",
    "results_dataset",
    "rotating",
    "run_case",
    "save_case",
    "si",
    "simulate",
    "summary",
    "sweep",
    "write_results",
]
