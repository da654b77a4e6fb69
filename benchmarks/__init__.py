"""Benchmarks and studies of quadmodes: plain scripts that print tables, not tests (nothing here
asserts on timings). Run them from the repository root as modules, e.g.
``python -m benchmarks.performance.bench_fe --help``; see benchmarks/README.md.

* ``benchmarks.performance``: timings, old against new side by side;
* ``benchmarks.studies``: one-issue physics studies (their figures are in the docs);
* ``benchmarks.common``: the helpers more than one script uses;
* ``benchmarks/cases/``: benchmark-only case files.
"""
