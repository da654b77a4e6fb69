"""Snapshot coordinates with mass (quadmodes.experimental.augmented_basis): the linear algebra it
rests on and the kinetic integrals of an augmented chart against those of a model that retains
the same shape as an ordinary mode."""

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.linalg as sla

from quadmodes.experimental.augmented_basis import (
    augmented_model,
    modal_damping,
    pod_of_minimisers,
    split_basis,
)
from quadmodes.rom.reduced import reduce


def _spd(rng, n, scale=1.0):
    a = rng.standard_normal((n, n))
    return scale * (a @ a.T + n * np.eye(n))


def test_modal_damping_gives_zeta_below_the_cutoff_and_nothing_above():
    rng = np.random.default_rng(3)
    k, m = _spd(rng, 8, 1e4), _spd(rng, 8)
    zeta = 0.02
    c, f = modal_damping(k, m, zeta, cutoff_hz=np.median(np.sqrt(sla.eigh(k, m)[0])) / (2 * np.pi))
    w2, v = sla.eigh(k, m)  # V is M-normalised: Vᵀ M V = I
    w = np.sqrt(w2)
    modal = v.T @ c @ v
    below = w / (2 * np.pi) < np.median(f)
    assert below.sum() == 4
    # A modal damping matrix is diagonal in the undamped modes: 2ζω below the cutoff, 0 above.
    np.testing.assert_allclose(np.diag(modal)[below], 2 * zeta * w[below], rtol=1e-9)
    np.testing.assert_allclose(np.diag(modal)[~below], 0.0, atol=1e-9 * zeta * w.max())
    np.testing.assert_allclose(modal - np.diag(np.diag(modal)), 0.0, atol=1e-9 * zeta * w.max())
    np.testing.assert_allclose(f, w / (2 * np.pi), rtol=1e-12)


def test_pod_of_minimisers_recovers_the_snapshot_span_orthogonal_to_the_chart():
    rng = np.random.default_rng(5)
    n_dof = 30
    mass = _spd(rng, n_dof)
    chart = rng.standard_normal((n_dof, 4))  # [Φ Ψ]
    hidden = rng.standard_normal((n_dof, 3))  # the directions the snapshots really move in
    coefficients = rng.standard_normal((20, 3)) * np.array([1.0, 0.3, 0.1])
    snapshots = coefficients @ hidden.T + rng.standard_normal((20, 4)) @ chart.T
    ctx = SimpleNamespace(mass=mass, basis=chart)
    b, captured = pod_of_minimisers(ctx, snapshots, tol=1e-10, max_vectors=10)
    assert b.shape == (n_dof, 3)
    assert captured == pytest.approx(1.0, abs=1e-10)
    np.testing.assert_allclose(b.T @ mass @ b, np.eye(3), atol=1e-10)
    np.testing.assert_allclose(b.T @ mass @ chart, 0.0, atol=1e-9 * np.abs(mass @ chart).max())
    # The snapshots' part off the chart lies in span(B): M-projecting it on B leaves nothing.
    y = snapshots.T - chart @ np.linalg.solve(chart.T @ mass @ chart, chart.T @ mass @ snapshots.T)
    residual = y - b @ (b.T @ mass @ y)
    assert np.linalg.norm(residual) < 1e-9 * np.linalg.norm(y)


def test_split_basis_removes_the_dynamic_span_and_keeps_the_rest():
    rng = np.random.default_rng(7)
    mass = _spd(rng, 20)
    full = sla.qr(rng.standard_normal((20, 6)), mode="economic")[0]
    full = full @ np.linalg.cholesky(np.linalg.inv(full.T @ mass @ full))  # M-orthonormal
    dynamic = full[:, :2]
    rest = split_basis(mass, full, dynamic)
    assert rest.shape == (20, 4)
    np.testing.assert_allclose(rest.T @ mass @ rest, np.eye(4), atol=1e-10)
    np.testing.assert_allclose(dynamic.T @ mass @ rest, 0.0, atol=1e-10)
    both = np.hstack([dynamic, rest])  # spans exactly span(full)
    projector = both @ (both.T @ mass)
    np.testing.assert_allclose(projector @ full, full, atol=1e-10)


def test_an_augmented_shape_has_the_kinetic_integrals_of_a_retained_mode(small_modal_model):
    """Reduce with 4 modes and add mode 5 as a snapshot coordinate: every kinetic integral that
    does not involve a quadratic mode must equal the 5-mode model's (the snapshot's g is zero)."""
    m = small_modal_model
    freqs, shapes = m.modes.frequencies_hz, m.modes.shapes
    five = reduce(m.structure, m.x, freqs, shapes, m.labels, 0.02)
    four = reduce(m.structure, m.x, freqs[:4], shapes[:4], m.labels[:4], 0.02)
    extra = shapes[4].reshape(-1, 1)
    aug = augmented_model(four, m.structure, extra, np.asarray(five.Lam), zeta=0.02,
                          cutoff_hz=10.0 * freqs.max())  # fmt: skip
    assert aug.n_modes == 5
    for name in ("J1", "J2u", "c", "Cuu", "mu", "S1", "Lam"):
        want, got = np.asarray(getattr(five, name)), np.asarray(getattr(aug, name))
        scale = np.abs(want).max()
        np.testing.assert_allclose(got, want, atol=1e-10 * scale, err_msg=name)
    # Every mode is below the cutoff, so the damping is 2ζω in modal coordinates.
    np.testing.assert_allclose(np.diag(aug.C) / np.diag(aug.mu),
                               2 * 0.02 * 2 * np.pi * np.asarray(freqs), rtol=1e-6)  # fmt: skip
    np.testing.assert_allclose(aug.frequencies_hz, freqs, rtol=1e-6)
