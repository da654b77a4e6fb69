"""Kane–Ryan–Banerjee spin-up of a hub-clamped cantilever with the reduced model.

The hub turns about the inertial (and hub-fixed) z axis with the prescribed rate

    Ω(t) = (Ωs/T) [t − (T/2π) sin(2πt/T)]   for t ≤ T,      Ω(t) = Ωs  for t > T,

so that ω(t) = (0, 0, Ω(t)) in the hub (body) frame. The beam lies along +x from the hub point
(hub radius 0, X measured from the axis: ``ReducedModel.free is False``), so the deflection *in
the plane of rotation* is the hub-frame y component of the tip displacement and the tip *lags*
(v < 0) while the hub accelerates. The reduced modal equation (theory.md §4, prescribed rotation)

    μ s̈ + (Γ(ω) + C) ṡ + (Λ − ωᵀJ2ω) s = ½ ωᵀJ1ω − A(s) ω̇

is integrated with :func:`quadmodes.rom.dynamics.prescribed_rhs` and scipy's DOP853. The tip
displacement is rebuilt from both terms of the quadratic-mode kinematics,
``U = Σ s_k u^k + Σ s_m s_n g^{mn}`` (the g term is the axial foreshortening of the bent beam).

Mode choice (theory.md §5 "Which modes"): only the soft *bending* modes in the plane of rotation
(hub-frame y) are kept by default. The out-of-plane (z) bending modes are inert under a rotation
about z (no centrifugal, Coriolis or ω̇ coupling to the y modes; they can be added with
``out_of_plane=True`` and stay at zero), and stiff axial modes are *not* added: their products
with the bending coordinates are not small (theory §5) and the stretching that matters is
already represented quasi-statically by g. The clamped ANCF eigenvectors of a symmetric section
come in degenerate y/z pairs that the eigensolver returns as arbitrary mixtures; each degenerate
set is rotated into pure in-plane and out-of-plane members before selection. The model is built
by :func:`quadmodes.models.beam.kane_model` (with :func:`~quadmodes.models.beam.split_planes`).

Kane's parameters are function arguments with the published defaults (references.md §3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from quadmodes.models.beam import kane_model
from quadmodes.rom.dynamics import prescribed_rhs
from quadmodes.rom.reduced import ReducedModel
from quadmodes.rom.system import reduced_system

#: In-plane (y) tip-deflection peaks of the published solution: Ωs (rad/s) → (v m, t s).
KANE_REFERENCE_PEAKS = {4.0: (-0.400, 6.95), 6.0: (-0.574, 6.76), 10.0: (-0.860, 6.45)}

#: Chordwise first rotating-frame frequency at steady spin: Ωs (rad/s) → ω (rad/s).
KANE_REFERENCE_CHORDWISE = {4.0: 4.158, 6.0: 4.513, 10.0: 5.298}


# ---------------------------------------------------------------------------------------------
# hub motion
# ---------------------------------------------------------------------------------------------


def kane_rate(t, omega_s: float = 6.0, t_ramp: float = 15.0):
    """Hub rate Ω(t) (rad/s) and its derivative Ω̇(t) (rad/s²) of the Kane spin-up profile.

    ``t`` scalar or array (s). Ω̇ and Ω̈ vanish at t = 0 and t = T, so the ramp is smooth."""
    t = np.asarray(t, float)
    ramp = t <= t_ramp
    a = 2.0 * np.pi / t_ramp
    rate = np.where(ramp, (omega_s / t_ramp) * (t - np.sin(a * t) / a), omega_s)
    acc = np.where(ramp, (omega_s / t_ramp) * (1.0 - np.cos(a * t)), 0.0)
    if rate.ndim == 0:
        return float(rate), float(acc)
    return rate, acc


# ---------------------------------------------------------------------------------------------
# tip of the model (:func:`quadmodes.models.beam.kane_model`)
# ---------------------------------------------------------------------------------------------


def tip_index(model: ReducedModel) -> int:
    """Index of the tip position DOF (largest |X| among positions)."""
    r = np.where(model.translational, np.linalg.norm(model.X, axis=1), -np.inf)
    return int(np.argmax(r))


def tip_displacement(model: ReducedModel, s: np.ndarray, quadratic: bool = True) -> np.ndarray:
    """Hub-frame tip displacement U_tip (..., 3) m for modal coordinates s (..., N):
    ``Σ s_k u^k + Σ s_m s_n g^{mn}`` (the second term only with ``quadratic``)."""
    i = tip_index(model)
    s = np.asarray(s, float)
    u = s @ model.Phi[:, i, :]
    if quadratic:
        u = u + np.einsum("...m,...n,mna->...a", s, s, model.G[:, :, i, :])
    return u


# ---------------------------------------------------------------------------------------------
# simulation
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SpinupResult:
    """Kane spin-up run (SI).

    time (nt,) s; rate (nt,) hub rate Ω rad/s; s, sdot (nt, N) modal coordinates (√kg·m, /s);
    tip (nt, 3) hub-frame tip displacement U_tip (m): [axial x, in-plane y (= v), out-of-plane z].
    peak_deflection (m, signed) and peak_time (s): the extreme in-plane tip deflection (largest
    |v|, refined on the dense solution; for a diverged run, the last value before the stop). after_ramp_max (m): max |v| for t > T.
    status: "ok", "diverged" (|U_tip| passed ``blowup`` × L or became non-finite: the run was
    stopped there) or "failed" (integrator error); message explains.
    A spin change of a free body on a hub (:mod:`quadmodes.runs.spin_change`) also has omega_0
    (rad/s, the spin before the change; 0 for Kane's spin-up from rest), settling_time (s, when
    |v| stays within 5 % of its peak; NaN: not within the run) and omega (nt, 3) rad/s the
    frame's angular velocity; its ``rate`` is the hub's own spin rate.
    """

    omega_s: float
    t_ramp: float
    formulation: str
    time: np.ndarray
    rate: np.ndarray
    s: np.ndarray
    sdot: np.ndarray
    tip: np.ndarray
    peak_deflection: float
    peak_time: float
    after_ramp_max: float
    status: str
    message: str
    model: ReducedModel = field(repr=False)
    n_steps: int = 0
    omega_0: float = 0.0
    settling_time: float = math.nan
    omega: np.ndarray | None = field(default=None, repr=False)

    @property
    def diverged(self) -> bool:
        return self.status != "ok"

    @property
    def tip_inplane(self) -> np.ndarray:
        """In-plane tip deflection v (nt,) m (hub-frame y)."""
        return self.tip[:, 1]

    @property
    def tip_outofplane(self) -> np.ndarray:
        """Out-of-plane tip deflection (nt,) m (hub-frame z)."""
        return self.tip[:, 2]

    @property
    def tip_axial(self) -> np.ndarray:
        """Axial tip displacement (nt,) m (hub-frame x; the foreshortening)."""
        return self.tip[:, 0]


@dataclass(frozen=True, eq=False)
class _Pieces:
    """DOP853 solutions of the consecutive pieces of a spin-up (dense output), how it ended
    ("ok", "diverged" or "failed", with a message) and the number of accepted output times."""

    sols: list
    status: str
    message: str
    n_steps: int

    def state(self, t) -> np.ndarray:
        """State [s, ṡ] (nt, 2N) at times ``t`` (s) from the dense outputs of the pieces."""
        t = np.atleast_1d(np.asarray(t, float))
        out = np.empty((t.size, self.sols[0].y.shape[0]))
        for k, sol in enumerate(self.sols):
            lo, hi = sol.t[0], sol.t[-1]
            sel = (t >= lo) & (t <= hi) if k == 0 else (t > lo) & (t <= hi)
            if np.any(sel):
                out[sel] = sol.sol(t[sel]).T
        return out


def _integrate_pieces(
    sys, model: ReducedModel, omega_s, t_ramp, duration, formulation, rtol, atol, blowup
) -> _Pieces:
    """DOP853 from rest through the ramp (0 … T) and the steady spin (T … ``duration``), with
    a terminal event when |U_tip| exceeds ``blowup`` × (beam length)."""
    n = sys.n_modes
    length = float(np.max(np.linalg.norm(model.X[model.translational], axis=1)))
    limit = blowup * length

    def omega(t):
        return np.array([0.0, 0.0, kane_rate(t, omega_s, t_ramp)[0]])

    def omega_dot(t):
        return np.array([0.0, 0.0, kane_rate(t, omega_s, t_ramp)[1]])

    def fun(t, y):
        return prescribed_rhs(sys, t, y, omega, omega_dot)

    def blown(t, y):
        s = y[:n]
        if not np.all(np.isfinite(s)):
            return -1.0
        return limit - float(np.linalg.norm(tip_displacement(model, s)))

    blown.terminal = True
    blown.direction = -1

    # the profile is C² but its third derivative jumps at t = T: integrate in two pieces
    y0 = np.zeros(2 * n)
    pieces = [(0.0, min(t_ramp, duration))]
    if duration > t_ramp:
        pieces.append((t_ramp, duration))
    sols, status, message, n_steps = [], "ok", "completed", 0
    for t0, t1 in pieces:
        with np.errstate(over="ignore", invalid="ignore"):
            sol = solve_ivp(
                fun, (t0, t1), y0, method="DOP853", rtol=rtol, atol=atol, dense_output=True,
                events=blown,
            )  # fmt: skip
        n_steps += sol.t.size
        sols.append(sol)
        if sol.status == 1:
            te = float(sol.t_events[0][0])
            status = "diverged"
            message = (
                f"formulation {formulation}: tip displacement exceeded {blowup:g} × L "
                f"= {limit:g} m at t = {te:.3f} s (Ω = {kane_rate(te, omega_s, t_ramp)[0]:.3f}"
                " rad/s); stopped"
            )
            break
        if sol.status < 0 or not np.all(np.isfinite(sol.y[:, -1])):
            status = "diverged" if not np.all(np.isfinite(sol.y)) else "failed"
            message = f"formulation {formulation}: integrator stopped: {sol.message}"
            break
        y0 = sol.y[:, -1]
    return _Pieces(sols, status, message, n_steps)


def _inplane_peak(model: ReducedModel, n: int, pieces: _Pieces, time: np.ndarray, v: np.ndarray):
    """(time s, value m) of the largest |v| of the in-plane tip deflection ``v`` sampled at
    ``time``, refined on the dense solution of the ``n`` modal coordinates for a completed run
    (bounded scalar search)."""
    k = int(np.nanargmax(np.abs(v)))
    peak_t, peak_v = float(time[k]), float(v[k])
    if pieces.status == "ok" and 0 < k < time.size - 1:
        sign = math.copysign(1.0, peak_v)
        res = minimize_scalar(
            lambda tt: -sign * tip_displacement(model, pieces.state(tt)[0, :n])[1],
            bounds=(time[k - 1], time[k + 1]),
            method="bounded",
            options={"xatol": 1e-6},
        )
        peak_t, peak_v = float(res.x), float(-sign * res.fun)
    return peak_t, peak_v


def kane_spinup(
    omega_s: float = 6.0,
    t_ramp: float = 15.0,
    duration: float = 30.0,
    n_modes: int = 4,
    formulation: str = "Q",
    model: ReducedModel | None = None,
    n_elements: int = 20,
    out_of_plane: bool = False,
    rtol: float = 1e-9,
    atol: float = 1e-11,
    n_out: int = 3001,
    blowup: float = 100.0,
    **beam,
) -> SpinupResult:
    """Kane spin-up 0 → ``omega_s`` (rad/s) in ``t_ramp`` (s), run to ``duration`` (s).

    ``formulation``: "Q" (quadratic modes, spin stiffening through J2g) or "L" (linear modes,
    no stiffening: diverges for Ωs above the first bending frequency, 3.80 rad/s). ``model``: a
    clamped :class:`ReducedModel` (X from the hub point); default :func:`kane_model` with
    ``n_modes`` in-plane bending modes on ``n_elements`` cable elements; ``beam``: beam data
    overriding :data:`~quadmodes.models.beam.KANE_BEAM` (``length``, ``youngs_modulus``, …). Integration: DOP853 with
    ``rtol``/``atol``; a terminal event stops the run cleanly when |U_tip| exceeds
    ``blowup`` × (beam length); output on ``n_out`` uniform times."""
    if model is None:
        model = kane_model(n_modes, n_elements, out_of_plane, **beam)
    if model.free:
        raise ValueError("kane_spinup: the model must be clamped to the hub (free=False)")
    sys = reduced_system(model, formulation)
    n = sys.n_modes
    pieces = _integrate_pieces(
        sys, model, omega_s, t_ramp, duration, formulation, rtol, atol, blowup
    )
    t_end = float(pieces.sols[-1].t[-1])
    time = np.linspace(0.0, t_end, max(2, int(round(n_out * t_end / duration))))
    y = pieces.state(time)
    s, sd = y[:, :n], y[:, n:]
    tip = tip_displacement(model, s)
    v = tip[:, 1]
    peak_t, peak_v = _inplane_peak(model, n, pieces, time, v)
    after = v[time > t_ramp]
    after_max = float(np.max(np.abs(after))) if after.size else float("nan")
    return SpinupResult(
        omega_s=float(omega_s),
        t_ramp=float(t_ramp),
        formulation=formulation,
        time=time,
        rate=kane_rate(time, omega_s, t_ramp)[0],
        s=s,
        sdot=sd,
        tip=tip,
        peak_deflection=peak_v,
        peak_time=peak_t,
        after_ramp_max=after_max,
        status=pieces.status,
        message=pieces.message,
        model=model,
        n_steps=pieces.n_steps,
    )
