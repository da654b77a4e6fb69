"""Compiled (numba) time loop of the Lie-group implicit midpoint of :mod:`quadmodes.rom.integrators`.

The numpy midpoint (:class:`~quadmodes.rom.midpoint.MidpointStep` driven by
:func:`~quadmodes.rom.fixed_step.run_fixed`) spends almost
all of its time in Python and numpy call overhead: one step of the N = 5 system is a few thousand
floating-point operations on arrays of 8 and 64 numbers. This module runs the *whole* fixed-step
loop (predictor, analytic Jacobian, chord Newton, the ω projection, dissipated energy, sampling
and failure detection) in one compiled call: ≈1.2–1.5e5 steps/s for N = 5, 20–30× the numpy backend
(benchmarks/performance/bench_rom.py, docs/performance.md).

It solves exactly the same step equations with the same convergence test (see the docstring of
:mod:`quadmodes.rom.integrators`)::

    h(s₁, ω₁, ṡ₁) = exp(−Δt ω̂½) h₀
    p_s(s₁, ω₁, ṡ₁) − p_s(0) = Δt F_s(s½, ω½, ṡ½),   F_s = ∂T/∂s − Λs − Cṡ
    s₁ − s₀ = Δt ṡ½,   q₁ = q₀ ⊗ exp(Δt ω½ / 2)

so the two backends agree to round-off amplified by the dynamics (≲1e-12 relative over
thousands of steps). The only deliberate difference: the chord iteration solves with an LU
factorisation of the Newton matrix (partial pivoting) instead of multiplying by its inverse;
both are backward stable, and the converged steps differ at round-off level.

Generic over the formulations (Q, P, L, rigid) through the blocks of the mass matrix
𝕄(s) = [[J̃(s), A_rot(s)ᵀ], [A(s), μ]] (:mod:`quadmodes.rom.structured_mass`): 𝕄(0), J1, J2 and
D, the rotational rows from the formulation's arrays (J2_rot, D_rot), the modal rows and ∂T/∂s
from the energy arrays (J2, D); for "P" they differ, for the others they are the same arrays.
Every product with 𝕄 and its derivatives costs O(N²) (:func:`_block_mass_matrix`,
:func:`_block_products`, :func:`_block_second`), so a step costs O(N³) (the LU of the Newton
matrix). The dense mass tensor ``𝕄(s) = Σ_ij z_i z_j Mt[i, j]``, z = (1, s), Mt flattened as
((N+1)², (3+N)²) (the ``FlatTensors.Mt`` layout, O(N⁴) work per product) is kept as the
reference (``fixed_run(..., dense=True)``; benchmarks/performance/bench_step_scaling.py).
N = 0 (rigid) is the same code with empty loops.
Formulation "Q4" adds the cubic/quartic potential through ``v3g = 3 V3`` (N, N²) and
``v4g = 4 V4`` (N, N³) (the ``FlatTensors.V3g/V4g`` layout; other formulations pass
(N, 0) arrays and skip it), with the average-vector-field force of :class:`~quadmodes.rom.midpoint.MidpointStep`.

Units: SI. ω (rad/s), s (√kg·m), ṡ (√kg·m/s), h (kg m²/s), energies (J), Δt (s).

Every function is ``@njit(cache=True)``: the machine code is written next to this file
(``__pycache__``; or under ``$NUMBA_CACHE_DIR``) at the first call, so the compile cost (≈10 s)
is paid once per machine and later processes load it in well under a second. The rotation
helpers are the scalar leaves of :mod:`quadmodes.rotations` (written once for both backends),
compiled here with the same options. Numba checks only this file's time stamp before loading the
cached loop (the leaves are compiled into it): after editing those leaves, touch this file or
clear the cache (``*.nbi``/``*.nbc`` in ``__pycache__`` or ``$NUMBA_CACHE_DIR``), or the old
machine code is loaded; ``LEAVES_DIGEST`` below and its test make sure this file is edited
then. For the same reason the kernel stays in this one file.

Layout: the scalar rotation leaves; products with the mass matrix (by blocks, and the dense
reference) and the quartic potential; dense LU; one step (:func:`_residual`, :func:`_jacobian`, :func:`_linearise`, :func:`_chord`,
:func:`_advance`); the loop :func:`run_midpoint`; the Python wrapper :func:`fixed_run`.
"""

from __future__ import annotations

import hashlib
import inspect
import math
import time

import numba as nb
import numpy as np

from quadmodes import rotations as rot
from quadmodes.rom.fixed_step import failure_message, newton_weights
from quadmodes.rom.solution import work_counters

# fastmath is off on purpose: the kernel must reproduce the numpy backend to round-off, and the
# Newton test relies on IEEE semantics for NaN/inf (a diverging iterate must be seen).
_jit = nb.njit(cache=True, nogil=True, fastmath=False)
# The pieces of one step (residual, Jacobian, linearisation, chord iteration) take tuples of
# arrays; compiled as separate functions they cost ≈10 % of the loop's speed (measured), so numba
# inlines them into the loop (same operations, same results).
_jit_inline = nb.njit(cache=True, nogil=True, fastmath=False, inline="always")

#: Failure codes of :func:`run_midpoint` (``info[0]``).
OK, NOT_CONVERGED, SINGULAR = 0, 1, 2


# ---------------------------------------------------------------------------------------------
# rotations: the scalar leaves of quadmodes.rotations, compiled, on (3,) and (4,) arrays
# ---------------------------------------------------------------------------------------------

