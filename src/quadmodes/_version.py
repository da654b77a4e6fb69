"""The package version (one home; ``quadmodes.__version__`` re-exports it)."""

__version__ = "0.1.0"
