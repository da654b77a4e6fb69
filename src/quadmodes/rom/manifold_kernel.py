"""Compiled (numba) time loop of formulation "QM": the whole fixed-step loop of
:class:`~quadmodes.rom.manifold_midpoint.ManifoldMidpointStep` driven by
:func:`~quadmodes.rom.fixed_step.run_fixed` (predictor, chord Newton, the ω projection, the
dissipated energy, sampling, failure codes) in one compiled call, with the same step equations
and the same convergence test::

    h(s₁, ν₁) = exp(−Δt ω̂½) h₀,   p(s₁, ν₁) − p₀ = Δt [∂T/∂s(s½, ν½) − F̄_V − C(s½) ṡ½]
    s₁ − s₀ = Δt ṡ½,   q₁ = q₀ ⊗ exp(Δt ω½ / 2),   ΔE_d = Δt ṡ½ᵀ C(s½) ṡ½

With ``order = 1`` (the numpy step's predictor 2ν₀ − ν₋₁) and ``refresh = 1`` it runs the numpy
step's iterations and the two backends agree to round-off amplified by the dynamics; by default
(``order = 4``) each step converges to the same Newton tolerance from a better predictor, in
fewer iterations, and the backends agree to that tolerance amplified.

The kinetic energy is that of the R pseudo-particles of :mod:`quadmodes.rom.manifold_kinetics`,
w_ρ(s) = X̃_ρ + Φ̃_ρ s + Σ s_m s_n g̃_ρ^{mn}, T = ½ Σ_ρ |ω × w_ρ + E_ρ ṡ|², E(s) = Φ̃ + 2 G̃ s.
What a step costs, and why (docs/manifold-formulation.md "Compiled step"):

* **one sweep over G̃ a residual**, E(s₁) (3RN² products; its cost is reading G̃ from the cache).
  E is linear in s, so E(s½) = ½(E(s₀) + E(s₁)) with E(s₀) kept from the previous step; the step
  enforces s₁ − s₀ = Δt ṡ½, so the velocity part of ∂v/∂s at the midpoint,
  2 Σ_n g̃^{jn} ṡ½_n, is (E(s₁) − E(s₀))_j / Δt; the positions are w = X̃ + ½(Φ̃ + E(s)) s (w is
  quadratic). Hence ∂T/∂s(s½, ν½)_j = Σ_ρ E_ρj(s½)·(v½ × ω½) + (E(s₁) − E(s₀))_ρj·v½ / Δt with
  v½ = ω½ × w(s½) + E(s½) ṡ½, and (h₁, p₁) = Σ_ρ (w × v, Eᵀv) at s₁. 𝕄(s) itself is formed only
  for the Newton matrix. The sweep at the end of a step also gives E at the next step's
  predicted s₁ (two columns, one read of G̃), so the first residual of a step costs no sweep:
  two sweeps a step when the chord converges in two iterations.
* **the predictor** of ν₁: extrapolation of the last ν of degree ``order`` (default 4): the
  chord iteration starts ~1e-9 of the state away instead of ~1e-4 (Δt = 0.25 ms) and converges
  by the numpy step's test in two iterations (the least the test allows) instead of four.
* **Q4's potential** ∂V/∂s − Λs − F1 = 3V3·ss + 4V4·sss on the distinct monomials
  (s_m s_q, m ≤ q; s_m s_q s_p, m ≤ q ≤ p; their coefficients summed over the permutations):
  N(N(N+1)/2 + N(N+1)(N+2)/6) products instead of N³ + N⁴ (N = 16: 15 232 against 69 632), at
  several points in one product (s₀ and the predictor's s½, s₁ together).
* **damping** C(s)ṡ = B(s)ᵀ C_d (B(s) ṡ), B = B0 + Σ s_n B1_n, without forming C(s) (2DN² + D²).
* **the Newton matrix**: that of the numpy step (Q4's analytic Jacobian — the compiled Q
  pieces of :mod:`quadmodes.rom.midpoint_kernel` — with 𝕄_Q(s₁) replaced by the manifold
  𝕄(s₁)), at each step's predictor (its chord rate, ~1e-4 – 1e-3, is what two iterations need;
  the exact Jacobian would cost one more sweep a step, a matrix kept one step already loses a
  factor 5 of rate: docs). ``refresh > 1`` keeps it across steps: recomputed every ``refresh``
  steps, after a step that needed more than ``REFRESH_ITS`` chord iterations, and, before any
  failure is reported, for a step whose chord iteration with an old matrix did not converge
  (the step is then redone from its predictor).
* **R h carried**: the next step's h₀ is this step's exp(−φ̂) h₀ (which the projected state
  reproduces to round-off), not re-evaluated from the state, so |R h| does not drift by the
  evaluations' round-off.

Caching: every function is ``@njit(cache=True)`` and calls compiled helpers of
:mod:`quadmodes.rom.midpoint_kernel` (rotations, LU, Q's residual and Jacobian), which numba
compiles *into* this file's cached loop but does not check before loading it (only this file's
time stamp is checked). ``HELPERS_DIGEST`` below is the digest of those helpers' sources and of
the rotation leaves; a test compares it with :func:`helpers_digest`, so editing a helper forces
an edit here, which recompiles the loop.

Units: SI. ω (rad/s), s (√kg·m), ṡ (√kg·m/s), h (kg m²/s), energies (J), Δt (s).
"""

from __future__ import annotations

import hashlib
import inspect
import math
import time

import numba as nb
import numpy as np

from quadmodes.rom import midpoint_kernel as qk
from quadmodes.rom.fixed_step import failure_message
from quadmodes.rom.solution import work_counters

# Reassociation lets the short reductions over the modes vectorise (results change at round-off
# only); no 'nnan'/'ninf': the Newton test must see a diverging (NaN, inf) iterate.
_FLAGS = {"reassoc", "contract"}
_jit = nb.njit(cache=True, nogil=True, fastmath=_FLAGS)
_jit_inline = nb.njit(cache=True, nogil=True, fastmath=_FLAGS, inline="always")

