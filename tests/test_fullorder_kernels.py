"""The fast full-order step against its straightforward forms: the element forces (numpy and
compiled), the Newton matrix summed into its CSC pattern against a COO assembly, the tangent
through the precomputed CSR scatter, the damping force without forming W, the tie-condensed
solve, the Krylov solve on a kept factorisation (the path of models with too many ties to
condense), and short spinning runs with the modified (condensed or Krylov, reused) Newton
against the same run with a fresh factorisation at every iteration.

All on the small capsule of conftest.py (≈400 nodes, a rear end body on stiff ties)."""

import math
from dataclasses import replace

import numpy as np
import pytest

from quadmodes.fe.assembly import assemble_matrix, csr_pattern, submatrix_map
from quadmodes.fe.model import centre_of_mass, mass_matrix, strain_energy, tangent_stiffness
from quadmodes.fe.pressure import PressureSet
from quadmodes.fullorder import (
    FullOrderOptions,
    condensed,
    initial_state_from_reduced,
    integrate_full_order,
)
from quadmodes.fullorder import kinematics as kin
from quadmodes.fullorder import newton as nwt
from quadmodes.fullorder import step as stp
from quadmodes.fullorder.condensed import CondensedNewtonMatrix, TieSplit
from quadmodes.fullorder.kernels import StepOperators, jit_module
from quadmodes.fullorder.krylov import KrylovNewtonMatrix
from quadmodes.fullorder.newton import NewtonMatrix, step_jacobian
from quadmodes.fullorder.setup import setup_problem
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import system as rsys
from quadmodes.runs.initial import largest_nodal_displacement

H = 2.5e-4
JIT = [False] + ([True] if jit_module() is not None else [])


def _with_gas_law(structure, x):
    """The structure with a gas-law pressure (κ = 1.4): exercises the rank-one terms."""
    sets = tuple(
        replace(e, gas_law_exponent=1.4, reference_volume=e.volume(x))
        if isinstance(e, PressureSet) else e
        for e in structure.elements
    )  # fmt: skip
    return replace(structure, elements=sets)


@pytest.fixture(scope="module")
def pair(small_modal_model):
    """A step pair (x0, x1) near the inflated state: random displacements of 0.1 mm and a
    rotation of 2° between the two, and the free DOFs, mass and a gas-law structure."""
    m = small_modal_model
    rng = np.random.default_rng(3)
    x0 = m.x + 1e-4 * rng.standard_normal(m.x.shape)
    c = centre_of_mass(m.structure, x0)
    rot = kin.axis_rotation(np.array([0.3, 0.2, 1.0]), math.radians(2.0))
    x1 = (x0 - c) @ rot.T + c + 1e-4 * rng.standard_normal(m.x.shape)
    return m.structure, _with_gas_law(m.structure, m.x), x0, x1


@pytest.mark.parametrize("jit", JIT)
def test_step_force_kernels_match_the_reference(pair, jit):
    structure, gas, x0, x1 = pair
    for s in (structure, gas):
        ops = StepOperators.build(s, mass_matrix(s), s.free_dofs, True, jit=jit)
        ref = stp.step_force(s, x0, x1)
        got = ops.step_force(ops.start(x0), x1)
        assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()


def test_potential_energy_through_the_kernels(pair):
    structure, gas, x0, _ = pair
    for s in (structure, gas):
        ops = StepOperators.build(s, mass_matrix(s), s.free_dofs, True)
        assert ops.energy(x0) == pytest.approx(strain_energy(s, x0), rel=1e-12)


def test_newton_matrix_in_its_pattern_equals_a_coo_assembly(pair):
    structure, gas, x0, x1 = pair
    w = 0.5 * H * H
    m_full = mass_matrix(structure)
    free = structure.free_dofs
    ops = StepOperators.build(structure, m_full, free, True)
    jac, _ = step_jacobian(structure, x0, x1, True)  # per-set COO → CSR, summed
    ref = (m_full + w * jac)[free][:, free]
    got = ops.newton_matrix(x0, x1, w)
    assert got.format == "csc" and got.shape == ref.shape
    assert abs(got - ref).max() <= 1e-12 * abs(ref).max()


def test_tangent_through_the_scatter_map_equals_a_coo_assembly(pair):
    structure, _, x0, _ = pair
    ref = sum(assemble_matrix(e.conn, e.stiffness(x0), structure.n) for e in structure.elements)
    got = tangent_stiffness(structure, x0)
    assert abs(got - ref).max() <= 1e-12 * abs(ref).max()