#: The leaves of :mod:`quadmodes.rotations` compiled into the loop.
LEAVES = (
    rot.half_angle_coefficients,
    rot.rodrigues_coefficients,
    rot.left_jacobian_coefficients,
    rot.rodrigues_rotate,
    rot.quat_times_exp,
)
#: :func:`leaves_digest` of the leaves this file was last checked against. A test compares the
#: two: editing a leaf then forces an edit here, which makes numba recompile the cached loop.
LEAVES_DIGEST = "12678275153a93c0"

(
    _half_angle_coefficients,
    _rodrigues_coefficients,
    _left_jacobian_coefficients,
    _rodrigues_rotate,
    _quat_times_exp,
) = (_jit(f) for f in LEAVES)


def leaves_digest() -> str:
    """First 16 hex digits of the SHA-256 of the source of :data:`LEAVES`."""
    text = "".join(inspect.getsource(f) for f in LEAVES)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


@_jit
def _rotate(theta, v, out):
    """``out = exp(θ̂) v`` (Rodrigues); θ (3,) rad, v (3,), out (3,) (may alias θ). Returns False
    if |θ|² is not finite (the numpy backend raises a math domain error there; a diverged
    iterate)."""
    tx, ty, tz = theta[0], theta[1], theta[2]
    a2 = tx * tx + ty * ty + tz * tz
    if not math.isfinite(a2):
        return False
    sa, ca = _rodrigues_coefficients(a2)
    out[0], out[1], out[2] = _rodrigues_rotate(sa, ca, tx, ty, tz, v[0], v[1], v[2])
    return True


@_jit
def _left_jacobian(theta, out):
    """Left Jacobian (3,3) of SO(3) at θ (3,) rad into ``out``:
    ``exp((θ+δ)^) = exp((J_l δ)^) exp(θ̂) + O(δ²)``, ``J_l = I + c θ̂ + d θ̂²``."""
    x, y, z = theta[0], theta[1], theta[2]
    a2 = x * x + y * y + z * z
    c, d = _left_jacobian_coefficients(a2)
    # θ̂² = θθᵀ − |θ|² I
    out[0, 0] = 1.0 + d * (x * x - a2)
    out[1, 1] = 1.0 + d * (y * y - a2)
    out[2, 2] = 1.0 + d * (z * z - a2)
    out[0, 1] = -c * z + d * x * y
    out[1, 0] = c * z + d * x * y
    out[0, 2] = c * y + d * x * z
    out[2, 0] = -c * y + d * x * z
    out[1, 2] = -c * x + d * y * z
    out[2, 1] = c * x + d * y * z


@_jit
def _quat_step(q, phi):
    """``q ← q ⊗ exp(φ/2)``, normalised, in place; q (4,) scalar first, φ (3,) rad."""
    px, py, pz = phi[0], phi[1], phi[2]
    c, k = _half_angle_coefficients(math.sqrt(px * px + py * py + pz * pz))
    q[0], q[1], q[2], q[3] = _quat_times_exp(q[0], q[1], q[2], q[3], c, k, px, py, pz)


# ---------------------------------------------------------------------------------------------
# products with the mass matrix (dense reference, then by blocks), and the quartic potential
# ---------------------------------------------------------------------------------------------


@_jit
def _mass_matrix(mt, z, out):
    """Dense reference: ``out = 𝕄(s) = Σ_ij z_i z_j Mt[i, j]`` (3+N, 3+N); mt ((N+1)², (3+N)²)
    the flattened mass tensor (``FlatTensors.Mt`` layout), z (N+1,) = (1, s).

    Mt is symmetric in (i, j), so only i ≤ j is visited (off-diagonal pairs counted twice). The
    inner loop runs over the (3+N)² contiguous entries of a block: independent multiply-adds
    that the compiler vectorises (a sparse, indexed form was measured 5× slower)."""
    nz = z.shape[0]
    mm = mt.shape[1]
    o = out.reshape(mm)  # a view: out is C-contiguous
    o[:] = 0.0
    for i in range(nz):
        for j in range(i, nz):
            w = z[i] * z[j] if i == j else 2.0 * z[i] * z[j]
            row = mt[i * nz + j]
            for e in range(mm):
                o[e] += w * row[e]


@_jit
def _y_times(mt, z, v, y, out):
    """Dense reference: ``out[k] = Y_k v`` (N, 3+N) with ``Y_k = Σ_j z_j Mt[j, k+1]``
    (= ½ ∂𝕄/∂s_k); z (N+1,), v (3+N,), y ((3+N)²,) work array. Forming Y_k first keeps the
    inner loops contiguous."""
    nz = z.shape[0]
    m3 = v.shape[0]
    mm = m3 * m3
    for k in range(nz - 1):
        y[:] = 0.0
        for j in range(nz):
            zj = z[j]
            row = mt[j * nz + k + 1]
            for e in range(mm):
                y[e] += zj * row[e]
        for a in range(m3):
            acc = 0.0
            for b in range(m3):
                acc += y[a * m3 + b] * v[b]
            out[k, a] = acc


