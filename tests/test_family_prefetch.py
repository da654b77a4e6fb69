"""Members of a spin family built ahead in a worker process (quadmodes.runs.family_prefetch,
quadmodes.runs.family_worker).

The small capsule spun at 300 rad/s, coning 10°, members 1e-6 apart in spin (its spin wanders:
a switch every chunk or two in 0.04 s). Asserted: a library user's script without an
``if __name__ == "__main__":`` guard runs once and its run completes (a multiprocessing child
imported the script again and the run failed); the path with every member after the first built
by the worker, in its own process, is the path with every member built in the run's process,
bit for bit (fresh caches both), and a model built in the process is laid out as one read from
the cache; a worker that cannot start or fails is logged once and the run goes on, the same
path; the worker and its request files do not outlive the run (its end, Ctrl-C, an error); the
worker answers every request, never looks up a class of ``__main__``, and its answers can be
waited for in any order; it runs with one BLAS thread and this process's cache and code.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from test_run import run_toml
from test_spin_family import stop_at_chunk

from quadmodes.case import load_run_case
from quadmodes.runs import family_prefetch as fp
from quadmodes.runs import simulate as sim
from quadmodes.runs import spin_family as sf

SRC = Path(__file__).resolve().parents[1] / "src"


def _family_case(folder: Path) -> Path:
    from conftest import SMALL_CAPSULE

    (folder / "small.toml").write_text(SMALL_CAPSULE, encoding="utf-8")
    text = run_toml(spin='"300 rad/s"', cone='"10 deg"', amplitude='"0 in"', duration='"0.04 s"',
                    dt='"0.2 ms"', save_every="50")  # fmt: skip
    text = text.replace('formulation = "Q"', 'formulation = "Q"\nreference = "spinning"\n'
                        'path_model = "spin-family"\npath_switch = 1e-6')  # fmt: skip
    (folder / "fam.toml").write_text(text, encoding="utf-8")
    return folder / "fam.toml"


@pytest.fixture
def family(tmp_path, monkeypatch):
    """(the run case, a function giving a fresh private cache folder); request files in a
    private temporary folder (``tmp``, empty when a run has cleaned up)."""
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    caches = iter(range(10))

    def fresh_cache() -> None:
        monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / f"cache{next(caches)}"))

    return load_run_case(_family_case(tmp_path)), fresh_cache, tmp_path / "tmp"


@pytest.fixture
def workers(monkeypatch):
    """The worker processes the prefetchers of this test started (forced on: one core is
    enough)."""
    monkeypatch.setattr(fp, "ENABLED", True)
    monkeypatch.setattr(fp, "MIN_CORES", 1)
    started, start = [], fp.Prefetcher._start

    def recorded(self):
        start(self)
        started.append(self.worker)

    monkeypatch.setattr(fp.Prefetcher, "_start", recorded)
    return started


def _builds_in_this_process(monkeypatch) -> list:
    """The spins (rad/s) of the reduced models built in this process from now on."""
    from quadmodes.models import build

    spins, real = [], build.build_reduced_model
    monkeypatch.setattr(build, "build_reduced_model",
                        lambda case, n, progress=None, spin=0.0, axis=None:
                        spins.append(spin) or real(case, n, progress, spin, axis))  # fmt: skip
    return spins


def test_unguarded_script_runs_once(tmp_path):
    """A script calling the library at its top level (no ``__main__`` guard), building ahead
    forced on: it completes (status 0), its top-level code ran once, members were switched."""
    case = _family_case(tmp_path)
    script = tmp_path / "user_script.py"
    script.write_text(textwrap.dedent(f"""
        from quadmodes.case import load_run_case
        from quadmodes.runs import family_prefetch
        from quadmodes.runs.simulate import simulate

        family_prefetch.MIN_CORES = 1
        with open({str(tmp_path / "ran.txt")!r}, "a") as f:
            f.write("ran\\n")
        result = simulate(load_run_case({str(case)!r}))
        print("members", len(result.family) + 1, result.complete)
    """), encoding="utf-8")  # fmt: skip
    env = {**os.environ, "QUADMODES_CACHE": str(tmp_path / "cache"), "PYTHONPATH": str(SRC),
           "OPENBLAS_NUM_THREADS": "1"}  # fmt: skip
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "ran.txt").read_text().splitlines() == ["ran"]
    members, complete = done.stdout.split()[1:]
    assert int(members) >= 3 and complete == "True"
    assert "failed" not in done.stderr


def test_members_built_ahead_give_the_same_path(family, workers, monkeypatch):
    """Every member after the first built by the worker (asked for in the order the path
    takes them), each run in a fresh cache: the run's process builds only the first member, and
    the path is the one of members all built in the run's process, bit for bit."""
    run, fresh_cache, tmp = family
    monkeypatch.setattr(fp, "ENABLED", False)
    fresh_cache()
    alone = sim.simulate(run)
    order = [sw.spin_to for sw in alone.family]
    assert len(order) >= 2
    monkeypatch.setattr(fp, "ENABLED", True)

    class AllAhead(fp.Prefetcher):
        """Asks for every member of the path when the run starts."""

        def __init__(self, setup):
            super().__init__(setup)
            self.ahead(None)

        def ahead(self, spin):
            for w in order:
                super().ahead(w)

    monkeypatch.setattr(sf, "Prefetcher", AllAhead)
    fresh_cache()
    built = _builds_in_this_process(monkeypatch)
    ahead = sim.simulate(run)
    assert built == [run.reference_spin]  # the first member; the rest from the worker
    np.testing.assert_array_equal(ahead.solution.y, alone.solution.y)
    np.testing.assert_array_equal(ahead.diagnostics.E + ahead.diagnostics.E_d,
                                  alone.diagnostics.E + alone.diagnostics.E_d)  # fmt: skip
    assert ahead.family == alone.family
    assert len(workers) == 1 and workers[0].poll() is not None  # ended with the run
    assert not list(tmp.iterdir())  # no request file left


