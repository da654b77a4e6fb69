"""Exact slack onset along a manifold displacement (structure.tension_margin, item 6 of issue
26): the second-order strain of a flat prestretched membrane deflected out of its plane, which
the linearised onset cannot see, against closed forms derived here.

The membrane: a square of side L in z = 0 on a structured grid of right triangles, stretched
uniformly, x0 = (1 + λ) X. Every displacement below is linear or quadratic in X, so on the
constant-strain triangles it is represented exactly (for w = b X² the element slope is b times
twice the column's mid-x, which is the closed form's slope there).
"""

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from quadmodes.fe.membrane import membrane_set
from quadmodes.fe.model import Structure
from quadmodes.structure.tension_margin import manifold_slack_onset, slack_onset, taut_set

E, NU, T, RHO = 3.0e9, 0.3, 7.5e-6, 1420.0  # a polyimide sail
L, CELLS, LAM = 2.0, 8, 1e-4  # side (m), cells a side, prestretch


def _square():
    g = np.linspace(-L / 2, L / 2, CELLS + 1)
    xx, yy = np.meshgrid(g, g, indexing="ij")
    points = np.c_[xx.ravel(), yy.ravel(), np.zeros(xx.size)]
    idx = np.arange(xx.size).reshape(CELLS + 1, CELLS + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()
    conn = np.r_[np.c_[a, b, c], np.c_[b, d, c]]
    membrane = membrane_set(conn, points, T, E, NU, RHO)
    n = len(points)
    structure = Structure(points, np.ones(n, bool), (membrane,), sp.identity(n, format="csr"),
                          np.zeros((n, 3), bool))  # fmt: skip
    return structure, membrane, points


@pytest.fixture(scope="module")
def square():
    return _square()


def _svk_minor(e11: float, e22: float) -> float:
    """Minor principal 2nd PK stress resultant (N/m) of diagonal Green strains (SVK)."""
    c = E / (1 - NU**2)
    return T * c * min(e11 + NU * e22, NU * e11 + e22)


def test_flat_bending_is_invisible_to_the_linearised_onset(square):
    """w = b X²: F0ᵀF1 = 0, so the linearised onset is infinite; the exact strain is the stretch
    E11 = e0 + ½ w'² per element (w' = 2b x̄, x̄ the element column's mid-x), E22 = e0."""
    structure, membrane, X = square
    x0 = (1 + LAM) * X
    b = 0.05
    u = np.c_[np.zeros((len(X), 2)), b * X[:, 0] ** 2]
    assert slack_onset(structure, x0, u).fraction == np.inf
    taut = taut_set(structure, x0)
    e0 = 0.5 * ((1 + LAM) ** 2 - 1)
    xm = X[membrane.conn, 0]
    mid = 0.5 * (xm.min(axis=1) + xm.max(axis=1))
    stretched = e0 + 0.5 * (2 * b * mid) ** 2
    # the Cauchy resultant: t F S Fᵀ / J, F = diag(√C11, √C22) in the plane's directions
    c11, c22 = 1 + 2 * stretched, 1 + 2 * e0
    cd = E / (1 - NU**2)
    s11, s22 = cd * (stretched + NU * e0), cd * (NU * stretched + e0)
    expected = T * np.minimum(s11 * c11, s22 * c22) / np.sqrt(c11 * c22)
    np.testing.assert_allclose(taut.tensions(x0 + u), expected, rtol=1e-10)
    assert manifold_slack_onset(structure, x0, u).fraction == np.inf  # only stretches


def test_rigid_tilt_changes_no_strain_to_second_order(square):
    """The tilt w = θX alone stretches by ½θ² (a linear mode's rotation is not rigid); with its
    quadratic part u2 = −½θ²X e_x the strain change is E11 = ((1+λ−½θ²)² + θ² − (1+λ)²)/2
    = −λθ²/2 + θ⁴/8 (closed form): zero to second order for λ → 0."""
    structure, _, X = square
    x0 = (1 + LAM) * X
    u1 = np.c_[np.zeros((len(X), 2)), X[:, 0]]
    u2 = np.c_[-0.5 * X[:, 0], np.zeros((len(X), 2))]
    taut = taut_set(structure, x0)
    e0 = 0.5 * ((1 + LAM) ** 2 - 1)
    for theta in (1e-3, 0.05, 0.3):
        exact = 0.5 * ((1 + LAM - 0.5 * theta**2) ** 2 + theta**2 - 1)
        assert exact - e0 == pytest.approx(-LAM * theta**2 / 2 + theta**4 / 8, rel=1e-6)
        c11, c22 = 1 + 2 * exact, 1 + 2 * e0
        cd = E / (1 - NU**2)
        s = [cd * (exact + NU * e0) * c11, cd * (NU * exact + e0) * c22]
        expected = T * min(s) / np.sqrt(c11 * c22)
        np.testing.assert_allclose(taut.tensions(x0 + theta * u1 + theta**2 * u2), expected,
                                   rtol=1e-8)  # fmt: skip


def test_onset_of_an_overshooting_quadratic_part(square):
    """u1 = X e_z, u2 = −k X e_x (k > ½: the in-plane part overshoots the tilt's and compresses):
    F11 = 1 + λ − k a², F31 = a, so E11 = ½((1 + λ − k a²)² + a² − 1) and the minor stress
    E11 + ν e0 = 0 at b = a² the smallest positive root of
    k² b² + (1 − 2k(1 + λ)) b + (1 + λ)² − 1 + 2ν e0 = 0."""
    structure, _, X = square
    x0 = (1 + LAM) * X
    k = 0.8
    e0 = 0.5 * ((1 + LAM) ** 2 - 1)
    roots = np.roots([k * k, 1 - 2 * k * (1 + LAM), (1 + LAM) ** 2 - 1 + 2 * NU * e0])
    expected = np.sqrt(roots[roots > 0].min())
    u1 = np.c_[np.zeros((len(X), 2)), X[:, 0]]
    u2 = np.c_[-k * X[:, 0], np.zeros((len(X), 2))]
    scale = 10.0 * expected  # the direction given at 10 × the onset
    onset = manifold_slack_onset(structure, x0, scale * u1, scale**2 * u2)
    assert onset.fraction * scale == pytest.approx(expected, rel=1e-9)
    assert onset.slack_area == 1.0 and onset.reference_slack_area == 0.0
    assert onset.fraction == pytest.approx(0.1, rel=1e-9)
    # at x0 the stretch is isotropic: the Cauchy resultant t S (1+λ)² / (1+λ)² = t S
    assert onset.least_tension < 0.0
    assert onset.least_reference == pytest.approx(_svk_minor(e0, e0), rel=1e-9)


def test_reference_slack_is_reported_apart(square):
    """Elements already in compression at x0 are not judged: the onset is that of the taut ones,
    the slack area at x0 is reported apart."""
    structure, membrane, X = square
    x0 = (1 + LAM) * X
    left = X[:, 0] < -L / 4
    x0[left, 0] = (1 - LAM) * X[left, 0] - 2 * LAM * L / 4  # the left quarter compressed along x
    taut = taut_set(structure, x0)
    assert 0.0 < taut.reference_slack_area < 0.5
    u = np.c_[np.zeros((len(X), 2)), 0.05 * X[:, 0] ** 2]  # stretches only
    onset = manifold_slack_onset(structure, x0, u)
    assert onset.fraction == np.inf and onset.reference_slack_area == taut.reference_slack_area


def test_a_bonded_stiffener_pushed_into_the_membrane_slackens_its_seam(square):
    """A rigid stiffener bonded along the line X = 0 (an end body's patch: group "attach:…")
    moved by δ along x: the seam column on its right (X in [0, h]) has u_x = δ(1 − X/h), so
    F11 = λ' − δ/h, F22 = λ', no shear; its 2nd PK S11 ∝ E11 + ν E22 vanishes at
    (λ' − δ/h)² = 1 − ν(λ'² − 1). Only the seam can lose tension (nothing else moves), and the
    run's row names it."""
    from quadmodes.structure.tension_margin import slack_place

    structure, membrane, X = square
    h = L / CELLS
    on_line = np.flatnonzero(np.isclose(X[:, 0], 0.0))
    structure = dataclasses.replace(structure, groups={"attach:stiffener": on_line})
    x0 = (1 + LAM) * X
    stretch = 1 + LAM
    expected = h * (stretch - np.sqrt(1 - NU * (stretch**2 - 1)))
    delta = 4 * LAM * h  # the direction given: a = 1 is this push
    u = np.zeros_like(X)
    u[on_line, 0] = delta
    onset = manifold_slack_onset(structure, x0, u)
    assert onset.fraction * delta == pytest.approx(expected, rel=1e-9)
    assert 0.0 < onset.position[0] < h  # the seam column ahead of the stiffener
    taut = taut_set(structure, x0)
    slack = taut.tensions(x0 + u) <= 0.0
    mid_x = x0[membrane.conn, 0].mean(axis=1)
    np.testing.assert_array_equal(slack, (mid_x > 0) & (mid_x < h * stretch))  # that column only
    # the farthest slack centroid from a stiffener node: (2h/3, h/3) off, h√5/3
    nearest = 1e3 * h * np.sqrt(5) / 3 * (1 + LAM)
    assert slack_place(structure, taut, x0, slack) == (
        f"at the seam of end body 'stiffener' (within {nearest:.3g} mm of the bonded patch)")


def test_slack_off_a_compact_patch_is_said_to_be_off_the_seam(square):
    """A bonded block of 3 × 3 nodes at the centre (radius h√2): the seam is the elements with
    a node on it or whose centroid lies within h√2 of one of its nodes; a uniform contraction below the stress-free
    size slackens every element, the place names the seam and counts the others."""
    from quadmodes.structure.tension_margin import seam_bodies, slack_place

    structure, membrane, X = square
    h = L / CELLS
    block = np.flatnonzero((np.abs(X[:, 0]) < 1.01 * h) & (np.abs(X[:, 1]) < 1.01 * h))
    structure = dataclasses.replace(structure, groups={"attach:hub": block})
    x0 = (1 + LAM) * X
    taut = taut_set(structure, x0)
    body, _ = seam_bodies(structure, taut, x0)
    centroid = x0[membrane.conn].mean(axis=1)
    gap = np.min(np.linalg.norm(centroid[:, None] - x0[block][None], axis=2), axis=1)
    bonded = np.isin(membrane.conn, block).all(axis=1)
    touching = np.isin(membrane.conn, block).any(axis=1) & ~bonded
    np.testing.assert_array_equal(body == "hub", ~bonded & (touching | (gap <= np.sqrt(2) * h * (1 + LAM))))
    everywhere = taut.tensions((1 - LAM) * X) <= 0.0
    assert everywhere[taut.judged].all()
    off = int(np.sum(taut.judged & (body == "")))
    assert 0 < off < len(body) and slack_place(structure, taut, x0, everywhere & taut.judged).endswith(
        f"of the bonded patch) and {off} elements off the seams")


def test_minor_resultant_is_the_cauchy_resultants_least_eigenvalue(square):
    """The minor resultant (by components, :func:`minor_resultant`) against the Cauchy
    resultant t F S Fᵀ / J computed here in an orthonormal basis of the deformed plane
    (F = Q R: t R S Rᵀ / |det R|, its least eigenvalue), S = D E from E = (FᵀF − I)/2, on
    random large deformations (tension and compression); and the batched evaluation of many
    states equals the states one by one."""
    structure, membrane, X = square
    taut = taut_set(structure, (1 + LAM) * X)
    rng = np.random.default_rng(11)
    states = (1 + LAM) * X + 0.05 * rng.standard_normal((5, *X.shape))
    c = E / (1 - NU**2)
    d = c * np.array([[1, NU, 0], [NU, 1, 0], [0, 0, (1 - NU) / 2]])
    for x in states:
        got = taut.tensions(x)
        for e, nodes in enumerate(membrane.conn):
            f = x[nodes].T @ membrane.gradients[e]  # (3, 2)
            g = 0.5 * (f.T @ f - np.eye(2))
            sv = d @ [g[0, 0], g[1, 1], 2 * g[0, 1]]
            s = np.array([[sv[0], sv[2]], [sv[2], sv[1]]])
            r = np.linalg.qr(f, mode="r")
            expected = np.linalg.eigvalsh(T * r @ s @ r.T / abs(np.linalg.det(r)))[0]
            assert got[e] == pytest.approx(expected, rel=1e-9, abs=1e-12 * np.abs(sv).max() * T)
    np.testing.assert_array_equal(taut.tensions_many(states), [taut.tensions(x) for x in states])
