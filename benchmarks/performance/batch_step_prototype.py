"""Prototype (issue 27, item 3): the compiled midpoint loop stepping B states of one reduced
model at once, for :mod:`benchmarks.performance.bench_sweep_batch`. Not used by the package.

What is batched: the contractions with the quadratic-mode tensors, i.e. the mass matrix 𝕄(s)
and the products ½(∂𝕄/∂s_k)ν by blocks (J2 (N², 9) and D (N², 3), the same arrays for every
point), evaluated for the B states together with the batch index innermost, so that each row
of J2 and D is loaded once per batch and the B multiply-adds on it run as SIMD lanes. What stays
per point: the Newton solve (LU of each point's (3+N)² matrix, its chord iterations and
convergence test), the rotations, the Jacobian assembly and the ω projection, written as in
:mod:`quadmodes.rom.midpoint_kernel` (same operations in the same order, so that each point's
trajectory is its single run's, bit for bit where the compiler keeps IEEE order).

The points run in lock step: a chord round evaluates the batched residual for every point and
uses it only for the points still iterating (the others' results are discarded). Formulations
Q, P, L (no quartic potential); blocks only (no dense reference); the run stops at the first
failing point (a prototype).

Two more modes of :func:`batch_run`, for the benchmark: ``use_blas=True`` evaluates the same
contractions as matrix products over the batch (``np.dot`` in the compiled loop, i.e. BLAS;
the sums in another order, so equal to the single runs to round-off only), and ``free=True``
skips them altogether (a timing bound whose states mean nothing).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from quadmodes.rom import midpoint_kernel as K

# not cached: numba would check only this file's time stamp, not the kernel pieces it calls
_jit = nb.njit(cache=False, nogil=True, fastmath=False)
# the per-point pieces are inlined into the loop, as the kernel's step pieces are
_jit_inline = nb.njit(cache=False, nogil=True, fastmath=False, inline="always")


@_jit
def batched_mass(mass, zt, g, out):
    """``out[:, :, b] = 𝕄(s_b)`` (m3, m3, B) by blocks for the states ``zt`` (N+1, B) (column b =
    (1, s_b)); g (9, B) work. Each point's sums in the order of
    :func:`quadmodes.rom.midpoint_kernel._block_mass_matrix`."""
    m0, j1, j2r, dr, de = mass[0], mass[1], mass[2], mass[4], mass[5]
    n = zt.shape[0] - 1
    nb_ = zt.shape[1]
    m3 = n + 3
    for a in range(m3):
        for c in range(m3):
            v = m0[a, c]
            for b in range(nb_):
                out[a, c, b] = v
    for k in range(n):
        for e in range(9):
            v = j1[k, e]
            for b in range(nb_):
                g[e, b] = v
        for m in range(n):
            row = j2r[k * n + m]
            for e in range(9):
                re = row[e]
                for b in range(nb_):
                    g[e, b] += zt[m + 1, b] * re
        for a in range(3):
            for c in range(3):
                for b in range(nb_):
                    out[a, c, b] += zt[k + 1, b] * g[3 * a + c, b]
        for c in range(n):
            r = k * n + c
            for a in range(3):
                d1 = dr[r, a]
                d2 = de[r, a]
                for b in range(nb_):
                    out[a, 3 + c, b] += zt[k + 1, b] * d1
                    out[3 + c, a, b] += zt[k + 1, b] * d2


@_jit
def batched_products(mass, energy, zt, vt, g, acc, out):
    """``out[k, :, b] = ½ (∂𝕄/∂s_k) v_b`` (N, m3, B) for zt (N+1, B), vt (m3, B); g (9, B),
    acc (B,) work; the order of :func:`quadmodes.rom.midpoint_kernel._block_products`."""
    j1, de = mass[1], mass[5]
    j2 = mass[3] if energy else mass[2]
    drow = mass[5] if energy else mass[4]
    n = out.shape[0]
    nb_ = zt.shape[1]
    for k in range(n):
        for e in range(9):
            h = 0.5 * j1[k, e]
            for b in range(nb_):
                g[e, b] = h
        for m in range(n):
            row = j2[k * n + m]
            for e in range(9):
                re = row[e]
                for b in range(nb_):
                    g[e, b] += zt[m + 1, b] * re
        for a in range(3):
            for b in range(nb_):
                acc[b] = 0.0
            for c in range(n):
                d = drow[k * n + c, a]
                for b in range(nb_):
                    acc[b] += d * vt[3 + c, b]
            for b in range(nb_):
                out[k, a, b] = (g[3 * a, b] * vt[0, b] + g[3 * a + 1, b] * vt[1, b]
                                + g[3 * a + 2, b] * vt[2, b] + 0.5 * acc[b])  # fmt: skip
        for c in range(n):
            r = k * n + c
            d0, d1, d2 = de[r, 0], de[r, 1], de[r, 2]
            for b in range(nb_):
                out[k, 3 + c, b] = 0.5 * (d0 * vt[0, b] + d1 * vt[1, b] + d2 * vt[2, b])


@_jit
def _mass_blas(mass, zs, bw, dest):
    """dest[b] = 𝕄(zs[b]) for every point from matrix products (BLAS): G = S·J2 (B, 9N),
    S·J1, S·D_rot and S·D (B, 3N); the same sums in another order (round-off)."""
    s_, g_, l_, hr, he = bw[7], bw[10], bw[11], bw[12], bw[13]
    a_r, dr_m, de_m, j1 = bw[16], bw[18], bw[19], mass[1]
    m0 = mass[0]
    nb_, n = s_.shape
    for b in range(nb_):
        for k in range(n):
            s_[b, k] = zs[b, k + 1]
    np.dot(s_, a_r, g_)
    np.dot(s_, j1, l_)
    np.dot(s_, dr_m, hr)
    np.dot(s_, de_m, he)
    m3 = n + 3
    for b in range(nb_):
        for a in range(m3):
            for c in range(m3):
                dest[b, a, c] = m0[a, c]
        for e in range(9):
            acc = l_[b, e]
            for k in range(n):
                acc += s_[b, k] * g_[b, k * 9 + e]
            dest[b, e // 3, e % 3] += acc
        for c in range(n):
            for a in range(3):
                dest[b, a, 3 + c] += hr[b, c * 3 + a]
                dest[b, 3 + c, a] += he[b, c * 3 + a]


@_jit
def _products_blas(mass, energy, zs, vs, bw, dest):
    """dest[b] = ½ (∂𝕄/∂s_k)(zs[b]) vs[b] (N, m3) from matrix products (BLAS): G = S·J2,
    Ṡ·Dᵀ (B, 3N) and Ω·Dᵀ (B, N²); round-off differences from the loops."""
    s_, sd, w_, g_, acc, mod = bw[7], bw[8], bw[9], bw[10], bw[14], bw[15]
    a_m = bw[17] if energy else bw[16]
    dt_m = bw[21] if energy else bw[20]
    de_t, j1 = bw[22], mass[1]
    nb_, n = s_.shape
    for b in range(nb_):
        for k in range(n):
            s_[b, k] = zs[b, k + 1]
            sd[b, k] = vs[b, 3 + k]
        for a in range(3):
            w_[b, a] = vs[b, a]
    np.dot(s_, a_m, g_)
    np.dot(sd, dt_m, acc)
    np.dot(w_, de_t, mod)
    for b in range(nb_):
        w0, w1, w2 = w_[b, 0], w_[b, 1], w_[b, 2]
        for k in range(n):
            for a in range(3):
                r = k * 9 + 3 * a
                dest[b, k, a] = ((0.5 * j1[k, 3 * a] + g_[b, r]) * w0
                                 + (0.5 * j1[k, 3 * a + 1] + g_[b, r + 1]) * w1
                                 + (0.5 * j1[k, 3 * a + 2] + g_[b, r + 2]) * w2
                                 + 0.5 * acc[b, k * 3 + a])  # fmt: skip
            for c in range(n):
                dest[b, k, 3 + c] = 0.5 * mod[b, k * n + c]


@_jit
def _mass_all(mass, zs, bw, dest):
    """dest[b] = 𝕄(zs[b]) for every point (batched), bw the batch work arrays."""
    if bw[6][0] == 1:
        _mass_blas(mass, zs, bw, dest)
        return
    zt, g, om = bw[0], bw[2], bw[4]
    nb_, nz = zs.shape
    for b in range(nb_):
        for i in range(nz):
            zt[i, b] = zs[b, i]
    batched_mass(mass, zt, g, om)
    m3 = om.shape[0]
    for b in range(nb_):
        for a in range(m3):
            for c in range(m3):
                dest[b, a, c] = om[a, c, b]


@_jit
def _products_all(mass, energy, zs, vs, bw, dest):
    """dest[b] = ½ (∂𝕄/∂s_k)(zs[b]) vs[b] (N, m3) for every point (batched)."""
    if bw[6][0] == 1:
        _products_blas(mass, energy, zs, vs, bw, dest)
        return
    zt, vt, g, acc, op = bw[0], bw[1], bw[2], bw[3], bw[5]
    nb_, nz = zs.shape
    m3 = vs.shape[1]
    for b in range(nb_):
        for i in range(nz):
            zt[i, b] = zs[b, i]
        for i in range(m3):
            vt[i, b] = vs[b, i]
    batched_products(mass, energy, zt, vt, g, acc, op)
    n = op.shape[0]
    for b in range(nb_):
        for k in range(n):
            for a in range(m3):
                dest[b, k, a] = op[k, a, b]


@_jit_inline
def _pre(x, x0, sb1, sbm, dt, z1, zm, numid):
    """z₁, z½ and ν½ of one point at the iterate x (as the start of ``_residual``)."""
    n = sb1.shape[0]
    hdt = 0.5 * dt
    z1[0] = 1.0
    zm[0] = 1.0
    for k in range(n):
        z1[k + 1] = sb1[k] + hdt * x[3 + k]
        zm[k + 1] = sbm[k] + 0.25 * dt * x[3 + k]
    for a in range(x.shape[0]):
        numid[a] = 0.5 * (x0[a] + x[a])


@_jit_inline
def _post(x, m1, pm, numid, zm, lam, cmat, h0, p0, dt, theta, rh0, r):
    """The rest of one point's residual given 𝕄(s₁) = m1 and P_E(z½, ν½) = pm (as
    ``_residual``); False for a non-finite iterate."""
    n = lam.shape[0]
    m3 = n + 3
    for a in range(m3):
        acc = 0.0
        for b in range(m3):
            acc += m1[a, b] * x[b]
        r[a] = acc
    for a in range(3):
        theta[a] = -dt * numid[a]
    if not K._rotate(theta, h0, rh0):
        return False
    for a in range(3):
        r[a] -= rh0[a]
    for k in range(n):
        f = 0.0
        for a in range(m3):
            f += pm[k, a] * numid[a]
        for j in range(n):
            f -= lam[k, j] * zm[j + 1] + cmat[k, j] * numid[3 + j]
        r[3 + k] -= p0[k] + dt * f
    return True


@_jit_inline
def _jac(m1, p1, pm, w2, numid, theta, rh0, lam, cmat, dt, jl, jm):
    """One point's Jacobian from its intermediates (as ``_jacobian``, P(z₁, ν₁) = p1 given)."""
    n = lam.shape[0]
    m3 = n + 3
    hdt = 0.5 * dt
    for a in range(m3):
        for b in range(m3):
            jm[a, b] = m1[a, b]
    for a in range(m3):
        for k in range(n):
            jm[a, 3 + k] += dt * p1[k, a]
    K._left_jacobian(theta, jl)
    hx, hy, hz = rh0[0], rh0[1], rh0[2]
    for b in range(3):
        c0 = -hz * jl[1, b] + hy * jl[2, b]
        c1 = hz * jl[0, b] - hx * jl[2, b]
        c2 = -hy * jl[0, b] + hx * jl[1, b]
        jm[0, b] -= hdt * c0
        jm[1, b] -= hdt * c1
        jm[2, b] -= hdt * c2
    qdt2 = 0.25 * dt * dt
    for k in range(n):
        for a in range(m3):
            jm[3 + k, a] -= dt * pm[k, a]
        for j in range(n):
            jm[3 + k, 3 + j] += hdt * cmat[k, j] - qdt2 * (w2[k, j] - lam[k, j])


