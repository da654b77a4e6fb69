"""The arrays of one formulation of the reduced equations, and the state vector.

Lagrangian of formulation "Q" (theory.md §3, derivation in docs/derivation.md)::

    L̃ = ½ ωᵀ J̃(s) ω + ωᵀ A(s) ṡ + ½ ṡᵀ μ ṡ − ½ sᵀ Λ s
    J̃(s) = J0 + Σ_k s_k J1_k + Σ_mn s_m s_n J2_mn,   J2 = J2u + J2g
    A(s) = [a_1 … a_N],  a_n = c_n + Σ_m s_m D_mn,     D = Cuu + 2 Cxg

In the code ``A`` is stored transposed, as rows ``a_n``: an ``(N, 3)`` array, so that
``h = J̃ ω + Aᵀ ṡ`` reads ``Jt @ w + sd @ A`` and ``p_s = A ω + μ ṡ`` reads ``A @ w + mu @ sd``.

Formulations (``reduced_system(model, formulation)``):

* ``"Q"``: the above; E and H conserved exactly by the continuous equations.
* ``"P"``: the seed's printed equations. Modal row as Q; rotational row built from
  ``J2u`` and ``Cuu`` only (no g terms): ``h_P = (J0 + sJ1 + ssJ2u) ω + (c + s Cuu)ᵀ ṡ``.
  ``h_P`` is conserved, E (same formula as Q) is not.
* ``"L"``: linear modes: ``J2g = 0`` and ``Cxg = 0`` everywhere (a consistent Lagrangian too).
* ``"rigid"``: N = 0.
* ``"Q4"``: Q kinetics with the manifold potential truncated at fourth order,
  ``V(s) = ½ sᵀΛs + V3_mnp s_m s_n s_p + V4_mnpq s_m s_n s_p s_q`` (tensors of
  :func:`quadmodes.rom.reduced.manifold_potential_tensors`).
* ``"QM"`` (not in ``FORMULATIONS``: it needs the structure's mass matrix, made by
  :func:`quadmodes.rom.manifold_kinetics.manifold_system`): the exact kinetic energy of the
  quadratic manifold, Q4's potential, the damping on the manifold velocity; Q4's arrays kept
  (the Newton matrix, weights and diagnostics that need a quadratic 𝕄 use them).

The mass matrix: T = ½ νᵀ𝕄(s)ν with ν = (ω, ṡ), 𝕄(s) = [[J̃, Aᵀ], [A, μ]], evaluated by blocks
(:mod:`quadmodes.rom.structured_mass`, ``ReducedSystem.mass_blocks``: O(N²) per evaluation) for
momenta and the equations of motion (:mod:`quadmodes.rom.dynamics`). The same matrix as a dense
mass tensor, 𝕄(s) = Σ_ij z_i z_j Mt_ij, z = (1, s), Mt (N+1, N+1, 3+N, 3+N) (O(N⁴) numbers,
built on first use: :class:`FlatTensors`), serves the backward-Euler step and as the reference.

State vector ``y = [q (4), ω (3), s (N), ṡ (N)]``, length ``7 + 2N``: q a unit quaternion,
scalar first, rotating body-frame vectors into the inertial frame; ω (rad/s) body-frame angular
velocity; s (√kg·m) modal coordinates; ṡ (√kg·m/s). Translation is decoupled (p = centre of
mass) and not part of y. SI units throughout: J in kg m², h in kg m²/s, energies in J.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from quadmodes.rom.reduced import ReducedModel
from quadmodes.rom.structured_mass import MassBlocks, mass_blocks

FORMULATIONS = ("Q", "P", "L", "rigid", "Q4")


@dataclass(frozen=True, eq=False)
class FlatTensors:
    """Flattened copies of a :class:`ReducedSystem`'s tensors, laid out so that each use is one
    matrix product (N modes, m3 = 3 + N, z = (1, s)). All C-contiguous float arrays.

    J1f (N, 9): J1. J2s (N, 9N): ``G(s)_k = Σ_m s_m J2_mk = (s @ J2s).reshape(N, 9)``.
    J2w (N², 9): J2. Ds (N, 3N): D. Dsk (N², 3): ``D_km − D_mk``.
    V3g (N, N²) = 3 V3, V4g (N, N³) = 4 V4: ``∂V/∂s − Λs = V3g @ (s⊗s) + V4g @ (s⊗s⊗s)``
    ("Q4" only; ``(N, 0)`` for the other formulations).

    The dense mass tensors, O(N⁴) numbers each, built on first use from ``system`` (the steps
    evaluate 𝕄 by blocks, :attr:`ReducedSystem.mass_blocks`; these serve backward Euler and the
    reference :class:`~quadmodes.rom.structured_mass.DenseMass`):
    Mt, MtE ((N+1)², m3²): mass tensor ``𝕄(s) = Σ_ij z_i z_j Mt[i, j]`` of the momenta
    (rotational rows from J2_rot/D_rot) and of the energy (J2/D; the same array unless "P").
    Yt, YtE (N+1, N·m3²): ``Y(z)[k] = Σ_j z_j Mt[k+1, j] = ½ ∂𝕄/∂s_k = (z @ Yt).reshape(N·m3, m3)``.
    WtE (N², m3²), Wt (N, N·m3²): ``∂²𝕄/∂s_k∂s_j = 2 Mt[k+1, j+1]`` (energy, momenta).
    """

    J1f: np.ndarray
    J2s: np.ndarray
    J2w: np.ndarray
    Ds: np.ndarray
    Dsk: np.ndarray
    V3g: np.ndarray
    V4g: np.ndarray
    system: ReducedSystem = field(repr=False)

    @cached_property
    def _tensors(self) -> tuple[np.ndarray, np.ndarray]:
        """(momenta, energy) mass tensors (N+1, N+1, 3+N, 3+N) (the same array unless "P")."""
        sys = self.system
        # 𝕄(s) = Σ_ij z_i z_j Mt[i, j], z = (1, s): symmetric in (i, j). Rows 0–2 (rotational)
        # from J2_rot/D_rot, rows 3… (modal) from J2/D.
        mom = _mass_tensor(sys, sys.J2_rot, sys.D_rot, sys.D)
        en = mom if sys.same_rows else _mass_tensor(sys, sys.J2, sys.D, sys.D)
        return mom, en

    def _flat(self, energy: bool, rows: slice, cols: slice, shape: tuple) -> np.ndarray:
        return np.ascontiguousarray(self._tensors[1 if energy else 0][rows, cols].reshape(shape))

    def _sizes(self) -> tuple[int, int]:
        n = self.system.n_modes
        return n, (3 + n) ** 2

    @cached_property
    def Mt(self) -> np.ndarray:
        n, mm = self._sizes()
        return self._flat(False, slice(None), slice(None), ((n + 1) ** 2, mm))

    @cached_property
    def MtE(self) -> np.ndarray:
        n, mm = self._sizes()
        return self._flat(True, slice(None), slice(None), ((n + 1) ** 2, mm))

    @cached_property
    def Yt(self) -> np.ndarray:
        n, mm = self._sizes()
        return self._flat(False, slice(None), slice(1, None), (n + 1, n * mm))

    @cached_property
    def YtE(self) -> np.ndarray:
        n, mm = self._sizes()
        return self._flat(True, slice(None), slice(1, None), (n + 1, n * mm))

    @cached_property
    def WtE(self) -> np.ndarray:
        n, mm = self._sizes()
        return self._flat(True, slice(1, None), slice(1, None), (n * n, mm))

    @cached_property
    def Wt(self) -> np.ndarray:
        n, mm = self._sizes()
        return self._flat(False, slice(1, None), slice(1, None), (n, n * mm))


@dataclass(frozen=True, eq=False)
class ReducedSystem:
    """Arrays of one formulation of the reduced equations (SI units, N modes).

    J0 (3,3) kg m². J1 (N,3,3) √kg·m. J2 (N,N,3,3) and D (N,N,3), dimensionless, J2 symmetrised:
    second-order inertia and rotation–deformation coupling of the Lagrangian (modal row and
    energy). J2_rot, D_rot: the same arrays as used by the rotational row (differ from J2, D for
    "P" only). c (N,3) √kg·m. mu (N,N) 1, Lam (N,N) 1/s², C (N,N) 1/s. quat_gain (1/s): gain of
    the quaternion norm-drift correction ``k (1 − |q|²) q`` in :func:`quadmodes.rom.dynamics.rhs`.
    V3 (N,N,N), V4 (N,N,N,N) J/(√kg·m)^k: symmetric cubic and quartic potential coefficients,
    used only when ``quartic`` (formulation "Q4"); None means zeros. F1 (N,) J/(√kg·m): linear
    potential coefficient (a model expanded about a spinning state), ``V = F1·s + ½ sᵀΛs + …``;
    None means zeros. reference_omega (3,) rad/s: the body angular velocity of that state (zeros
    for a model about the state at rest); the effective potential ``V − ½ωᵀJ̃(s)ω`` at it is
    what bounds the motion (:func:`quadmodes.rom.dynamics.potential_barrier`).
    nonlinear_potential: None, or an object adding ``N(s)`` to the potential,
    ``V = F1·s + ½ sᵀΛs (+ V3, V4) + N(s)``, with methods ``nonlinear_energy(s)`` (J),
    ``nonlinear_force(s)`` = ∂N/∂s (N,) and ``nonlinear_hessian(s)`` = ∂²N/∂s² (N,N), N = O(|s|³)
    (e.g. :class:`quadmodes.experimental.condensed_potential.CondensedPotential`, the condensed
    energy of a wrinkling membrane); integrated by the numpy steppers only.
    manifold: None, or the :class:`~quadmodes.rom.manifold_kinetics.ManifoldArrays` of
    formulation "QM" (the exact manifold kinetic energy and C(s); Q4's potential; made by
    :func:`~quadmodes.rom.manifold_kinetics.manifold_system`): the kinetic quantities of
    :mod:`quadmodes.rom.dynamics` and the midpoint step use them in place of J̃, A, μ, C.
    ``flat``: the :class:`FlatTensors` for fast matrix products; ``mass_blocks``: the
    :class:`~quadmodes.rom.structured_mass.MassBlocks` of 𝕄(s).
    """

    formulation: str
    free: bool
    J0: np.ndarray
    J1: np.ndarray
    J2: np.ndarray
    D: np.ndarray
    c: np.ndarray
    mu: np.ndarray
    Lam: np.ndarray
    C: np.ndarray
    J2_rot: np.ndarray
    D_rot: np.ndarray
    quat_gain: float = 1.0
    V3: np.ndarray | None = None
    V4: np.ndarray | None = None
    F1: np.ndarray | None = None
    reference_omega: np.ndarray | None = None
    nonlinear_potential: object | None = None
    manifold: object | None = None
    n_modes: int = field(init=False)
    quartic: bool = field(init=False)
    nonlinear: bool = field(init=False)
    same_rows: bool = field(init=False, repr=False)
    flat: FlatTensors = field(init=False, repr=False)
    mass_blocks: MassBlocks = field(init=False, repr=False)

    def __post_init__(self):
        n = self.J1.shape[0]
        put = object.__setattr__
        put(self, "n_modes", n)
        put(self, "quartic", self.formulation in ("Q4", "QM"))
        #: the potential has terms beyond ½ sᵀΛs (Q4's tensors or a nonlinear potential)
        put(self, "nonlinear", self.quartic or self.nonlinear_potential is not None)
        # absent (Q, P, L): read-only zeros of no memory, never multiplied (N⁴ numbers at N = 31)
        put(self, "V3", _zeros((n,) * 3) if self.V3 is None else np.asarray(self.V3, float))
        put(self, "V4", _zeros((n,) * 4) if self.V4 is None else np.asarray(self.V4, float))
        put(self, "F1", np.zeros(n) if self.F1 is None else np.asarray(self.F1, float))
        w = self.reference_omega
        put(self, "reference_omega", np.zeros(3) if w is None else np.asarray(w, float))
        put(self, "same_rows", self.J2_rot is self.J2 and self.D_rot is self.D)
        put(self, "flat", flat_tensors(self))
        put(self, "mass_blocks", mass_blocks(self.J0, self.J1, self.J2, self.D, self.c,
                                             self.mu, self.J2_rot, self.D_rot))  # fmt: skip

    @property
    def n_state(self) -> int:
        """Length of the state vector, ``7 + 2N``."""
        return 7 + 2 * self.n_modes


def _zeros(shape: tuple[int, ...]) -> np.ndarray:
    """Read-only zeros of ``shape`` that take no memory (a broadcast view of one zero)."""
    return np.broadcast_to(np.zeros(()), shape)


def flat_tensors(sys: ReducedSystem) -> FlatTensors:
    """The :class:`FlatTensors` of ``sys`` (its V3, V4 already arrays); V3g and V4g only for
    "Q4" (``quartic``), else ``(N, 0)`` (no cubic or quartic potential: nothing to multiply)."""
    n = sys.n_modes
    c = np.ascontiguousarray
    dsk = sys.D - sys.D.transpose(1, 0, 2)  # D_km − D_mk
    quartic = sys.quartic
    return FlatTensors(
        J1f=c(sys.J1.reshape(n, 9)),
        J2s=c(sys.J2.reshape(n, n * 9)),
        J2w=c(sys.J2.reshape(n * n, 9)),
        Ds=c(sys.D.reshape(n, n * 3)),
        Dsk=c(dsk.reshape(n * n, 3)),
        V3g=c(3.0 * sys.V3.reshape(n, n * n)) if quartic else np.zeros((n, 0)),
        V4g=c(4.0 * sys.V4.reshape(n, n * n * n)) if quartic else np.zeros((n, 0)),
        system=sys,
    )


def sym_pair(a: np.ndarray) -> np.ndarray:
    """Symmetrise ``a`` (N,N,...) in its first two indices."""
    return 0.5 * (a + np.swapaxes(a, 0, 1))


def sym_tensor(a: np.ndarray) -> np.ndarray:
    """Symmetrise ``a`` (...,3,3) in its last two indices."""
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def _mass_tensor(sys: ReducedSystem, j2_rot, d_rot, d_mod) -> np.ndarray:
    """Coefficients Mt (N+1, N+1, 3+N, 3+N) of 𝕄(s) = Σ_ij z_i z_j Mt[i,j], z = (1, s)."""
    n = sys.J1.shape[0]
    m3 = 3 + n
    mt = np.zeros((n + 1, n + 1, m3, m3))
    mt[0, 0, :3, :3] = sys.J0
    mt[0, 0, :3, 3:] = sys.c.T
    mt[0, 0, 3:, :3] = sys.c
    mt[0, 0, 3:, 3:] = sys.mu
    for k in range(n):  # linear terms, split evenly between (0, k) and (k, 0)
        blk = np.zeros((m3, m3))
        blk[:3, :3] = sys.J1[k]
        blk[:3, 3:] = d_rot[k].T  # Aᵀ column n gets s_k D_kn
        blk[3:, :3] = d_mod[k]
        mt[0, k + 1] = mt[k + 1, 0] = 0.5 * blk
    mt[1:, 1:, :3, :3] = j2_rot
    return mt


def _check_formulation(model: ReducedModel, formulation: str) -> None:
    if formulation == "QM":
        raise ValueError(
            'formulation "QM" needs the structure\'s mass matrix: it is built by '
            "quadmodes.runs.manifold_system.run_system (a run) or "
            "quadmodes.rom.manifold_kinetics.manifold_system; this use does not support it yet"
        )
    if formulation not in FORMULATIONS:
        raise ValueError(f"unknown formulation {formulation!r}; choose one of {FORMULATIONS}")
    if formulation == "Q4" and not getattr(model, "manifold_potential", False):
        raise ValueError(
            "formulation Q4 needs the manifold potential (V3, V4) of the reduced model, which this "
            "model does not have (a file of artifact format 1: rebuild it with `quadmodes "
            "reduce`; or a gas-law pressure, which is not polynomial: use Q)"
        )


def reduced_system(
    model: ReducedModel, formulation: str = "Q", quat_gain: float = 1.0
) -> ReducedSystem:
    """The :class:`ReducedSystem` of ``model`` for ``formulation`` in ``FORMULATIONS``.

    J2 is symmetrised in (m, n) and in its 3×3 indices (it is symmetric by construction; this
    removes round-off so that the equations are exactly variational).
    """
    if formulation == "rigid":
        model = model.rigid()
    _check_formulation(model, formulation)
    f = np.asarray
    j2u = sym_tensor(sym_pair(f(model.J2u, float)))
    j2g = sym_tensor(sym_pair(f(model.J2g, float)))
    cuu = f(model.Cuu, float)
    cxg = f(model.Cxg, float)
    if formulation == "L":
        j2, d = j2u, cuu.copy()
    else:
        j2, d = j2u + j2g, cuu + 2.0 * cxg
    if formulation == "P":
        j2_rot, d_rot = j2u, cuu.copy()
    else:
        j2_rot, d_rot = j2, d
    return ReducedSystem(
        formulation=formulation,
        free=bool(model.free),
        J0=sym_tensor(f(model.J0, float)),
        J1=sym_tensor(f(model.J1, float)),
        J2=j2,
        D=d,
        c=f(model.c, float).copy(),
        mu=sym_pair(f(model.mu, float)),
        Lam=sym_pair(f(model.Lam, float)),
        C=f(model.C, float).copy(),
        J2_rot=j2_rot,
        D_rot=d_rot,
        quat_gain=float(quat_gain),
        V3=f(model.V3, float) if formulation == "Q4" else None,
        V4=f(model.V4, float) if formulation == "Q4" else None,
        F1=f(getattr(model, "F1", None) if model.n_modes else np.zeros(0), float),
        reference_omega=getattr(model, "reference_spin", 0.0)
        * f(getattr(model, "reference_axis", np.array([0.0, 0.0, 1.0])), float),
    )


def with_damping(sys: ReducedSystem, C: np.ndarray) -> ReducedSystem:
    """``sys`` with the modal damping matrix replaced by ``C`` (N,N) 1/s."""
    return ReducedSystem(
        sys.formulation, sys.free, sys.J0, sys.J1, sys.J2, sys.D, sys.c, sys.mu, sys.Lam,
        np.asarray(C, float), sys.J2_rot, sys.D_rot, sys.quat_gain, sys.V3, sys.V4, sys.F1,
        sys.reference_omega, sys.nonlinear_potential, sys.manifold,
    )  # fmt: skip


def with_nonlinear_potential(sys: ReducedSystem, potential) -> ReducedSystem:
    """``sys`` with ``potential`` added to its potential (see :class:`ReducedSystem`)."""
    return ReducedSystem(
        sys.formulation, sys.free, sys.J0, sys.J1, sys.J2, sys.D, sys.c, sys.mu, sys.Lam, sys.C,
        sys.J2_rot, sys.D_rot, sys.quat_gain, sys.V3, sys.V4, sys.F1, sys.reference_omega,
        potential, sys.manifold,
    )  # fmt: skip


def split_state(sys: ReducedSystem, y: np.ndarray):
    """``(q, ω, s, ṡ)`` views of ``y`` (..., 7+2N)."""
    n = sys.n_modes
    return y[..., 0:4], y[..., 4:7], y[..., 7 : 7 + n], y[..., 7 + n : 7 + 2 * n]


def pack_state(sys: ReducedSystem, q=None, omega=None, s=None, sdot=None) -> np.ndarray:
    """State vector ``y`` (7+2N,) from its parts (defaults: identity, zeros); q is normalised."""
    n = sys.n_modes
    q = np.array([1.0, 0.0, 0.0, 0.0]) if q is None else np.asarray(q, float)
    z = np.zeros(n)
    parts = [
        q / np.linalg.norm(q),
        np.zeros(3) if omega is None else np.asarray(omega, float),
        z if s is None else np.asarray(s, float),
        z if sdot is None else np.asarray(sdot, float),
    ]
    return np.concatenate(parts)
