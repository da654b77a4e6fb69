"""Compiled (numba) loops of a full-order step: the energy–momentum membrane force, the
follower-pressure force at x½ (:mod:`quadmodes.fullorder.kernels`), the free-body modal damping
force (:func:`quadmodes.fullorder.step.damping_force`) and the ties' blocks of the condensed
Newton matrix (:mod:`quadmodes.fullorder.condensed`). Used when numba (a core
dependency) is importable; the numpy forms there are the fallback and the reference (same
arithmetic, so the two agree to round-off; the tests compare them). ``@njit(cache=True, nogil=True)`` (a renewal on a second thread runs beside them):
compiled once per machine and numba version (then about 0.4 s to load in a fresh process).
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def membrane_force(conn, g0, g1, vg0, vg1, d, a0, b0, e0, x1, out):  # pragma: no cover - jit
    """Add the membrane step forces to ``out`` (n,3): per element F(x₁) columns from ``g0, g1``
    (ne,3), S̄ = D (ε₀ + ε₁)/2 with ``e0`` (3,ne) the Voigt start strain, F(x½) from the start
    columns ``a0, b0`` (ne,3), and ``f_a = vg0_a F½S̄[:,0] + vg1_a F½S̄[:,1]`` (vg = A₀t G)."""
    a1 = np.empty(3)  # F(x₁) columns of the current element (allocated once)
    b1 = np.empty(3)
    for e in range(conn.shape[0]):
        n0, n1, n2 = conn[e, 0], conn[e, 1], conn[e, 2]
        for i in range(3):
            a1[i] = g0[e, 0] * x1[n0, i] + g0[e, 1] * x1[n1, i] + g0[e, 2] * x1[n2, i]
            b1[i] = g1[e, 0] * x1[n0, i] + g1[e, 1] * x1[n1, i] + g1[e, 2] * x1[n2, i]
        e11 = 0.5 * (e0[0, e] + 0.5 * (a1[0] * a1[0] + a1[1] * a1[1] + a1[2] * a1[2] - 1.0))
        e22 = 0.5 * (e0[1, e] + 0.5 * (b1[0] * b1[0] + b1[1] * b1[1] + b1[2] * b1[2] - 1.0))
        g12 = 0.5 * (e0[2, e] + (a1[0] * b1[0] + a1[1] * b1[1] + a1[2] * b1[2]))
        s11 = d[0, 0] * e11 + d[0, 1] * e22 + d[0, 2] * g12
        s22 = d[1, 0] * e11 + d[1, 1] * e22 + d[1, 2] * g12
        s12 = d[2, 0] * e11 + d[2, 1] * e22 + d[2, 2] * g12
        for i in range(3):
            fh0 = 0.5 * (a0[e, i] + a1[i])
            fh1 = 0.5 * (b0[e, i] + b1[i])
            p0 = fh0 * s11 + fh1 * s12
            p1 = fh0 * s12 + fh1 * s22
            out[n0, i] += vg0[e, 0] * p0 + vg1[e, 0] * p1
            out[n1, i] += vg0[e, 1] * p0 + vg1[e, 1] * p1
            out[n2, i] += vg0[e, 2] * p0 + vg1[e, 2] * p1


@nb.njit(cache=True, nogil=True)
def pressure_gradient(conn, xh, out):  # pragma: no cover - jit
    """Add ``∇V`` at xh (n,3) of the triangles ``conn`` (nt,3) to ``out`` (n,3) (m²) and
    return the enclosed volume V (m³)."""
    volume = 0.0
    for e in range(conn.shape[0]):
        p, q, r = conn[e, 0], conn[e, 1], conn[e, 2]
        for a in range(3):
            u = xh[q] if a == 0 else (xh[r] if a == 1 else xh[p])
            w = xh[r] if a == 0 else (xh[p] if a == 1 else xh[q])
            node = p if a == 0 else (q if a == 1 else r)
            c0 = (u[1] * w[2] - u[2] * w[1]) / 6.0
            c1 = (u[2] * w[0] - u[0] * w[2]) / 6.0
            c2 = (u[0] * w[1] - u[1] * w[0]) / 6.0
            out[node, 0] += c0
            out[node, 1] += c1
            out[node, 2] += c2
            if a == 0:
                volume += xh[p, 0] * c0 + xh[p, 1] * c1 + xh[p, 2] * c2
    return volume


@nb.njit(cache=True, nogil=True)
def damping_frame(x, v, t, w, mx, indptr, indices, data):  # pragma: no cover - jit
    """The n-sized sums of the free-body damping force at state (x, v) (n,3), M_s in CSR
    (indptr, indices, data), t (n,) translational indicator, w = M_s t, mx = M_s X (n,3):
    ``(p, r, A, P, s, a)``: centre of mass p (3,), r = x − t p (n,3), ``A = rᵀ M_s X``
    (3,3; its polar factor is the best-fit rotation), ``P = rᵀ M_s r`` (3,3), ``s = Σ wᵢrᵢ``
    (3,) and ``a = Ψᵀ M v`` (6,) (net and moment of M v about p)."""
    n = x.shape[0]
    mass = 0.0
    p = np.zeros(3)
    for i in range(n):
        mass += w[i]
        for k in range(3):
            p[k] += w[i] * x[i, k]
    p /= mass
    r = np.empty((n, 3))
    for i in range(n):
        for k in range(3):
            r[i, k] = x[i, k] - t[i] * p[k]
    big_a, big_p, mom = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3))
    s, net = np.zeros(3), np.zeros(3)
    mr, mv = np.empty(3), np.empty(3)
    for i in range(n):
        mr[:] = 0.0
        mv[:] = 0.0
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            for k in range(3):
                mr[k] += data[q] * r[j, k]
                mv[k] += data[q] * v[j, k]
        for a in range(3):
            s[a] += w[i] * r[i, a]
            net[a] += t[i] * mv[a]
            for b in range(3):
                big_a[a, b] += r[i, a] * mx[i, b]
                big_p[a, b] += r[i, a] * mr[b]
                mom[a, b] += r[i, a] * mv[b]
    moments = np.array([net[0], net[1], net[2], mom[1, 2] - mom[2, 1],
                        mom[2, 0] - mom[0, 2], mom[0, 1] - mom[1, 0]])  # fmt: skip
    return p, r, big_a, big_p, s, moments


@nb.njit(cache=True, nogil=True)
def damping_modal(r, v, t, c6, rot, mphi_flat, cmat):  # pragma: no cover - jit
    """``(f, b)``: the modal damping force before its projection, ``f = Y C Yᵀ (v − Ψ c6)``
    (n,3) with ``Y = M 𝒬 Φ`` (``mphi_flat`` = M_s Φ (K, 3n), rot the frame), and its net and
    moment ``b = Ψᵀ f`` (6,) about the point of r (n,3)."""
    n = r.shape[0]
    u = np.empty((n, 3))
    for i in range(n):
        w0 = v[i, 0] - t[i] * c6[0] - (c6[4] * r[i, 2] - c6[5] * r[i, 1])
        w1 = v[i, 1] - t[i] * c6[1] - (c6[5] * r[i, 0] - c6[3] * r[i, 2])
        w2 = v[i, 2] - t[i] * c6[2] - (c6[3] * r[i, 1] - c6[4] * r[i, 0])
        for b in range(3):  # (v − Ψc) @ rot: body-frame components
            u[i, b] = w0 * rot[0, b] + w1 * rot[1, b] + w2 * rot[2, b]
    q = cmat @ (mphi_flat @ u.reshape(3 * n))
    g = (q @ mphi_flat).reshape(n, 3)
    f = np.empty((n, 3))
    moments = np.zeros(6)
    for i in range(n):
        for a in range(3):
            f[i, a] = g[i, 0] * rot[a, 0] + g[i, 1] * rot[a, 1] + g[i, 2] * rot[a, 2]
            moments[a] += t[i] * f[i, a]
        moments[3] += r[i, 1] * f[i, 2] - r[i, 2] * f[i, 1]
        moments[4] += r[i, 2] * f[i, 0] - r[i, 0] * f[i, 2]
        moments[5] += r[i, 0] * f[i, 1] - r[i, 1] * f[i, 0]
    return f, moments


@nb.njit(cache=True, nogil=True)
def _pinv_symmetric(g, rcond):  # pragma: no cover - jit
    w, u = np.linalg.eigh(g)
    big = np.max(np.abs(w))
    out = np.zeros_like(g)
    for k in range(w.shape[0]):
        if abs(w[k]) > rcond * big:
            out += np.outer(u[:, k], u[:, k]) / w[k]
    return out


@nb.njit(cache=True, nogil=True)
def damping_free(x, v, t, w, mx, indptr, indices, data, mphi_flat, cmat):  # pragma: no cover
    """The free-body modal damping force (n,3) N at state (x, v) of
    :func:`quadmodes.fullorder.step.damping_force` in one compiled call: the frame sums
    (:func:`damping_frame`), the best-fit rotation (polar factor by SVD), the pseudo-inverse
    of ``ΨᵀMΨ`` (rcond 1e-12), the modal force (:func:`damping_modal`) and its projection."""
    p, r, big_a, big_p, s, mv = damping_frame(x, v, t, w, mx, indptr, indices, data)
    u, _, vt = np.linalg.svd(big_a)
    d = np.linalg.det(u @ vt)
    sign = 1.0 if d >= 0.0 else -1.0
    for k in range(3):
        u[k, 2] *= sign
    rot = u @ vt
    g = np.zeros((6, 6))
    tw = 0.0
    for i in range(t.shape[0]):
        tw += t[i] * w[i]
    trace = big_p[0, 0] + big_p[1, 1] + big_p[2, 2]
    skew = np.array([[0.0, -s[2], s[1]], [s[2], 0.0, -s[0]], [-s[1], s[0], 0.0]])
    for a in range(3):
        g[a, a] = tw
        for b in range(3):
            g[a, 3 + b] = -skew[a, b]
            g[3 + b, a] = -skew[a, b]
            g[3 + a, 3 + b] = (trace if a == b else 0.0) - big_p[a, b]
    g_inv = _pinv_symmetric(g, 1e-12)
    f, moments = damping_modal(r, v, t, g_inv @ mv, rot, mphi_flat, cmat)
    c7 = g_inv @ moments
    n = x.shape[0]
    rigid = np.empty((n, 3))
    for i in range(n):
        rigid[i, 0] = t[i] * c7[0] + c7[4] * r[i, 2] - c7[5] * r[i, 1]
        rigid[i, 1] = t[i] * c7[1] + c7[5] * r[i, 0] - c7[3] * r[i, 2]
        rigid[i, 2] = t[i] * c7[2] + c7[3] * r[i, 1] - c7[4] * r[i, 0]
    for i in range(n):  # f − M_s Ψ c7
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            for k in range(3):
                f[i, k] -= data[q] * rigid[j, k]
    return f


@nb.njit(cache=True, nogil=True)
def bar_force(conn, l2, k, d0, e0, x1, out):  # pragma: no cover - jit
    """Add the Green-strain bars' step forces ``∓ k ε̄ d½`` (ε̄ = (ε₀ + ε₁)/2, k = EA/L₀) to
    ``out`` (n,3), bar by bar in index order: the sums of ``BarKernel.force``'s sparse
    products, bit for bit. conn (nb,2), l2 = L₀² (nb,), d0 (nb,3) and e0 (nb,) the start
    vectors and strains, x1 (n,3)."""
    for e in range(conn.shape[0]):
        a, b = conn[e, 0], conn[e, 1]
        d10 = x1[b, 0] - x1[a, 0]
        d11 = x1[b, 1] - x1[a, 1]
        d12 = x1[b, 2] - x1[a, 2]
        e1 = (d10 * d10 + d11 * d11 + d12 * d12 - l2[e]) / (2.0 * l2[e])
        s = k[e] * (0.5 * (e0[e] + e1))
        f0 = s * (0.5 * (d0[e, 0] + d10))
        f1 = s * (0.5 * (d0[e, 1] + d11))
        f2 = s * (0.5 * (d0[e, 2] + d12))
        out[a, 0] -= f0
        out[a, 1] -= f1
        out[a, 2] -= f2
        out[b, 0] += f0
        out[b, 1] += f1
        out[b, 2] += f2


@nb.njit(cache=True, nogil=True)
def scatter_add(positions, values, out):  # pragma: no cover - jit
    """``out[positions[i]] += values[i]`` in the order of i, skipping ``positions[i] < 0``
    (the sums of ``np.bincount``, bit for bit; :mod:`quadmodes.fullorder.preconditioner`)."""
    for i in range(positions.shape[0]):
        p = positions[i]
        if p >= 0:
            out[p] += values[i]


@nb.njit(cache=True, nogil=True)
def tie_blocks(conn, l2, k, x0, x1, positions, weight, out):  # pragma: no cover - jit
    """Add ``weight ×`` the Green-strain bars' energy–momentum Jacobian blocks
    ``½k(ε̄ I + d½ d₁ᵀ/L₀²)`` (as ``[[kb, −kb], [−kb, kb]]``) at the pair (x0, x1) (n,3) to the
    raveled dense matrix ``out``, entry ``(r, c)`` of bar e at ``positions[e, 6r + c]`` (−1:
    dropped). conn (nb,2), l2 = L₀² (nb,), k = EA/L₀ (nb,)."""
    kb = np.empty((3, 3))
    for e in range(conn.shape[0]):
        a, b = conn[e, 0], conn[e, 1]
        d0 = x0[b] - x0[a]
        d1 = x1[b] - x1[a]
        e0 = (d0[0] * d0[0] + d0[1] * d0[1] + d0[2] * d0[2] - l2[e]) / (2.0 * l2[e])
        e1 = (d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2] - l2[e]) / (2.0 * l2[e])
        half = 0.5 * k[e]
        for i in range(3):
            for j in range(3):
                kb[i, j] = half * ((0.5 * (e0 + e1) if i == j else 0.0)
                                   + 0.5 * (d0[i] + d1[i]) * d1[j] / l2[e])  # fmt: skip
        for r in range(6):
            for c in range(6):
                pos = positions[e, 6 * r + c]
                if pos >= 0:
                    sign = 1.0 if (r < 3) == (c < 3) else -1.0
                    out[pos] += weight * sign * kb[r % 3, c % 3]


@nb.njit(cache=True, nogil=True)
def membrane_block_scatter(conn, g0, g1, vol, d, x0, x1, positions, weight, out):  # pragma: no cover
    """Add ``weight ×`` the SVK membranes' energy–momentum Jacobian blocks
    ``½ A₀t [B(x½)ᵀ D B(x₁) + K_geo(S̄)]`` (``MembraneKernel.block``, 9 × 9 per element, rows
    3a + i for node a, component i) at the pair (x0, x1) (n,3) to ``out``, entry (p, q) of
    element e at ``positions[81 e + 9 p + q]`` (−1: dropped), element by element: the blocks'
    sums in the order of :func:`scatter_add`, the blocks themselves to round-off (not formed:
    no (ne, 9, 9) array). conn (ne,3), g0, g1 (ne,3) shape-function gradients, vol = A₀t (ne,),
    d (3,3) the Voigt stiffness."""
    fa0, fb0, fa1, fb1 = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    bh, b1, db1 = np.empty((3, 9)), np.empty((3, 9)), np.empty((3, 9))
    for e in range(conn.shape[0]):
        for i in range(3):
            fa0[i] = fb0[i] = fa1[i] = fb1[i] = 0.0
            for a in range(3):
                fa0[i] += g0[e, a] * x0[conn[e, a], i]
                fb0[i] += g1[e, a] * x0[conn[e, a], i]
                fa1[i] += g0[e, a] * x1[conn[e, a], i]
                fb1[i] += g1[e, a] * x1[conn[e, a], i]
        e11 = 0.5 * (fa0 @ fa0 - 1.0 + fa1 @ fa1 - 1.0) * 0.5
        e22 = 0.5 * (fb0 @ fb0 - 1.0 + fb1 @ fb1 - 1.0) * 0.5
        g12 = 0.5 * (fa0 @ fb0 + fa1 @ fb1)
        s11 = d[0, 0] * e11 + d[0, 1] * e22 + d[0, 2] * g12
        s22 = d[1, 0] * e11 + d[1, 1] * e22 + d[1, 2] * g12
        s12 = d[2, 0] * e11 + d[2, 1] * e22 + d[2, 2] * g12
        for a in range(3):
            for i in range(3):
                c = 3 * a + i
                ah, bb = 0.5 * (fa0[i] + fa1[i]), 0.5 * (fb0[i] + fb1[i])
                bh[0, c] = g0[e, a] * ah
                bh[1, c] = g1[e, a] * bb
                bh[2, c] = g1[e, a] * ah + g0[e, a] * bb
                b1[0, c] = g0[e, a] * fa1[i]
                b1[1, c] = g1[e, a] * fb1[i]
                b1[2, c] = g1[e, a] * fa1[i] + g0[e, a] * fb1[i]
        for r in range(3):
            for c in range(9):
                db1[r, c] = d[r, 0] * b1[0, c] + d[r, 1] * b1[1, c] + d[r, 2] * b1[2, c]
        scale = weight * 0.5 * vol[e]
        for p in range(9):
            a, i = p // 3, p % 3
            for q in range(9):
                pos = positions[81 * e + 9 * p + q]
                if pos < 0:
                    continue
                k = bh[0, p] * db1[0, q] + bh[1, p] * db1[1, q] + bh[2, p] * db1[2, q]
                b, j = q // 3, q % 3
                if i == j:
                    k += (s11 * g0[e, a] * g0[e, b] + s12 * (g0[e, a] * g1[e, b] + g1[e, a] * g0[e, b])
                          + s22 * g1[e, a] * g1[e, b])  # fmt: skip
                out[pos] += scale * k