@_jit
def _residuals(mass, lam, cmat, dt, xs, st, wk, bw, free):
    """Batched residuals of every point at xs (B, m3); returns False where an iterate is
    non-finite (wk[8][b] = 0)."""
    x0, h0, p0, sb1, sbm = st
    z1, zm, m1, numid, theta, rh0, pm, r, ok = wk[0], wk[1], wk[2], wk[3], wk[4], wk[5], wk[6], wk[7], wk[8]
    nb_ = xs.shape[0]
    for b in range(nb_):
        _pre(xs[b], x0[b], sb1[b], sbm[b], dt, z1[b], zm[b], numid[b])
    if not free:
        _mass_all(mass, z1, bw, m1)
        _products_all(mass, True, zm, numid, bw, pm)
    for b in range(nb_):
        ok[b] = 1 if _post(xs[b], m1[b], pm[b], numid[b], zm[b], lam, cmat, h0[b], p0[b], dt,
                           theta[b], rh0[b], r[b]) else 0  # fmt: skip


@_jit
def _linearise_all(mass, lam, cmat, wt, f1, dt, ps, st, wk, bw, nw, info, free):
    """Start a step for every point: per-step constants, the predictor 2ν₀ − ν₋₁, the batched
    residual there, each point's Jacobian, its LU and the convergence scale. Returns the index
    of a point whose start failed (singular or non-finite), or −1."""
    q, s, x, x_prev, m, zs, e_d = ps
    x0, h0, p0, sb1, sbm = st
    z1, m1, numid, theta, rh0, pm, ok = wk[0], wk[2], wk[3], wk[4], wk[5], wk[6], wk[8]
    xg, dx, jm, piv, p1, w2, jl, scale, err_prev, active = nw
    nb_, n = s.shape
    m3 = n + 3
    for b in range(nb_):
        K._begin(m[b], dt, x[b], s[b], h0[b], p0[b], sb1[b], sbm[b])
        for k in range(n):
            p0[b, k] -= dt * f1[k]
        for a in range(m3):
            xg[b, a] = 2.0 * x[b, a] - x_prev[b, a]
    _residuals(mass, lam, cmat, dt, xg, st, wk, bw, free)
    if not free:
        _products_all(mass, False, z1, xg, bw, p1)
    for b in range(nb_):
        if ok[b] == 0:
            return b
        if not free:
            K._block_second(mass[3], numid[b], w2[b])
        _jac(m1[b], p1[b], pm[b], w2[b], numid[b], theta[b], rh0[b], lam, cmat, dt, jl, jm[b])
        if not K._lu_factor(jm[b], piv[b]):
            return b
        scale[b] = K._state_scale(x[b], xg[b], s[b], wt, lam)
        err_prev[b] = math.inf
        active[b] = 1
    return -1