NAME = "midpoint-QM"
#: Default number of steps a Newton matrix is kept (docs/manifold-formulation.md: measured).
REFRESH = 1
#: Default order of the predictor of ν₁ (polynomial extrapolation of the last values; 1 is
#: the numpy step's 2ν₀ − ν₋₁). Measured on the coarse 45° member at Δt = 0.25 ms (docs): the
#: chord iteration starts ~1e-4 (order 1), 2.5e-7 (3) of the state away; chord iterations a
#: step 3.95 / 2.07 / 2.007 for orders 1 / 3 / 4 (at 0.5 ms: 3.1 for 3, 2.2 for 4).
PREDICTOR = 4
#: A step needing more chord iterations than this refreshes the Newton matrix for the next.
REFRESH_ITS = 3

#: The compiled helpers of midpoint_kernel that this loop calls (module docstring, caching).
HELPERS = (qk._rotate, qk._left_jacobian, qk._quat_step, qk._lu_factor, qk._lu_solve,
           qk._jacobian, qk._products, qk._y_times, qk._block_products, qk._second,
           qk._second_derivative, qk._block_second, qk._nl_hessian, qk._work_arrays,
           qk._state_scale, qk._weighted_max, qk._store)  # fmt: skip
#: :func:`helpers_digest` of the helpers this file was last checked against.
HELPERS_DIGEST = "6ca6501d35d1a543"


def helpers_digest() -> str:
    """First 16 hex digits of the SHA-256 of the helpers' sources and the rotation leaves'."""
    text = "".join(inspect.getsource(f.py_func) for f in HELPERS) + qk.leaves_digest()
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


# ---------------------------------------------------------------------------------------------
# the particles: tangents, momenta, mass matrix
# ---------------------------------------------------------------------------------------------


@_jit
def _tangents(phi, g, s, e):
    """``e = E(s) = Φ̃ + 2 G̃ s`` (R, 3, N): the one 3RN² contraction, a sweep over G̃ (its cost
    is reading G̃: 3RN² numbers from the cache)."""
    n = s.shape[0]
    g1, e1, p1 = g.reshape(-1), e.reshape(-1), phi.reshape(-1)
    for i in range(e1.shape[0]):
        acc = 0.0
        base = i * n
        for m in range(n):
            acc += g1[base + m] * s[m]
        e1[i] = p1[i] + 2.0 * acc


@_jit
def _tangents2(phi, g, sa, sb, ea, eb):
    """``ea = E(sa)``, ``eb = E(sb)`` in one sweep over G̃ (:func:`_tangents` twice for ~1.4
    times the cost of one, measured: the end of a step and the next step's predictor)."""
    n = sa.shape[0]
    g1, a1, b1, p1 = g.reshape(-1), ea.reshape(-1), eb.reshape(-1), phi.reshape(-1)
    for i in range(a1.shape[0]):
        acc_a = acc_b = 0.0
        base = i * n
        for m in range(n):
            gm = g1[base + m]
            acc_a += gm * sa[m]
            acc_b += gm * sb[m]
        a1[i] = p1[i] + 2.0 * acc_a
        b1[i] = p1[i] + 2.0 * acc_b


@_jit_inline
def _particle(xp, phi, e, s, sd, p, w, d):
    """Particle p's position w = X̃_p + ½(Φ̃_p + E_p)s and elastic velocity d = E_p ṡ (3,),
    e = E(s), sd = ṡ (N,)."""
    n = s.shape[0]
    for c in range(3):
        a = b = 0.0
        for j in range(n):
            a += (phi[p, c, j] + e[p, c, j]) * s[j]
            b += e[p, c, j] * sd[j]
        w[c] = xp[p, c] + 0.5 * a
        d[c] = b


@_jit
def _momenta(xp, phi, e, s, x, out):
    """``out = 𝕄(s) ν`` (3+N,) = (Σ w × v, Σ Eᵀv) with v = ω × w + E ṡ, w = X̃ + ½(Φ̃ + E)s;
    e = E(s), x = ν = (ω, ṡ)."""
    n = s.shape[0]
    out[:] = 0.0
    w, v = np.empty(3), np.empty(3)
    for r in range(xp.shape[0]):
        _particle(xp, phi, e, s, x[3:], r, w, v)
        v[0] += x[1] * w[2] - x[2] * w[1]
        v[1] += x[2] * w[0] - x[0] * w[2]
        v[2] += x[0] * w[1] - x[1] * w[0]
        out[0] += w[1] * v[2] - w[2] * v[1]
        out[1] += w[2] * v[0] - w[0] * v[2]
        out[2] += w[0] * v[1] - w[1] * v[0]
        for c in range(3):
            vc = v[c]
            for j in range(n):
                out[3 + j] += e[r, c, j] * vc


@_jit
def _mass_matrix(xp, phi, e, s, out):
    """``out = 𝕄(s)`` (3+N, 3+N) of the particles: J = Σ(|w|²I − wwᵀ), the coupling Σ w × E_k,
    μ = Σ EᵀE (one matrix product); e = E(s)."""
    n = s.shape[0]
    out[:, :] = 0.0
    e2 = e.reshape(-1, n)
    mu = np.dot(e2.T, e2)
    w = np.empty(3)
    for r in range(xp.shape[0]):
        for c in range(3):
            a = 0.0
            for j in range(n):
                a += (phi[r, c, j] + e[r, c, j]) * s[j]
            w[c] = xp[r, c] + 0.5 * a
        ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        for a in range(3):
            out[a, a] += ww
            for b in range(3):
                out[a, b] -= w[a] * w[b]
        for k in range(n):
            e0, e1, e2k = e[r, 0, k], e[r, 1, k], e[r, 2, k]
            out[0, 3 + k] += w[1] * e2k - w[2] * e1
            out[1, 3 + k] += w[2] * e0 - w[0] * e2k
            out[2, 3 + k] += w[0] * e1 - w[1] * e0
    for k in range(n):
        for a in range(3):
            out[3 + k, a] = out[a, 3 + k]
        for j in range(n):
            out[3 + k, 3 + j] = mu[k, j]


