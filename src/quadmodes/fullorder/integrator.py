"""Time stepping of the full finite-element model (choices: the package docstring).

One step from ``(x₀, v₀)`` at ``t₀`` to ``t₁ = t₀ + Δt`` solves for ``x₁``::

    v½ = (x₁ − x₀)/Δt,  x½ = (x₀ + x₁)/2,  v₁ = 2 v½ − v₀
    r(x₁) = M (v₁ − v₀)/Δt + f_step(x₀, x₁) + f_d(x½, v½) = 0        (free components)

with f_step the energy–momentum internal force (:func:`step_force`) or ``f(x½)``, by Newton
iterations ``δx = −(Δt²/2) A⁻¹ r``, ``A = M + (Δt²/2) ∂f_step/∂x₁`` (+ gas-law rank-one terms by
Sherman–Morrison; the rank-N damping term is left out of A).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

from quadmodes.fe.assembly import assemble_matrix, assemble_vector
from quadmodes.fe.bar import BarSet
from quadmodes.fe.membrane import MembraneSet, _voigt_stress, green_strain
from quadmodes.fe.model import (
    Structure,
    centre_of_mass,
    internal_force,
    mass_matrix,
    strain_energy,
    tangent_low_rank,
    tangent_stiffness,
)
from quadmodes.fullorder import kinematics as kin
from quadmodes.io.atomic import atomic_path
from quadmodes.rom.reduced import ReducedModel, cross_form

#: Refactor when successive Newton corrections shrink by less than this factor.
RHO_REFACTOR = 0.5
#: Backtrack on the incremental potential when a Newton correction exceeds this (relative).
LINE_SEARCH = 1e-5
#: Checkpoint file format version.
CHECKPOINT_VERSION = 1


class FullOrderNewtonError(RuntimeError):
    """Newton did not converge in a full-order step; the message is one line."""

    def __init__(self, step: int, time: float, residual: float, checkpoint: Path | None = None):
        self.step, self.time, self.residual, self.checkpoint = step, time, residual, checkpoint
        kept = f"checkpoint kept at {checkpoint}" if checkpoint else "no checkpoint"
        super().__init__(
            f"full-order Newton did not converge at step {step}, t = {time:.6g} s, residual "
            f"{residual:.2e} (relative correction); {kept}"
        )


@dataclass(frozen=True, eq=False)
class FullOrderSolution:
    """Full-order transient, sampled (k samples; SI units).

    t (k,) s. H (k,3) inertial angular momentum about the centre of mass (kg m²/s), H_norm (k,).
    T (k,) J kinetic energy without the CoM translation; V (k,) J potential (strain + pressure)
    relative to the reference state; E = T + V; E_d (k,) J energy dissipated by the damping
    force since the start (Σ Δt v½ᵀ f_d). spin_rate (k,) rad/s: mean-axes angular velocity on the
    tracked minor principal axis of the deformed inertia; cone_angle (k,) rad in [0, π/2]
    between H and that axis; axis (k,3) the tracked axis (inertial). modal_coordinates (k,N)
    √kg·m (N = 0 without a model). tip (k,3) m hub-frame tip displacement (hub-driven) or None.
    status 0 ok, 1 stopped early (message says why); dt s; stats: n_steps, n_newton, n_factor,
    wall_s, newton_per_step, factor_per_step."""

    t: np.ndarray
    H: np.ndarray
    H_norm: np.ndarray
    H_discrete: np.ndarray
    T: np.ndarray
    V: np.ndarray
    E: np.ndarray
    E_d: np.ndarray
    spin_rate: np.ndarray
    cone_angle: np.ndarray
    axis: np.ndarray
    modal_coordinates: np.ndarray
    tip: np.ndarray | None
    status: int
    message: str
    dt: float
    stats: dict = field(default_factory=dict)

    @property
    def E_balance(self) -> np.ndarray:
        """E + E_d (k,) J: constant for the exact dynamics."""
        return self.E + self.E_d


# ---------------------------------------------------------------------------------------------
# step force: midpoint with the Simo–Tarnow stress average
# ---------------------------------------------------------------------------------------------


def step_force(structure: Structure, x0: np.ndarray, x1: np.ndarray, strain0=None) -> np.ndarray:
    """Internal force (n,3) N of the step x0 → x1 (energy–momentum midpoint).

    St Venant–Kirchhoff membranes and Green-strain bars: ``Dε(x½)ᵀ S̄`` with the stress of the
    averaged strain ``S̄ = S((ε₀ + ε₁)/2)`` (Simo & Tarnow 1992). Since ε is quadratic in x,
    ``ε₁ − ε₀ = Dε(x½)(x₁ − x₀)`` and the energy is quadratic in ε, the step's work equals
    the energy change exactly; ``Dε(x½)ᵀ S̄`` is equilibrated at x½, so H is conserved too.
    Other sets (pressure, cable) use ``f(x½)``: the constant-pressure potential is cubic, and the
    midpoint's energy error is the enclosed volume of the increment field (zero for a rigid
    rotation). ``strain0``: per-set strains at x0 from :func:`step_strains` (else computed)."""
    xh = 0.5 * (x0 + x1)
    out = np.zeros((structure.n, 3))
    strain0 = step_strains(structure, x0) if strain0 is None else strain0
    for e, e0 in zip(structure.elements, strain0, strict=True):
        if isinstance(e, MembraneSet):
            fh, _ = green_strain(e.gradients, xh[e.conn])
            _, e1 = green_strain(e.gradients, x1[e.conn])
            sbar = _voigt_stress(e.d, 0.5 * (e0 + e1))
            fe = e._volume()[:, None, None] * np.einsum("eij,ejk,eak->eai", fh, sbar, e.gradients)
        elif isinstance(e, BarSet):
            ebar = 0.5 * (e0 + e.strain(x1))
            fb = (e.EA * ebar / e.length0)[:, None] * e._d(xh)
            fe = np.stack([-fb, fb], 1)
        else:
            fe = e.force(xh)
        out += assemble_vector(e.conn, fe, structure.n)
    return out


def step_strains(structure: Structure, x: np.ndarray) -> list:
    """Per element set the strains at x used by :func:`step_force` (None for other sets)."""
    out = []
    for e in structure.elements:
        if isinstance(e, MembraneSet):
            out.append(green_strain(e.gradients, x[e.conn])[1])
        elif isinstance(e, BarSet):
            out.append(e.strain(x))
        else:
            out.append(None)
    return out


# ---------------------------------------------------------------------------------------------
# Newton matrix
# ---------------------------------------------------------------------------------------------


def _strain_rows(f: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Membrane strain–displacement rows ``(ne, 3, 9)`` for ``[E11, E22, 2E12]`` at F (ne,3,2)."""
    return np.stack(
        [
            np.einsum("ei,ea->eai", f[:, :, 0], g[:, :, 0]),
            np.einsum("ei,ea->eai", f[:, :, 1], g[:, :, 1]),
            np.einsum("ei,ea->eai", f[:, :, 0], g[:, :, 1])
            + np.einsum("ei,ea->eai", f[:, :, 1], g[:, :, 0]),
        ],
        1,
    ).reshape(-1, 3, 9)