@pytest.mark.parametrize("broken", ["interpreter", "module"])
def test_failing_worker_does_not_fail_the_run(family, workers, monkeypatch, caplog, broken):
    """A worker that cannot start (no such interpreter) or ends at once (no such module): one
    warning, the members built in the run's process, the path the same."""
    run, fresh_cache, tmp = family
    fresh_cache()
    monkeypatch.setattr(fp, "ENABLED", False)
    alone = sim.simulate(run)
    monkeypatch.setattr(fp, "ENABLED", True)
    if broken == "interpreter":
        monkeypatch.setattr(fp.sys, "executable", str(tmp / "no-such-python"))
    else:
        monkeypatch.setattr(fp, "WORKER_MODULE", "quadmodes.runs.no_such_worker")
    fresh_cache()
    with caplog.at_level(logging.WARNING, logger=fp.__name__):
        result = sim.simulate(run)
    warned = [r for r in caplog.records if r.name == fp.__name__]
    assert len(warned) == 1 and "ahead failed" in warned[0].getMessage()
    assert result.complete
    np.testing.assert_array_equal(result.solution.y, alone.solution.y)
    assert all(w.poll() is not None for w in workers) and not list(tmp.iterdir())


@pytest.mark.parametrize("stop", [KeyboardInterrupt, RuntimeError])
def test_a_stopped_run_leaves_no_worker(family, workers, monkeypatch, stop):
    """Ctrl-C (or an error) in the run's third chunk, members asked for ahead: the run stops
    (Ctrl-C: with its partial path), the worker has ended and no request file is left."""
    from quadmodes.runs.chunked import Interrupted

    run, fresh_cache, tmp = family
    fresh_cache()
    stop_at_chunk(monkeypatch, 3, stop)
    with pytest.raises(Interrupted if stop is KeyboardInterrupt else stop):
        sim.execute(sim.prepare(run))
    assert workers and all(w.poll() is not None for w in workers)
    assert not list(tmp.iterdir())