# ---------------------------------------------------------------------------------------------
# the potential on distinct monomials, and the damping
# ---------------------------------------------------------------------------------------------


@_jit
def _nl_forces(vpt, pidx, tidx, sv, mono, out):
    """``out[c] = 3V3·ss + 4V4·sss`` (c, N) at the c points ``sv`` (c, N), by one product with
    the coefficients of the distinct monomials ``vpt`` (P2 + P3, N) (:func:`packed_potential`,
    transposed: read once for all the points); pidx (P2, 2), tidx (P3, 3) their indices; mono
    (c, P2 + P3) work array."""
    p2 = pidx.shape[0]
    for c in range(sv.shape[0]):
        s, mc = sv[c], mono[c]
        for a in range(p2):
            mc[a] = s[pidx[a, 0]] * s[pidx[a, 1]]
        for b in range(tidx.shape[0]):
            mc[p2 + b] = s[tidx[b, 0]] * s[tidx[b, 1]] * s[tidx[b, 2]]
    np.dot(mono, vpt, out)


@_jit
def _nl_hessian(wh, pidx, sa, sb, z, out):
    """``out = 2 H(sa) + H(sb)`` (N, N), H = 6V3·s + 12V4·ss the Hessian of the cubic and
    quartic potential, in one product (H is affine in s ⊗ s): its distinct entries k ≤ m (it
    is symmetric) are ``wh`` (P2, N + P2) of :func:`packed_hessian` times
    z = (2sa + sb, 2 sa_q sa_p + sb_q sb_p for q ≤ p) (z (N + P2,) work array)."""
    n = sa.shape[0]
    for q in range(n):
        z[q] = 2.0 * sa[q] + sb[q]
    for a in range(pidx.shape[0]):
        q, p = pidx[a, 0], pidx[a, 1]
        z[n + a] = 2.0 * sa[q] * sa[p] + sb[q] * sb[p]
    hs = np.dot(wh, z)
    for a in range(pidx.shape[0]):
        k, m = pidx[a, 0], pidx[a, 1]
        out[k, m] = hs[a]
        out[m, k] = hs[a]


@_jit
def _damping_force(b0, b1, cd, c0, s, sd, bm, bd, out):
    """``out = C(s) ṡ`` (N,): Bᵀ C_d (B ṡ) with B = B0 + Σ s_n B1_n (b0 (D, N), b1 (N, D, N),
    cd (D, D)), or c0 ṡ without damping modes (D = 0); bm (D, N), bd (2D,) work arrays."""
    n, nd = s.shape[0], b0.shape[0]
    if nd == 0:
        for k in range(n):
            acc = 0.0
            for j in range(n):
                acc += c0[k, j] * sd[j]
            out[k] = acc
        return
    for d in range(nd):
        row = bm[d]
        for k in range(n):
            row[k] = b0[d, k]
        for m in range(n):
            sm, b1r = s[m], b1[m, d]
            for k in range(n):
                row[k] += sm * b1r[k]
        acc = 0.0
        for k in range(n):
            acc += row[k] * sd[k]
        bd[d] = acc
    for d in range(nd):
        acc = 0.0
        for e in range(nd):
            acc += cd[d, e] * bd[e]
        bd[nd + d] = acc
    for k in range(n):
        out[k] = 0.0
    for d in range(nd):
        cb, row = bd[nd + d], bm[d]
        for k in range(n):
            out[k] += row[k] * cb


# ---------------------------------------------------------------------------------------------
# one step: residual, Newton matrix, chord iteration, advance
# ---------------------------------------------------------------------------------------------


@_jit
def _kinetic(xp, phi, e0, e1, s1, sm, x0, x, numid, dt, r, f):
    """The kinetic terms of the residual at ν₁ = x: ``r = 𝕄(s₁)ν₁`` (3+N,) and ``f = ∂T/∂s``
    (N,) at (s½, ν½ = numid) by the particles (module docstring), e0 = E(s₀), e1 = E(s₁).
    Returns ν₀ᵀ(𝕄(s₁) − 𝕄(s₀))ν₁ (ν₀ = x0) through the particles' differences, as
    :func:`quadmodes.rom.manifold_kinetics.kinetic_difference` takes it (Δw = E½Δs,
    w̄ = w½ + ⅛ΔE·Δs, Ē = E½, the product rule; ΔE = E₁ − E₀ here): the discrete gradient's."""
    n = s1.shape[0]
    inv_dt = 1.0 / dt
    buf = np.empty((12, 3))
    w1, v1, wm, vm, al, be = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5]
    dw, wb, dv0, vb0, dv1, vb1 = buf[6], buf[7], buf[8], buf[9], buf[10], buf[11]
    o0, o1, o2 = numid[0], numid[1], numid[2]
    r[:] = 0.0
    f[:] = 0.0
    diff = 0.0
    for p in range(xp.shape[0]):
        for c in range(3):
            a1 = d1 = am = dm = 0.0
            aw = cw = de0 = de1 = em0 = em1 = 0.0
            for j in range(n):
                pe, ea, eb = phi[p, c, j], e0[p, c, j], e1[p, c, j]
                a1 += (pe + eb) * s1[j]
                d1 += eb * x[3 + j]
                em = 0.5 * (ea + eb)
                am += (pe + em) * sm[j]
                dm += em * numid[3 + j]
                de, dsj = eb - ea, dt * numid[3 + j]  # ΔE, Δs = Δt ṡ½
                aw += em * dsj
                cw += de * dsj
                de0 += de * x0[3 + j]
                de1 += de * x[3 + j]
                em0 += em * x0[3 + j]
                em1 += em * x[3 + j]
            w1[c] = xp[p, c] + 0.5 * a1
            v1[c] = d1
            wm[c] = xp[p, c] + 0.5 * am
            vm[c] = dm
            dw[c], wb[c] = aw, wm[c] + 0.125 * cw
            dv0[c], vb0[c], dv1[c], vb1[c] = de0, em0, de1, em1
        # the kinetic difference: Δv(ν)·v̄(ν') with Δv = ω × Δw + ΔE ṡ, v̄ = ω × w̄ + Ē ṡ
        for c in range(3):
            c1, c2 = (c + 1) % 3, (c + 2) % 3
            dv0[c] += x0[c1] * dw[c2] - x0[c2] * dw[c1]
            vb0[c] += x0[c1] * wb[c2] - x0[c2] * wb[c1]
            dv1[c] += x[c1] * dw[c2] - x[c2] * dw[c1]
            vb1[c] += x[c1] * wb[c2] - x[c2] * wb[c1]
        for c in range(3):
            diff += dv0[c] * vb1[c] + vb0[c] * dv1[c]
        v1[0] += x[1] * w1[2] - x[2] * w1[1]
        v1[1] += x[2] * w1[0] - x[0] * w1[2]
        v1[2] += x[0] * w1[1] - x[1] * w1[0]
        r[0] += w1[1] * v1[2] - w1[2] * v1[1]
        r[1] += w1[2] * v1[0] - w1[0] * v1[2]
        r[2] += w1[0] * v1[1] - w1[1] * v1[0]
        vm[0] += o1 * wm[2] - o2 * wm[1]
        vm[1] += o2 * wm[0] - o0 * wm[2]
        vm[2] += o0 * wm[1] - o1 * wm[0]
        # ∂T/∂s_j = E½_j·(v½ × ω½) + (E₁ − E₀)_j·v½/Δt = E₁_j·(½u + v/Δt) + E₀_j·(½u − v/Δt)
        u0 = 0.5 * (vm[1] * o2 - vm[2] * o1)
        u1 = 0.5 * (vm[2] * o0 - vm[0] * o2)
        u2 = 0.5 * (vm[0] * o1 - vm[1] * o0)
        al[0], al[1], al[2] = u0 + vm[0] * inv_dt, u1 + vm[1] * inv_dt, u2 + vm[2] * inv_dt
        be[0], be[1], be[2] = u0 - vm[0] * inv_dt, u1 - vm[1] * inv_dt, u2 - vm[2] * inv_dt
        for c in range(3):
            vc, ac, bc = v1[c], al[c], be[c]
            ra, rb = e1[p, c], e0[p, c]
            for j in range(n):
                r[3 + j] += ra[j] * vc
                f[j] += ra[j] * ac + rb[j] * bc
    return diff


