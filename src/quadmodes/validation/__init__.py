"""The validation suites: measured rows against references (finite elements, reduced dynamics,
full order), written to ``docs/validation.md``."""