@_jit
def _chord_round(wt, newton_tol, max_newton, its, r, nw, info):
    """One chord iteration for every point still iterating (the test of
    ``midpoint_kernel._chord``). Returns (points left, index of a failed point or −1)."""
    xg, dx, jm, piv, p1, w2, jl, scale, err_prev, active = nw
    nb_, m3 = xg.shape
    left = 0
    for b in range(nb_):
        if active[b] == 0:
            continue
        K._lu_solve(jm[b], piv[b], r[b], dx[b])
        for a in range(m3):
            xg[b, a] -= dx[b, a]
        err = K._weighted_max(dx[b], wt) / scale[b]
        info[b, 1] += 1
        if not math.isfinite(err):
            return left, b
        if err <= newton_tol:
            active[b] = 0
            continue
        if err_prev[b] < math.inf:
            rho = err / err_prev[b]
            if (rho < 0.5 and err * rho <= (1.0 - rho) * newton_tol) or (
                rho >= 1.0 and err <= 1e3 * newton_tol
            ):
                active[b] = 0
                continue
        err_prev[b] = err
        if its >= max_newton:
            return left, b
        left += 1
    return left, -1


@_jit
def _advance_all(mass, cmat, dt, ps, st, bw, nw, i, info, small, free):
    """Finish the step of every point: s₁, 𝕄(s₁) (batched), then each point's ω projection,
    dissipated energy and attitude."""
    q, s, x, x_prev, m, zs, e_d = ps
    sb1, h0 = st[3], st[1]
    xg = nw[0]
    phi, tgt, lu3, piv3 = small
    nb_, n = s.shape
    hdt = 0.5 * dt
    for b in range(nb_):
        zs[b, 0] = 1.0
        for k in range(n):
            s[b, k] = sb1[b, k] + hdt * xg[b, 3 + k]
            zs[b, k + 1] = s[b, k]
    if not free:
        _mass_all(mass, zs, bw, m)
    for b in range(nb_):
        e_d[b] += _finish(cmat, dt, x[b], xg[b], h0[b], m[b], phi, tgt, lu3, piv3)
        K._quat_step(q[b], phi)
        for a in range(n + 3):
            x_prev[b, a] = x[b, a]
            x[b, a] = xg[b, a]
        info[b, 2] = i