@_jit
def _discrete_gradient(f, numid, dt, diff):
    """``f`` (N,) = ∂T/∂s(s½, ν½) corrected along Δs = Δt ṡ½ so that f·Δs = ½ ``diff``
    (= ½ν₀ᵀ(𝕄(s₁) − 𝕄(s₀))ν₁): the Gonzalez correction of
    :meth:`quadmodes.rom.manifold_midpoint.ManifoldMidpointStep._kinetic_discrete_gradient`,
    which makes the step's energy balance exact."""
    n = f.shape[0]
    dd = gds = 0.0
    for j in range(n):
        dsj = dt * numid[3 + j]
        dd += dsj * dsj
        gds += f[j] * dsj
    if dd <= 1e-300:
        return
    k = (0.5 * diff - gds) / dd
    for j in range(n):
        f[j] += k * dt * numid[3 + j]


@_jit_inline
def _residual(x, qm, dt, consts, wk, r, have_e1=False):
    """Residual r (3+N,) of the step equations at ν₁ = x; False if the iterate is non-finite.
    Mirrors :meth:`quadmodes.rom.manifold_midpoint.ManifoldMidpointStep.residual`.

    ``qm`` of :func:`_arrays`; ``consts`` = (ν₀, h₀, p₀ − Δt F1, sb1, sbm, n0 = the nonlinear
    force at s₀, E(s₀)) of :func:`_begin`; ``wk`` of :func:`_work_arrays`: on return it holds
    s₁, s½, E(s₁) (and the rest of the intermediates). ``have_e1``: wk[2] already holds E(s₁)
    of this x (the predictor's, from the previous step's sweep)."""
    xp, phi, g, lam, vp, pidx, tidx, b0, b1, cd, c0, _ = qm
    x0, h0, p0, sb1, sbm, n0, e0 = consts
    s1, sm, e1, numid, theta, rh0, mono, sv, nv, f, cs, bm, bd = wk
    nm, n1 = nv[0], nv[1]
    n = lam.shape[0]
    hdt = 0.5 * dt
    for a in range(x.shape[0]):
        if not math.isfinite(x[a]):
            return False
        numid[a] = 0.5 * (x0[a] + x[a])
    for k in range(n):
        s1[k] = sb1[k] + hdt * x[3 + k]
        sm[k] = sbm[k] + 0.25 * dt * x[3 + k]
    if not have_e1:
        _tangents(phi, g, s1, e1)
    diff = _kinetic(xp, phi, e0, e1, s1, sm, x0, x, numid, dt, r, f)
    _discrete_gradient(f, numid, dt, diff)
    for a in range(3):  # rotational rows: 𝕄(s₁)ν₁ − exp(−Δt ω̂½) h₀
        theta[a] = -dt * numid[a]
    if not qk._rotate(theta, h0, rh0):
        return False
    for a in range(3):
        r[a] -= rh0[a]
    # modal rows: p₁ − p₀ − Δt [∂T/∂s − Λs½ − (n₀ + 4n½ + n₁)/6 − C(s½)ṡ½] (F1 is in p₀)
    if not have_e1:  # else: nv holds the forces at the predictor's s½, s₁ (_begin)
        sv[0, :] = sm
        sv[1, :] = s1
        _nl_forces(vp, pidx, tidx, sv[:2], mono[:2], nv[:2])
    _damping_force(b0, b1, cd, c0, sm, numid[3:], bm, bd, cs)
    for k in range(n):
        fk = f[k] - cs[k] - (n0[k] + 4.0 * nm[k] + n1[k]) / 6.0
        for j in range(n):
            fk -= lam[k, j] * sm[j]
        r[3 + k] -= p0[k] + dt * fk
    return True


