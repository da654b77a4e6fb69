"""The mass matrix 𝕄(s) of the reduced equations by blocks: O(N²) work per evaluation instead
of the O(N⁴) of the dense mass tensor.

With ν = (ω, ṡ) the kinetic energy is T = ½ νᵀ𝕄(s)ν (:mod:`quadmodes.rom.system`,
docs/derivation.md §1)::

    𝕄(s) = [[J̃(s), A_rot(s)ᵀ], [A(s), μ]],   J̃ = J0 + Σ_k s_k J1_k + Σ_mk s_m s_k J2_mk,
    (A_rot)_n = c_n + Σ_k s_k D_rot,kn,          A_n = c_n + Σ_k s_k D_kn

J̃ is quadratic and A linear in s, and only the 3×3 block J̃ is quadratic. The dense form
𝕄(s) = Σ_ij z_i z_j Mt[i, j], z = (1, s), with Mt (N+1, N+1, 3+N, 3+N), is exact but stores
and visits (N+1)²(3+N)² numbers per evaluation, almost all zero: Mt[m, k] (m, k ≥ 1) is zero
outside its 3×3 corner J2_mk, and Mt[0, k] is zero in its N×N block. Evaluated by blocks, every
quantity a step needs costs O(N²) (9N² for the J2 contractions, 3N² for each D one):

* the mass matrix 𝕄(s) (:func:`mass_matrix`): momenta (h, p_s) = 𝕄(s)ν;
* ``P[k] = ½ (∂𝕄/∂s_k) ν`` (N, 3+N) (:func:`half_derivative_products`)::

      P[k, :3]  = (½ J1_k + G_k) ω + ½ Σ_n D_rot,kn ṡ_n,    G_k = Σ_m s_m J2_km
      P[k, 3+n] = ½ D_kn · ω

  so that ∂T/∂s = P_E·ν (energy arrays) and 𝕄̇ν = 2 ṡ·P;
* ``W[k, j] = ½ νᵀ (∂²𝕄_E/∂s_k∂s_j) ν = ωᵀ J2_kj ω`` (N, N) (:func:`second_derivative`), the
  s–s block of ∂²T/∂s².

The same sums as the dense products, in another order: results agree to round-off. The rows of
the momenta (h = 𝕄ν[:3]) use the rotational-row arrays J2_rot, D_rot and the modal rows the
energy arrays J2, D (they differ for formulation "P" only); P_E and W use J2, D throughout. The
compiled kernel (:mod:`quadmodes.rom.midpoint_kernel`) evaluates the same blocks in loops.

Units: SI as in :class:`~quadmodes.rom.system.ReducedSystem` (s in √kg·m, ω in rad/s, ṡ in
√kg·m/s; 𝕄 has kg m² in the J̃ block, √kg·m in A, 1 in μ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The numpy stepper evaluates 𝕄 by blocks from this many modes on, and from the dense tensor
#: below: at a few modes a numpy step is bound by call overhead and the dense products, O(N⁴)
#: but one matrix product each, cost fewer numpy calls (measured crossover N ≈ 10–12,
#: benchmarks/performance/bench_step_scaling.py). The compiled kernel uses blocks at every N.
NUMPY_BLOCKS_FROM = 12


@dataclass(frozen=True, eq=False)
class MassBlocks:
    """The blocks of 𝕄(s) laid out so that each evaluation is a few matrix products (N modes,
    m3 = 3 + N; C-contiguous; O(N²) numbers each). Fewer numpy calls matter as much as fewer
    operations: below N ≈ 10 a numpy step is bound by call overhead.

    M0f (m3²,): 𝕄(0) = [[J0, cᵀ], [c, μ]] flattened. L (N, 9 + 6N) = [J1 | D_rot | D]: ``s @ L``
    = the parts of 𝕄(s) − 𝕄(0) linear in s, J̃'s (3×3 flattened), then Σ_k s_k D_rot,kn and
    Σ_k s_k D_kn (rows n, 3 each); ``scatter`` (9 + 6N,) their flat positions in 𝕄.
    J2s_rot (N, 9N): ``G(s)_k = (s @ J2s_rot).reshape(N, 9)[k] = Σ_m s_m J2_rot,mk``.
    B_rot, B (3N, 3 + 4N): ``(B @ (ω, s⊗ω, ṡ))[3k + a] = P[k, a]``, i.e. columns ½J1_k,ab (b),
    J2_km,ab (3 + 3m + b), ½D_kn,a (3 + 3N + n) (rotational-row or energy arrays).
    hDw (N², 3): ½ D, row k·N + n = ½ D_kn. J2w (N², 9): J2 (energy), row k·N + j = J2_kj."""

    M0f: np.ndarray
    L: np.ndarray
    scatter: np.ndarray
    J2s_rot: np.ndarray
    B_rot: np.ndarray
    B: np.ndarray
    hDw: np.ndarray
    J2w: np.ndarray


def _product_matrix(J1, J2, D) -> np.ndarray:
    """B (3N, 3 + 4N) of :class:`MassBlocks` from J1 (N,3,3), J2 (N,N,3,3), D (N,N,3)."""
    n = J1.shape[0]
    b = np.zeros((3 * n, 3 + 4 * n))
    b[:, :3] = 0.5 * J1.reshape(3 * n, 3)
    b[:, 3 : 3 + 3 * n] = J2.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)
    b[:, 3 + 3 * n :] = 0.5 * D.transpose(0, 2, 1).reshape(3 * n, n)
    return b


def mass_blocks(J0, J1, J2, D, c, mu, J2_rot=None, D_rot=None) -> MassBlocks:
    """:class:`MassBlocks` from the arrays of a :class:`~quadmodes.rom.system.ReducedSystem`:
    J0 (3,3), J1 (N,3,3), J2 (N,N,3,3) (symmetric in its mode pair), D (N,N,3), c (N,3), mu
    (N,N); J2_rot, D_rot the rotational-row arrays (default: J2, D)."""
    n = J1.shape[0]
    m3 = 3 + n
    f = np.ascontiguousarray
    same = J2_rot is None and D_rot is None
    J2_rot = J2 if J2_rot is None else J2_rot
    D_rot = D if D_rot is None else D_rot
    m0 = np.zeros((m3, m3))
    m0[:3, :3] = J0
    m0[:3, 3:] = np.asarray(c).T
    m0[3:, :3] = c
    m0[3:, 3:] = mu
    a, b, k = np.arange(3)[:, None], np.arange(3)[None, :], np.arange(n)[:, None]
    # J̃ at (a, b); D_rot terms at (a, 3 + n), D terms at (3 + n, a), in the order of L's columns
    scatter = np.concatenate([(a * m3 + b).ravel(), (b * m3 + 3 + k).ravel(),
                              ((3 + k) * m3 + b).ravel()])  # fmt: skip
    b_en = _product_matrix(J1, J2, D)
    return MassBlocks(
        M0f=m0.ravel(),
        L=f(np.hstack([J1.reshape(n, 9), D_rot.reshape(n, 3 * n), D.reshape(n, 3 * n)])),
        scatter=scatter,
        J2s_rot=f(J2_rot.reshape(n, 9 * n)),
        B_rot=b_en if same else _product_matrix(J1, J2_rot, D_rot),
        B=b_en,
        hDw=f(0.5 * D.reshape(n * n, 3)),
        J2w=f(J2.reshape(n * n, 9)),
    )


def mass_matrix(mb: MassBlocks, s: np.ndarray) -> np.ndarray:
    """𝕄(s) (3+N, 3+N) at s (N,): rotational rows from the rotational-row arrays, modal rows
    from the energy arrays (unsymmetric for formulation "P" only)."""
    n = s.shape[0]
    lin = s @ mb.L
    lin[:9] += s @ (s @ mb.J2s_rot).reshape(n, 9)  # J̃ − J0 = Σ_k s_k (J1_k + G_k)
    m = mb.M0f.copy()
    m[mb.scatter] += lin
    return m.reshape(3 + n, 3 + n)


def half_derivative_products(
    mb: MassBlocks, s: np.ndarray, nu: np.ndarray, energy: bool = True
) -> np.ndarray:
    """``P[k] = ½ (∂𝕄/∂s_k) ν`` (N, 3+N) at s (N,), ν = (ω, ṡ) (3+N,): with the energy arrays
    (``energy=True``: P_E, ∂T/∂s = P_E·ν) or the momenta's (rotational rows from J2_rot, D_rot:
    ∂(𝕄ν)/∂s_k = 2 P[k])."""
    n = s.shape[0]
    w = nu[:3]
    v = np.concatenate((w, (s[:, None] * w).ravel(), nu[3:]))  # (ω, s⊗ω, ṡ)
    rows = (mb.B if energy else mb.B_rot) @ v  # (½J1_k + G_k) ω + ½ Σ_n D_kn ṡ_n
    return np.concatenate((rows.reshape(n, 3), (mb.hDw @ w).reshape(n, n)), axis=1)


def second_derivative(mb: MassBlocks, nu: np.ndarray) -> np.ndarray:
    """``W[k, j] = ωᵀ J2_kj ω`` (N, N) = ½ νᵀ(∂²𝕄_E/∂s_k∂s_j)ν, ν = (ω, ṡ) (3+N,): the s–s
    block of ∂²T/∂s² (energy arrays)."""
    n = nu.shape[0] - 3
    w = nu[:3]
    return (mb.J2w @ (w[:, None] * w).ravel()).reshape(n, n)


class BlockMass:
    """The evaluations of 𝕄 a step needs, by blocks (O(N²) each), on z = (1, s) (N+1,): the
    interface shared with :class:`DenseMass`."""

    def __init__(self, mb: MassBlocks):
        self.mb = mb

    def matrix(self, z: np.ndarray) -> np.ndarray:
        """𝕄(s) (3+N, 3+N)."""
        return mass_matrix(self.mb, z[1:])

    def products(self, z: np.ndarray, nu: np.ndarray, energy: bool = True) -> np.ndarray:
        """``P[k] = ½ (∂𝕄/∂s_k) ν`` (N, 3+N) (energy or momenta arrays)."""
        return half_derivative_products(self.mb, z[1:], nu, energy)

    def second(self, nu: np.ndarray) -> np.ndarray:
        """``ωᵀ J2_kj ω`` (N, N)."""
        return second_derivative(self.mb, nu)


class DenseMass:
    """The same evaluations from the dense mass tensors of
    :class:`~quadmodes.rom.system.FlatTensors` (``flat``: its Mt, Yt, YtE, WtE),
    ``𝕄(s) = Σ_ij z_i z_j Mt[i, j]``: O(N⁴) work each. The reference the block form is checked
    and timed against (benchmarks/performance/bench_step_scaling.py), not used by default."""

    def __init__(self, flat):
        self.Mt, self.Yt, self.YtE, self.WtE = flat.Mt, flat.Yt, flat.YtE, flat.WtE

    def matrix(self, z: np.ndarray) -> np.ndarray:
        """𝕄(s) (3+N, 3+N)."""
        m3 = z.shape[0] + 2
        return ((z[:, None] * z).ravel() @ self.Mt).reshape(m3, m3)

    def products(self, z: np.ndarray, nu: np.ndarray, energy: bool = True) -> np.ndarray:
        """``P[k] = ½ (∂𝕄/∂s_k) ν`` (N, 3+N) (energy or momenta arrays)."""
        n, m3 = z.shape[0] - 1, nu.shape[0]
        yt = self.YtE if energy else self.Yt
        return ((z @ yt).reshape(n * m3, m3) @ nu).reshape(n, m3)

    def second(self, nu: np.ndarray) -> np.ndarray:
        """``ωᵀ J2_kj ω`` (N, N)."""
        n = nu.shape[0] - 3
        return (self.WtE @ (nu[:, None] * nu).ravel()).reshape(n, n)


def mass_evaluation(sys, dense: bool | None = None) -> BlockMass | DenseMass:
    """The evaluation of 𝕄 for a numpy step of ``sys`` (a ReducedSystem): :class:`DenseMass`
    if ``dense``, :class:`BlockMass` if not, and with ``dense=None`` (the default) blocks from
    :data:`NUMPY_BLOCKS_FROM` modes on (the same results to round-off either way)."""
    if dense is None:
        dense = sys.n_modes < NUMPY_BLOCKS_FROM
    return DenseMass(sys.flat) if dense else BlockMass(sys.mass_blocks)
