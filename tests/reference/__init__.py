"""Independent reference solutions used by the tests (no quadmodes code imported here).

``rotating_beam``: spectral Rayleigh–Ritz solution of a uniform free-free beam spinning about its
centre (flap, lag and axial motion in the rotating frame); ``closed_forms``: closed-form and
semi-analytic values it is checked against. See docs/rotating-beam-reference.md.
"""
