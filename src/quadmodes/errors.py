"""The one exception type of quadmodes's API: :class:`QuadmodesError`.

Every problem a user can act on — a bad case or quantity, an input beyond a bound, an output
path that would overwrite someone's files, a model that does not converge, a checkpoint that
belongs to another case — is raised as a subclass of :class:`QuadmodesError` whose ``str`` is
the one line the command line prints after ``error:`` (the field or option, and the fix). The
subclasses keep the built-in base they always had (``CaseError`` is also a ``ValueError``,
``ConvergenceError`` a ``RuntimeError``), so older ``except ValueError`` code keeps working.

A leaf module (it imports nothing of quadmodes), so every layer can raise these.
"""

from __future__ import annotations

__all__ = ["InputError", "QuadmodesError"]


class QuadmodesError(Exception):
    """A problem the user can act on: ``str(exc)`` is one line naming the field or option and
    the fix; the CLI prints it as ``error: …`` and exits with status 2."""


class InputError(QuadmodesError, ValueError):
    """Bad input met below the case validation (a value or type a function of the API cannot
    use); raised by the API in place of a bare ``ValueError``/``TypeError``, with the same
    message (the original is chained as ``__cause__``)."""
