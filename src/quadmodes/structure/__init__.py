"""The structure before reduction: prestress (inflation), free-free modes and their labels,
calibration of end bodies, the bordered sparse solves they share, and the glue
(:mod:`quadmodes.structure.pipeline`) that builds a modal model from a case."""