@_jit
def _work_arrays(n, rr, nd, npoly):
    """Work arrays of :func:`_residual` for N = n modes, R = rr particles, D = nd damping modes
    and npoly monomials: ``(s1, sm (n,), e1 (rr, 3, n), numid (n+3,), theta, rh0 (3,), mono
    (3, npoly), sv, nv (3, n), f, cs (n,), bm (nd, n), bd (2nd,))``."""
    return (np.empty(n), np.empty(n), np.empty((rr, 3, n)), np.empty(n + 3), np.empty(3),
            np.empty(3), np.empty((3, npoly)), np.empty((3, n)), np.empty((3, n)), np.empty(n),
            np.empty(n), np.empty((nd, n)), np.empty(2 * nd))  # fmt: skip


@_jit
def _begin(qm, dt, x0, s0, consts, wk, first, pred):
    """Per-step constants (``consts`` of :func:`_residual`) from ν₀ = consts[0], s₀ and
    E(s₀) = consts[6]: p₀ = ∂T/∂ṡ by the particles, p₀ − Δt F1, the parts of s₁ = sb1 + ½Δt ṡ₁
    and s½ = sbm + ¼Δt ṡ₁, and in one product the nonlinear force at s₀ and at the predictor
    ``pred``'s s½ and s₁ (into wk[8], for its residual); h₀ likewise at the ``first`` step
    only: after that consts[1] holds the last step's exp(−φ̂) h₀ (:func:`_advance`), which the
    state reproduces to the round-off of the projection, so R h is carried without a drift of
    the evaluations' round-off (measured: 6e-13 in 2×10⁴ steps when recomputed)."""
    xp, phi, vp, pidx, tidx, f1 = qm[0], qm[1], qm[4], qm[5], qm[6], qm[11]
    _, h0, p0, sb1, sbm, n0, e0 = consts
    mono, sv, nv = wk[6], wk[7], wk[8]
    n = s0.shape[0]
    mom = np.empty(n + 3)
    _momenta(xp, phi, e0, s0, x0, mom)
    if first:
        for a in range(3):
            h0[a] = mom[a]
    for k in range(n):
        p0[k] = mom[3 + k] - dt * f1[k]
        sb1[k] = s0[k] + 0.5 * dt * x0[3 + k]
        sbm[k] = s0[k] + 0.25 * dt * x0[3 + k]
        sv[0, k] = sbm[k] + 0.25 * dt * pred[3 + k]  # as _residual forms s½ and s₁
        sv[1, k] = sb1[k] + 0.5 * dt * pred[3 + k]
        sv[2, k] = s0[k]
    _nl_forces(vp, pidx, tidx, sv, mono, nv)
    n0[:] = nv[2]


@_jit
def _newton_matrix(xg, qm, qarr, quart, dt, wk, wkq, jm, piv):
    """The numpy step's Newton matrix at ν₁ = xg, LU-factored in (jm, piv): Q4's analytic
    Jacobian (Q's kinetics, constant C: :func:`quadmodes.rom.midpoint_kernel._jacobian`, its
    quartic Hessians added here) with 𝕄_Q(s₁) replaced by the manifold 𝕄(s₁). ``wk`` must
    hold :func:`_residual`'s intermediates at xg (s₁, s½, E(s₁), ν½, θ, exp(θ̂)h₀); qarr Q's
    arrays (no quartic part), quart the potential's Hessian (:func:`packed_hessian`); wkq the
    work arrays of Q's Jacobian (:func:`quadmodes.rom.midpoint_kernel._work_arrays`), filled
    here with what Q's residual would leave there, the manifold 𝕄(s₁) in the place of Q's.
    False if the matrix is singular."""
    z1, zm, m1, numid, theta, rh0, pm, y, hm = (wkq[0], wkq[1], wkq[2], wkq[3], wkq[4], wkq[5],
                                                wkq[6], wkq[10], wkq[13])  # fmt: skip
    z1[0] = zm[0] = 1.0
    z1[1:] = wk[0]
    zm[1:] = wk[1]
    numid[:] = wk[3]
    theta[:] = wk[4]
    rh0[:] = wk[5]
    qk._products(qarr[0], True, zm, numid, y, pm)  # P_E(z½, ν½) of Q's kinetics
    _mass_matrix(qm[0], qm[1], wk[2], wk[0], m1)
    qk._jacobian(xg, qarr, dt, wkq, jm)
    _nl_hessian(quart, qm[5], zm[1:], z1[1:], np.empty(quart.shape[1]), hm)  # 2H(s½) + H(s₁)
    n, dt2 = hm.shape[0], dt * dt
    for k in range(n):
        for j in range(n):
            jm[3 + k, 3 + j] += dt2 * hm[k, j] / 12.0  # Δt²(H(s½)/6 + H(s₁)/12)
    return qk._lu_factor(jm, piv)


@_jit_inline
def _chord(xg, qm, dt, consts, wk, r, jm, piv, dx, wt, scale, newton_tol, max_newton):
    """Chord iterations ``xg ← xg − J⁻¹ r(xg)`` with the factors (jm, piv) and the convergence
    test of :func:`quadmodes.rom.fixed_step.chord_newton` (as
    :func:`quadmodes.rom.midpoint_kernel._chord`, on this formulation's residual). Returns
    (OK / NOT_CONVERGED / SINGULAR, iterations, last relative update)."""
    err_prev = math.inf
    err = math.inf
    its = 0
    for it in range(1, max_newton + 1):
        its = it
        qk._lu_solve(jm, piv, r, dx)
        for a in range(xg.shape[0]):
            xg[a] -= dx[a]
        err = qk._weighted_max(dx, wt) / scale
        if not math.isfinite(err):
            return qk.NOT_CONVERGED, its, err
        if err <= newton_tol:
            return qk.OK, its, err
        if err_prev < math.inf:
            rho = err / err_prev
            if rho < 0.5 and err * rho <= (1.0 - rho) * newton_tol:
                return qk.OK, its, err
            if rho >= 1.0 and err <= 1e3 * newton_tol:
                return qk.OK, its, err  # stagnation at round-off
        err_prev = err
        if not _residual(xg, qm, dt, consts, wk, r):
            return qk.SINGULAR, its, err
    return qk.NOT_CONVERGED, its, err