@pytest.mark.timeout(120)
def test_answers_waited_for_out_of_order(family, workers):
    """Two members asked for, the second waited for first, then the first (a guess the path
    did not take at once): no wait hangs on an answer read on the way, both are in the cache
    (found there, not built in this process), nothing logged."""
    from quadmodes.models import cache

    run, fresh_cache, tmp = family
    fresh_cache()
    setup = sim.prepare(run)
    spins = [run.reference_spin * (1.0 + 2e-6), run.reference_spin * (1.0 - 2e-6)]
    prefetch = fp.Prefetcher(setup, enabled=True)
    try:
        for w in spins:
            prefetch.ahead(w)
        for w in spins[::-1]:
            prefetch.wait(w)
        assert prefetch.enabled and not prefetch.pending
    finally:
        prefetch.close()
    case, axis = setup.model_case, run.reference_axis
    for w in spins:
        assert cache.find_model(case, 5, cache.cache_path(case, 5, w, axis), w, axis)[1] == "hit"
    assert workers[0].poll() is not None and not list(tmp.iterdir())


def test_worker_environment(monkeypatch, tmp_path):
    """The worker: one BLAS/OpenMP thread, this process's cache folder, this package's code."""
    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "c"))
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    env = fp.worker_environment()
    assert all(env[k] == "1" for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"))
    assert env["QUADMODES_CACHE"] == str(tmp_path / "c")
    assert env["PYTHONPATH"].split(os.pathsep)[0] == os.path.realpath(SRC)  # a source tree: first


def test_worker_answers_every_request_and_refuses_main(tmp_path):
    """The worker alone: a request file that is missing and one naming a class of ``__main__``
    (never looked up: refused) each get their ``failed`` line; the worker exits 0 at the end of
    its input."""
    missing, main = tmp_path / "missing.pickle", tmp_path / "main.pickle"
    main.write_bytes(b"c__main__\nScript\n)R.")  # GLOBAL __main__.Script, called: protocol 0
    done = subprocess.run([sys.executable, "-P", "-m", fp.WORKER_MODULE], input=f"{missing}\n{main}\n",
                          env=fp.worker_environment(), capture_output=True, text=True, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert len(lines) == 2 and lines[0].startswith(f"failed {missing} FileNotFoundError")
    assert lines[1].startswith(f"failed {main} UnpicklingError: the request names __main__.Script: refused")
    assert not main.exists()  # removed once read


def test_a_model_built_here_is_laid_out_as_one_read_from_the_cache(tmp_path, monkeypatch):
    """A member built in this process and the same member read from the cache (built ahead by
    the worker): the same arrays, all C-contiguous (einsum and BLAS sum in an order that
    depends on the layout: a path with transposed views departed at round-off)."""
    from conftest import SMALL_CAPSULE

    from quadmodes.case import case_from_toml
    from quadmodes.models import build
    from quadmodes.rom import artifact

    monkeypatch.setenv("QUADMODES_CACHE", str(tmp_path / "cache"))
    info = {}
    built = build.reduced_model_for(case_from_toml(SMALL_CAPSULE, source="small"), 5, spin=300.0, info=info)
    read = artifact.load_reduced_model(info["path"])
    arrays = [f.name for f in dataclasses.fields(built) if isinstance(getattr(built, f.name), np.ndarray)]
    assert {"G", "S2", "J2u", "C", "Phi"} <= set(arrays)
    for name in arrays:
        a, b = getattr(built, name), getattr(read, name)
        assert a.flags.c_contiguous and b.flags.c_contiguous, name
        np.testing.assert_array_equal(a, b, err_msg=name)


def test_worker_says_when_the_cache_cannot_keep_the_member(tmp_path):
    """A cache folder that cannot be made (under a file): the member is built but not stored, so
    the run would not find it: the worker answers ``failed`` (the run stops building ahead)."""
    import pickle

    from conftest import SMALL_CAPSULE

    from quadmodes.case import case_from_toml

    (tmp_path / "file").write_text("not a folder")
    request = tmp_path / "request.pickle"
    request.write_bytes(pickle.dumps({"case": case_from_toml(SMALL_CAPSULE, source="small"),
                                      "n_modes": 5, "spin": 300.0, "axis": None}))  # fmt: skip
    env = {**fp.worker_environment(), "QUADMODES_CACHE": str(tmp_path / "file" / "cache")}
    done = subprocess.run([sys.executable, "-P", "-m", fp.WORKER_MODULE], input=f"{request}\n",
                          env=env, capture_output=True, text=True, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"failed {request} the member was built but not saved")
