"""Case input: the TOML schema (validated, SI floats inside), quantities with units, and the
built-in case files in ``builtin/``."""
