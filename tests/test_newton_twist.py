"""The full order's Newton on beams whose sections twist freely (issue 26: the spin-stiffened
string rotor stalled because an additive correction that turns a section stretches its
directors, and the stress of that stretch swamped the string's twist stiffness in the exact
Jacobian; docs/full-order.md "A string's sections in Newton")."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import quadmodes.fullorder.newton as nw
from quadmodes.fe.beam import SECTION_NEWTON_STRESS, BeamSectionSet, solid_section
from quadmodes.fe.build import _build_3d_beam
from quadmodes.fullorder.setup import setup_problem
from quadmodes.fullorder.step import StepResidual

# a string as in string-blade-rotor: EA 3e4 N, GJ 2.3e-5 N m², element 0.25 m
STRING = solid_section(1e-5, 1e-14, 3e9, 1420.0)


def _string(exact_jacobian: bool = False):
    s = _build_3d_beam(2.0, 8, STRING, False)
    if exact_jacobian:
        s = replace(s, elements=tuple(replace(e, newton_stress=None)
                                      if isinstance(e, BeamSectionSet) else e
                                      for e in s.elements))  # fmt: skip
    return s


def _section_set(s):
    return next(e for e in s.elements if isinstance(e, BeamSectionSet))


def test_newton_block_is_the_jacobian_less_the_section_rigidity_stress():
    """Central differences of the step force: with ``newton_stress`` None the block is the
    exact ∂f/∂x₁; the beam's Newton block differs from it by ½ Σ w σ_s a_s ⊗ I₃ over the
    section's rigidity strains (|d₂|², |d₃|², d₂·d₃) alone."""
    s = _string()
    e = _section_set(s)
    rng = np.random.default_rng(1)
    x0 = s.reference + 1e-3 * rng.standard_normal(s.reference.shape)
    x1 = x0 + 1e-3 * rng.standard_normal(s.reference.shape)
    q = e.conn[3]  # one element: its 8 vector DOFs
    fd = np.zeros((24, 24))
    for col in range(24):
        node, comp = q[col // 3], col % 3
        hi, lo = x1.copy(), x1.copy()
        hi[node, comp] += 1e-6
        lo[node, comp] -= 1e-6
        fd[:, col] = (e.step_force(x0, hi)[3] - e.step_force(x0, lo)[3]).ravel() / 2e-6
    exact = replace(e, newton_stress=None).step_block(x0, x1)[3]
    assert np.abs(exact - fd).max() < 1e-6 * np.abs(fd).max()
    ebar = 0.5 * (e.strains(x0) + e.strains(x1))[3]
    sigma = e.weights[3][:, None] * e.moduli[3] * ebar * (1.0 - SECTION_NEWTON_STRESS)
    geo = np.einsum("ps,psjl->jl", sigma, e.operators[3])
    dropped = 0.5 * np.kron(geo, np.eye(3))
    assert np.allclose(e.step_block(x0, x1)[3], exact - dropped, rtol=0, atol=1e-9)
    assert list(SECTION_NEWTON_STRESS) == [1.0, 1.0, 0.0, 0.0, 0.0]  # the ties keep theirs


def _newton_from_twisted_tip(structure, theta: float):
    """One step of 10 ms from rest, started from an iterate whose tip section is turned by
    ``theta`` about the string's axis (the root: the reference). Full Newton (a matrix of the
    current iterate at every iteration). Returns (result, corrections)."""
    h = 0.01
    p = setup_problem(structure, structure.reference, (0.0, h), h, model=None, damping=False,
                      hub=None, newton_tol=1e-11, energy_momentum=True,
                      rotation_map=False)  # fmt: skip
    x = structure.reference
    y0 = x.copy()
    tip = structure.n - 4
    y0[tip + 2 : tip + 4] = x[tip + 2 : tip + 4] @ Rotation.from_rotvec([theta, 0, 0]).as_matrix().T
    seen = []
    inner = nw._step_to

    def logged(*args, **kw):
        y, dx = inner(*args, **kw)
        seen.append(float(np.abs(dx).max()))
        return y, dx

    nw._step_to = logged
    try:
        res = nw.solve_step(p, None, x, y0, np.eye(3), StepResidual.start(p, x, 0 * x, 0.0), 40,
                            full_newton=True, policy="adaptive")  # fmt: skip
    finally:
        nw._step_to = inner
    return res, seen


@pytest.mark.parametrize("theta", [1e-2, 5e-2])
def test_a_twisted_string_section_converges_with_the_newton_block(theta):
    """The exact Jacobian at an iterate whose directors the previous correction stretched by
    θ²/2 has the twist stiffness EA θ²/2 × L/2 (0.2 N m at 0.01 rad) in place of GJ/L (9e-5):
    its corrections plateau (near 1e-6 from 0.01 rad, 2e-5 from 0.05 rad, where 40 iterations
    do not converge: the rotor's stall). The Newton block (the section rigidity's stress left
    out) converges in at most five, to the state at rest."""
    res, seen = _newton_from_twisted_tip(_string(), theta)
    assert res.converged and res.n_newton <= 5
    assert np.abs(res.x1 - _string().reference).max() < 1e-12
    res_exact, seen_exact = _newton_from_twisted_tip(_string(exact_jacobian=True), theta)
    assert res_exact.n_newton >= 3 * res.n_newton
    assert res_exact.converged == (theta < 0.03)
    ratios = [b / a for a, b in zip(seen_exact[3:-1], seen_exact[4:], strict=False)]
    assert max(ratios) > 0.8  # a plateau: the slow contraction of the stall


def test_directions_are_held_to_the_relative_tolerance_adaptive_only():
    """The adaptive test measures a position in metres and a direction DOF (slope, director:
    dimensionless) in radians × the body size; the fixed policy is the plain max |δx|."""
    s = _string()
    p = setup_problem(s, s.reference, (0.0, 0.01), 0.01, model=None, damping=False, hub=None,
                      newton_tol=1e-11, energy_momentum=True, rotation_map=False)  # fmt: skip
    assert np.isclose(p.scale, 1.0)  # the string's half-length about its centre of mass
    dx = np.zeros_like(s.reference)
    dx[4] = [3e-12, 0.0, 0.0]  # a position
    dx[7] = [0.0, -2e-12, 0.0]  # a director of the same node
    assert nw.measured(p, dx, "fixed") == 3e-12
    p2 = replace(p, scale=10.0)
    assert nw.measured(p2, dx, "adaptive") == 2e-11
    assert nw.measured(p2, dx, "fixed") == 3e-12
