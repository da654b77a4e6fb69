"""The API's error boundary: every public function raises :class:`~quadmodes.errors.QuadmodesError`
for a problem the caller can fix, with the message the command line prints.

Errors of quadmodes's own types pass unchanged. A bare ``ValueError`` met inside (a value a
stage cannot use, which the CLI also reports as ``error: …``) becomes an
:class:`~quadmodes.errors.InputError` with the same message; arguments that do not fit the
function's signature (an unknown keyword, a missing argument) become one naming the parameters.
The original exception is chained (``__cause__``), so nothing is hidden from a debugger.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any, TypeVar

from quadmodes.errors import InputError, QuadmodesError

F = TypeVar("F", bound=Callable[..., Any])


def _signature_error(function: Callable[..., Any], exc: TypeError) -> InputError:
    """One line naming ``function``'s parameters after a call that does not fit them."""
    names = ", ".join(inspect.signature(function).parameters)
    return InputError(f"{function.__name__}(): {exc}; its parameters are: {names}")


def api_function(function: F) -> F:
    """``function`` with the API's error boundary (see the module's docstring)."""
    signature = inspect.signature(function)

    @functools.wraps(function)
    def boundary(*args: Any, **kwargs: Any) -> Any:
        try:
            signature.bind(*args, **kwargs)
        except TypeError as exc:
            raise _signature_error(function, exc) from None
        try:
            return function(*args, **kwargs)
        except QuadmodesError:
            raise
        except ValueError as exc:
            raise InputError(str(exc)) from exc

    return boundary  # type: ignore[return-value]
