"""Independent reference: a uniform free-free beam spinning about its centre (the two-blade rotor),
and, with the same equations, a blade clamped or hinged on a hub (the published cases).

Written without any quadmodes code, with its own equations and discretisation, so that the
package's free 3-D beam can be checked against it (docs/rotating-beam-reference.md).

Model: frame rotating at Ω about z; the beam along x (rotor: x ∈ [−a, a], a = L/2); small
motions about the steady spinning state: flap w (along z), lag v (along y), axial u (along x).
From the kinetic energy ½∫ρA|ṙ + Ω×r|² (+ the sections' rotary terms) and the strain energy:

  flap   ρA ẅ − ((T/λ) w')' + (EI_y κ_w)'' + rotary terms = 0
  lag    ρA (v̈ − Ω² v) + 2ρAΩ u̇ − ((T/λ) v')' + (EI_z κ_v)'' + rotary terms = 0
  axial  ρA (ü − Ω² u) − 2ρAΩ v̇ − (EA u')' = 0

with T(x) = ½ρAΩ²(a² − x²) (+ its first-order correction from the steady stretch when EA is
finite), λ = 1 + T/EA, κ = (1/λ)(w'/λ)'; ends free (natural conditions), rigid-body motions in
the Ritz space (ritz.py). The gyroscopic problem M q̈ + G q̇ + K q = 0 is solved as a quadratic
eigenvalue problem in first-order companion form (scipy.linalg.eig). The rotor splits exactly by
the half-turn about the spin axis (x → −x, u → −u, v → −v, w → w): "sym" modes are unchanged by
it (both blades deform alike in their own frame: w even, v and u odd in x), "anti" modes change
sign (w odd, v and u even).

Units: SI (m, kg, s, N); frequencies in rad/s.
"""

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from .ritz import (
    Basis,
    Span,
    SpinningBeam,
    basis,
    fit,
    flap_system,
    lag_system,
    points,
    quadrature,
    steady_state,
)

RIGID_CONTENT = 0.9  # rigid-subspace fraction (mass norm) above which a root is a rigid motion
SYM_PARITY = {"flap": 0, "lag": 1}  # parity in x of the transverse field in the "sym" class


@dataclass(frozen=True)
class ClassRoots:
    """Roots of one problem: elastic bending and axial frequencies [rad/s] (ascending,
    positive), the rigid-body roots |s| [rad/s] (each with its conjugate), and the largest
    |Re s|/|s| among the lowest n_basis/4 bending roots (0 for a conservative, stable system)."""

    bending: np.ndarray
    axial: np.ndarray
    rigid: np.ndarray
    max_real_part_ratio: float


def quadratic_roots(mass, gyro, stiff, omega_scale: float):
    """Roots s of det(s²M + sG + K) = 0 and their position parts q (n, n_roots), from the
    companion pencil [[0, I], [−K, −G]] − s[[I, 0], [0, M]] in time units of 1/omega_scale [s],
    after the symmetric diagonal scaling 1/sqrt(|K_ii| + omega_scale² M_ii) of the coordinates
    (eigenvalues unchanged)."""
    n = mass.shape[0]
    mass, gyro = mass * omega_scale**2, gyro * omega_scale
    scale = 1.0 / np.sqrt(np.abs(np.diag(stiff)) + np.diag(mass))
    m_s, g_s, k_s = (scale[:, None] * x * scale[None, :] for x in (mass, gyro, stiff))
    eye, zero = np.eye(n), np.zeros((n, n))
    s, z = sla.eig(np.block([[zero, eye], [-k_s, -g_s]]), np.block([[eye, zero], [zero, m_s]]))
    finite = np.isfinite(s)
    return s[finite] * omega_scale, scale[:, None] * z[:n, finite]


