"""The next member of a spin family built ahead, on another core, while the current one
integrates (:mod:`quadmodes.runs.spin_family`).

The spin along a coning path changes monotonically (it falls on a prolate body as the cone
opens), and the spacing fixes where the next member lies before the current segment starts
(:meth:`~quadmodes.runs.family_spacing.AdaptiveSpacing.predicted`): a worker process builds that
member into the model cache (:func:`quadmodes.models.build.reduced_model_for`, under the cache
file's lock), and the switch then finds it there (or waits for the lock while it is finished).
The members are the same arrays either way (the cache stores them exactly), so the path does
not depend on whether a member was prefetched. Used when the machine has at least two cores
(:data:`MIN_CORES`) and the cache is on.
"""

from __future__ import annotations

import concurrent.futures as cf
import logging
import multiprocessing
import os

log = logging.getLogger(__name__)

#: Prefetch only with at least this many cores (the build runs beside the integration).
MIN_CORES = 2
#: Prefetch at all (False: every member built in the run's process, when the switch needs it).
ENABLED = True


def _build(case, modes, spin: float, axis) -> None:
    """The worker: the member about ``spin`` (rad/s) into the cache (nothing returned)."""
    from quadmodes.models.build import reduced_model_for

    reduced_model_for(case, modes, spin=spin, axis=axis)


class Prefetcher:
    """One worker process building the predicted next member of a family; ``enabled`` False
    (one core, the cache off): every call does nothing."""

    def __init__(self, setup, enabled: bool | None = None):
        from quadmodes.models.cache import caching_enabled

        if enabled is None:
            enabled = ENABLED and (os.cpu_count() or 1) >= MIN_CORES and caching_enabled()
        self.setup, self.enabled = setup, enabled
        self.pool: cf.ProcessPoolExecutor | None = None
        self.pending: dict[float, cf.Future] = {}

    def ahead(self, spin: float | None) -> None:
        """Start building the member about ``spin`` (rad/s; None: no prediction)."""
        if not self.enabled or spin is None or spin in self.pending:
            return
        if self.pool is None:
            self.pool = cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
        run = self.setup.run
        self.pending[spin] = self.pool.submit(_build, self.setup.model_case, run.reduced.modes,
                                              spin, run.reference_axis)  # fmt: skip

    def wait(self, spin: float) -> None:
        """Wait for a build of ``spin`` under way (its failure is logged: the caller builds)."""
        future = self.pending.pop(spin, None)
        if future is None:
            return
        try:
            future.result()
        except Exception as exc:  # noqa: BLE001  (the member is built in this process then)
            log.info("prefetch of the member about %.6g rad/s failed: %s", spin, exc)

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=False, cancel_futures=True)
            self.pool = None
