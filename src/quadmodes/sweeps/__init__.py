"""Parameter sweeps of a run case on dask.distributed: stability maps, critical speeds, coning
time constants and the energy-sink estimate (docs/sweeps.md).

Modules: ``params`` (``PATH=VALUES`` → parameters, the grid), ``overrides`` (values into the run
and model case, validated), ``points`` (one point: model, time run, roots, energy sink),
``energy_sink`` (the estimate), ``critical`` (critical speeds), ``engine`` (dask execution,
per-point files, resume), ``dataset`` (``sweep.nc``), ``plots`` (figures).
"""