@_jit
def _advance(qm, dt, x0, x1, consts, s1, phi, wk, lu3, piv3, sd_next):
    """Finish a converged step in place: s₁; E(s₁) into consts[6] (the next step's E(s₀)) and,
    in the same sweep, E at the next step's predicted s₁ (from its predicted ṡ, ``sd_next``)
    into wk[2]; the rotation vector φ = Δt ω½ (3,); ω₁ projected (one 3×3 solve with J(s₁))
    onto h(s₁, ν₁) = exp(−φ̂) h₀ so that R h is conserved to round-off, and that h₁ into
    consts[1]. Returns ΔE_d = Δt ṡ½ᵀC(s½)ṡ½ (J)."""
    xp, ph, g, b0, b1, cd, c0 = qm[0], qm[1], qm[2], qm[7], qm[8], qm[9], qm[10]
    h0, sb1, sbm, e1 = consts[1], consts[3], consts[4], consts[6]
    sm, cs, bm, bd = wk[1], wk[10], wk[11], wk[12]
    n, hdt = s1.shape[0], 0.5 * dt
    for k in range(n):
        s1[k] = sb1[k] + hdt * x1[3 + k]
        sm[k] = (s1[k] + hdt * x1[3 + k]) + hdt * sd_next[k]  # as _residual forms it
    _tangents2(ph, g, s1, sm, e1, wk[2])
    tgt, w, d = np.zeros(3), np.empty(3), np.empty(3)
    lu3[:, :] = 0.0
    for p in range(xp.shape[0]):
        _particle(xp, ph, e1, s1, x1[3:], p, w, d)
        ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
        for a in range(3):
            lu3[a, a] += ww
            for b in range(3):
                lu3[a, b] -= w[a] * w[b]
        tgt[0] -= w[1] * d[2] - w[2] * d[1]
        tgt[1] -= w[2] * d[0] - w[0] * d[2]
        tgt[2] -= w[0] * d[1] - w[1] * d[0]
    for a in range(3):
        phi[a] = hdt * (x0[a] + x1[a])  # the same φ moves q: R₁h₁ = R₀h₀ exactly
        w[a] = -phi[a]
    qk._rotate(w, h0, w)
    for a in range(3):
        tgt[a] += w[a]
    if qk._lu_factor(lu3, piv3):  # J(s₁) is positive definite; guard anyway
        qk._lu_solve(lu3, piv3, tgt, tgt)
        for a in range(3):
            x1[a] = tgt[a]
    for a in range(3):
        h0[a] = w[a]  # h₁ = exp(−φ̂) h₀: the next step's h₀ (see _begin)
    sdm = np.empty(n)
    for k in range(n):
        sm[k] = sbm[k] + 0.25 * dt * x1[3 + k]
        sdm[k] = 0.5 * (x0[3 + k] + x1[3 + k])
    _damping_force(b0, b1, cd, c0, sm, sdm, bm, bd, cs)
    ded = 0.0
    for k in range(n):
        ded += sdm[k] * cs[k]
    return dt * ded


@_jit
def _predict(hist, nh, order, out):
    """The predictor ``out`` (3+N,) of ν₁: polynomial extrapolation of the last ``nh`` values
    ν₀, ν₋₁, … (rows of ``hist``), of degree min(order, nh − 1) ≤ 4 (1: 2ν₀ − ν₋₁, the numpy
    step's; 4: 5ν₀ − 10ν₋₁ + 10ν₋₂ − 5ν₋₃ + ν₋₄)."""
    k = min(order, nh - 1)
    for a in range(out.shape[0]):
        if k == 0:
            out[a] = hist[0, a]
        elif k == 1:
            out[a] = 2.0 * hist[0, a] - hist[1, a]
        elif k == 2:
            out[a] = 3.0 * (hist[0, a] - hist[1, a]) + hist[2, a]
        elif k == 3:
            out[a] = 4.0 * (hist[0, a] + hist[2, a]) - 6.0 * hist[1, a] - hist[3, a]
        else:
            out[a] = 5.0 * (hist[0, a] - hist[3, a]) + 10.0 * (hist[2, a] - hist[1, a]) + hist[4, a]


@_jit_inline
def _solve(x, pred, have_e1, s, qm, qarr, quart, wt, dt, consts, wk, wkq, bufs, tol, max_newton,
           fresh):  # fmt: skip
    """ν₁ of one step into ``bufs[0]`` from the predictor ``pred`` by chord iterations: with
    the kept Newton matrix (bufs[4], bufs[5]), or, if ``fresh`` or that failed, a new one at
    the predictor (the step redone). ``have_e1``: wk[2] holds E at the predictor's s₁. Returns
    (code, chord iterations, last update, matrices made)."""
    xg, r, dx, jm, piv = bufs
    its_all, n_jac = 0, 0
    code, err = qk.OK, 0.0
    for _ in range(2):
        for a in range(x.shape[0]):
            xg[a] = pred[a]
        if not _residual(xg, qm, dt, consts, wk, r, have_e1):
            return qk.SINGULAR, its_all, err, n_jac
        have_e1 = False
        if fresh:
            n_jac += 1
            if not _newton_matrix(xg, qm, qarr, quart, dt, wk, wkq, jm, piv):
                return qk.SINGULAR, its_all, err, n_jac
        scale = qk._state_scale(x, xg, s, wt, qm[3])
        code, its, err = _chord(xg, qm, dt, consts, wk, r, jm, piv, dx, wt, scale, tol,
                                max_newton)  # fmt: skip
        its_all += its
        if code == qk.OK or fresh:
            break
        fresh = True  # a kept matrix failed: the step again with a new one
    return code, its_all, err, n_jac


