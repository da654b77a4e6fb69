"""One-issue physics studies: each compares models or measures a physical or numerical property
(reduced potentials, large amplitude, wrinkling, long windows, damping, mesh convergence,
conservation) and prints the tables the docs quote. Plain scripts; benchmarks/README.md."""