@_jit
def _arrays_for(y0s, n, blas, use_blas):
    """Per-point state ``ps``, step constants ``st``, residual work ``wk``, batch work ``bw``
    and Newton arrays ``nw`` for the states y0s (B, 7+2N)."""
    nb_ = y0s.shape[0]
    m3 = n + 3
    x = np.empty((nb_, m3))
    x[:, :3] = y0s[:, 4:7]
    x[:, 3:] = y0s[:, 7 + n:7 + 2 * n]
    s = y0s[:, 7:7 + n].copy()
    zs = np.ones((nb_, n + 1))
    zs[:, 1:] = s
    ps = (y0s[:, 0:4].copy(), s, x, x.copy(), np.empty((nb_, m3, m3)), zs, np.zeros(nb_))
    st = (x, np.empty((nb_, 3)), np.empty((nb_, n)), np.empty((nb_, n)), np.empty((nb_, n)))
    wk = (np.empty((nb_, n + 1)), np.empty((nb_, n + 1)), np.empty((nb_, m3, m3)),
          np.empty((nb_, m3)), np.empty((nb_, 3)), np.empty((nb_, 3)), np.empty((nb_, n, m3)),
          np.empty((nb_, m3)), np.zeros(nb_, np.int64))  # fmt: skip
    bw = (np.empty((n + 1, nb_)), np.empty((m3, nb_)), np.empty((9, nb_)), np.empty(nb_),
          np.empty((m3, m3, nb_)), np.empty((n, m3, nb_)),
          np.full(1, 1 if use_blas else 0, np.int64),
          np.empty((nb_, n)), np.empty((nb_, n)), np.empty((nb_, 3)), np.empty((nb_, 9 * n)),
          np.empty((nb_, 9)), np.empty((nb_, 3 * n)), np.empty((nb_, 3 * n)),
          np.empty((nb_, 3 * n)), np.empty((nb_, n * n)),
          blas[0], blas[1], blas[2], blas[3], blas[4], blas[5], blas[6])  # fmt: skip
    nw = (np.empty((nb_, m3)), np.empty((nb_, m3)), np.empty((nb_, m3, m3)),
          np.empty((nb_, m3), np.int64), np.empty((nb_, n, m3)), np.empty((nb_, n, n)),
          np.empty((3, 3)), np.empty(nb_), np.empty(nb_), np.zeros(nb_, np.int64))  # fmt: skip
    return ps, st, wk, bw, nw


