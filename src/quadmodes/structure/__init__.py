"""The structure before reduction: prestress (inflation), free-free modes and their labels,
calibration of end bodies, and the glue that builds a modal model from a case."""