def step_jacobian(structure: Structure, x0: np.ndarray, x1: np.ndarray, energy_momentum: bool):
    """``∂f_step/∂x₁`` (3n,3n) sparse (N/m) of :func:`step_force` (or of ``f(x½)``: ½K(x½)) and
    its rank-one gas-law terms ``[(c, v)]``. The energy–momentum blocks are not symmetric:
    ``½[K_geo(S̄) + B(x½)ᵀ D B(x₁)]`` for membranes, likewise for bars."""
    xh = 0.5 * (x0 + x1)
    low = [(0.5 * c, v) for c, v in tangent_low_rank(structure, xh)]
    if not energy_momentum:
        return 0.5 * tangent_stiffness(structure, xh), low
    mats = []
    for e in structure.elements:
        if isinstance(e, MembraneSet):
            fh, _ = green_strain(e.gradients, xh[e.conn])
            f1, e1 = green_strain(e.gradients, x1[e.conn])
            _, e0 = green_strain(e.gradients, x0[e.conn])
            sbar = _voigt_stress(e.d, 0.5 * (e0 + e1))
            g = e.gradients
            k_mat = np.einsum("epa,pq,eqb->eab", _strain_rows(fh, g), e.d, _strain_rows(f1, g))
            k_geo = np.einsum("eak,ekl,ebl->eab", g, sbar, g)
            k_geo = np.einsum("eab,ij->eaibj", k_geo, np.eye(3)).reshape(-1, 9, 9)
            ke = 0.5 * e._volume()[:, None, None] * (k_mat + k_geo)
        elif isinstance(e, BarSet):
            dh, d1 = e._d(xh), e._d(x1)
            ebar = 0.5 * (e.strain(x0) + e.strain(x1))
            k = e.EA / e.length0
            kb = (0.5 * k)[:, None, None] * (
                ebar[:, None, None] * np.eye(3)
                + np.einsum("ei,ej->eij", dh, d1) / (e.length0**2)[:, None, None]
            )
            ke = np.block([[kb, -kb], [-kb, kb]])
        else:
            ke = 0.5 * e.stiffness(xh)
        mats.append(assemble_matrix(e.conn, ke, structure.n))
    out = mats[0]
    for m in mats[1:]:
        out = out + m
    return out.tocsr(), low


