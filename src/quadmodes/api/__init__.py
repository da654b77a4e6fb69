"""The public Python API of quadmodes (re-exported by :mod:`quadmodes`): build or load cases
with quantities in any unit (:mod:`.cases`) and run every stage the command line runs
(:mod:`.compute`). Reference: docs/api.md."""

from quadmodes.api import cases as _cases
from quadmodes.api import compute as _compute
from quadmodes.api import results as _results
from quadmodes.api.boundary import api_function
from quadmodes.api.quantities import si as _si

# every public function behind the error boundary: a problem the caller can fix is a
# quadmodes.QuadmodesError with the CLI's message (api/boundary.py)
cases = api_function(_cases.cases)
changed = api_function(_cases.changed)
load = api_function(_cases.load)
model_case = api_function(_cases.model_case)
run_case = api_function(_cases.run_case)
save_case = api_function(_cases.save_case)
calibrate = api_function(_compute.calibrate)
campbell = api_function(_compute.campbell)
compare = api_function(_compute.compare)
dt_convergence = api_function(_compute.dt_convergence)
modal_model = api_function(_compute.modal_model)
mode_convergence = api_function(_compute.mode_convergence)
modes_summary = api_function(_compute.modes_summary)
reduced_model = api_function(_compute.reduced_model)
results_dataset = api_function(_compute.results_dataset)
rotating = api_function(_compute.rotating)
simulate = api_function(_compute.simulate)
summary = api_function(_compute.summary)
sweep = api_function(_compute.sweep)
write_results = api_function(_compute.write_results)
open_results = api_function(_results.open_results)
si = api_function(_si)

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
    "open_results",
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