@_jit
def _second_derivative(mte, v, vv, out):
    """Dense reference: ``out[k, j] = vᵀ MtE[k+1, j+1] v`` (N, N) = ½ ∂²(vᵀ𝕄_E v)/∂s_k∂s_j;
    v (3+N,), vv ((3+N)²,) work array (receives v vᵀ)."""
    n = out.shape[0]
    nz = n + 1
    m3 = v.shape[0]
    for a in range(m3):
        for b in range(m3):
            vv[a * m3 + b] = v[a] * v[b]
    for k in range(n):
        for j in range(k, n):  # symmetric in (k, j)
            row = mte[(k + 1) * nz + j + 1]
            acc = 0.0
            for e in range(m3 * m3):
                acc += row[e] * vv[e]
            out[k, j] = acc
            out[j, k] = acc


@_jit
def _block_mass_matrix(mass, z, g, out):
    """``out = 𝕄(s)`` (3+N, 3+N) by blocks, O(N²)
    (:func:`quadmodes.rom.structured_mass.mass_matrix`); mass = (𝕄(0) (m3, m3), J1 (N, 9), J2_rot, J2 (N², 9), D_rot, D (N², 3), …) of
    :func:`_arrays` (row k·N + m of J2 is J2_km, row k·N + n of D is D_kn), z (N+1,) = (1, s),
    g (≥ 9,) work array."""
    m0, j1, j2r, dr, de = mass[0], mass[1], mass[2], mass[4], mass[5]
    n = z.shape[0] - 1
    m3 = n + 3
    for a in range(m3):
        for b in range(m3):
            out[a, b] = m0[a, b]
    for k in range(n):
        # J̃ − J0 = Σ_k s_k (J1_k + G_k),  G_k = Σ_m s_m J2_km
        for e in range(9):
            g[e] = j1[k, e]
        for m in range(n):
            sm = z[m + 1]
            row = j2r[k * n + m]
            for e in range(9):
                g[e] += sm * row[e]
        sk = z[k + 1]
        for a in range(3):
            for b in range(3):
                out[a, b] += sk * g[3 * a + b]
        # rotational columns Σ_k s_k D_rot,kn and modal rows Σ_k s_k D_kn
        for c in range(n):
            r = k * n + c
            for a in range(3):
                out[a, 3 + c] += sk * dr[r, a]
                out[3 + c, a] += sk * de[r, a]


@_jit
def _block_products(mass, energy, z, v, g, out):
    """``out[k] = ½ (∂𝕄/∂s_k) v`` (N, 3+N) by blocks, O(N²)
    (:func:`quadmodes.rom.structured_mass.half_derivative_products`): ``(½J1_k + G_k) ω +
    ½ Σ_n D_kn ṡ_n`` in the rotational columns (J2, D of the energy if ``energy``, else the
    rotational-row J2_rot, D_rot), ``½ D_kn·ω`` in the modal ones; v = (ω, ṡ) (3+N,)."""
    j1, de = mass[1], mass[5]
    j2 = mass[3] if energy else mass[2]
    drow = mass[5] if energy else mass[4]
    n = out.shape[0]
    w0, w1, w2 = v[0], v[1], v[2]
    for k in range(n):
        for e in range(9):
            g[e] = 0.5 * j1[k, e]
        for m in range(n):
            sm = z[m + 1]
            row = j2[k * n + m]
            for e in range(9):
                g[e] += sm * row[e]
        for a in range(3):
            acc = 0.0
            for c in range(n):
                acc += drow[k * n + c, a] * v[3 + c]
            out[k, a] = g[3 * a] * w0 + g[3 * a + 1] * w1 + g[3 * a + 2] * w2 + 0.5 * acc
        for c in range(n):
            r = k * n + c
            out[k, 3 + c] = 0.5 * (de[r, 0] * w0 + de[r, 1] * w1 + de[r, 2] * w2)


@_jit
def _block_second(j2e, v, out):
    """``out[k, j] = ωᵀ J2_kj ω`` (N, N) = ½ vᵀ(∂²𝕄_E/∂s_k∂s_j)v, O(N²); j2e (N², 9) the energy
    J2 (symmetric in k, j), v = (ω, ṡ)."""
    n = out.shape[0]
    w0, w1, w2 = v[0], v[1], v[2]
    for k in range(n):
        for j in range(k, n):
            row = j2e[k * n + j]
            acc = w0 * (row[0] * w0 + row[1] * w1 + row[2] * w2)
            acc += w1 * (row[3] * w0 + row[4] * w1 + row[5] * w2)
            acc += w2 * (row[6] * w0 + row[7] * w1 + row[8] * w2)
            out[k, j] = acc
            out[j, k] = acc


@_jit
def _mass(mass, z, y, out):
    """``out = 𝕄(s)``: by blocks, or from the dense tensor Mt = mass[6] when it is given (not
    (0, 0): the reference); y work array ((3+N)²,)."""
    if mass[6].shape[0] > 0:
        _mass_matrix(mass[6], z, out)
    else:
        _block_mass_matrix(mass, z, y, out)


@_jit
def _products(mass, energy, z, v, y, out):
    """``out[k] = ½ (∂𝕄/∂s_k) v`` (N, 3+N), energy or momenta arrays: by blocks, or from the
    dense tensors (MtE = mass[7], Mt = mass[6]) when given; y work array ((3+N)²,)."""
    mt = mass[7] if energy else mass[6]
    if mt.shape[0] > 0:
        _y_times(mt, z, v, y, out)
    else:
        _block_products(mass, energy, z, v, y, out)