class _Factor:
    """Sparse LU of ``A = M + (Δt²/2) J`` on the free DOFs, J = ∂f_step/∂x₁ at a body-frame
    pair (z₀, z₁) (:func:`step_jacobian`).

    Frame covariance ``J(𝒬z₀, 𝒬z₁) = 𝒬 J(z₀, z₁) 𝒬ᵀ`` (𝒬 = I ⊗ Q; M commutes with 𝒬) lets one
    factorisation serve later steps whose body-frame pair is close to (z₀, z₁):
    ``A⁻¹ r ≈ 𝒬 A(z)⁻¹ 𝒬ᵀ r`` with Q the current frame, whatever the rigid rotation since."""

    def __init__(self, structure, m_full, z0, z1, dt: float, free: np.ndarray, em: bool):
        jac, low = step_jacobian(structure, z0, z1, em)
        a = m_full + (0.5 * dt * dt) * jac
        self.lu = spla.splu(a[free][:, free].tocsc(), permc_spec="COLAMD")
        self.low = []
        for coef, vec in low:
            vf = np.asarray(vec).ravel()[free]
            self.low.append((0.5 * dt * dt * coef, vf, self.lu.solve(vf)))

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        y = self.lu.solve(rhs)
        for coef, vec, av in self.low:  # Sherman–Morrison for c v vᵀ
            y = y - av * (coef * (vec @ y) / (1.0 + coef * (vec @ av)))
        return y


def _line_search(residual_norm, x1: np.ndarray, dx: np.ndarray, r0: float):
    """Backtracking along dx on the residual norm (N): the first α of 1, ½, ¼, … (six halvings)
    with ``‖r(x₁ + α dx)‖ < (1 − 10⁻⁴α) r0``. Returns ``(α, trial point)``, or ``(1, None)`` if
    none qualifies (the caller's convergence control takes over)."""
    alpha = 1.0
    for _ in range(7):
        y = x1 + alpha * dx
        trial = residual_norm(y)
        if np.isfinite(trial) and trial < (1.0 - 1e-4 * alpha) * r0:
            return alpha, y
        alpha *= 0.5
    return 1.0, None


# ---------------------------------------------------------------------------------------------
# damping force
# ---------------------------------------------------------------------------------------------


