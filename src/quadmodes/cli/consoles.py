"""The two consoles of the command line: progress, notes, warnings and errors on stderr
(``err``), results on stdout (``out``)."""

from rich.console import Console

#: Progress on stderr (bars, warnings, errors); results on stdout.
err = Console(stderr=True)
out = Console()