@_jit
def _second(mass, v, y, out):
    """``out[k, j] = ½ vᵀ(∂²𝕄_E/∂s_k∂s_j)v`` (N, N): by blocks, or from the dense MtE = mass[7]
    when given; y work array ((3+N)²,)."""
    if mass[7].shape[0] > 0:
        _second_derivative(mass[7], v, y, out)
    else:
        _block_second(mass[3], v, out)


@_jit
def _nl_force(v3g, v4g, z, out):
    """``out = 3 V3·ss + 4 V4·sss`` (N,) at s = z[1:] (z = (1, s)); v3g (N, N²), v4g (N, N³)."""
    n = out.shape[0]
    for k in range(n):
        acc = 0.0
        for m in range(n):
            sm = z[m + 1]
            for q in range(n):
                smq = sm * z[q + 1]
                acc += v3g[k, m * n + q] * smq
                base = (m * n + q) * n
                for p in range(n):
                    acc += v4g[k, base + p] * smq * z[p + 1]
        out[k] = acc


@_jit
def _nl_hessian(v3g, v4g, z, out):
    """``out = 6 V3·s + 12 V4·ss`` (N, N) at s = z[1:]: the Hessian of the cubic/quartic
    potential (V3, V4 symmetric)."""
    n = out.shape[0]
    for k in range(n):
        for m in range(n):
            acc = 0.0
            for q in range(n):
                sq = z[q + 1]
                acc += 2.0 * v3g[k, m * n + q] * sq
                base = (m * n + q) * n
                for p in range(n):
                    acc += 3.0 * v4g[k, base + p] * sq * z[p + 1]
            out[k, m] = acc


# ---------------------------------------------------------------------------------------------
# dense LU with partial pivoting (the (3+N)² Newton matrix and the 3×3 projection)
# ---------------------------------------------------------------------------------------------


@_jit
def _lu_factor(a, piv):
    """In-place LU of ``a`` (m, m) with partial pivoting; piv (m,) int64 row swaps. Returns False
    for an exactly zero pivot (singular matrix), as LAPACK's getrf does."""
    m = a.shape[0]
    for k in range(m):
        p = k
        big = abs(a[k, k])
        for i in range(k + 1, m):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                p = i
        piv[k] = p
        if big == 0.0:
            return False
        if p != k:
            for j in range(m):
                a[k, j], a[p, j] = a[p, j], a[k, j]
        inv = 1.0 / a[k, k]
        for i in range(k + 1, m):
            f = a[i, k] * inv
            a[i, k] = f
            if f != 0.0:
                for j in range(k + 1, m):
                    a[i, j] -= f * a[k, j]
    return True


@_jit
def _lu_solve(lu, piv, b, x):
    """Solve ``A x = b`` with the factors of :func:`_lu_factor`; b, x (m,) (may alias)."""
    m = lu.shape[0]
    for i in range(m):
        x[i] = b[i]
    for k in range(m):
        p = piv[k]
        if p != k:
            x[k], x[p] = x[p], x[k]
    for i in range(m):
        acc = x[i]
        for j in range(i):
            acc -= lu[i, j] * x[j]
        x[i] = acc
    for i in range(m - 1, -1, -1):
        acc = x[i]
        for j in range(i + 1, m):
            acc -= lu[i, j] * x[j]
        x[i] = acc / lu[i, i]


# ---------------------------------------------------------------------------------------------
# one midpoint step
# ---------------------------------------------------------------------------------------------


@_jit
def _begin(m0, dt, x0, s0, h0, p0, sb1, sbm):
    """Per-step constants from the state at t0: momenta (h₀ (3,), p₀ (N,)) = 𝕄(s₀)ν₀ and the
    parts of s₁ = sb1 + ½Δt ṡ₁ and s½ = sbm + ¼Δt ṡ₁ that do not depend on the unknowns
    (s₁ is an explicit linear function of ṡ₁ and is eliminated). m0 = 𝕄(s₀) (3+N, 3+N): the
    previous step's 𝕄(s₁), not recomputed; x0 = ν₀ (3+N,), s0 (N,)."""
    n = s0.shape[0]
    m3 = n + 3
    for k in range(n):
        sb1[k] = s0[k] + 0.5 * dt * x0[3 + k]
        sbm[k] = s0[k] + 0.25 * dt * x0[3 + k]
    for a in range(m3):
        acc = 0.0
        for b in range(m3):
            acc += m0[a, b] * x0[b]
        if a < 3:
            h0[a] = acc
        else:
            p0[a - 3] = acc


@_jit
def _work_arrays(n):
    """Work arrays of :func:`_residual` and :func:`_jacobian` for N = n modes (m3 = 3 + n):
    ``(z1, zm (n+1,), m1 (m3, m3), numid (m3,), theta, rh0 (3,), pm, p1 (n, m3), w2 (n, n),
    jl (3, 3), y (m3²,), nm, n1 (n,), hm, h1 (n, n))``."""
    m3 = n + 3
    return (np.empty(n + 1), np.empty(n + 1), np.empty((m3, m3)), np.empty(m3), np.empty(3),
            np.empty(3), np.empty((n, m3)), np.empty((n, m3)), np.empty((n, n)),
            np.empty((3, 3)), np.empty(m3 * m3), np.empty(n), np.empty(n), np.empty((n, n)),
            np.empty((n, n)))  # fmt: skip