def rigid_basis(body: kin.Body, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Rigid motions Ψ (n,3,6) of state x about p: translations (positions only), rotations
    ``e_a × (x − t p)``."""
    n = x.shape[0]
    r = x - np.outer(body.t, p)
    psi = np.zeros((n, 3, 6))
    for a in range(3):
        psi[:, a, a] = body.t
        e = np.zeros(3)
        e[a] = 1.0
        psi[:, :, 3 + a] = np.cross(e, r)
    return psi


def damping_force(
    body: kin.Body,
    c: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    hub_rotation: np.ndarray | None = None,
    hub_omega: np.ndarray | None = None,
    hub_point: np.ndarray | None = None,
) -> np.ndarray:
    """Modal damping force f_d (n,3) N at state (x, v) (the force in ``M a + f_d + f = 0``).

    Free body: ``f_d = W C Wᵀ v`` with ``W = Π M 𝒬 Φ``, Q the best-fit (mean-axes) rotation of x,
    Π the M-orthogonal projector off the rigid motions Ψ(x) about the CoM
    (``Π = I − MΨ(ΨᵀMΨ)⁻¹Ψᵀ``): ``Wᵀv`` is the modal velocity of the elastic part of v, f_d has
    zero net force and zero moment about the CoM (H is untouched) and ``vᵀ f_d ≥ 0``.
    Clamped body: ``W = M 𝒬 Φ`` with Q the hub rotation, applied to the velocity relative to
    the hub (the clamp reactions take the net load). ``c`` (N,N) 1/s: the ROM's C."""
    n_modes = body.n_modes
    n = x.shape[0]
    if hub_rotation is None:
        p = kin.centre(body, x)
        rot = kin.best_fit_rotation(body, x, p)
        w = (body.MPhi @ rot.T).reshape(n_modes, 3 * n).T
        psi = rigid_basis(body, x, p).reshape(3 * n, 6)
        mpsi = (body.ms @ psi.reshape(n, 18)).reshape(3 * n, 6)
        g6 = psi.T @ mpsi
        w = w - mpsi @ (np.linalg.pinv(g6, rcond=1e-12, hermitian=True) @ (psi.T @ w))
        vel = v.ravel()
    else:
        w = (body.MPhi @ hub_rotation.T).reshape(n_modes, 3 * n).T
        r = x - np.outer(body.t, hub_point)
        vel = (v - np.cross(hub_omega, r)).ravel()
    return (w @ (c @ (w.T @ vel))).reshape(n, 3)


def body_frame(
    body: kin.Body, x: np.ndarray, hub: kin.HubDrive | None, t: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(c, R, b)`` of state x at time t: origin c (3,) (CoM of a free body, hub point of a
    clamped one), frame R (3,3) (best-fit rotation, or hub rotation) and the body-frame
    configuration ``b = Rᵀ(x − t c)`` (n,3)."""
    if hub is None:
        c = kin.centre(body, x)
        rot = kin.best_fit_rotation(body, x, c)
    else:
        c = np.asarray(hub.point, float)
        rot = hub.rotation(t)
    return c, rot, (x - np.outer(body.t, c)) @ rot


def extrapolate(
    body: kin.Body, prev: tuple, now: tuple, hub: kin.HubDrive | None, t1: float
) -> np.ndarray:
    """Predicted x₁ (n,3) from the body frames ``(c, R, b)`` of the last two states: origin,
    rotation (``R₁ = R₀ R₋₁ᵀ R₀``, or the hub's R(t₁)) and body-frame configuration extrapolated
    linearly. Exact for a steady rigid rotation; the error is O(h²) of the body-frame (elastic)
    acceleration. The plain ``x + h v`` would be off by ½h²Ω²|r| (mm at 41 Hz), and any use of the
    velocity or acceleration would feed the unresolved stiff components (ωh ≫ 1), which the
    midpoint keeps nearly frozen in position while their velocity alternates."""
    c_m, r_m, b_m = prev
    c_0, r_0, b_0 = now
    c_1 = 2.0 * c_0 - c_m
    r_1 = hub.rotation(t1) if hub is not None else r_0 @ (r_m.T @ r_0)
    return np.outer(body.t, c_1) + (2.0 * b_0 - b_m) @ r_1.T


# ---------------------------------------------------------------------------------------------
# checkpoints
# ---------------------------------------------------------------------------------------------


def write_checkpoint(path: Path, data: dict) -> None:
    """Write ``data`` (arrays) to ``path`` (.npz) atomically: temporary file + ``os.replace``."""
    with atomic_path(path, fsync=True) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **data)


def read_checkpoint(path: Path) -> dict:
    """Arrays of a checkpoint written by :func:`write_checkpoint`."""
    with np.load(Path(path), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


_SERIES = ("t", "H", "Hd", "T", "V", "E_d", "omega", "axis", "s", "tip")


# ---------------------------------------------------------------------------------------------
# the integrator
# ---------------------------------------------------------------------------------------------


def _n_steps(t_span, dt: float) -> tuple[int, float]:
    span = float(t_span[1]) - float(t_span[0])
    if not span > 0 or not dt > 0:
        raise ValueError("t_span must be increasing and dt positive")
    n = max(1, math.ceil(span / dt - 1e-9))
    return n, span / n


def integrate_full_order(
    structure: Structure,
    x_ref: np.ndarray,
    x0: np.ndarray,
    v0: np.ndarray,
    t_span: tuple[float, float],
    dt: float,
    *,
    model: ReducedModel | None = None,
    damping: bool = True,
    save_every: int = 1,
    hub: kin.HubDrive | None = None,
    spin_axis: np.ndarray | None = None,
    rotation_map: bool = True,
    energy_momentum: bool = True,
    newton_tol: float = 1e-11,
    max_newton: int = 40,
    checkpoint: Path | None = None,
    checkpoint_every: int = 1000,
    resume: bool = False,
    progress: Callable[[float], None] | None = None,
) -> FullOrderSolution:
    """Integrate ``M ẍ + f_d + f(x) = 0`` with the implicit midpoint from ``(x0, v0)`` (n,3).

    structure, x_ref (n,3): the FE model and its reference (inflated equilibrium) state; V is
    measured from x_ref and the body reference X is x_ref about its CoM (free) or the hub point.
    t_span (s): (t0, t1); the step is ``span / ceil(span/dt)``. model: the reduced model whose
    modes give the damping (its C) and the modal coordinates (None: no damping, N = 0).
    damping: apply the modal damping force. save_every: sample every so many steps (and the
    last). hub: prescribed rotation of the clamped DOFs (needed iff the structure has fixed
    DOFs; default for a clamped structure: a fixed clamp). spin_axis (3,): nominal spin axis in
    the initial body frame for the axis tracking (default: the minor axis of the initial
    inertia). newton_tol: relative (to the body size) Newton correction at convergence.
    max_newton: iterations per step. checkpoint: .npz path written every ``checkpoint_every``
    steps (atomic); ``resume``: continue from it (same t0, dt; the end may differ) — the result
    equals the uninterrupted run's (the factorisation is renewed after every checkpoint in both).
    rotation_map: map the initial state to the scheme's steady-rotation form and the sampled
    end states back for the diagnostics (free bodies; see the package docstring).
    energy_momentum: averaged-stress internal force (False: plain ``f(x½)``).
    progress(fraction). Raises :class:`FullOrderNewtonError` on a Newton failure; Ctrl-C returns
    what was computed with status 1."""
    start = time.perf_counter()
    n = structure.n
    x_ref = np.asarray(x_ref, float)
    tr = structure.translational.astype(float)
    if hub is None and not structure.is_free:
        hub = kin.HubDrive(angle=lambda t: (0.0, 0.0))
    if hub is not None and structure.is_free:
        raise ValueError("hub: the structure has no clamped DOFs to drive")
    point = None if hub is None else np.asarray(hub.point, float)
    origin_ref = centre_of_mass(structure, x_ref) if hub is None else point
    big_x = x_ref - np.outer(tr, origin_ref)
    if model is not None:
        if model.X.shape != big_x.shape or not np.allclose(model.X, big_x, atol=1e-9, rtol=0):
            raise ValueError("model: its reference X does not match x_ref of the structure")
    body = kin.make_body(structure.mass_scalar, structure.translational, big_x, model, hub is not None)
    c = None
    if damping and model is not None and model.n_modes and np.any(model.C):
        c = np.asarray(model.C, float)
    m_full = mass_matrix(structure).tocsc()
    free = structure.free_dofs
    n_steps, h = _n_steps(t_span, dt)
    t0 = float(t_span[0])
    scale = float(np.max(np.linalg.norm(big_x[tr > 0], axis=1)))
    tol = newton_tol * scale
    v_ref = strain_energy(structure, x_ref)
    ms = structure.mass_scalar
    fixed_rows = np.flatnonzero(structure.fixed.any(axis=1))

    def frame_at(tt: float, xh: np.ndarray) -> np.ndarray:
        if hub is not None:
            return hub.rotation(tt)
        return kin.best_fit_rotation(body, xh, kin.centre(body, xh))

    def prescribe(x1: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """Set the clamped components (hub frame) of x1 to the reference values."""
        if hub is None or not len(fixed_rows):
            return x1
        rel = x1 - np.outer(tr, point)
        z = rel[fixed_rows] @ rot
        z[structure.fixed[fixed_rows]] = big_x[fixed_rows][structure.fixed[fixed_rows]]
        x1 = x1.copy()
        x1[fixed_rows] = z @ rot.T + np.outer(tr[fixed_rows], point)
        return x1

    def force_d(tt: float, xh: np.ndarray, vh: np.ndarray) -> np.ndarray:
        if c is None:
            return np.zeros_like(xh)
        if hub is None:
            return damping_force(body, c, xh, vh)
        return damping_force(body, c, xh, vh, hub.rotation(tt), hub.angular_velocity(tt), point)

    # series accumulated at the samples
    series: dict[str, list] = {k: [] for k in _SERIES}
    axis_prev = None
    x, v = np.asarray(x0, float).copy(), np.asarray(v0, float).copy()
    step, e_d = 0, 0.0
    stats = {"n_newton": 0, "n_factor": 0}
    wall_before = 0.0
    resumed_frame = None
    ck = Path(checkpoint) if checkpoint is not None else None
    if resume and ck is not None and ck.is_file():
        data = read_checkpoint(ck)
        if int(data["n"]) != n or not math.isclose(float(data["dt"]), h, rel_tol=1e-12) or not (
            math.isclose(float(data["t0"]), t0, abs_tol=1e-12)
        ):
            raise ValueError(f"checkpoint {ck}: made for another model, t0 or time step")
        step = int(data["step"])
        x, v = data["x"].copy(), data["v"].copy()
        e_d = float(data["E_d_now"])
        axis_prev = data["axis_prev"].copy()
        resumed_frame = (data["prev_c"].copy(), data["prev_R"].copy(), data["prev_b"].copy())
        stats = {"n_newton": int(data["n_newton"]), "n_factor": int(data["n_factor"])}
        wall_before = float(data["wall_s"])
        for k in _SERIES:
            if f"series_{k}" in data:
                series[k] = list(data[f"series_{k}"])
        if step > n_steps:
            raise ValueError(f"checkpoint {ck}: already past the end of t_span")

    def record(tt: float, xs: np.ndarray, vs: np.ndarray) -> None:
        nonlocal axis_prev
        rs = xs - np.outer(tr, kin.centre(body, xs))
        series["Hd"].append(cross_form(rs.T @ (ms @ vs)))
        if mapped:
            xs, vs = kin.to_physical_rotation(body, xs, vs, h, not energy_momentum)
        rot = hub.rotation(tt) if hub is not None else None
        om = hub.angular_velocity(tt) if hub is not None else None
        smp = kin.sample(body, xs, vs, rot, point, om)
        if axis_prev is None:
            if spin_axis is None:
                axis_prev = kin.minor_axis(smp.inertia)
            else:
                r0 = rot if rot is not None else kin.best_fit_rotation(body, xs, kin.centre(body, xs))
                axis_prev = r0 @ (np.asarray(spin_axis, float) / np.linalg.norm(spin_axis))
        axis_prev = kin.track(smp.inertia, axis_prev)
        series["axis"].append(axis_prev)
        series["t"].append(tt)
        series["H"].append(smp.H)
        series["T"].append(smp.T)
        series["V"].append(strain_energy(structure, xs) - v_ref)
        series["E_d"].append(e_d)
        series["omega"].append(smp.omega)
        series["s"].append(smp.s)
        series["tip"].append(smp.tip if smp.tip is not None else np.full(3, np.nan))

    mapped = rotation_map and hub is None
    if step == 0 and not series["t"]:
        if mapped:
            x, v = kin.to_discrete_rotation(body, x, v, h, not energy_momentum)
        record(t0, x, v)
    fac: _Factor | None = None
    frame_prev = resumed_frame
    status, message = 0, "ok"
    report = max(1, n_steps // 100)
    try:
        while step < n_steps:
            t_now = t0 + step * h
            t1 = t0 + (step + 1) * h
            frame_now = body_frame(body, x, hub, t_now)
            if frame_prev is None:  # first step (or after a resume): straight-line predictor
                x1 = x + h * v
            else:
                x1 = extrapolate(body, frame_prev, frame_now, hub, t1)
            xh = 0.5 * (x + x1)
            rot = frame_at(t1, xh)
            x1 = prescribe(x1, rot)
            strain0 = step_strains(structure, x) if energy_momentum else None

            def residual(y, x=x, v=v, t_now=t_now, strain0=strain0):
                """``(v½, r, f_d)`` of the step x → y (r in N, (n,3))."""
                yh, vh_ = 0.5 * (x + y), (y - x) / h
                fd_ = force_d(t_now + 0.5 * h, yh, vh_)
                if energy_momentum:
                    f_int = step_force(structure, x, y, strain0)
                else:
                    f_int = internal_force(structure, yh)
                return vh_, (2.0 / h) * (ms @ (vh_ - v)) + f_int + fd_, fd_

            since = math.inf  # Newton iterations since the last factorisation
            if fac is None:
                fac = _Factor(structure, m_full, x @ rot, x1 @ rot, h, free, energy_momentum)
                stats["n_factor"] += 1
                since = 0
            prev, nd, ok = None, math.inf, False
            memo: list = [None, None]  # the last residual evaluated (by the line search)

            def residual_at(y, memo=memo, residual=residual):
                if memo[0] is not y:
                    memo[0], memo[1] = y, residual(y)
                return memo[1]

            for _ in range(max_newton):
                vh, r, fd = residual_at(x1)
                rb = (r @ rot).ravel()[free]
                dz = np.zeros(3 * n)
                dz[free] = -(0.5 * h * h) * fac.solve(rb)
                dx = dz.reshape(n, 3) @ rot.T
                if float(np.max(np.abs(dx))) > LINE_SEARCH * scale:
                    # far from the solution (a violent transient): backtrack on the residual
                    alpha, trial = _line_search(
                        lambda y: float(np.linalg.norm(residual_at(y)[1])), x1, dx,
                        float(np.linalg.norm(r)),
                    )  # fmt: skip
                    dx = alpha * dx
                    x1 = trial if trial is not None else x1 + dx
                else:
                    x1 = x1 + dx
                stats["n_newton"] += 1
                since += 1
                nd = float(np.max(np.abs(dx)))
                if not np.isfinite(nd):
                    break
                if nd <= tol:
                    ok = True
                    break
                if prev is not None and nd > RHO_REFACTOR * prev and since >= 2:
                    # the frozen matrix no longer contracts well: renew it at this iterate
                    fac = _Factor(structure, m_full, x @ rot, x1 @ rot, h, free, energy_momentum)
                    stats["n_factor"] += 1
                    since, prev = 0, None
                    continue
                prev = nd
            if not ok:
                raise FullOrderNewtonError(
                    step + 1, t1, nd / scale, ck if ck is not None and ck.is_file() else None
                )
            v1 = 2.0 * vh - v
            if hub is not None:  # dissipated: f_d's work on the motion relative to the hub
                rel = 0.5 * (x + x1) - np.outer(tr, point)
                vh = vh - np.cross(hub.angular_velocity(t_now + 0.5 * h), rel)
            e_d += h * float(np.sum(vh * fd))
            x, v = x1, v1
            frame_prev = frame_now
            step += 1
            if step % save_every == 0 or step == n_steps:
                record(t1, x, v)
            if ck is not None and step % checkpoint_every == 0 and step < n_steps:
                data = {
                    "version": CHECKPOINT_VERSION, "n": n, "dt": h, "t0": t0, "step": step,
                    "x": x, "v": v, "E_d_now": e_d, "axis_prev": axis_prev,
                    "n_newton": stats["n_newton"], "n_factor": stats["n_factor"],
                    "wall_s": wall_before + time.perf_counter() - start,
                }  # fmt: skip
                for k in _SERIES:
                    data[f"series_{k}"] = np.asarray(series[k])
                for k, arr in zip(("prev_c", "prev_R", "prev_b"), frame_prev, strict=True):
                    data[k] = arr  # the predictor's history
                write_checkpoint(ck, data)
                fac = None  # the same factorisation history with and without a resume
            if progress and (step % report == 0 or step == n_steps):
                progress(step / n_steps)
    except KeyboardInterrupt:
        status, message = 1, f"interrupted at t = {t0 + step * h:.6g} s"
        if not series["t"] or series["t"][-1] != t0 + step * h:
            record(t0 + step * h, x, v)
    wall = wall_before + time.perf_counter() - start
    return _solution(series, status, message, h, dict(stats, n_steps=step, wall_s=wall), hub)


def _solution(series, status, message, dt, stats, hub) -> FullOrderSolution:
    """Assemble the :class:`FullOrderSolution` from the sampled series (axis tracking here)."""
    t = np.asarray(series["t"], float)
    big_h = np.asarray(series["H"], float).reshape(-1, 3)
    h_disc = np.asarray(series["Hd"], float).reshape(-1, 3)
    t_kin = np.asarray(series["T"], float)
    v_pot = np.asarray(series["V"], float)
    e_d = np.asarray(series["E_d"], float)
    omega = np.asarray(series["omega"], float).reshape(-1, 3)
    axis = np.asarray(series["axis"], float).reshape(-1, 3)
    s = np.asarray(series["s"], float).reshape(len(t), -1)
    hn = np.linalg.norm(big_h, axis=1)
    cross = np.linalg.norm(np.cross(big_h, axis), axis=1)
    cone = np.arctan2(cross, np.abs(np.sum(big_h * axis, axis=1)))
    steps = max(int(stats.get("n_steps", 0)), 1)
    stats = dict(stats)
    stats["newton_per_step"] = stats.get("n_newton", 0) / steps
    stats["factor_per_step"] = stats.get("n_factor", 0) / steps
    return FullOrderSolution(
        t=t,
        H=big_h,
        H_norm=hn,
        H_discrete=h_disc,
        T=t_kin,
        V=v_pot,
        E=t_kin + v_pot,
        E_d=e_d,
        spin_rate=np.sum(omega * axis, axis=1),
        cone_angle=cone,
        axis=axis,
        modal_coordinates=s,
        tip=np.asarray(series["tip"], float).reshape(-1, 3) if hub is not None else None,
        status=status,
        message=message,
        dt=dt,
        stats=stats,
    )
