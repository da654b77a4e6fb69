"""The Krylov path's preconditioner renewed on a second thread
(:mod:`quadmodes.fullorder.renewal`): the schedule (swap a fixed number of steps after the
launch, at a pair extrapolated to the swap step), that the thread changes nothing against the
same schedule inline (bit for bit), and that the run gives the one-thread run's answers to the
Newton tolerance; the thread count's default. On the small capsule of conftest.py with its
ties treated as too many to condense (the path of paper-membrane)."""


import numpy as np
import pytest
from test_fullorder_kernels import _spin_start

import quadmodes.fullorder.renewal as rn
from quadmodes.errors import InputError
from quadmodes.fullorder import FullOrderOptions, integrate_full_order
from quadmodes.fullorder import newton as nwt

H = 2.5e-4
SERIES = ("H_norm", "H_discrete", "E", "E_d", "T", "modal_coordinates")


def _pairs(k: int, wobble: float) -> tuple[np.ndarray, np.ndarray]:
    """A start pair (z0, z1) (2,3) of step k: a uniform drift plus a component alternating
    from step to step (the stiff rim's Nyquist motion)."""
    z0 = np.full((2, 3), float(k)) + wobble * (-1.0) ** k
    return z0, z0 + 0.5


@pytest.mark.parametrize("background", [False, True])
def test_schedule_swaps_after_the_lag_at_the_extrapolated_pair(background):
    pipe = rn.RenewalPipeline(lambda z0, z1: (z0.copy(), z1.copy()), lag=2, background=background)
    swapped = {}
    for k in range(1, 12):
        due = pipe.step(*_pairs(k, 0.3))
        if due is not None:
            swapped[k] = due
    # step 1 has a fresh preconditioner; launches at 2, 4, 6, …, each swapped in two steps later
    assert sorted(swapped) == [4, 6, 8, 10] and pipe.launched == 5
    # the first launch has no history: built at its own pair; the later ones at
    # 2 z(n) − z(n − 2), which for a drift plus a Nyquist wobble is the swap step's own pair
    assert np.array_equal(swapped[4][0], _pairs(2, 0.3)[0])
    for k in (6, 8, 10):
        for got, want in zip(swapped[k], _pairs(k, 0.3), strict=True):
            assert np.allclose(got, want, rtol=0, atol=1e-12)


def test_a_failed_renewal_is_raised_on_the_stepping_thread():
    def fail(z0, z1):
        raise RuntimeError("singular")

    pipe = rn.RenewalPipeline(fail, lag=1, background=True)
    pipe.step(*_pairs(1, 0.0))
    pipe.step(*_pairs(2, 0.0))  # launched
    with pytest.raises(RuntimeError, match="singular"):
        pipe.step(*_pairs(3, 0.0))  # due


def test_thread_count_default_and_bad_value(monkeypatch):
    """One thread unless asked (a run's numbers do not depend on the machine's cores); a bad
    value is one line naming the variable."""
    monkeypatch.delenv("QUADMODES_THREADS", raising=False)
    assert rn.default_threads() == 1
    monkeypatch.setenv("QUADMODES_THREADS", "3")
    assert rn.default_threads() == 3
    for bad in ("0", "two", "-1"):
        monkeypatch.setenv("QUADMODES_THREADS", bad)
        with pytest.raises(InputError, match="QUADMODES_THREADS") as err:
            rn.default_threads()
        assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="threads"):
        FullOrderOptions(threads=0)


@pytest.fixture(scope="module")
def runs(small_modal_model, small_reduced_model):
    """40 steps (10 Hz, 5° cone, 1 mm bending, ζ = 2 %) on the Krylov path: one thread (the
    rationed renewal), two threads (the pipeline) and the pipeline's schedule inline."""
    model, m = small_reduced_model, small_modal_model
    x0, v0 = _spin_start(small_modal_model, small_reduced_model)

    def run(threads, background=True):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(nwt, "MAX_TIE_DOFS", 0)
            mp.setattr(rn, "BACKGROUND", background)
            opts = FullOrderOptions(model=model, threads=threads)
            return integrate_full_order(m.structure, m.x, x0, v0, (0.0, 40 * H), H, opts)

    return {"one": run(1), "two": run(2), "inline": run(2, background=False)}


def test_the_thread_changes_nothing(runs):
    two, inline = runs["two"], runs["inline"]
    assert two.status == 0 and inline.status == 0
    for key in SERIES:
        assert np.array_equal(getattr(two, key), getattr(inline, key)), key
    for key in ("n_newton", "n_factor"):
        assert two.stats[key] == inline.stats[key]


def test_pipeline_gives_the_one_thread_answers_to_the_newton_tolerance(runs):
    new, old = runs["two"], runs["one"]
    assert new.status == 0 and old.status == 0
    # the bounds of the modified-against-full-Newton comparison (test_fullorder_kernels.py)
    h0, t_ref = old.H_norm[0], np.abs(old.T).max()
    assert np.abs(new.H_norm - old.H_norm).max() <= 1e-9 * h0
    assert np.abs(new.H_discrete - old.H_discrete).max() <= 1e-9 * h0
    assert np.abs(new.E - old.E).max() <= 1e-7 * t_ref
    assert np.abs(new.E_balance - old.E_balance).max() <= 1e-7 * t_ref
    s_ref = np.abs(old.modal_coordinates).max()
    assert np.abs(new.modal_coordinates - old.modal_coordinates).max() <= 1e-6 * s_ref
    # the renewals launched on the thread are counted: one every RENEWAL_LAG steps
    assert new.stats["n_factor"] >= 40 // rn.RENEWAL_LAG - 1
