"""The next member of a spin family built ahead, on another core, while the current one
integrates (:mod:`quadmodes.runs.spin_family`).

The spin along a coning path changes monotonically (it falls on a prolate body as the cone
opens), and the spacing fixes where the next member lies before the current segment starts
(:meth:`~quadmodes.runs.family_spacing.AdaptiveSpacing.predicted`): a worker process builds that
member into the model cache (:mod:`quadmodes.runs.family_worker`, under the cache file's lock),
and the switch then finds it there (or waits for the worker to finish it). The members are the
same arrays either way (the cache stores them exactly), so the path does not depend on whether a
member was prefetched. Used when the machine has at least two cores (:data:`MIN_CORES`) and the
cache is on.

The worker is ``python -P -m quadmodes.runs.family_worker``, one process for the run (its state
at rest stays in memory from one member to the next), asked for one member at a time (a request
file's path on its stdin, the answer on its stdout), with one BLAS/OpenMP thread
(:data:`WORKER_ENV`), this process's cache folder and this package on its path: never a
``multiprocessing`` child, which would import the caller's main module again (a script without
an ``if __name__ == "__main__":`` guard ran its simulation twice, and the run failed). Building ahead never fails a run: a worker that cannot start or fails is
logged once (a warning), and from then on every member is built in the run's process, as
without building ahead. :meth:`Prefetcher.close` (the run's end, an exception, Ctrl-C)
terminates the worker and removes the request files it has not read.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import pickle
import site
import subprocess
import sys
import tempfile
from pathlib import Path

log = logging.getLogger(__name__)

#: Prefetch only with at least this many cores (the build runs beside the integration).
MIN_CORES = 2
#: Prefetch at all (False: every member built in the run's process, when the switch needs it).
ENABLED = True
#: The worker's environment on top of this process's: one BLAS/OpenMP thread (it shares the
#: machine with the integration).
WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "NUMBA_NUM_THREADS": "1"}  # fmt: skip
#: Seconds a terminated worker gets to unwind (its temporary files removed) before it is killed.
TERMINATE_WAIT_S = 10.0
#: The worker's module (run with ``python -P -m``).
WORKER_MODULE = "quadmodes.runs.family_worker"


def worker_environment() -> dict[str, str]:
    """The worker's environment: this one's, :data:`WORKER_ENV`, this process's cache folder
    and, for a package outside the interpreter's site folders, its folder first on
    ``PYTHONPATH`` (the worker builds with this code, whatever ``sys.path`` the caller set)."""
    from quadmodes.models.cache import cache_dir

    env = {**os.environ, **WORKER_ENV, "QUADMODES_CACHE": str(cache_dir())}
    root = os.path.realpath(Path(__file__).resolve().parents[2])
    found = [*getattr(site, "getsitepackages", list)(), site.getusersitepackages()]
    sites = {os.path.realpath(p) for p in found}
    if root not in sites:  # a source tree (else the interpreter finds this package anyway)
        path = env.get("PYTHONPATH")
        env["PYTHONPATH"] = root + (os.pathsep + path if path else "")
    return env


class Prefetcher:
    """One worker process (started at the first prediction) building the predicted members of
    a family, in the order asked; ``enabled`` False (one core, the cache off, or after a worker
    failed): every call does nothing. ``python``: the worker's interpreter (default
    ``sys.executable``)."""

    def __init__(self, setup, enabled: bool | None = None, python: str | None = None):
        from quadmodes.models.cache import caching_enabled

        if enabled is None:
            enabled = ENABLED and (os.cpu_count() or 1) >= MIN_CORES and caching_enabled()
        self.setup, self.enabled = setup, enabled
        self.python = sys.executable if python is None else python
        self.worker: subprocess.Popen | None = None
        self.errors = None  # the worker's stderr (an unnamed temporary file)
        self.pending: dict[float, str] = {}  # spin (rad/s) -> request file, not waited for
        self.answers: dict[str, str] = {}  # request file -> "ok" or why it failed, not waited for

    def ahead(self, spin: float | None) -> None:
        """Ask for the member about ``spin`` (rad/s; None: no prediction)."""
        if not self.enabled or spin is None or spin in self.pending:
            return
        try:
            if self.worker is None:
                self._start()
            run = self.setup.run
            name = _request_file({"case": self.setup.model_case, "n_modes": run.reduced.modes,
                                  "spin": float(spin), "axis": run.reference_axis})  # fmt: skip
            self.pending[spin] = name
            self.worker.stdin.write(f"{name}\n".encode())
            self.worker.stdin.flush()
        except Exception as exc:  # noqa: BLE001  (building ahead never fails the run)
            ended = self.worker is not None and self.worker.poll() is not None
            tail = self._stderr_tail() if ended else ""
            self._failed(spin, f"{type(exc).__name__}: {exc}{tail}")

    def _start(self) -> None:
        self.errors = tempfile.TemporaryFile()
        self.worker = subprocess.Popen(  # noqa: S603  (this interpreter, this package's module)
            [self.python, "-P", "-m", WORKER_MODULE], env=worker_environment(),
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.errors)  # fmt: skip

    def wait(self, spin: float, progress=None) -> None:
        """Wait for a build of ``spin`` asked for (its failure is logged: the caller builds);
        ``progress(stage, fraction)``: told while it waits."""
        name = self.pending.get(spin)
        if name is None or self.worker is None:
            return
        stage = f"member about {spin / (2 * math.pi):.6g} Hz, built ahead"
        waits = name not in self.answers and progress is not None
        try:
            if waits:
                progress(stage, 0.0)
            while name not in self.answers:
                self._read_answer()
        except BaseException:  # Ctrl-C while waiting: the worker does not outlive the wait
            self.close()
            raise
        del self.pending[spin]
        answer = self.answers.pop(name)
        if waits:
            progress(stage, 1.0)
        if answer != "ok":
            self._failed(spin, answer)

    def _read_answer(self) -> None:
        """The worker's next answer line into :attr:`answers` (request file → "ok" or why it
        failed); the worker's end: every request still unanswered failed."""
        raw = self.worker.stdout.readline()
        line = raw.decode(errors="replace").rstrip("\n")
        if not raw:
            why = f"the worker ended (exit status {self.worker.wait()}){self._stderr_tail()}"
            self.answers.update({n: why for n in self.pending.values() if n not in self.answers})
            return
        for name in self.pending.values():
            if line == f"ok {name}":
                self.answers[name] = "ok"
            elif line.startswith(f"failed {name} "):
                self.answers[name] = line[len(f"failed {name} ") :]

    def _stderr_tail(self) -> str:
        """The last line the worker wrote to stderr, as ": LINE" (or "")."""
        try:
            self.errors.seek(0)
            text = self.errors.read().decode(errors="replace")
            lines = [s for s in text.splitlines() if s.strip()]
        except (OSError, ValueError, AttributeError):
            return ""
        return f": {lines[-1][:300]}" if lines else ""

    def _failed(self, spin: float, why: str) -> None:
        """Log the failure once; no building ahead for the rest of the run."""
        log.warning("spin family: building the member about %.6g rad/s ahead failed (%s); the "
                    "members are built in the run's process", spin, why)  # fmt: skip
        self.enabled = False
        self.close()

    def close(self) -> None:
        """Stop the worker (it unwinds: :mod:`quadmodes.runs.family_worker`; killed if it does
        not end within :data:`TERMINATE_WAIT_S`) and remove the requests it has not read."""
        worker, self.worker = self.worker, None
        if worker is not None:
            if worker.poll() is None:
                worker.terminate()
            try:
                worker.communicate(timeout=TERMINATE_WAIT_S)
            except subprocess.TimeoutExpired:
                worker.kill()
                worker.communicate()
        for name in self.pending.values():
            with contextlib.suppress(OSError):
                os.unlink(name)
        self.pending.clear()
        self.answers.clear()
        if self.errors is not None:
            self.errors.close()
            self.errors = None


def _request_file(request: dict) -> str:
    """A request written for the worker alone (``mkstemp``: its owner's only); its path."""
    fd, name = tempfile.mkstemp(prefix="quadmodes-member-", suffix=".pickle")
    try:
        with os.fdopen(fd, "wb") as fh:
            pickle.dump(request, fh, protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(name)
        raise
    return name