def rigid_content(q: np.ndarray, rigid: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Fraction (mass norm) of each column of q inside span(rigid) (n, n_rigid)."""
    if rigid.shape[1] == 0:
        return np.zeros(q.shape[1])
    mr = mass @ rigid
    proj = rigid @ np.linalg.solve(rigid.T @ mr, mr.T @ q)
    num = np.real(np.sum(np.conj(q) * (mass @ proj), axis=0))
    return num / np.real(np.sum(np.conj(q) * (mass @ q), axis=0))


def classify(system, rigid: np.ndarray, n_v: int, omega_scale: float, n_low: int) -> ClassRoots:
    """Solve (M, G, K), set apart the roots whose shape lies in span(rigid) (and numerical
    zeros), and split the others into bending (most kinetic energy in the first ``n_v``
    coordinates) and axial."""
    mass = system[0]
    s, q = quadratic_roots(*system, omega_scale)
    is_rigid = (rigid_content(q, rigid, mass) > RIGID_CONTENT) | (np.abs(s) < 1e-7 * omega_scale)
    keep = ~is_rigid & (s.imag > 0)
    total = np.real(np.sum(np.conj(q) * (mass @ q), axis=0))
    qv = q[:n_v]
    is_bending = np.real(np.sum(np.conj(qv) * (mass[:n_v, :n_v] @ qv), axis=0)) / total > 0.5
    bend = keep & is_bending
    order = np.argsort(s.imag[bend])
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = (np.abs(s.real) / np.abs(s))[bend][order][:n_low]
    return ClassRoots(
        bending=s.imag[bend][order],
        axial=np.sort(s.imag[keep & ~is_bending]),
        rigid=np.sort(np.abs(s[is_rigid])),
        max_real_part_ratio=float(np.max(ratio, initial=0.0)),
    )


def _omega_scale(beam: SpinningBeam, span: Span, omega: float) -> float:
    ei = max(beam.ei_flap, beam.ei_lag)
    return math.sqrt(ei / (beam.rho_a * span.half**4) + omega**2) or 1.0


def _fields(beam, span, omega, family, parity, n_basis, quad, st):
    """(system, transverse basis, axial basis) of one family on the quadrature nodes."""
    tb = basis(n_basis, 2, parity, quad)
    ab = basis(1 if math.isinf(beam.ea) else n_basis, 1, parity, quad)
    if family == "flap":
        return flap_system(beam, span, omega, tb, quad, st), tb, ab
    if family == "lag":
        return lag_system(beam, span, omega, tb, ab, quad, st), tb, ab
    raise ValueError(f"family: {family!r}; use 'flap' or 'lag'")


def _rotor_rigid_shapes(span: Span, family: str, parity: int, tb: Basis, ab: Basis, quad,
                        st) -> np.ndarray:  # fmt: skip
    """Coefficient columns of the exact rigid motions of the stretched rotor in one class:
    flap: translation w = 1 (sym) or tilt about y w = x + u₀ (anti); lag: spin rotation
    v = x + u₀ (sym) or the in-plane translations v = 1 and u = 1 (anti)."""
    ones, line = np.ones_like(quad.xi), span.centre + span.half * quad.xi + st.axial_offset
    if family == "flap":
        return fit(tb, ones if parity == 0 else line)[:, None]
    zu, zv = np.zeros(ab.size), np.zeros(tb.size)
    if parity == 1:
        return np.concatenate([fit(tb, line), zu])[:, None]
    cols = [np.concatenate([fit(tb, ones), zu])]
    if ab.size:
        cols.append(np.concatenate([zv, fit(ab, ones)]))
    return np.stack(cols, axis=1)


def class_roots(beam: SpinningBeam, length: float, omega: float, family: str, parity: int,
                n_basis: int, stretch: bool = True) -> ClassRoots:  # fmt: skip
    """One symmetry class of the free-free rotor of ``length`` L [m] at spin ``omega``
    [rad/s]: ``family`` 'flap' or 'lag' (lag includes axial u), ``parity`` in x of the
    transverse field (see SYM_PARITY), ``n_basis`` Ritz functions per field (both parities)."""
    span = Span(-0.5 * length, 0.5 * length, 0.0)
    quad = quadrature(2 * n_basis + 40)
    st = steady_state(beam, span, omega, quad, stretch)
    system, tb, ab = _fields(beam, span, omega, family, parity, n_basis, quad, st)
    rigid = _rotor_rigid_shapes(span, family, parity, tb, ab, quad, st)
    n_v = tb.size if family == "lag" else system[0].shape[0]
    return classify(system, rigid, n_v, _omega_scale(beam, span, omega), max(1, n_basis // 4))


ROOTS = ("clamped", "hinged", "guided")


def _root_constraint(n_basis: int, n_axial: int, family: str, root: str) -> np.ndarray:
    """Columns spanning the coefficients that meet the root (ξ = −1) conditions, block-diagonal
    per field (transverse block first): clamped w = w' = 0, hinged w = 0, guided w' = 0 (lag the
    same for v, with u = 0 when clamped or hinged and u free when guided)."""
    at = points(-1.0)
    tb = basis(n_basis, 2, None, at)
    rows = {"clamped": np.vstack([tb.value, tb.slope]), "hinged": tb.value,
            "guided": tb.slope}[root]  # fmt: skip
    zt = sla.null_space(rows)
    if family == "flap":
        return zt
    ub = basis(n_axial, 1, None, at).value
    zu = np.eye(ub.shape[1]) if root == "guided" else sla.null_space(ub)
    return sla.block_diag(zt, zu)


def _blade_rigid(family: str, tb: Basis, ab: Basis, quad, z: np.ndarray) -> np.ndarray:
    """Rigid translations left by a guided root (w = 1; v = 1 and u = 1), in z's coordinates."""
    ones = np.ones_like(quad.xi)
    if family == "flap":
        cols = [fit(tb, ones)]
    else:
        zu, zv = np.zeros(ab.size), np.zeros(tb.size)
        cols = [np.concatenate([fit(tb, ones), zu]), np.concatenate([zv, fit(ab, ones)])]
    return z.T @ np.stack(cols, axis=1)  # z has orthonormal columns and contains them


def blade_roots(beam: SpinningBeam, length: float, hub_radius: float, omega: float, family: str,
                root: str = "clamped", n_basis: int = 32, stretch: bool = True) -> ClassRoots:  # fmt: skip
    """A blade of ``length`` ℓ [m] on a rigid hub of radius ``hub_radius`` [m] spinning at
    ``omega`` [rad/s] with its ``root`` clamped, hinged or guided (zero slope, free to slide):
    the published cantilever and hinged cases, and (at hub_radius 0) the two halves of the
    rotor's classes. Same equations and bases as the rotor, on [r, r + ℓ]."""
    if root not in ROOTS:
        raise ValueError(f"root: {root!r}; use one of {ROOTS}")
    span = Span(hub_radius, hub_radius + length, hub_radius)
    quad = quadrature(2 * n_basis + 40)
    st = steady_state(beam, span, omega, quad, stretch)
    system, tb, ab = _fields(beam, span, omega, family, None, n_basis, quad, st)
    z = _root_constraint(n_basis, ab.size, family, root)
    system = tuple(z.T @ x @ z for x in system)
    n_v = int(np.count_nonzero(np.any(z[: tb.size] != 0.0, axis=0)))  # v columns come first
    rigid = _blade_rigid(family, tb, ab, quad, z) if root == "guided" else np.zeros((z.shape[1], 0))
    return classify(system, rigid, n_v, _omega_scale(beam, span, omega), max(1, n_basis // 4))


def rotating_free_beam(L: float, EI_flap: float, EI_lag: float, EA: float, rho_A: float,
                       Omega: float, *, rho_I_flap: float = 0.0, rho_I_lag: float = 0.0,
                       n_basis: int = 32, n_modes: int = 6, stretch: bool = True) -> dict:  # fmt: skip
    """Rotating-frame elastic frequencies of a uniform free-free beam of length ``L`` [m]
    spinning at ``Omega`` [rad/s] about an axis through its centre, transverse to it.

    Inputs (SI): EI_flap (bending out of the spin plane, w along the spin axis) and EI_lag (in
    it, v) [N m²], EA [N] (``math.inf``: inextensible), rho_A [kg/m], rho_I_flap / rho_I_lag:
    section rotary inertia per length ρI_y / ρI_z [kg m]; ``n_basis`` Ritz functions per field;
    ``n_modes`` elastic modes returned per list; ``stretch``: with a finite EA, include the
    steady centrifugal stretch to first order (tension correction, stretched geometry).

    Returns ascending arrays in rad/s: 'flap', 'lag' (the first ``n_modes`` elastic roots of
    each family, both symmetry classes merged); 'flap_sym' / 'flap_anti' (w even / odd in x);
    'lag_sym' / 'lag_anti' (v and u odd / even in x): "sym" = unchanged by the half-turn about
    the spin axis, both blades alike in their own frame; 'axial' (elastic axial roots,
    Coriolis-coupled to lag); 'rigid': {'flap_translation': 0, 'flap_tilt': Ω, 'lag_spin': 0,
    'lag_translation': Ω, Ω} as found (each with its conjugate; excluded from the lists);
    'max_real_part_ratio' (largest |Re s|/|s| of the low roots, ≈ 1e-12 when stable); 'Omega';
    'units'. Included: centrifugal tension on flap and lag, centrifugal softening −Ω²ρA of lag
    and axial, Coriolis lag–axial coupling, section rotary inertia (and the flap section's
    centrifugal term). Not included: torsion, shear deformation."""
    beam = SpinningBeam(EI_flap, EI_lag, EA, rho_A, rho_I_flap, rho_I_lag)
    roots = {(fam, p): class_roots(beam, L, Omega, fam, p, n_basis, stretch)
             for fam in ("flap", "lag") for p in (0, 1)}  # fmt: skip
    out: dict = {"units": "rad/s", "Omega": float(Omega)}
    for fam in ("flap", "lag"):
        sym, anti = roots[(fam, SYM_PARITY[fam])], roots[(fam, 1 - SYM_PARITY[fam])]
        out[fam] = np.sort(np.concatenate([sym.bending, anti.bending]))[:n_modes]
        out[f"{fam}_sym"] = sym.bending[:n_modes]
        out[f"{fam}_anti"] = anti.bending[:n_modes]
    out["axial"] = np.sort(np.concatenate([roots[("lag", p)].axial for p in (0, 1)]))[:n_modes]
    out["rigid"] = {
        "flap_translation": roots[("flap", 0)].rigid,
        "flap_tilt": roots[("flap", 1)].rigid,
        "lag_spin": roots[("lag", 1)].rigid,
        "lag_translation": roots[("lag", 0)].rigid,
    }
    out["max_real_part_ratio"] = max(r.max_real_part_ratio for r in roots.values())
    return out