@_jit
def _start(qm, dt, x, s, hist, pred, consts, wk):
    """Before the first step: the history (ν₀ only), its predictor (ν₀) and, in one sweep, E(s₀)
    into consts[6] and E at the predictor's s₁ into wk[2]."""
    hist[0, :] = x
    _predict(hist, 1, 1, pred)
    s1 = wk[0]
    for k in range(s.shape[0]):
        s1[k] = (s[k] + 0.5 * dt * x[3 + k]) + 0.5 * dt * pred[3 + k]
    _tangents2(qm[1], qm[2], s, s1, consts[6], wk[2])


@_jit
def run_manifold_midpoint(qm, qarr, quart, wt, y0, n_steps, dt, save_idx, newton_tol,
                          max_newton, refresh, order, out, ed_out, last, info, finfo):  # fmt: skip
    """Run ``n_steps`` QM midpoint steps of ``dt`` (s) from ``y0`` (7+2N,) = [q, ω, s, ṡ].

    qm, qarr, quart of :func:`_arrays`; wt (3+N,) the convergence weights; save_idx (K,) int64
    increasing step indices to sample (save_idx[0] = 0); newton_tol relative; max_newton;
    refresh: the steps a Newton matrix is kept; order: the predictor's (module docstring).
    Outputs as :func:`quadmodes.rom.midpoint_kernel.run_midpoint`: out (K, 7+2N), ed_out (K,),
    last (7+2N,), info (int64, 7) = [status, failing step, its iterations, n_newton, n_jac,
    n_res, steps done], finfo (2,) = [relative update at failure, E_d of the last state].
    Returns the number of samples written."""
    n, rr = qm[3].shape[0], qm[0].shape[0]
    m3 = n + 3
    q, s = y0[0:4].copy(), y0[7 : 7 + n].copy()
    x, hist, pred = np.empty(m3), np.empty((5, m3)), np.empty(m3)
    x[:3] = y0[4:7]
    x[3:] = y0[7 + n : 7 + 2 * n]
    consts = (x, np.empty(3), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
              np.empty((rr, 3, n)))  # fmt: skip
    wk = _work_arrays(n, rr, qm[7].shape[0], qm[4].shape[0])
    wkq = qk._work_arrays(n)
    bufs = (np.empty(m3), np.empty(m3), np.empty(m3), np.empty((m3, m3)), np.empty(m3, np.int64))
    phi, lu3, piv3 = np.empty(3), np.empty((3, 3)), np.empty(3, np.int64)
    _start(qm, dt, x, s, hist, pred, consts, wk)
    qk._store(out, ed_out, 0, q, x, s, 0.0)
    k_save, nh = 1, 1
    next_save = save_idx[1] if save_idx.shape[0] > 1 else -1
    e_d, fail_err = 0.0, 0.0
    n_newton = n_jac = status = fail_step = fail_its = done = 0
    age, slow = refresh, False
    for i in range(1, n_steps + 1):
        _predict(hist, nh, order, pred)
        _begin(qm, dt, x, s, consts, wk, i == 1, pred)
        code, its, err, jacs = _solve(x, pred, True, s, qm, qarr, quart, wt, dt, consts, wk, wkq,
                                      bufs, newton_tol, max_newton, slow or age >= refresh)  # fmt: skip
        n_newton += its
        n_jac += jacs
        if code != qk.OK:
            status, fail_step = code, i
            if code == qk.NOT_CONVERGED:
                fail_its, fail_err = its, err
            break
        age, slow = (1 if jacs else age + 1), its > REFRESH_ITS
        xg = bufs[0]
        nh = min(nh + 1, 5)
        hist[1:, :] = hist[:4, :].copy()
        hist[0, :] = xg
        _predict(hist, nh, order, pred)  # its ṡ part: where the next step's s₁ will be
        e_d += _advance(qm, dt, x, xg, consts, s, phi, wk, lu3, piv3, pred[3:])
        qk._quat_step(q, phi)
        hist[0, :3] = xg[:3]  # ω₁ projected
        x[:] = xg
        done = i
        if i == next_save:
            qk._store(out, ed_out, k_save, q, x, s, e_d)
            k_save += 1
            next_save = save_idx[k_save] if k_save < save_idx.shape[0] else -1
    qk._store(last.reshape(1, last.shape[0]), finfo[1:], 0, q, x, s, e_d)
    info[0], info[1], info[2] = status, fail_step, fail_its
    info[3], info[4], info[5], info[6] = n_newton, n_jac, n_newton, done
    finfo[0] = fail_err
    return k_save


# ---------------------------------------------------------------------------------------------
# Python wrapper (the contract of quadmodes.rom.fixed_step.run_fixed)
# ---------------------------------------------------------------------------------------------


def packed_potential(v3g: np.ndarray, v4g: np.ndarray):
    """``(vp (N, P2 + P3), pidx (P2, 2), tidx (P3, 3))``: the coefficients of 3V3·ss + 4V4·sss
    on the distinct monomials s_m s_q (m ≤ q) and s_m s_q s_p (m ≤ q ≤ p), each the sum of the
    flat coefficients (v3g (N, N²), v4g (N, N³)) over the index orders giving that monomial (so
    the force is the same for any, not only symmetric, tensors)."""
    n = v3g.shape[0]
    v3, v4 = v3g.reshape(n, n, n), v4g.reshape(n, n, n, n)
    pairs = np.array([(m, q) for m in range(n) for q in range(m, n)], np.int64).reshape(-1, 2)
    trips = [(m, q, p) for m in range(n) for q in range(m, n) for p in range(q, n)]
    trips = np.array(trips, np.int64).reshape(-1, 3)
    c3 = np.array([v3[:, m, q] + (v3[:, q, m] if q != m else 0.0) for m, q in pairs]).reshape(-1, n)
    c4 = [sum(v4[:, i, j, k] for i, j, k in set(_orders(t))) for t in trips]
    c4 = np.array(c4).reshape(-1, n)
    return np.ascontiguousarray(np.concatenate([c3, c4]).T), pairs, trips


