"""The Dask cluster of a sweep: a local cluster that only this process can use, or an external
scheduler reached over Dask's own TLS, whose workers are checked and configured like local ones.

* **Local** (:func:`local_client`): scheduler and workers bind to the loopback interface only,
  talk TLS with a key pair made for this sweep alone (:meth:`distributed.Security.temporary`):
  a second process on the machine cannot submit work (it has no certificate; a plain TCP
  connection is refused at the handshake). The dashboard, when Dask can start one, listens on
  loopback too.
* **External** (:func:`external_client`): the scheduler's address, with the TLS files from the
  Dask configuration (``DASK_DISTRIBUTED__COMM__TLS__CA_FILE``, ``…__CLIENT__CERT``,
  ``…__CLIENT__KEY``, or ``distributed.comm.tls`` in a Dask config file; docs/sweeps.md). Every
  worker must run this quadmodes version (checked; one line naming the workers otherwise), and
  each worker, present or joining later, gets the client's cache folder and one BLAS/OpenMP
  thread (:class:`WorkerSetup`).
* **Lost workers** are counted (:func:`lost_workers`): Dask reruns their points elsewhere; the
  sweep says so.
"""

from __future__ import annotations

import contextlib
import os
import signal
from collections.abc import Iterator

from quadmodes._version import __version__
from quadmodes.models.cache import cache_dir
from quadmodes.sweeps.params import SweepError

#: Environment of every worker: one BLAS/OpenMP/numba thread each (one worker per core).
WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "NUMBA_NUM_THREADS": "1"}  # fmt: skip
#: Where a local cluster listens.
LOOPBACK = "127.0.0.1"


def _security():
    """A TLS key pair for this sweep only (``distributed.Security.temporary``), or a
    :class:`SweepError` naming the missing package."""
    from distributed import Security

    try:
        return Security.temporary()
    except ImportError:
        raise SweepError("sweep: the local cluster needs the package `cryptography` for its "
                         "private TLS key (pip install cryptography)") from None  # fmt: skip


@contextlib.contextmanager
def local_client(workers: int | None = None) -> Iterator:
    """A Client on a new LocalCluster of ``workers`` processes (default one per core), one thread
    each, on loopback over TLS with a key of its own (module docstring)."""
    import dask
    from distributed import Client, LocalCluster

    security = _security()
    n = workers or os.cpu_count() or 1
    env = {**WORKER_ENV, "QUADMODES_CACHE": str(cache_dir())}
    if "PYTHONPATH" in os.environ:
        env["PYTHONPATH"] = os.environ["PYTHONPATH"]
    with dask.config.set({"distributed.scheduler.allowed-failures": 1,
                          "distributed.nanny.pre-spawn-environ": env}):  # fmt: skip
        with contextlib.ExitStack() as stack:
            with _children_ignore_ctrl_c():
                cluster = stack.enter_context(LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, host=LOOPBACK,
                    protocol="tls://", security=security, dashboard_address=f"{LOOPBACK}:0",
                    worker_dashboard_address=None, env=env))  # fmt: skip
            yield stack.enter_context(Client(cluster, security=security, set_as_default=False))


@contextlib.contextmanager
def _children_ignore_ctrl_c() -> Iterator[None]:
    """Inside, Ctrl-C is ignored, and so in the worker processes started here for good (an
    ignored SIGINT is inherited through exec, and Python then installs no KeyboardInterrupt
    handler): a Ctrl-C in the terminal reaches the whole process group, and only the parent
    must act on it (say where the finished points are and close the cluster), not every worker
    with its own traceback. Outside the main thread nothing changes."""
    try:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _worker_version() -> str:
    """The quadmodes version of the worker this runs on ("missing" without quadmodes)."""
    try:
        from quadmodes._version import __version__ as version
    except ImportError:  # pragma: no cover - a worker without the package
        return "missing"
    return version


def worker_setup(cache: str):
    """A :class:`WorkerSetup` plugin for the cache folder ``cache`` (distributed is imported
    here, when a cluster is used)."""
    return _plugin_class()(cache)


def _plugin_class():
    from distributed.diagnostics.plugin import WorkerPlugin

    class _WorkerSetup(WorkerSetup, WorkerPlugin):
        pass

    return _WorkerSetup


class WorkerSetup:
    """Worker plugin (``Client.register_plugin``): the client's cache folder and the thread
    limits of :data:`WORKER_ENV`, applied when a worker joins (and to the present ones); BLAS
    libraries the worker loaded before are limited to one thread by ``threadpoolctl``."""

    name = "quadmodes-worker-setup"

    def __init__(self, cache: str):
        self.cache = cache

    def setup(self, worker=None) -> None:
        from threadpoolctl import threadpool_limits

        os.environ.update({**WORKER_ENV, "QUADMODES_CACHE": self.cache})
        threadpool_limits(1)  # BLAS pools loaded before the environment took effect


def check_workers(client) -> dict[str, str]:
    """The quadmodes version of every worker (address → version); a :class:`SweepError` naming
    the workers whose version differs from this one's."""
    versions = client.run(_worker_version)
    wrong = {w: v for w, v in versions.items() if v != __version__}
    if wrong:
        listed = ", ".join(f"{w} ({v})" for w, v in sorted(wrong.items()))
        raise SweepError(f"--scheduler: workers run another quadmodes version than this one "
                         f"({__version__}): {listed}; install {__version__} on them")  # fmt: skip
    return versions


@contextlib.contextmanager
def external_client(scheduler: str) -> Iterator:
    """A Client on the scheduler at ``scheduler`` with the TLS settings of the Dask configuration
    (none: plain TCP, as the address says); its workers checked (:func:`check_workers`) and set
    up (:class:`WorkerSetup`)."""
    from distributed import Client, Security

    try:
        client = Client(scheduler, timeout="5s", set_as_default=False, security=Security())
    except (OSError, TimeoutError, ValueError) as exc:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise SweepError(f"--scheduler {scheduler}: cannot reach the scheduler ({reason}); "
                         "start one with `dask scheduler` and workers with `dask worker "
                         "ADDRESS` (TLS: docs/sweeps.md), or drop --scheduler for a local "
                         "cluster") from None  # fmt: skip
    with client:
        check_workers(client)
        client.register_plugin(worker_setup(str(cache_dir())))
        yield client


def lost_workers(before: set[str], client) -> list[str]:
    """Workers of ``before`` (addresses) that have left the cluster of ``client``."""
    try:
        now = set(client.scheduler_info().get("workers", {}))
    except (OSError, TimeoutError):
        return sorted(before)
    return sorted(before - now)