@_jit_inline
def _residual(x, arrays, dt, consts, wk, r):
    """Residual r (3+N,) of the step equations at ν₁ = x (3+N,). Returns False if the iterate
    is non-finite. Mirrors :meth:`quadmodes.rom.midpoint.MidpointStep.residual`.

    ``arrays`` = (mass, Λ, C, 3V3, 4V4, F1) of :func:`_arrays`; ``consts`` = (ν₀, h₀, p₀, sb1,
    sbm, n0) of the step (n0 (N,) = 3V3·s₀s₀ + 4V4·s₀s₀s₀ for Q4, ``v3g.shape[1] > 0``); ``wk``
    of :func:`_work_arrays`: on return it holds z₁, z½, 𝕄(s₁), ν½, θ = −Δt ω½, exp(θ̂) h₀ and
    P_E(z½, ν½) for :func:`_jacobian`."""
    mass, lam, cmat, v3g, v4g, _ = arrays
    x0, h0, p0, sb1, sbm, n0 = consts
    z1, zm, m1, numid, theta, rh0, pm, p1, w2, jl, y, nm, n1, hm, h1 = wk
    quartic = v3g.shape[1] > 0
    n = lam.shape[0]
    m3 = n + 3
    hdt = 0.5 * dt
    z1[0] = 1.0
    zm[0] = 1.0
    for k in range(n):
        z1[k + 1] = sb1[k] + hdt * x[3 + k]
        zm[k + 1] = sbm[k] + 0.25 * dt * x[3 + k]
    _mass(mass, z1, y, m1)
    for a in range(m3):
        acc = 0.0
        for b in range(m3):
            acc += m1[a, b] * x[b]
        r[a] = acc
        numid[a] = 0.5 * (x0[a] + x[a])
    # rotational rows: 𝕄(s₁)ν₁ − exp(−Δt ω̂½) h₀ (exact discrete transport of R h)
    for a in range(3):
        theta[a] = -dt * numid[a]
    if not _rotate(theta, h0, rh0):
        return False
    for a in range(3):
        r[a] -= rh0[a]
    # modal rows: p₁ − p₀ − Δt F_s(½),  F_s = P_E(z½, ν½)·ν½ − Λs½ − Cṡ½
    _products(mass, True, zm, numid, y, pm)
    if quartic:  # average vector field (Simpson, exact for the cubic ∂V/∂s)
        _nl_force(v3g, v4g, zm, nm)
        _nl_force(v3g, v4g, z1, n1)
    for k in range(n):
        f = 0.0
        for a in range(m3):
            f += pm[k, a] * numid[a]
        for j in range(n):
            f -= lam[k, j] * zm[j + 1] + cmat[k, j] * numid[3 + j]
        if quartic:
            f -= (n0[k] + 4.0 * nm[k] + n1[k]) / 6.0
        r[3 + k] -= p0[k] + dt * f
    return True


@_jit_inline
def _jacobian(x, arrays, dt, wk, jm):
    """Jacobian ``jm`` (3+N, 3+N) of the residual with respect to ν₁ = x, from the intermediates
    that :func:`_residual` left in ``wk`` at the same x."""
    mass, lam, cmat, v3g, v4g, _ = arrays
    z1, zm, m1, numid, theta, rh0, pm, p1, w2, jl, y, nm, n1, hm, h1 = wk
    n = lam.shape[0]
    m3 = n + 3
    hdt = 0.5 * dt
    for a in range(m3):
        for b in range(m3):
            jm[a, b] = m1[a, b]
    # ∂(𝕄(s₁)ν₁)/∂s₁ · ∂s₁/∂ṡ₁ = 2 P(z₁, ν₁)ᵀ · ½Δt
    _products(mass, False, z1, x, y, p1)
    for a in range(m3):
        for k in range(n):
            jm[a, 3 + k] += dt * p1[k, a]
    # rotational rows: ∂(exp(θ̂) h₀)/∂ω₁ = ½Δt ĥ J_l(θ) with θ = −Δt ω½, ĥ = hat(exp(θ̂) h₀)
    _left_jacobian(theta, jl)
    hx, hy, hz = rh0[0], rh0[1], rh0[2]
    for b in range(3):
        c0 = -hz * jl[1, b] + hy * jl[2, b]
        c1 = hz * jl[0, b] - hx * jl[2, b]
        c2 = -hy * jl[0, b] + hx * jl[1, b]
        jm[0, b] -= hdt * c0
        jm[1, b] -= hdt * c1
        jm[2, b] -= hdt * c2
    # modal rows: −Δt ∂F_s/∂ν₁ (ν½ = ½(ν₀+ν₁), s½ = sbm + ¼Δt ṡ₁)
    _second(mass, numid, y, w2)
    qdt2 = 0.25 * dt * dt
    for k in range(n):
        for a in range(m3):
            jm[3 + k, a] -= dt * pm[k, a]
        for j in range(n):
            jm[3 + k, 3 + j] += hdt * cmat[k, j] - qdt2 * (w2[k, j] - lam[k, j])
    if v3g.shape[1] > 0:  # Q4; ∂s½/∂ṡ₁ = ¼Δt, ∂s₁/∂ṡ₁ = ½Δt
        _nl_hessian(v3g, v4g, zm, hm)
        _nl_hessian(v3g, v4g, z1, h1)
        dt2 = dt * dt
        for k in range(n):
            for j in range(n):
                jm[3 + k, 3 + j] += dt2 * (hm[k, j] / 6.0 + h1[k, j] / 12.0)


