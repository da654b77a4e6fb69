"""The compiled loop of formulation "QM" (rom.manifold_kernel) on the small capsule, N = 5: it
runs the numpy step's equations (rom.manifold_midpoint) — the states and the dissipated energy
agree to round-off amplified by the dynamics over hundreds of steps, with the Newton matrix made
every step as numpy does or kept across steps — conserves |R h| to round-off, reports failures
as the numpy driver does, and is what ``integrate`` runs for a QM system by default."""

import numpy as np
import pytest

from quadmodes.rom import dynamics as dyn
from quadmodes.rom import manifold_kernel as mkk
from quadmodes.rom import manifold_kinetics as mk
from quadmodes.rom import manifold_midpoint as mm
from quadmodes.rom.fixed_step import newton_weights, run_fixed
from quadmodes.rom.integrators import integrate

DT, STEPS = 5e-5, 300


@pytest.fixture(scope="module")
def qm(small_modal_model, small_reduced_model):
    """The capsule's QM system (default truncation, its own modes as damping modes) and a
    state: spin 300 rad/s, tilt 0.05 rad/s, 2 mm of nodal displacement at rest."""
    model = small_reduced_model
    mass = small_modal_model.structure.mass_scalar
    sys_qm = mk.manifold_system(model, mk.manifold_arrays(model, mass, mk.retained_damping(model)))
    n = model.n_modes
    t = np.asarray(model.translational, bool)
    scale = np.array([np.max(np.linalg.norm(p[t], axis=1)) for p in model.Phi])
    d = np.random.default_rng(4).standard_normal(n)
    y0 = np.zeros(7 + 2 * n)
    y0[0], y0[4:7] = 1.0, [0.05, 0.0, 300.0]
    y0[7 : 7 + n] = 2e-3 * d / np.linalg.norm(d) / scale
    return sys_qm, y0


def _numpy(sys_qm, y0, steps=STEPS, max_newton=25):
    idx = np.arange(steps + 1)
    step = mm.ManifoldMidpointStep(sys_qm, DT)
    return run_fixed(step, sys_qm, y0, steps, DT, idx, 1e-13, max_newton, 0.0, step.name)


def _kernel(sys_qm, y0, steps=STEPS, max_newton=25, refresh=1, order=1):
    return mkk.fixed_run(sys_qm, y0, steps, DT, np.arange(steps + 1), 1e-13, max_newton, 0.0,
                         refresh=refresh, order=order)  # fmt: skip


def _weighted(sys_qm, y):
    """The states' velocities in the Newton test's energy weights (√J)."""
    n = sys_qm.n_modes
    return y[:, np.r_[4:7, 7 + n : 7 + 2 * n]] * newton_weights(sys_qm)


def test_helpers_digest_matches():
    """The compiled helpers of midpoint_kernel are compiled into this loop's cache, which numba
    does not check: editing one must force an edit of manifold_kernel.py (new HELPERS_DIGEST)."""
    assert mkk.helpers_digest() == mkk.HELPERS_DIGEST, (
        f"a helper changed: set HELPERS_DIGEST = {mkk.helpers_digest()!r} in manifold_kernel.py"
    )


