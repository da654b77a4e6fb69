"""Analyses built on the reduced model and the full order: Campbell diagrams, the
rotating-frame full-order linearisation, and reduced-vs-full-order comparison."""