@_jit_inline
def _linearise(m, z, x_prev, s, xg, arrays, dt, consts, wk, r, jm, piv):
    """Start a step: per-step constants (``consts``, from ν₀ = consts[0], s₀ = s, 𝕄(s₀) = m and
    z = (1, s₀)), the predictor ``xg = 2ν₀ − ν_prev``, the residual r there and the LU factors
    of its Jacobian in ``jm``, ``piv``. Returns False for a non-finite predictor or a singular
    Jacobian."""
    x, h0, p0, sb1, sbm, n0 = consts
    _begin(m, dt, x, s, h0, p0, sb1, sbm)
    v3g, v4g, f1 = arrays[3], arrays[4], arrays[5]
    for k in range(f1.shape[0]):  # the constant potential force F1 folded into p₀ − Δt F1
        p0[k] -= dt * f1[k]
    if v3g.shape[1] > 0:
        _nl_force(v3g, v4g, z, n0)  # z = (1, s₀)
    for a in range(x.shape[0]):
        xg[a] = 2.0 * x[a] - x_prev[a]
    # analytic Jacobian once per step, at the predictor; chord iterations after that
    if not _residual(xg, arrays, dt, consts, wk, r):
        return False
    _jacobian(xg, arrays, dt, wk, jm)
    return _lu_factor(jm, piv)


@_jit_inline
def _chord(xg, arrays, dt, consts, wk, r, jm, piv, dx, wt, scale, newton_tol, max_newton):
    """Chord iterations ``xg ← xg − J⁻¹ r(xg)`` with the LU factors (jm, piv) of
    :func:`_linearise`; the convergence test of :func:`quadmodes.rom.fixed_step.chord_newton`.
    Returns (OK / NOT_CONVERGED / SINGULAR, iterations, last relative update)."""
    err_prev = math.inf
    err = math.inf
    its = 0
    for it in range(1, max_newton + 1):
        its = it
        _lu_solve(jm, piv, r, dx)
        for a in range(xg.shape[0]):
            xg[a] -= dx[a]
        err = _weighted_max(dx, wt) / scale
        if not math.isfinite(err):
            return NOT_CONVERGED, its, err
        if err <= newton_tol:
            return OK, its, err
        if err_prev < math.inf:
            rho = err / err_prev
            # remaining error ≈ ρ/(1−ρ)·update for a linearly contracting chord iteration
            if rho < 0.5 and err * rho <= (1.0 - rho) * newton_tol:
                return OK, its, err
            if rho >= 1.0 and err <= 1e3 * newton_tol:
                return OK, its, err  # stagnation at round-off
        err_prev = err
        if not _residual(xg, arrays, dt, consts, wk, r):
            return SINGULAR, its, err
    return NOT_CONVERGED, its, err


@_jit
def _weighted_max(dx, wt):
    """max_i |dx_i wt_i| (energy-weighted max-norm); NaN if any entry is NaN (as numpy's max)."""
    m = 0.0
    for i in range(dx.shape[0]):
        v = abs(dx[i] * wt[i])
        if v != v:
            return v
        if v > m:
            m = v
    return m


@_jit
def _state_scale(x, xg, s, wt, lam):
    """Energy-like scale (√J) of the Newton unknowns for the relative convergence test:
    max|ν₀ w| + max|ν_pred w| + √|sᵀΛs| (w = √diag(J0, μ)); as ``fixed_step.state_scale``."""
    n = s.shape[0]
    v = 0.0
    for k in range(n):
        acc = 0.0
        for j in range(n):
            acc += lam[k, j] * s[j]
        v += s[k] * acc
    return _weighted_max(x, wt) + _weighted_max(xg, wt) + math.sqrt(abs(v)) + 1e-300


@_jit
def _advance(mass, cmat, dt, x0, x1, h0, sb1, s1, phi, z, m1, g, lu3, piv3, tgt):
    """Finish a converged step in place: s₁ (N,), the rotation vector φ = Δt ω½ (3,) of the
    step, and ω₁ projected (one 3×3 solve) onto ``h(s₁, ω₁, ṡ₁) = exp(−φ̂) h₀`` so that R h is
    conserved to round-off, not only to the Newton tolerance. Returns the energy dissipated in
    the step, Δt ṡ½ᵀCṡ½ (J): the exact discrete balance of the quadratic part. ``m1`` receives
    𝕄(s₁) (3+N, 3+N), which the next step's :func:`_begin` reuses as its 𝕄(s₀); g work array
    ((3+N)²,); mass as in :func:`_arrays`."""
    n = s1.shape[0]
    hdt = 0.5 * dt
    z[0] = 1.0
    for k in range(n):
        s1[k] = sb1[k] + hdt * x1[3 + k]
        z[k + 1] = s1[k]
    _mass(mass, z, g, m1)
    for a in range(3):
        phi[a] = hdt * (x0[a] + x1[a])  # the same φ moves q: R₁h₁ = R₀h₀ exactly
    for a in range(3):
        tgt[a] = -phi[a]
    _rotate(tgt, h0, tgt)  # finite: φ comes from a converged (finite) iterate
    for a in range(3):
        acc = tgt[a]
        for k in range(n):
            acc -= m1[a, 3 + k] * x1[3 + k]
        tgt[a] = acc
        for b in range(3):
            lu3[a, b] = m1[a, b]
    if _lu_factor(lu3, piv3):  # J̃(s₁) is positive definite; guard anyway
        _lu_solve(lu3, piv3, tgt, tgt)
        for a in range(3):
            x1[a] = tgt[a]
    ded = 0.0
    for k in range(n):
        acc = 0.0
        for j in range(n):
            acc += cmat[k, j] * 0.5 * (x0[3 + j] + x1[3 + j])
        ded += 0.5 * (x0[3 + k] + x1[3 + k]) * acc
    return dt * ded


