"""The full order's Newton on beams whose sections twist freely (issue 26: the spin-stiffened
string rotor stalled because an additive correction that turns a section stretches its frame
by θ²/2, and the stress of that stretch swamped the string's twist stiffness in the Jacobian;
docs/full-order.md "A string's sections in Newton")."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import quadmodes.fullorder.newton as nw
from quadmodes.fe.beam import solid_section
from quadmodes.fe.build import _build_3d_beam
from quadmodes.fe.hub import BoomSpec, HubSpec, build_hub_structure
from quadmodes.fullorder.setup import section_triads, setup_problem
from quadmodes.fullorder.step import StepResidual

# a string as in string-blade-rotor: EA 3e4 N, GJ 2.3e-5 N m², element 0.25 m
STRING = solid_section(1e-5, 1e-14, 3e9, 1420.0)


def _string():
    return _build_3d_beam(2.0, 8, STRING, False)


def test_triads_are_the_beam_nodes_own_frames():
    """A free beam: every node's [t, d₂, d₃]; a hub's booms: every node but the clamped root
    (an image of the hub's axes), and not the hub's own axes."""
    s = _string()
    assert np.array_equal(section_triads(s), 4 * np.arange(9)[:, None] + [1, 2, 3])
    booms = [BoomSpec(n, (d * 0.5, 0, 0), (d, 0, 0), 2.0, 4, STRING)
             for n, d in (("a", 1), ("b", -1))]  # fmt: skip
    hub = build_hub_structure(HubSpec(10.0, (0.9, 0.9, 1.25)), booms)
    rows = section_triads(hub)
    assert rows.shape == (8, 3) and rows.min() == 5  # the hub's rows 0–3 excluded
    assert not hub.translational[rows].any() and hub.translational[rows[:, 0] - 1].all()


def test_a_turn_of_a_frame_is_applied_as_a_rotation():
    """The additive first-order turn φ × v of a frame (|t| = 1.3, rows t, d₂, d₃) is carried to
    the exact rotation R(φ)v (to round-off, large and small φ); a stretch along t stays
    additive."""
    e = Rotation.random(random_state=1).as_matrix().T.copy()
    e[0] *= 1.3
    rows = np.array([[0, 1, 2]])
    for phi in ([0.3, -0.2, 0.5], [1e-6, 2e-6, -1e-6], [3e-5, 0.0, 1e-5]):
        turned = e @ Rotation.from_rotvec(phi).as_matrix().T
        assert np.abs(nw.advanced(rows, e, np.cross(phi, e)) - turned).max() < 1e-15
    stretch = np.zeros_like(e)
    stretch[0] = 1e-3 * e[0]
    assert np.allclose(nw.advanced(rows, e, stretch), e + stretch, rtol=0, atol=1e-18)


def _newton_from_twisted_tip(problem, theta: float):
    """One step of 10 ms from rest, started from an iterate whose tip section is turned by
    ``theta`` about the string's axis. Full Newton (the exact Jacobian at every iterate).
    Returns (result, corrections)."""
    x = problem.X
    y0 = x.copy()
    tip = problem.n - 4
    y0[tip + 2 : tip + 4] = x[tip + 2 : tip + 4] @ Rotation.from_rotvec([theta, 0, 0]).as_matrix().T
    seen = []
    inner = nw._step_to

    def logged(*args, **kw):
        y, dx = inner(*args, **kw)
        seen.append(float(np.abs(dx).max()))
        return y, dx

    nw._step_to = logged
    try:
        res = nw.solve_step(problem, None, x, y0, np.eye(3),
                            StepResidual.start(problem, x, 0 * x, 0.0), 40, full_newton=True,
                            policy="adaptive")  # fmt: skip
    finally:
        nw._step_to = inner
    return res, seen


@pytest.mark.parametrize("theta", [1e-2, 5e-2])
def test_a_twisted_string_section_converges_when_turned_as_a_frame(theta):
    """Additive corrections (no triads: the update before issue 26's fix) stretch the section
    by θ²/2; the exact Jacobian at that iterate has the twist stiffness EA θ²/2 × L/2 (0.2 N m
    at 0.01 rad) in place of GJ/L (9e-5): corrections plateau (near 1e-6 from 0.01 rad, 2e-5
    from 0.05 rad, where 40 iterations do not converge: the rotor's stall). Turned as a frame,
    Newton converges in at most five, to the state at rest."""
    s = _string()
    p = setup_problem(s, s.reference, (0.0, 0.01), 0.01, model=None, damping=False, hub=None,
                      newton_tol=1e-11, energy_momentum=True, rotation_map=False)  # fmt: skip
    assert np.allclose(p.X, s.reference - [1.0, 0.0, 0.0] * s.translational[:, None])
    res, _ = _newton_from_twisted_tip(p, theta)
    assert res.converged and res.n_newton <= 5
    assert np.abs(res.x1 - p.X).max() < 1e-12
    additive, seen = _newton_from_twisted_tip(replace(p, triads=None), theta)
    assert additive.n_newton >= 3 * res.n_newton
    assert additive.converged == (theta < 0.03)
    ratios = [b / a for a, b in zip(seen[3:-1], seen[4:], strict=False)]
    assert max(ratios) > 0.8  # a plateau: the slow contraction of the stall


def test_beam_directions_are_held_to_the_relative_tolerance_adaptive_only():
    """The adaptive test measures a position in metres and a beam's slope or director
    (dimensionless) in radians × the body size; the fixed policy is the plain max |δx|."""
    s = _string()
    p = setup_problem(s, s.reference, (0.0, 0.01), 0.01, model=None, damping=False, hub=None,
                      newton_tol=1e-11, energy_momentum=True, rotation_map=False)  # fmt: skip
    dx = np.zeros_like(s.reference)
    dx[4] = [3e-12, 0.0, 0.0]  # a position
    dx[7] = [0.0, -2e-12, 0.0]  # a director of the same node
    p10 = replace(p, scale=10.0)
    assert nw.measured(p10, dx, "adaptive") == 2e-11
    assert nw.measured(p10, dx, "fixed") == 3e-12
    assert nw.measured(replace(p10, triads=None), dx, "adaptive") == 3e-12
