"""The reduced model of a case: :mod:`~quadmodes.models.build` builds it (structure → modes →
quadratic modes → artifact, about the state at rest or spinning; the mode spectrum; the Campbell
model) and is the one way in (:func:`~quadmodes.models.build.reduced_model_for`);
:mod:`~quadmodes.models.cache` only finds and stores the files (keys, lock, code hash),
:mod:`~quadmodes.models.cache_entries` lists and clears them; :mod:`~quadmodes.models.beam` is
the hub-clamped beam of a spin-up. Below both the runs and the full order."""