def test_submatrix_map_of_a_clamped_subset():
    conn = np.array([[0, 1, 2], [1, 2, 3], [2, 3, 4]])
    rng = np.random.default_rng(0)
    blocks = rng.standard_normal((3, 9, 9))
    pattern = csr_pattern([conn], 5)
    data = np.bincount(pattern.slots, weights=blocks.ravel(), minlength=pattern.indices.size)
    keep = np.setdiff1d(np.arange(15), [0, 4, 13])
    got = submatrix_map(pattern, keep).csc(data)
    ref = assemble_matrix(conn, blocks, 5)[keep][:, keep]
    assert abs(got - ref).max() <= 1e-14 * abs(ref).max()


def _explicit_damping(body, c, x, v, mphi):
    """f_d = W C Wᵀ v with W = Π M 𝒬 Φ formed explicitly (the form before issue 10)."""
    n, k = x.shape[0], mphi.shape[0]
    p = kin.centre(body, x)
    rot = kin.best_fit_rotation(body, x, p)
    w = (mphi @ rot.T).reshape(k, 3 * n).T
    psi = stp.rigid_basis(body, x, p).reshape(3 * n, 6)
    mpsi = (body.ms @ psi.reshape(n, 18)).reshape(3 * n, 6)
    w = w - mpsi @ (np.linalg.pinv(psi.T @ mpsi, rcond=1e-12, hermitian=True) @ (psi.T @ w))
    return (w @ (c @ (w.T @ v.ravel()))).reshape(n, 3)


@pytest.mark.parametrize("jit", JIT)
def test_damping_force_without_w_equals_the_explicit_form(pair, small_reduced_model, jit,
                                                          monkeypatch):  # fmt: skip
    if not jit:
        monkeypatch.setattr(stp, "jit_module", lambda: None)
    structure, _, x0, x1 = pair
    model = small_reduced_model
    body = kin.make_body(structure.mass_scalar, structure.translational, model.X, model, False)
    v = np.random.default_rng(5).standard_normal(x0.shape)
    c = np.diag(np.linspace(1.0, 9.0, model.n_modes))
    ref = _explicit_damping(body, c, x1, v, body.MPhi)
    got = stp.damping_force(body, c, x1, v)
    assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()


@pytest.mark.parametrize("jit", JIT)
def test_condensed_solve_is_the_block_elimination_of_the_whole_matrix(pair, small_modal_model,
                                                                      jit, monkeypatch):  # fmt: skip
    if not jit:
        monkeypatch.setattr(condensed, "jit_module", lambda: None)
    _, gas, x0, x1 = pair
    m = small_modal_model
    problem = setup_problem(gas, m.x, (0.0, H), H, model=None, damping=False, hub=None,
                            newton_tol=1e-11, energy_momentum=True, rotation_map=True)  # fmt: skip
    ops = StepOperators.build(gas, problem.m_full, problem.free, True)
    split = TieSplit.of(ops, problem.free)
    assert split is not None and 0 < len(split.tie) < 0.2 * len(problem.free)
    mat = CondensedNewtonMatrix(problem, ops, split, x0, x0, single=False)  # soft at (x0, x0)
    mat.update(x0, x1)  # ties at (x0, x1)
    approx = CondensedNewtonMatrix(problem, ops, split, x0, x0)  # A_II in float32
    approx.update(x0, x1)
    w = 0.5 * H * H
    soft = ops.newton_matrix(x0, x0, w, skip=split.stiff)
    ties = ops.newton_matrix(x0, x1, w) - ops.newton_matrix(x0, x1, w, skip=split.stiff)
    _, low = step_jacobian(gas, x0, x1, True)
    dense = (soft + ties).toarray()
    for coef, vec in low:  # the gas law's rank-one term at the ties' pair
        vf = vec[problem.free]
        dense += w * coef * np.outer(vf, vf)
    rhs = np.random.default_rng(7).standard_normal(len(problem.free))
    ref = np.linalg.solve(dense, rhs)
    assert np.abs(mat.solve(rhs) - ref).max() <= 1e-9 * np.abs(ref).max()
    assert np.abs(approx.solve(rhs) - ref).max() <= 1e-4 * np.abs(ref).max()


@pytest.mark.parametrize("policy, jv_tol, resid_tol", [("fixed", 1e-8, 1e-4),
                                                      ("adaptive", 1e-6, 5e-4)])