def test_packed_potential_is_the_flat_one(qm):
    """The force and the Hessian on the distinct monomials equal 3V3·ss + 4V4·sss and
    H = 6V3·s + 12V4·ss of the flat tensors (V3, V4 symmetric; the Newton matrix's
    2H(s½) + H(s₁) in one product)."""
    sys_qm, y0 = qm
    n = sys_qm.n_modes
    vp, pidx, tidx = mkk.packed_potential(sys_qm.flat.V3g, sys_qm.flat.V4g)
    assert vp.shape == (n, n * (n + 1) // 2 + n * (n + 1) * (n + 2) // 6)
    sv = np.stack([y0[7 : 7 + n], np.random.default_rng(1).standard_normal(n) * 1e-2])
    out, mono = np.empty((2, n)), np.empty((2, vp.shape[1]))
    mkk._nl_forces(np.ascontiguousarray(vp.T), pidx, tidx, sv, mono, out)
    for s, o in zip(sv, out, strict=True):
        ref = dyn.potential_nonlinear_force(sys_qm, s)
        assert np.max(np.abs(o - ref)) <= 1e-13 * np.max(np.abs(ref))
    h, wh = np.empty((n, n)), mkk.packed_hessian(sys_qm.flat.V3g, sys_qm.flat.V4g, pidx)
    mkk._nl_hessian(wh, pidx, sv[0], sv[1], np.empty(wh.shape[1]), h)
    ref = 2.0 * dyn.potential_hessian(sys_qm, sv[0]) + dyn.potential_hessian(sys_qm, sv[1])
    ref -= 3.0 * sys_qm.Lam
    assert np.max(np.abs(h - ref)) <= 1e-12 * np.max(np.abs(ref))


def test_kernel_is_the_numpy_step(qm):
    """With the numpy step's predictor and one Newton matrix a step: the same samples and E_d
    to round-off amplified over 300 steps, the same Newton work; |R h| constant to round-off."""
    sys_qm, y0 = qm
    yn, edn, done_n, stn, status_n, _ = _numpy(sys_qm, y0)
    yk, edk, done_k, stk, status_k, msg = _kernel(sys_qm, y0)
    assert status_n == status_k == 0 and msg == "ok" and done_k == done_n == STEPS
    scale = np.max(np.abs(yn), axis=0)
    assert np.max(np.abs(yk - yn) / scale) < 1e-10
    assert abs(edk[-1] - edn[-1]) <= 1e-10 * edn[-1] and edn[-1] > 0
    assert stk == stn
    h = np.array([mm.angular_momentum(sys_qm.manifold, y) for y in yk])
    assert np.max(np.abs(h - h[0])) <= 1e-13 * np.linalg.norm(h[0])


@pytest.mark.parametrize("refresh", [1, 10])
def test_default_predictor_and_kept_matrix_converge_to_the_same_steps(qm, refresh):
    """The default predictor (order 4) and a Newton matrix kept across steps (refreshed when the
    chord slows or fails) converge each step to the same tolerance (1e-13 of the energy scale):
    the numpy trajectory to that tolerance amplified (the velocities in the Newton test's
    weights), E_d to 1e-9, fewer chord iterations; |R h| still to round-off."""
    sys_qm, y0 = qm
    yn, edn, _, stn, _, _ = _numpy(sys_qm, y0)
    yk, edk, _, stk, status, _ = _kernel(sys_qm, y0, refresh=refresh, order=mkk.PREDICTOR)
    assert status == 0 and stk["n_newton"] < stn["n_newton"]
    assert refresh == 1 or stk["n_jac"] < STEPS
    wn, wk = _weighted(sys_qm, yn), _weighted(sys_qm, yk)
    assert np.max(np.abs(wk - wn)) < 1e-10 * np.max(np.abs(wn))
    assert abs(edk[-1] - edn[-1]) <= 1e-9 * edn[-1]  # measured 1.2e-10
    h = np.array([mm.angular_momentum(sys_qm.manifold, y) for y in yk])
    assert np.max(np.abs(h - h[0])) <= 1e-13 * np.linalg.norm(h[0])
    # the kinetic force is a discrete gradient: E + E_d to the Newton tolerance (the plain
    # midpoint force leaves an O(Δt²) drift, 1e-7 of E here)
    e = dyn.energy(sys_qm, yk) + edk
    assert edk[-1] > 1e-4 * abs(e[0]) and np.max(np.abs(e - e[0])) <= 1e-11 * abs(e[0])


def test_failures_are_reported_as_numpy_does(qm):
    """Newton not converging (one iteration allowed) and a non-finite state: status 1, the
    numpy driver's message, the samples so far plus the last accepted state."""
    sys_qm, y0 = qm
    for kw in ({"max_newton": 1},):
        yn, _, _, _, sn, mn = _numpy(sys_qm, y0, 5, **kw)
        yk, _, done, _, sk, mk_ = _kernel(sys_qm, y0, 5, **kw)
        assert sn == sk == 1 and done == 0 and mk_ == mn and "did not converge at step 1" in mk_
        assert np.array_equal(yk[-1], y0) and len(yk) == len(yn)
    bad = y0.copy()
    bad[4] = np.inf
    yk, _, done, _, sk, msg = _kernel(sys_qm, bad, 5)
    assert sk == 1 and done == 0 and "singular or non-finite" in msg


def test_integrate_runs_the_kernel_for_qm(qm):
    """``integrate`` of a QM system: "auto" and "numba" run the compiled loop (backend "numba",
    the numpy samples to the Newton tolerance), "numpy" the numpy step; a user's stepper is
    numpy only."""
    sys_qm, y0 = qm
    span = (0.0, 100 * DT)
    kw = {"dt": DT, "save_every": 10, "newton_tol": 1e-13}
    ref = integrate(sys_qm, y0, span, backend="numpy", **kw)
    assert ref.stats["backend"] == "numpy" and ref.method == "midpoint-QM"
    for backend in ("auto", "numba"):
        sol = integrate(sys_qm, y0, span, backend=backend, **kw)
        assert sol.stats["backend"] == "numba" and sol.method == "midpoint-QM"
        wn, wk = _weighted(sys_qm, ref.y), _weighted(sys_qm, sol.y)
        assert np.max(np.abs(wk - wn)) < 1e-10 * np.max(np.abs(wn))
    with pytest.raises(ValueError, match="midpoint"):
        integrate(sys_qm, y0, span, method=mm.ManifoldMidpointStep, backend="numba", **kw)
