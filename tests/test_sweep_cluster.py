"""The sweep's Dask cluster: a local cluster only this process can use (loopback, TLS with a key
of its own); an external scheduler's workers are checked for the version and configured like
local ones (issue 24 item 6, issue 25 item 8)."""

import os

import pytest

pytest.importorskip("distributed")

from distributed import Client  # noqa: E402

from quadmodes.sweeps import cluster  # noqa: E402
from quadmodes.sweeps.params import SweepError  # noqa: E402


@pytest.fixture(scope="module")
def local():
    with cluster.local_client(1) as client:
        yield client


def test_local_cluster_listens_on_loopback_over_tls(local):
    address = local.scheduler.address
    assert address.startswith(f"tls://{cluster.LOOPBACK}:")
    assert all(w.startswith(f"tls://{cluster.LOOPBACK}:") for w in local.nthreads())
    assert local.submit(os.getpid).result() != os.getpid()  # the owner's client works


def test_a_strangers_connection_is_refused(local):
    """A second process on the machine, without the sweep's key, cannot reach the scheduler:
    neither over TLS without a certificate nor over plain TCP on the same port."""
    address = local.scheduler.address
    port = address.rsplit(":", 1)[1]
    for attempt in (address, f"tcp://{cluster.LOOPBACK}:{port}"):
        with pytest.raises((OSError, TimeoutError, ValueError, TypeError)):
            stranger = Client(attempt, timeout="3s", set_as_default=False)
            stranger.close()


def test_worker_setup_gives_the_cache_folder_and_one_thread(local, tmp_path):
    local.register_plugin(cluster.worker_setup(str(tmp_path)))
    env = local.run(lambda: {k: os.environ.get(k) for k in ("QUADMODES_CACHE", "OPENBLAS_NUM_THREADS")})
    for values in env.values():
        assert values == {"QUADMODES_CACHE": str(tmp_path), "OPENBLAS_NUM_THREADS": "1"}

    def blas_threads():
        from threadpoolctl import threadpool_info

        return [pool["num_threads"] for pool in threadpool_info()]

    for pools in local.run(blas_threads).values():
        assert all(n == 1 for n in pools)


def test_workers_of_another_version_are_refused(local, monkeypatch):
    assert set(cluster.check_workers(local).values()) == {cluster.__version__}
    monkeypatch.setattr(cluster, "__version__", "0.0.0-other")
    with pytest.raises(SweepError, match="another quadmodes version"):
        cluster.check_workers(local)


def test_a_lost_worker_is_named(local):
    before = set(local.nthreads()) | {"tls://127.0.0.1:1"}
    assert cluster.lost_workers(before, local) == ["tls://127.0.0.1:1"]


def test_a_ctrl_c_reaches_the_parent_only(local):
    """A Ctrl-C in the terminal goes to the whole process group: the workers ignore it (the
    parent says where the finished points are and closes the cluster) instead of each dying
    with its own traceback."""
    import signal

    assert set(local.run(lambda: signal.getsignal(signal.SIGINT) is signal.SIG_IGN).values()) == {True}
    pids = local.run(os.getpid)
    for pid in pids.values():
        os.kill(pid, signal.SIGINT)  # ignored: the same workers answer afterwards
    assert local.run(os.getpid) == pids


def test_the_parent_keeps_its_own_ctrl_c_handler():
    """Ctrl-C is ignored only while the workers are spawned; the parent's handler (whatever it
    was: a test runner started in the background has SIG_IGN) is put back."""
    import signal

    def mine(signum, frame):  # pragma: no cover - never called
        pass

    before = signal.signal(signal.SIGINT, mine)
    try:
        with cluster._children_ignore_ctrl_c():
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        assert signal.getsignal(signal.SIGINT) is mine
    finally:
        signal.signal(signal.SIGINT, before)