def test_krylov_operator_and_solve_on_a_stale_factorisation(pair, small_modal_model, policy,
                                                            jv_tol, resid_tol):  # fmt: skip
    # the matrix-free operator is the assembled Newton matrix (with the gas law's rank-one term)
    # at the current pair; GMRES preconditioned by a float32 factorisation at another pair (2°
    # and 0.1 mm away) solves the current matrix to the tolerance it was asked for. J v by the
    # central difference ("fixed") or the forward one ("adaptive": truncation and round-off
    # ~4e-8 of max |J v| here; the stiff ties amplify it in the true residual of the solve,
    # 2.1e-4 where GMRES asked 1e-4 of its operator; Newton's own residual stays exact)
    _, gas, x0, x1 = pair
    m = small_modal_model
    problem = setup_problem(gas, m.x, (0.0, H), H, model=None, damping=False, hub=None,
                            newton_tol=1e-11, energy_momentum=True, rotation_map=True)  # fmt: skip
    ops = StepOperators.build(gas, problem.m_full, problem.free, True)
    w = 0.5 * H * H
    _, low = step_jacobian(gas, x0, x1, True)
    dense = ops.newton_matrix(x0, x1, w).toarray()
    for coef, vec in low:
        vf = vec[problem.free]
        dense += w * coef * np.outer(vf, vf)
    base = NewtonMatrix.at(problem, x0, x0, ops, single=True)
    mat = KrylovNewtonMatrix(problem, ops, base, policy)
    mat.update(x0, x1)
    v = np.random.default_rng(11).standard_normal(len(problem.free))
    ref = dense @ v
    assert np.abs(mat.apply(v) - ref).max() <= jv_tol * np.abs(ref).max()
    rhs = np.random.default_rng(7).standard_normal(len(problem.free))
    exact = np.linalg.solve(dense, rhs)
    got = mat.solve(rhs)
    stale = mat.base.solve(rhs)
    assert not mat.stale and mat.krylov_steps >= 2
    resid = np.linalg.norm(dense @ got - rhs) / np.linalg.norm(rhs)
    assert resid <= resid_tol  # KRYLOV_RTOL_MIN: this rhs's correction is far above tolerance
    err = np.abs(got - exact).max() / np.abs(exact).max()
    assert err <= 1e-3 and err <= 0.01 * np.abs(stale - exact).max() / np.abs(exact).max()


def _spin_start(small_modal_model, small_reduced_model):
    """10 Hz spin with a 5° cone and a 1 mm bending of the small capsule: (x0, v0)."""
    model, m = small_reduced_model, small_modal_model
    system = rsys.reduced_system(model, "Q")
    omega = dyn.coning_omega(model.J0, 2 * np.pi * 10.0, math.radians(5.0))
    s0 = np.zeros(model.n_modes)
    s0[2] = 1e-3 / largest_nodal_displacement(model, 2)
    y0 = rsys.pack_state(system, omega=omega, s=s0)
    return initial_state_from_reduced(model, y0, p=centre_of_mass(m.structure, m.x))


@pytest.fixture(scope="module")
def spin_runs(small_modal_model, small_reduced_model):
    """The spin of :func:`_spin_start`, 40 steps at 0.25 ms, damped (ζ = 2 %): the default
    stepping (condensed ties), the same with the ties treated as too many to condense (the
    Krylov path of paper-membrane) and the reference with a fresh factorisation at every
    iteration."""
    model, m = small_reduced_model, small_modal_model
    x0, v0 = _spin_start(m, model)

    def run(full):  # one thread: the renewal rule on the stepping thread (counted below)
        return integrate_full_order(m.structure, m.x, x0, v0, (0.0, 40 * H), H,
                                    FullOrderOptions(model=model, full_newton=full, threads=1))  # fmt: skip

    made = []

    class Counted(KrylovNewtonMatrix):
        def __init__(self, *args):
            super().__init__(*args)
            made.append(self)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nwt, "MAX_TIE_DOFS", 0)
        mp.setattr(nwt, "KrylovNewtonMatrix", Counted)
        krylov = run(False)
    assert len(made) == krylov.stats["n_factor"] and sum(k.krylov_steps for k in made) > 0
    return run(False), run(True), krylov


@pytest.mark.parametrize("path", ["condensed", "krylov"])
def test_modified_newton_matches_full_newton_to_the_newton_tolerance(spin_runs, path):
    cond, ref, krylov = spin_runs
    new = cond if path == "condensed" else krylov
    assert new.status == 0 and ref.status == 0
    assert new.stats["n_factor"] < ref.stats["n_factor"] / 10  # the point of it
    h_ref = ref.H_norm[0]
    assert np.abs(new.H_norm - ref.H_norm).max() <= 1e-9 * h_ref
    assert np.abs(new.H_discrete - ref.H_discrete).max() <= 1e-9 * h_ref
    # energies and modal coordinates: the trajectories differ by the Newton tolerance
    # (1e-11 of the body size per step), which the stiff ties turn into ~1e-9 of the energy
    t_ref = np.abs(ref.T).max()
    assert np.abs(new.E - ref.E).max() <= 1e-7 * t_ref
    assert np.abs(new.E_balance - ref.E_balance).max() <= 1e-7 * t_ref
    s_ref = np.abs(ref.modal_coordinates).max()
    assert np.abs(new.modal_coordinates - ref.modal_coordinates).max() <= 1e-6 * s_ref
    # and the scheme's invariant is kept by both to the tolerance
    for sol in (new, ref):
        hd = np.linalg.norm(sol.H_discrete, axis=1)
        assert np.max(np.abs(hd / hd[0] - 1.0)) <= 1e-8