# ---------------------------------------------------------------------------------------------
# the fixed-step loop
# ---------------------------------------------------------------------------------------------


@_jit
def _store(out, ed_out, k, q, x, s, e_d):
    """Write the state ``[q, ω, s, ṡ]`` (7+2N,) and E_d into row k of the samples."""
    n = s.shape[0]
    for a in range(4):
        out[k, a] = q[a]
    for a in range(3):
        out[k, 4 + a] = x[a]
    for j in range(n):
        out[k, 7 + j] = s[j]
        out[k, 7 + n + j] = x[3 + j]
    ed_out[k] = e_d


@_jit
def run_midpoint(mass, lam, cmat, wt, y0, n_steps, dt, save_idx, newton_tol, max_newton,
                 out, ed_out, last, info, finfo, v3g, v4g, f1):  # fmt: skip
    """Run ``n_steps`` midpoint steps of size ``dt`` (s) from ``y0`` (7+2N,) = [q, ω, s, ṡ].

    Inputs: mass, the blocks of the mass matrix (and the dense reference tensors, or (0, 0)
    arrays) of :func:`_arrays`; lam (N,N) 1/s²,
    cmat (N,N) 1/s; wt (3+N,) = √diag(J0, μ) weights of the convergence test; save_idx (K,)
    int64 increasing step indices to sample (save_idx[0] = 0); newton_tol relative; max_newton.
    Outputs: out (K, 7+2N) samples, ed_out (K,) dissipated energy (J) at the samples, last
    (7+2N,) the last accepted state, info (int64, 7) = [status (OK / NOT_CONVERGED /
    SINGULAR), failing step, its Newton iterations, n_newton, n_jac, n_res, steps done],
    finfo (float64, 2) = [relative Newton update at failure, E_d of the last accepted state].
    v3g (N, N²), v4g (N, N³): 3V3 and 4V4 of formulation Q4, or (N, 0) arrays (no quartic
    potential). f1 (N,) J/(√kg·m): the linear potential coefficient F1 (zeros for a model about
    the state at rest). Returns the number of samples written.
    """
    n = lam.shape[0]
    m3 = n + 3
    arrays = (mass, lam, cmat, v3g, v4g, f1)
    # state: q, s, ν = (ω, ṡ) and the previous ν for the linear-extrapolation predictor
    q = y0[0:4].copy()
    s = y0[7 : 7 + n].copy()
    x = np.empty(m3)
    x[:3] = y0[4:7]
    x[3:] = y0[7 + n : 7 + 2 * n]
    x_prev = x.copy()
    # per-step constants and work arrays, allocated once (no allocation inside the loop)
    consts = (x, np.empty(3), np.empty(n), np.empty(n), np.empty(n), np.zeros(n))
    wk = _work_arrays(n)
    xg, r, dx = np.empty(m3), np.empty(m3), np.empty(m3)
    jm, piv = np.empty((m3, m3)), np.empty(m3, np.int64)
    z, m = np.empty(n + 1), np.empty((m3, m3))  # 𝕄(s) of the current state (kept across steps)
    phi, tgt, lu3, piv3 = np.empty(3), np.empty(3), np.empty((3, 3)), np.empty(3, np.int64)
    z[0] = 1.0
    z[1:] = s
    _mass(mass, z, wk[10], m)
    _store(out, ed_out, 0, q, x, s, 0.0)
    k_save = 1
    next_save = save_idx[1] if save_idx.shape[0] > 1 else -1
    e_d = 0.0
    n_newton = n_jac = 0
    status = fail_step = fail_its = done = 0
    fail_err = 0.0
    for i in range(1, n_steps + 1):
        if not _linearise(m, z, x_prev, s, xg, arrays, dt, consts, wk, r, jm, piv):
            status, fail_step = SINGULAR, i
            break
        n_jac += 1
        scale = _state_scale(x, xg, s, wt, lam)
        code, its, err = _chord(
            xg, arrays, dt, consts, wk, r, jm, piv, dx, wt, scale, newton_tol, max_newton
        )
        if code == SINGULAR:
            status, fail_step = SINGULAR, i
            break
        n_newton += its
        if code == NOT_CONVERGED:
            status, fail_step, fail_its, fail_err = NOT_CONVERGED, i, its, err
            break
        h0, sb1 = consts[1], consts[3]
        e_d += _advance(mass, cmat, dt, x, xg, h0, sb1, s, phi, z, m, wk[10], lu3, piv3, tgt)
        _quat_step(q, phi)
        for a in range(m3):
            x_prev[a] = x[a]
            x[a] = xg[a]
        done = i
        if i == next_save:
            _store(out, ed_out, k_save, q, x, s, e_d)
            k_save += 1
            next_save = save_idx[k_save] if k_save < save_idx.shape[0] else -1
    _store(last.reshape(1, last.shape[0]), finfo[1:], 0, q, x, s, e_d)  # last accepted state
    info[0], info[1], info[2] = status, fail_step, fail_its
    info[3], info[4], info[5], info[6] = n_newton, n_jac, n_newton, done
    finfo[0] = fail_err
    return k_save


