"""The Krylov path's preconditioner renewed on a second core, a fixed number of steps behind.

Why: on the flange-bonded ``paper-41hz`` (6,085 nodes) a renewal of the kept float32
factorisation (element blocks, their sum into the permuted data, SuperLU's ``gstrf``: about
110 ms of CPU) was a fifth of the stepping thread's time, and it was rationed (renewed by
cost, :data:`~quadmodes.fullorder.krylov.FACTOR_COST`), so the preconditioner aged 0–7 steps
and GMRES paid for its age in solves. SciPy's SuperLU and numpy's large operations release the
GIL, so a Python thread can factorise while the stepping thread solves.

The schedule (:class:`RenewalPipeline`): at the start of a step the factorisation launched
:data:`RENEWAL_LAG` steps earlier (at that step's start pair) is swapped in, waiting for it if
it is not done, and the next one is launched at the current pair. The swap happens at a step
count, never "when ready", so a run repeats bit for bit whatever the load of the machine and
gives the same answers with the work done inline (``threads=1`` of the schedule, the tests'
check). On a single core the schedule would cost a renewal every :data:`RENEWAL_LAG` steps on
the stepping thread, more than the rationed one; it is therefore used only with ``threads ≥ 2``
(:func:`default_threads`: 1 unless ``$QUADMODES_THREADS`` asks for more).
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable

import numpy as np

from quadmodes.errors import InputError

#: Renewals on a Python thread (False: the same schedule computed inline, for the tests'
#: check that the thread changes nothing).
BACKGROUND = True
#: Steps between the launch of a renewal and its swap (and between renewals): the
#: preconditioner is 2–3 steps old. A renewal (≈ 110 ms of CPU on paper-41hz) must fit in
#: this many steps of the stepping thread (≈ 50 ms each) for the stepping thread not to wait.
RENEWAL_LAG = 2
#: Build the renewal at the pair extrapolated to its swap step, ``2 z(n) − z(n − lag)``
#: (a smooth drift carried forward, while a component alternating at the Nyquist frequency,
#: the stiff rim's, is left where it is for an even lag).
EXTRAPOLATE = True
#: Launch a renewal only when the last step's Krylov steps exceed the mean per step since the
#: last swap, a renewal counted as this many Krylov steps (the rule of
#: :data:`~quadmodes.fullorder.krylov.FACTOR_COST`, with the renewal off the stepping
#: thread); None: as soon as the last one is swapped in.
RENEWAL_COST = None


def default_threads() -> int:
    """Threads a full-order run may use: ``$QUADMODES_THREADS`` if set, else 1.

    One thread by default because the second-core renewal changes the iterates (to the Newton
    tolerance, not bit for bit) and paid off only with the second core idle: on the shared
    2-core machine it measured 0.64–0.95× in wall time (docs/performance.md). So a run's
    numbers do not depend on the machine's core count unless the user asks for threads.
    Raises :class:`~quadmodes.errors.InputError` (one line naming the variable) for a value that is not a whole number ≥ 1.
    """
    given = os.environ.get("QUADMODES_THREADS", "").strip()
    if not given:
        return 1
    try:
        value = int(given)
    except ValueError:
        value = 0
    if value < 1:
        raise InputError(f"QUADMODES_THREADS={given!r}: give a whole number of threads ≥ 1 "
                         "(1: the full order on one thread, 2: its preconditioner renewed on a "
                         "second core)")
    return value


class _Inline:
    """A renewal computed at once on the calling thread (the same schedule, one core)."""

    def __init__(self, work: Callable, args: tuple):
        self._value = work(*args)

    def result(self):
        return self._value


class _Background:
    """A renewal computed on a Python thread; :meth:`result` waits for it (and re-raises)."""

    def __init__(self, work: Callable, args: tuple):
        self._value = self._error = None
        self._thread = threading.Thread(target=self._run, args=(work, args),
                                        name="quadmodes-renewal")  # fmt: skip
        self._thread.start()

    def _run(self, work: Callable, args: tuple) -> None:
        try:
            self._value = work(*args)
        except BaseException as err:  # handed to the stepping thread by result()
            self._error = err

    def result(self):
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._value


class RenewalPipeline:
    """Renewals of a preconditioner on the schedule of the module docstring.

    factor: ``(z0, z1) -> preconditioner`` at a body-frame pair (n,3) (called on the worker
    thread: it must not touch the stepping thread's state); lag: :data:`RENEWAL_LAG`;
    background: on a Python thread (False: inline, the same results)."""

    def __init__(self, factor: Callable, lag: int | None = None, background: bool = True):
        lag = RENEWAL_LAG if lag is None else lag
        if lag < 1:
            raise ValueError(f"renewal lag {lag}: at least one step")
        self.factor, self.lag, self.background = factor, lag, background
        self.steps = 0  # steps started with this pipeline
        self.launched = 0  # renewals launched (for the statistics)
        self.waited = 0.0  # s of wall time the stepping thread waited for them (diagnostics)
        self._pending = None
        self._swap_at = 0
        self._history = []  # the start pairs of the last `lag` steps, oldest first

    def step(self, z0: np.ndarray, z1: np.ndarray, wanted: bool = True):
        """Called at the start of every step with its start pair (z0, z1) (n,3), the first
        step being the one whose preconditioner was just made at that pair: the renewal due
        now (its result, waited for), or None. wanted: launch the next renewal now if none is
        under way (False: not yet)."""
        self.steps += 1
        pair = (np.array(z0, float), np.array(z1, float))
        past = self._history[0] if len(self._history) == self.lag else None
        self._history = [*self._history[1 - self.lag :], pair] if self.lag > 1 else [pair]
        due = None
        if self._pending is not None and self.steps >= self._swap_at:
            start = time.perf_counter()
            due, self._pending = self._pending.result(), None
            self.waited += time.perf_counter() - start
        if self._pending is None and self.steps > 1 and wanted:
            kind = _Background if self.background else _Inline
            if EXTRAPOLATE and past is not None:  # the pair expected at the swap
                pair = tuple(2.0 * now - then for now, then in zip(pair, past, strict=True))
            self._pending = kind(self.factor, pair)
            self._swap_at = self.steps + self.lag
            self.launched += 1
        return due