def test_plain_midpoint_path_matches_full_newton(small_modal_model, small_reduced_model):
    # energy_momentum=False: f(x½) kernels, no condensation (the bars are not averaged)
    model, m = small_reduced_model, small_modal_model
    system = rsys.reduced_system(model, "Q")
    omega = dyn.coning_omega(model.J0, 2 * np.pi * 5.0, math.radians(3.0))
    y0 = rsys.pack_state(system, omega=omega, s=np.zeros(model.n_modes))
    x0, v0 = initial_state_from_reduced(model, y0, p=centre_of_mass(m.structure, m.x))
    sols = [integrate_full_order(m.structure, m.x, x0, v0, (0.0, 10 * H), H, FullOrderOptions(
                model=model, energy_momentum=False, full_newton=full))
            for full in (False, True)]  # fmt: skip
    new, ref = sols
    assert new.status == 0 and ref.status == 0
    assert np.abs(new.H_norm - ref.H_norm).max() <= 1e-8 * ref.H_norm[0]  # the scheme's test
    assert np.abs(new.E - ref.E).max() <= 1e-7 * np.abs(ref.T).max()


@pytest.fixture(scope="module")
def policy_runs(small_modal_model, small_reduced_model):
    """The spin of :func:`_spin_start` (40 steps, damped) by each Newton policy on the
    condensed and the Krylov paths, and a reference converged far tighter (full Newton at
    newton_tol 1e-14): ``{(path, policy): solution}``, ``"tight"``."""
    model, m = small_reduced_model, small_modal_model
    x0, v0 = _spin_start(m, model)

    def run(policy, krylov=False, full=False, tol=1e-11):
        opts = FullOrderOptions(model=model, full_newton=full, newton_policy=policy, newton_tol=tol,
                                threads=1)  # the rationed renewal (test_fullorder_renewal.py: 2)
        with pytest.MonkeyPatch.context() as mp:
            if krylov:
                mp.setattr(nwt, "MAX_TIE_DOFS", 0)
            return integrate_full_order(m.structure, m.x, x0, v0, (0.0, 40 * H), H, opts)

    out = {(path, pol): run(pol, krylov=path == "krylov")
           for path in ("condensed", "krylov") for pol in ("fixed", "adaptive")}  # fmt: skip
    out["tight"] = run("fixed", full=True, tol=1e-14)
    return out


def _distance(a, b) -> dict:
    """Largest differences of two runs on the same samples: |H| and H_discrete relative to
    |H(0)|, E and E + E_d relative to the largest kinetic energy, modal coordinates relative
    to the largest."""
    h0, t_ref, s_ref = b.H_norm[0], np.abs(b.T).max(), np.abs(b.modal_coordinates).max()
    return {"H": np.abs(a.H_norm - b.H_norm).max() / h0,
            "Hd": np.abs(a.H_discrete - b.H_discrete).max() / h0,
            "E": np.abs(a.E - b.E).max() / t_ref,
            "balance": np.abs(a.E_balance - b.E_balance).max() / t_ref,
            "s": np.abs(a.modal_coordinates - b.modal_coordinates).max() / s_ref}  # fmt: skip


@pytest.mark.parametrize("path", ["condensed", "krylov"])
def test_adaptive_newton_policy_gives_the_fixed_policys_answers_with_less_work(policy_runs, path):
    # issue 27: the "adaptive" policy (stop on the contraction estimate, end velocity from the
    # end state, preconditioner renewed by cost, forward-difference J v) against the rules
    # before it ("fixed"), both at newton_tol 1e-11 (of the 1 m body size), on the same start
    new, old = policy_runs[(path, "adaptive")], policy_runs[(path, "fixed")]
    tight = policy_runs["tight"]
    assert new.status == 0 and old.status == 0
    # the same answers to the Newton tolerance (the bounds of the full-Newton comparison)
    d = _distance(new, old)
    assert d["H"] <= 1e-9 and d["Hd"] <= 1e-9 and d["E"] <= 1e-7 and d["balance"] <= 1e-7
    assert d["s"] <= 1e-6
    # and no farther from the tightly converged trajectory than the fixed policy (each
    # measure, with a floor at round-off of the sums: 1e-12)
    d_new, d_old = _distance(new, tight), _distance(old, tight)
    for key in d_new:
        assert d_new[key] <= max(d_old[key], 1e-12), key
    # with no more work
    assert new.stats["n_newton"] <= old.stats["n_newton"]
    assert new.stats["n_factor"] <= old.stats["n_factor"]