def packed_hessian(v3g: np.ndarray, v4g: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``wh`` (P2, N + P2): row (k, m) (k ≤ m, ``pairs``) of the Hessian 6V3·s + 12V4·ss as
    coefficients of (s_q; s_q s_p, q ≤ p) (flat tensors v3g = 3V3 (N, N²), v4g = 4V4 (N, N³),
    symmetric)."""
    n = v3g.shape[0]
    v3, v4 = v3g.reshape(n, n, n), v4g.reshape(n, n, n, n)
    q, p = pairs[:, 0], pairs[:, 1]
    rows = []
    for k, m in pairs:
        a4 = 3.0 * v4[k, m]
        rows.append(np.concatenate([2.0 * v3[k, m], a4[q, p] + np.where(q != p, a4[p, q], 0.0)]))
    return np.ascontiguousarray(np.array(rows).reshape(len(pairs), n + len(pairs)))


def _orders(t):
    a, b, c = (int(v) for v in t)
    return ((a, b, c), (a, c, b), (b, a, c), (b, c, a), (c, a, b), (c, b, a))


def _arrays(sys):
    """``(qm, qarr, quart, wt)`` of a QM ``sys`` (a ReducedSystem with ``manifold``): qm =
    (X̃ (R, 3), Φ̃ (R, 3, N), G̃ (R, 3, N, N), Λ (N, N), vpᵀ, pidx, tidx (:func:`packed_potential`),
    B0 (D, N), B1 (N, D, N), C_d (D, D) (D = 0 without damping modes), C0 (N, N), F1 (N,));
    qarr: Q's arrays of :func:`quadmodes.rom.midpoint_kernel._arrays` without the quartic part
    (the Newton matrix); quart the potential's Hessian (:func:`packed_hessian`); wt the
    convergence weights."""
    ma, n = sys.manifold, sys.n_modes
    f = np.ascontiguousarray
    mass, lam, cmat, wt, v3g, v4g, f1 = qk._arrays(sys)
    vp, pidx, tidx = packed_potential(v3g, v4g)
    vpt = np.ascontiguousarray(vp.T)
    if ma.B0 is None:
        b0, b1, cd = np.zeros((0, n)), np.zeros((n, 0, n)), np.zeros((0, 0))
    else:
        b0, b1, cd = (f(a, dtype=np.float64) for a in (ma.B0, ma.B1, ma.Cd))
    qm = (f(ma.X, dtype=np.float64), f(ma.Phi, dtype=np.float64), f(ma.G, dtype=np.float64),
          lam, vpt, pidx, tidx, b0, b1, cd, f(ma.C0, dtype=np.float64), f1)  # fmt: skip
    empty = np.zeros((n, 0))
    return qm, (mass, lam, cmat, empty, empty, f1), packed_hessian(v3g, v4g, pidx), wt


def fixed_run(sys, y0, n_steps, dt, save_idx, newton_tol, max_newton, t0, name=NAME,
              refresh=REFRESH, order=PREDICTOR):  # fmt: skip
    """Compiled equivalent of ``fixed_step.run_fixed(ManifoldMidpointStep(sys, dt), ...)``
    (``refresh = 1``: the same Newton iteration; more: the Newton matrix kept that many steps).

    sys: a ReducedSystem of formulation "QM"; y0 (7+2N,) with q normalised; dt (s); save_idx
    increasing step indices, starting at 0; t0 (s, for messages). Returns
    ``(ys (K, 7+2N), dissipated (K,), steps done, stats, status, message)`` with the numpy
    driver's sampling, counters and failure messages."""
    qm, qarr, quart, wt = _arrays(sys)
    y0 = np.ascontiguousarray(y0, dtype=np.float64)
    idx = np.ascontiguousarray(save_idx, dtype=np.int64)
    out, ed_out, last = np.empty((len(idx), len(y0))), np.empty(len(idx)), np.empty(len(y0))
    info, finfo = np.zeros(7, np.int64), np.zeros(2)
    k_save = run_manifold_midpoint(qm, qarr, quart, wt, y0, int(n_steps), float(dt), idx,
                                   float(newton_tol), int(max_newton), int(refresh), int(order),
                                   out, ed_out, last, info, finfo)  # fmt: skip
    status, step, its, n_newton, n_jac, n_res, done = (int(v) for v in info)
    msg = "ok"
    out, ed_out = out[:k_save], ed_out[:k_save]
    if status:
        its_or_none = its if status == qk.NOT_CONVERGED else None
        msg = failure_message(name, step, t0 + step * dt, its_or_none, finfo[0])
        out = np.vstack([out, last])
        ed_out = np.append(ed_out, finfo[1])
    stats = work_counters(done, n_res, n_newton, n_jac)
    return out, ed_out, done, stats, (1 if status else 0), msg


def warm_up() -> float:
    """Compile the loop (or load it from the on-disk cache) by two steps of a one-mode,
    two-particle system; returns the wall time (s)."""
    from types import SimpleNamespace

    start = time.perf_counter()
    n = 1
    ma = SimpleNamespace(X=np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]),
                         Phi=np.full((2, 3, n), 0.5), G=np.full((2, 3, n, n), 0.1),
                         B0=None, C0=np.eye(n))  # fmt: skip
    qm = (ma.X, ma.Phi, ma.G, np.eye(n), np.zeros((2, n)), np.zeros((1, 2), np.int64),
          np.zeros((1, 3), np.int64), np.zeros((0, n)), np.zeros((n, 0, n)), np.zeros((0, 0)),
          ma.C0, np.zeros(n))  # fmt: skip
    mass = (np.eye(3 + n), np.zeros((n, 9)), np.zeros((n, 9)), np.zeros((n, 9)),
            np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((0, 0)), np.zeros((0, 0)))  # fmt: skip
    empty = np.zeros((n, 0))
    qarr = (mass, np.eye(n), np.eye(n), empty, empty, np.zeros(n))
    y0 = np.array([1.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3, 0.0, 0.0])
    run_manifold_midpoint(qm, qarr, np.zeros((1, n + 1)), np.ones(3 + n), y0, 2,
                          1e-3, np.array([0, 2], np.int64), 1e-13, 25, 1, 3, np.empty((2, 9)),
                          np.empty(2), np.empty(9), np.zeros(7, np.int64), np.zeros(2))  # fmt: skip
    return time.perf_counter() - start