# ---------------------------------------------------------------------------------------------
# Python wrapper (the contract of quadmodes.rom.fixed_step.run_fixed)
# ---------------------------------------------------------------------------------------------


def _arrays(sys, dense=False):
    """Arrays of ``sys`` (a ReducedSystem) in the kernel's layout, always with the same types and
    ranks, so one compiled specialisation serves every formulation and N: ``mass`` = (𝕄(0)
    (3+N, 3+N), J1 (N, 9), J2_rot, J2 (N², 9), D_rot, D (N², 3), Mt, MtE) (row k·N + m of J2 is
    J2_km, row k·N + n of D is D_kn; the rotational-row and energy arrays are the same arrays
    unless "P"; Mt, MtE the dense mass tensors ((N+1)², (3+N)²) if ``dense``, else (0, 0)
    arrays); Λ, C (N,N); weights √diag(J0, μ) (3+N,) of the Newton convergence test; 3V3
    (N, N²) and 4V4 (N, N³) for "Q4", else (N, 0) arrays; F1 (N,)."""
    f = np.ascontiguousarray
    n = sys.n_modes
    quartic = getattr(sys, "quartic", False)
    flat, mb = sys.flat, sys.mass_blocks
    none = np.zeros((0, 0))
    j2 = f(sys.J2.reshape(n * n, 9), dtype=np.float64)
    d = f(sys.D.reshape(n * n, 3), dtype=np.float64)
    mass = (
        f(mb.M0f.reshape(3 + n, 3 + n), dtype=np.float64),
        f(sys.J1.reshape(n, 9), dtype=np.float64),
        j2 if sys.same_rows else f(sys.J2_rot.reshape(n * n, 9), dtype=np.float64),
        j2,
        d if sys.same_rows else f(sys.D_rot.reshape(n * n, 3), dtype=np.float64),
        d,
        f(flat.Mt, dtype=np.float64) if dense else none,
        f(flat.MtE, dtype=np.float64) if dense else none,
    )
    return (
        mass,
        f(sys.Lam, dtype=np.float64),
        f(sys.C, dtype=np.float64),
        f(newton_weights(sys)),
        f(flat.V3g, dtype=np.float64) if quartic else np.zeros((n, 0)),
        f(flat.V4g, dtype=np.float64) if quartic else np.zeros((n, 0)),
        f(sys.F1, dtype=np.float64),
    )


def fixed_run(
    sys, y0, n_steps, dt, save_idx, newton_tol, max_newton, t0, name="midpoint", dense=False
):
    """Compiled equivalent of ``fixed_step.run_fixed(MidpointStep(sys, dt, dense), ...)``.

    sys: ReducedSystem; y0 (7+2N,) with q normalised; n_steps; dt (s); save_idx: increasing step
    indices to sample, starting at 0; newton_tol; max_newton; t0 (s, for messages); ``dense``:
    the products with 𝕄 from the dense mass tensor (the O(N⁴) reference) instead of by blocks
    (the same results to round-off). Returns
    ``(ys (K, 7+2N), dissipated (K,), steps done, stats, status, message)`` with the same
    sampling, counters and failure messages as the numpy driver."""
    mass, lam, cmat, wt, v3g, v4g, f1 = _arrays(sys, dense)
    y0 = np.ascontiguousarray(y0, dtype=np.float64)
    idx = np.ascontiguousarray(save_idx, dtype=np.int64)
    out = np.empty((len(idx), len(y0)))
    ed_out = np.empty(len(idx))
    last = np.empty(len(y0))
    info = np.zeros(7, np.int64)
    finfo = np.zeros(2)
    k_save = run_midpoint(mass, lam, cmat, wt, y0, int(n_steps), float(dt), idx,
                          float(newton_tol), int(max_newton), out, ed_out, last, info,
                          finfo, v3g, v4g, f1)  # fmt: skip
    status, step, its, n_newton, n_jac, n_res, done = (int(v) for v in info)
    msg = "ok"
    out, ed_out = out[:k_save], ed_out[:k_save]
    if status:
        t_fail = t0 + step * dt
        msg = failure_message(
            name, step, t_fail, its if status == NOT_CONVERGED else None, finfo[0]
        )
        out = np.vstack([out, last])  # keep what was saved plus the last accepted state
        ed_out = np.append(ed_out, finfo[1])
    stats = work_counters(done, n_res, n_newton, n_jac)
    return out, ed_out, done, stats, (1 if status else 0), msg


def warm_up() -> float:
    """Compile the kernel (or load it from the on-disk cache) by running two steps of a rigid
    body; returns the wall time (s) this took. Later calls in the process cost microseconds."""
    start = time.perf_counter()
    e = np.zeros((0, 0))
    m0, j1, j2, d = np.diag([1.0, 2.0, 3.0]), np.zeros((0, 9)), np.zeros((0, 9)), np.zeros((0, 3))
    mass = (m0, j1, j2, j2, d, d, e, e)
    y0 = np.array([1.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3])
    idx = np.array([0, 2], np.int64)
    run_midpoint(mass, e, e, np.ones(3), y0, 2, 1e-3, idx, 1e-13, 25, np.empty((2, 7)),
                 np.empty(2), np.empty(7), np.zeros(7, np.int64), np.zeros(2), e, e,
                 np.zeros(0))  # fmt: skip
    return time.perf_counter() - start