@_jit
def _two_rounds(mass, lam, cmat, dt, st, wk, bw, nw, info):
    """Two chord updates of every point with a residual between them, no convergence test
    (the ``free`` timing bound of :func:`run_batch`)."""
    xg, dx, jm, piv = nw[0], nw[1], nw[2], nw[3]
    nb_, m3 = xg.shape
    for rnd in range(2):
        if rnd == 1:
            _residuals(mass, lam, cmat, dt, xg, st, wk, bw, True)
        for b in range(nb_):
            K._lu_solve(jm[b], piv[b], wk[7][b], dx[b])
            for a in range(m3):
                xg[b, a] -= dx[b, a]
            info[b, 1] += 1


@_jit
def run_batch(mass, lam, cmat, wt, f1, y0s, n_steps, dt, newton_tol, max_newton, last, info,
              free, blas, use_blas):
    """``n_steps`` midpoint steps of the B states y0s (B, 7+2N) in lock step; last (B, 7+2N)
    the final states, info (B, 3) = [status, n_newton, steps done]. Returns 0, or the step at
    which a point (info[b, 0] ≠ 0) failed: the run stops there (a prototype).

    ``free``: a timing bound, not a computation: every contraction is skipped (its arrays keep
    their first values) and each step makes exactly two chord rounds, as the real steps of
    the benchmark do, so the time is that of the per-point work alone. ``use_blas``: the
    contractions as matrix products (:func:`_mass_blas`, :func:`_products_blas`; ``blas`` the
    layouts of :func:`blas_layouts`) instead of the SIMD-lane loops."""
    n = lam.shape[0]
    ps, st, wk, bw, nw = _arrays_for(y0s, n, blas, use_blas)
    _mass_all(mass, ps[5], bw, ps[4])
    small = (np.empty(3), np.empty(3), np.empty((3, 3)), np.empty(3, np.int64))
    info[:, :] = 0
    if free:  # the contractions' arrays hold the first step's values (not garbage)
        _linearise_all(mass, lam, cmat, wt, f1, dt, ps, st, wk, bw, nw, info, False)
    for i in range(1, n_steps + 1):
        bad = _linearise_all(mass, lam, cmat, wt, f1, dt, ps, st, wk, bw, nw, info, free)
        if free:
            _two_rounds(mass, lam, cmat, dt, st, wk, bw, nw, info)
            _advance_all(mass, cmat, dt, ps, st, bw, nw, i, info, small, free)
            continue
        if bad >= 0:
            info[bad, 0] = K.SINGULAR
            return i
        its = 0
        while True:  # chord rounds in lock step; a finished point ignores later residuals
            its += 1
            left, bad = _chord_round(wt, newton_tol, max_newton, its, wk[7], nw, info)
            if bad >= 0:
                info[bad, 0] = K.NOT_CONVERGED
                return i
            if left == 0:
                break
            _residuals(mass, lam, cmat, dt, nw[0], st, wk, bw, free)
            for b in range(y0s.shape[0]):
                if nw[9][b] == 1 and wk[8][b] == 0:
                    info[b, 0] = K.SINGULAR
                    return i
        _advance_all(mass, cmat, dt, ps, st, bw, nw, i, info, small, free)
    q, s, x, e_d = ps[0], ps[1], ps[2], ps[6]
    for b in range(y0s.shape[0]):
        K._store(last[b:b + 1], e_d[b:b + 1], 0, q[b], x[b], s[b], e_d[b])
    return 0


