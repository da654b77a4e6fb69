"""The reduced-order model: quadratic modes and the precomputed arrays, the artifact file, the
equations of motion (formulations Q, P, L, rigid, Q4), the integrators with the compiled
midpoint kernel, and the diagnostics of a solution."""
