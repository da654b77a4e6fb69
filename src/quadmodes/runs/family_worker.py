"""The worker process of :mod:`quadmodes.runs.family_prefetch`: ``python -P -m
quadmodes.runs.family_worker`` builds members of a spin family into the model cache
(:func:`quadmodes.models.build.reduced_model_for`, under the cache file's lock), one per request,
for as long as the run lasts (its state at rest stays in memory from one member to the next).

Why a module run by the interpreter and not a ``multiprocessing`` child: a spawned child imports
the caller's main module again (as ``__mp_main__``), so a library user's script without an
``if __name__ == "__main__":`` guard ran its own simulation again from the top and then failed
to start the pool (``BrokenProcessPool``, the run lost). Here ``__main__`` is this module, ``-P``
keeps the working folder off ``sys.path``, and a request naming any object of a ``__main__``
module is refused: the caller's script is never imported.

Protocol: each line on stdin is the path of a request file, a pickle the run wrote for this
worker alone (``mkstemp``: its owner's only) ``{"case", "n_modes", "spin" (rad/s), "axis"}``,
removed once read; for each, one line on stdout: ``ok PATH`` or ``failed PATH REASON`` (nothing
else: what else writes to stdout goes to stderr). End of stdin (the run closed it, or ended):
the worker exits. A SIGTERM unwinds like Ctrl-C, so an
interrupted cache write leaves no temporary file (:mod:`quadmodes.io.atomic`).
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import sys


class _Request(pickle.Unpickler):
    """The request's unpickler: no class of a ``__main__`` module (the caller's script)."""

    def find_class(self, module: str, name: str):
        if module in ("__main__", "__mp_main__"):
            raise pickle.UnpicklingError(f"the request names {module}.{name}: refused (the "
                                         "worker never imports the caller's script)")  # fmt: skip
        return super().find_class(module, name)


def read_request(path: str) -> dict:
    """The request at ``path`` (removed once read)."""
    try:
        with open(path, "rb") as fh:
            return _Request(fh).load()
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)


def build(path: str) -> str:
    """The member of the request file ``path`` built into the cache (or found there): the
    answer line, ``ok PATH`` or ``failed PATH REASON`` (also when the cache could not store it:
    a read-only cache, where building ahead is work for nothing)."""
    from quadmodes.models.build import reduced_model_for

    info: dict = {}
    try:
        request = read_request(path)
        reduced_model_for(request["case"], request["n_modes"], spin=request["spin"],
                          axis=request["axis"], info=info)  # fmt: skip
    except Exception as exc:  # noqa: BLE001  (the run builds the member itself then)
        reason = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
        return f"failed {path} {reason}"
    if str(info.get("cache", "")).startswith("not saved"):  # the run would not find it
        return f"failed {path} the member was built but {info['cache']} in the model cache"
    return f"ok {path}"


def _terminated(signum, frame):  # noqa: ARG001  (a signal handler's signature)
    raise SystemExit(128 + signum)


def main() -> int:
    """Answer the requests on stdin until it ends; the exit status."""
    signal.signal(signal.SIGTERM, _terminated)
    answers = os.fdopen(os.dup(1), "w", encoding="utf-8")  # the answers' own channel: whatever
    os.dup2(2, 1)  # else writes to stdout (a library's print, C code) goes to stderr instead
    sys.stdout = sys.stderr
    for line in sys.stdin:
        if line.strip():
            answers.write(build(line.strip()) + "\n")
            answers.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