@_jit_inline
def _finish(cmat, dt, x0, x1, h0, m1, phi, tgt, lu3, piv3):
    """The end of ``_advance`` for one point, 𝕄(s₁) = m1 given: φ, the ω projection, ΔE_d."""
    n = cmat.shape[0]
    hdt = 0.5 * dt
    for a in range(3):
        phi[a] = hdt * (x0[a] + x1[a])
    for a in range(3):
        tgt[a] = -phi[a]
    K._rotate(tgt, h0, tgt)
    for a in range(3):
        acc = tgt[a]
        for k in range(n):
            acc -= m1[a, 3 + k] * x1[3 + k]
        tgt[a] = acc
        for b in range(3):
            lu3[a, b] = m1[a, b]
    if K._lu_factor(lu3, piv3):
        K._lu_solve(lu3, piv3, tgt, tgt)
        for a in range(3):
            x1[a] = tgt[a]
    ded = 0.0
    for k in range(n):
        acc = 0.0
        for j in range(n):
            acc += cmat[k, j] * 0.5 * (x0[3 + j] + x1[3 + j])
        ded += 0.5 * (x0[3 + k] + x1[3 + k]) * acc
    return dt * ded


def blas_layouts(mass):
    """The kernel's J2, D (row k·N + m) laid out for matrix products over the batch: J2 as
    (N, 9N) with [m, 9k + e] = J2_km,e (rotational rows, energy); D_rot, D as (N, 3N) with
    [k, 3c + a] = D_kc,a (for Σ_k s_k D_kc) and as (N, 3N) with [c, 3k + a] (for Σ_c D_kc ṡ_c);
    Dᵀ (3, N²)."""
    n = mass[1].shape[0]
    c = np.ascontiguousarray

    def by_m(j2):
        return c(j2.reshape(n, n, 9).transpose(1, 0, 2).reshape(n, 9 * n))

    def by_c(d):
        return c(d.reshape(n, n, 3).transpose(1, 0, 2).reshape(n, 3 * n))

    return (by_m(mass[2]), by_m(mass[3]), c(mass[4].reshape(n, 3 * n)),
            c(mass[5].reshape(n, 3 * n)), by_c(mass[4]), by_c(mass[5]), c(mass[5].T))  # fmt: skip


def batch_run(sys, y0s, n_steps, dt, newton_tol=1e-13, max_newton=25, free=False,
              use_blas=False):  # fmt: skip
    """(final states (B, 7+2N), info (B, 3), failing step or 0) of ``n_steps`` lock-step steps
    (``free``: the timing bound of :func:`run_batch`, whose states mean nothing; ``use_blas``:
    the contractions as matrix products, equal to the single runs to round-off only)."""
    mass, lam, cmat, wt, _, _, f1 = K._arrays(sys)
    y0s = np.ascontiguousarray(y0s, dtype=np.float64)
    last = np.empty_like(y0s)
    info = np.zeros((len(y0s), 3), np.int64)
    fail = run_batch(mass, lam, cmat, wt, f1, y0s, int(n_steps), float(dt), float(newton_tol),
                     int(max_newton), last, info, bool(free), blas_layouts(mass),
                     bool(use_blas))  # fmt: skip
    return last, info, int(fail)
