"""Performance benchmarks: they time a stage (FE kernels and builds, reduced integration, full-order
stepping, offline build, sweeps) and print the figures side by side (old tree against this one,
one back end against another, reduced against full order). Plain scripts; benchmarks/README.md."""
