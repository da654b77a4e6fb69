"""A spin-rate change of a free body on a hub (a heliogyro's blades on their hub) with the
reduced model about the spinning state.

The hub is driven by a torque about its own spin axis (a motor or thrusters on the hub), shaped
so that the whole body's spin follows Kane's smooth profile from Ω₀ to Ω_s in T (s):

    Ω(t) = Ω₀ + (ΔΩ/T) [t − (T/2π) sin(2πt/T)],   τ(t) = J_e Ω̇(t) = J_e (ΔΩ/T)(1 − cos 2πt/T),

J_e = eᵀJ₀e the body's moment about the spin axis e at the reference state (so the axial angular
momentum changes by exactly J_e ΔΩ). The body is free: the blades lag behind the accelerating hub
and the hub's own rate departs from Ω(t) by the lag dynamics. Equations: the free body's reduced
Euler–Poincaré equations (:func:`quadmodes.rom.dynamics.generalised_system`) with the torque's
generalised forces. The hub's axes a₁, a₂, a₃ are vector DOFs of the structure (:mod:`quadmodes.
fe.hub`, indices 1–3); a torque τ on a rigid triad is the forces f_i = ½ τ × a_i on its axes
(Σ a_i × f_i = τ for orthonormal axes), so the modal force is Q_k = Σ_i f_i · ∂a_i/∂s_k
(∂a/∂s_k = u^k + 2 Σ_m s_m g^{km} with the quadratic modes) and the frame's torque Σ a_i × f_i.

Modes: the reduced model's frame obeys the mean-axes conditions, so no mode carries angular
momentum about e and only modes that turn the hub relative to the frame are driven by the hub's
torque — for a symmetric flat rotor the collective in-plane (lag) modes. Out-of-plane (flap,
twist) modes are inert by the mirror symmetry of a flat body spun about its normal (as the Kane
beam's out-of-plane modes, :mod:`quadmodes.runs.spinup`). ``reduced.modes = N`` keeps the lowest
N modes of the rotating-frame stiffness the hub turns in (:func:`driven_modes`); the blades'
lowest modes (flap, twist) are not among them.

Outputs in the hub's frame (:func:`hub_frame_tip`): the blade tip's displacement relative to the
hub (radial, in-plane v — negative: lagging —, out-of-plane) averaged over the nodes of the tip
edge of the blade farthest along the first direction, and the hub's own spin rate.

SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.integrate import solve_ivp

from quadmodes.rom.dynamics import generalised_system
from quadmodes.rom.reduced import ReducedModel
from quadmodes.rom.system import reduced_system
from quadmodes.runs.spinup import SpinupResult

#: Vector DOFs of the hub's axes a₁, a₂, a₃ in a structure with a hub (c is 0).
HUB_AXES = slice(1, 4)
#: A mode is driven by the hub's torque when the hub's rotation about the spin axis in it is
#: above this fraction of the body's rigid rotation (others: round-off, ~1e-12 of it).
DRIVEN_RATIO = 1e-6
#: The response has settled once |v| stays below this fraction of its peak.
SETTLING_FRACTION = 0.05


def spin_profile(t, omega_0: float, omega_s: float, t_ramp: float):
    """(Ω(t), Ω̇(t)) rad/s, rad/s² of the smooth change Ω₀ → Ω_s in ``t_ramp`` s (Kane's profile
    shifted by Ω₀; Ω̇ and Ω̈ vanish at 0 and T), scalar or array ``t`` (s)."""
    t = np.asarray(t, float)
    d, a = omega_s - omega_0, 2.0 * np.pi / t_ramp
    ramp = t <= t_ramp
    rate = np.where(ramp, omega_0 + (d / t_ramp) * (t - np.sin(a * t) / a), omega_s)
    acc = np.where(ramp, (d / t_ramp) * (1.0 - np.cos(a * t)), 0.0)
    return (float(rate), float(acc)) if rate.ndim == 0 else (rate, acc)


def hub_rotation(x_axes: np.ndarray, shapes: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Rotation (k,) of the hub about ``e`` (3,) in each of the shapes (k, n, 3) whose hub axes
    are ``x_axes`` (3, 3) (rows a₁, a₂, a₃): ½ Σ_i (a_i × δa_i)·e (the small rotation of a
    triad)."""
    da = np.asarray(shapes, float)[:, HUB_AXES, :]
    return 0.5 * np.einsum("kia,a->k", np.cross(np.asarray(x_axes, float)[None], da), e)


def driven_modes(x_axes, shapes, e, n_modes: int, moment: float) -> np.ndarray:
    """Indices of the lowest ``n_modes`` of ``shapes`` (k, n, 3) the hub's torque about ``e``
    drives: the hub turns about ``e`` in them by more than :data:`DRIVEN_RATIO` of a rigid
    rotation of the whole body (1/√J_e for a mass-normalised mode, ``moment`` = J_e kg m²);
    fewer if the candidates hold fewer."""
    rot = np.abs(hub_rotation(x_axes, shapes, e))
    return np.flatnonzero(rot > DRIVEN_RATIO / math.sqrt(moment))[:n_modes]


def check_hub(model: ReducedModel) -> None:
    """ValueError unless vector DOFs 1–3 of ``model`` are the hub's axes (unit directions)."""
    tr = np.asarray(model.translational, bool)
    ok = tr.size > 4 and tr[0] and not tr[HUB_AXES].any()
    norms = np.linalg.norm(np.asarray(model.X)[HUB_AXES], axis=1) if ok else np.zeros(3)
    if not ok or not np.allclose(norms, 1.0, atol=1e-3):
        raise ValueError("a spin change is applied by a torque on the hub: the model has no hub "
                         "(give the model case a [hub])")  # fmt: skip


def tip_nodes(model: ReducedModel, e: np.ndarray) -> np.ndarray:
    """Indices of the tip edge of one blade: the positions within 1 % of the largest distance
    from the spin axis ``e`` and within 0.1 rad of the azimuth of the farthest one, excluding
    the hub's DOFs."""
    x = np.asarray(model.X, float)
    r = x - np.outer(x @ e, e)
    rad = np.where(model.translational, np.linalg.norm(r, axis=1), -np.inf)
    rad[:4] = -np.inf
    far = int(np.argmax(rad))
    cosang = (r @ r[far]) / np.maximum(rad * rad[far], 1e-300)
    return np.flatnonzero((rad >= 0.99 * rad[far]) & (cosang >= math.cos(0.1)))


def _positions(model: ReducedModel, s: np.ndarray, idx, quadratic: bool) -> np.ndarray:
    """Vector DOFs ``idx`` at modal coordinates s (k, N): (k, len(idx), 3)."""
    x = model.X[idx] + np.einsum("km,mia->kia", s, model.Phi[:, idx, :])
    if quadratic:
        x = x + np.einsum("km,kn,mnia->kia", s, s, model.G[:, :, idx, :])
    return x


def hub_frame_tip(model: ReducedModel, s: np.ndarray, e: np.ndarray, quadratic: bool = True):
    """Tip displacement relative to the hub (k, 3) m for s (k, N): the mean over :func:`tip_nodes`
    of the hub-frame coordinates' change, on (radial, in-plane tangential e × radial, e)."""
    s = np.atleast_2d(s)
    tips = tip_nodes(model, e)
    c = _positions(model, s, [0], quadratic)[:, 0]
    axes = _positions(model, s, [1, 2, 3], quadratic)  # rows a_i
    pts = _positions(model, s, tips, quadratic) - c[:, None, :]
    xi = np.linalg.solve(np.swapaxes(axes, 1, 2)[:, None], pts[..., None])[..., 0].mean(axis=1)
    xi0 = np.linalg.solve(np.asarray(model.X[1:4]).T, (model.X[tips] - model.X[0]).T).T.mean(0)
    e_hub = np.linalg.solve(np.asarray(model.X[1:4]).T, e)
    radial = xi0 - (xi0 @ e_hub) * e_hub
    radial /= np.linalg.norm(radial)
    basis = np.stack([radial, np.cross(e_hub, radial), e_hub])
    return (xi - xi0) @ basis.T


def _generalised_torque(model: ReducedModel, s, tau: float, e_hub, quadratic: bool):
    """(frame torque (3,), modal force (N,)) of a torque ``tau`` (N m) about the hub's own axis
    (hub-frame components ``e_hub``) at s (N,)."""
    phi = model.Phi[:, HUB_AXES, :]  # (N, 3, 3)
    a = model.X[HUB_AXES] + np.einsum("m,mia->ia", s, phi)
    da = phi
    if quadratic:
        gs = np.einsum("m,kmia->kia", s, model.G[:, :, HUB_AXES, :])
        a = a + np.einsum("k,kia->ia", s, gs)
        da = phi + 2.0 * gs
    tvec = tau * (e_hub @ a)
    f = 0.5 * np.cross(tvec[None, :], a)  # forces on a_i (3, 3)
    return np.cross(a, f).sum(axis=0), np.einsum("ia,kia->k", f, da)


def hub_rate(model: ReducedModel, w, s, sd, e_hub, quadratic: bool = True) -> np.ndarray:
    """Spin rate (k,) rad/s of the hub about its own axis: (ω + ½ Σ a_i × ȧ_i)·a_e."""
    phi = model.Phi[:, HUB_AXES, :]
    a = model.X[HUB_AXES] + np.einsum("tm,mia->tia", s, phi)
    adot = np.einsum("tm,mia->tia", sd, phi)
    if quadratic:
        g = model.G[:, :, HUB_AXES, :]
        a = a + np.einsum("tm,tn,mnia->tia", s, s, g)
        adot = adot + 2.0 * np.einsum("tm,tn,mnia->tia", sd, s, g)
    rel = 0.5 * np.cross(a, adot).sum(axis=1)
    return np.einsum("ta,ta->t", w + rel, np.einsum("i,tia->ta", e_hub, a))


def settling_time(time, v, t_ramp: float, fraction: float = SETTLING_FRACTION) -> float:
    """First time ≥ ``t_ramp`` after which |v| stays within ``fraction`` of its peak |v|
    (s; NaN if it never does before the end)."""
    peak = float(np.max(np.abs(v))) if len(v) else 0.0
    if peak == 0.0:
        return float(t_ramp)
    out = np.flatnonzero((np.abs(v) > fraction * peak) | (time < t_ramp))
    if not out.size:
        return float(t_ramp)
    k = int(out[-1])
    return math.nan if k == len(time) - 1 else float(max(time[k + 1], t_ramp))


def spin_change(
    model: ReducedModel, omega_0: float, omega_s: float, t_ramp: float, duration: float,
    formulation: str = "Q", rtol: float = 1e-9, atol: float = 1e-11, n_out: int = 3001,
) -> SpinupResult:  # fmt: skip
    """The hub-torque spin change Ω₀ → Ω_s (rad/s) in ``t_ramp`` (s) of the free ``model`` (about
    its spinning state, with a hub), integrated with DOP853 to ``duration`` (s) from the relative
    equilibrium s = 0 at Ω₀ (the model's own reference when Ω₀ is its reference spin).

    Returns a :class:`~quadmodes.runs.spinup.SpinupResult`: ``rate`` the hub's spin rate,
    ``tip`` the blade tip's displacement relative to the hub (radial, in-plane v, out-of-plane;
    :func:`hub_frame_tip`), the peak of v and its time, max |v| after the ramp, the settling time
    (:func:`settling_time`) and ``omega`` (nt, 3) the frame's angular velocity."""
    check_hub(model)
    sys = reduced_system(model, formulation)
    n, quad = sys.n_modes, formulation != "L"
    e = np.asarray(model.reference_axis, float)
    e = e / np.linalg.norm(e)
    e_hub = np.linalg.solve(np.asarray(model.X[HUB_AXES]).T, e)
    j_e = float(e @ model.J0 @ e)

    def fun(t, y):
        w, s, sd = y[:3], y[3 : 3 + n], y[3 + n :]
        tau = j_e * spin_profile(t, omega_0, omega_s, t_ramp)[1]
        frame, force = _generalised_torque(model, s, tau, e_hub, quad)
        m, b = generalised_system(sys, s, w, sd, torque=frame, force=force)
        dnu = np.linalg.solve(m, b)
        return np.concatenate([dnu[:3], sd, dnu[3:]])

    y0 = np.concatenate([omega_0 * e, np.zeros(2 * n)])
    sols, t0 = [], 0.0
    for t1 in (min(t_ramp, duration), duration):  # Ω⃛ jumps at T: two pieces
        if t1 <= t0:
            continue
        sol = solve_ivp(fun, (t0, t1), y0, method="DOP853", rtol=rtol, atol=atol,
                        dense_output=True)  # fmt: skip
        sols.append(sol)
        if sol.status < 0:
            break
        y0, t0 = sol.y[:, -1], t1
    return _result(model, sols, omega_0, omega_s, t_ramp, duration, formulation, n_out, e, e_hub)


def _result(model, sols, omega_0, omega_s, t_ramp, duration, formulation, n_out, e, e_hub):
    """The :class:`SpinupResult` of the DOP853 pieces ``sols``."""
    n = model.n_modes
    t_end = float(sols[-1].t[-1])
    time = np.linspace(0.0, t_end, max(2, int(round(n_out * t_end / duration))))
    y = np.empty((time.size, 3 + 2 * n))
    for k, sol in enumerate(sols):
        sel = (time >= sol.t[0]) & (time <= sol.t[-1]) if k == 0 else (time > sol.t[0]) & (
            time <= sol.t[-1])
        y[sel] = sol.sol(time[sel]).T
    w, s, sd = y[:, :3], y[:, 3 : 3 + n], y[:, 3 + n :]
    quad = formulation != "L"
    tip = hub_frame_tip(model, s, e, quad)
    v = tip[:, 1]
    k = int(np.argmax(np.abs(v)))
    after = v[time > t_ramp]
    ok = all(sol.status == 0 for sol in sols) and t_end >= duration * (1 - 1e-12)
    status, message = ("ok", "completed") if ok else ("failed", f"integrator stopped: "
                                                      f"{sols[-1].message}")  # fmt: skip
    return SpinupResult(
        omega_s=float(omega_s), t_ramp=float(t_ramp), formulation=formulation, time=time,
        rate=hub_rate(model, w, s, sd, e_hub, quad), s=s, sdot=sd, tip=tip,
        peak_deflection=float(v[k]), peak_time=float(time[k]),
        after_ramp_max=float(np.max(np.abs(after))) if after.size else math.nan,
        status=status, message=message, model=model,
        n_steps=int(sum(sol.t.size for sol in sols)), omega_0=float(omega_0),
        settling_time=settling_time(time, v, t_ramp), omega=w,
    )  # fmt: skip


#: Mode counts searched for the driven modes, in turn (the last: every mode the solver gives).
SEARCH_COUNTS = (60, 240, 960)


def spin_change_model(case, n_modes: int, spin: float, progress=None) -> ReducedModel:
    """The reduced model of a free body on a hub (``case`` with a ``[hub]``) about its spinning
    state at ``spin`` (rad/s) about its major axis (a flat membrane: its normal) with the lowest
    ``n_modes`` driven modes (:func:`driven_modes`) of the rotating-frame stiffness, searched in
    the lowest :data:`SEARCH_COUNTS` modes. ValueError naming the field when the case has no
    hub or too few modes are driven."""
    from quadmodes.fe.model import inertia_tensor
    from quadmodes.models.build import _spinning_modes_of, damping_ratio_of, modal_model_for
    from quadmodes.rom.spinning_reduction import reduce_spinning

    if getattr(case, "hub", None) is None:
        raise ValueError(f'model = "{case.name}": a spin change is a torque on the hub; the model '
                         "needs a [hub] (e.g. heliogyro-blade, string-blade-rotor)")  # fmt: skip
    modal = modal_model_for(case, 1, progress)
    for count in SEARCH_COUNTS:
        eq, modes, labels = _spinning_modes_of(modal, count, spin, "major")
        e = np.asarray(eq.axis, float)
        j_e = float(e @ inertia_tensor(modal.structure, eq.x) @ e)
        idx = driven_modes(eq.x[HUB_AXES], modes.shapes, e, n_modes, j_e)
        if len(idx) >= n_modes or len(modes.frequencies_hz) < count:
            break
    if len(idx) < n_modes:
        raise ValueError(f"reduced.modes = {n_modes}: only {len(idx)} of the lowest "
                         f"{len(modes.frequencies_hz)} modes are driven by the hub's torque; "
                         f"use reduced.modes = {max(len(idx), 1)}")  # fmt: skip
    return reduce_spinning(
        modal.structure, modal.x, eq, modes.frequencies_hz[idx], modes.shapes[idx],
        [labels[i] for i in idx], damping_ratio_of(case), progress,
        {"case": case.name, "modes": "driven by a spin change (hub torque)"}, memo=modal.solved,
    )  # fmt: skip


def spin_change_path(model: ReducedModel, result: SpinupResult, case, formulation: str = "Q"):
    """:class:`~quadmodes.runs.path_validity.PathValidity` of a spin change: the centrifugal
    load and the rotating-frame stiffness along the path (:func:`~quadmodes.runs.
    path_validity.path_validity`); past the a-priori bound (a spin within ±1 % of the model's)
    the range is measured: the model of the same case and mode count rebuilt about the spin of
    largest departure (:func:`spin_change_model`), the rotating-frame frequencies of both
    compared there (:mod:`quadmodes.runs.spin_check`), and the spin limit set as a free-body
    run's (:func:`~quadmodes.runs.path_validity.with_measured_range`); the largest modal
    amplitude against the FE model's condensed energy
    (:func:`~quadmodes.runs.path_validity.with_amplitude_check`)."""
    from types import SimpleNamespace

    from quadmodes.runs import path_validity as pv

    system = reduced_system(model, formulation)
    e = np.asarray(model.reference_axis, float) / np.linalg.norm(model.reference_axis)
    w = np.asarray(result.omega, float)
    y = np.zeros((len(w), 7 + 2 * model.n_modes))
    y[:, 0], y[:, 4:7], y[:, 7:] = 1.0, w, np.hstack([result.s, result.sdot])
    solution = SimpleNamespace(t=np.asarray(result.time, float), y=y)
    norm = np.maximum(np.linalg.norm(w, axis=1), 1e-300)
    diag = SimpleNamespace(spin_rate=np.abs(w @ e), cone_angle=np.arccos(np.clip(np.abs(w @ e)
                                                                                 / norm, 0, 1)))
    setup = _Setup(system, model, case, _Initial(y[0]))
    path = _measured(pv.path_validity(setup, solution, diag), setup, solution, diag, w, e)
    return pv.with_amplitude_check(path, setup, solution, diag)


@dataclass(frozen=True)
class _Initial:
    """The initial state (7+2N,) of a spin change, as a run's (:mod:`quadmodes.runs.initial`)."""

    y0: np.ndarray


@dataclass(frozen=True)
class _Setup:
    """What the path checks read of a prepared run (:class:`~quadmodes.runs.simulate.RunSetup`)."""

    system: object
    model: ReducedModel
    model_case: object
    initial: _Initial


def _measured(path, setup, solution, diag, w, e):
    """``path`` with its spin range measured against the model rebuilt about the spin of the
    path's largest departure (when past the a-priori bound), as
    :func:`~quadmodes.runs.path_validity.with_measured_range` for a free-body run, by the
    rotating-frame frequencies only. The free-body run's second measure, the energy-sink coning
    rate (:func:`~quadmodes.runs.spin_check.sink_error`), is no measure of a spin change: its
    angular velocity stays on the axis (the hub's torque is along it; no cone to grow), and its
    driven modes (a flat rotor's in-plane lag) are not forced by a cone: by the mirror symmetry
    of the plane their J1 has no axial–in-plane component, so the coning dissipates nothing
    through them (θ̇/θ = 0 for both models; docs/sails.md). What the lag answer is made of is the
    driven modes' frequencies (the quasi-static lag ∝ 1/ω², its settling their period)."""
    from quadmodes.runs import path_validity as pv
    from quadmodes.runs.spin_check import frequency_difference, rotating_frequencies

    if not path.reference_spin or not path.centrifugal_max > path.centrifugal_limit:
        return path
    system, model, formulation = setup.system, setup.model, setup.system.formulation
    spin = pv.spin_and_tilt(w, system.reference_omega)[0]
    k = int(np.argmax(spin))
    rate = float(abs(w[k] @ e))
    rebuilt = reduced_system(spin_change_model(setup.model_case, model.n_modes, rate), formulation)
    eps = frequency_difference(rotating_frequencies(system, rate * e),
                               rotating_frequencies(rebuilt, rate * e))  # fmt: skip
    ok = eps <= pv.FREQUENCY_TOLERANCE
    limit = float(spin[k]) if ok else float(spin[k]) * pv.FREQUENCY_TOLERANCE / eps
    basis = (f"measured: the model rebuilt about {rate / (2 * math.pi):.5g} Hz differs by "
             f"{100 * eps:.2g} % in its rotating-frame frequencies there"
             + ("" if ok else ", taken linear in the departure")
             + "; no energy-sink coning rate: a spin change has no cone, and its driven modes "
             "are not forced by one")  # fmt: skip
    measured = pv.path_validity(setup, solution, diag, limit, basis)
    return replace(measured, measured_spin=rate, measured_error=eps)


def simulate_spin_change(run, model_case, model: ReducedModel | None, run_type):
    """The spin change of ``run`` (``[spinup]`` with ``omega_0`` > 0) on ``model_case`` (with a
    ``[hub]``): its model (:func:`spin_change_model` unless given), the integration
    (:func:`spin_change`), the rotating-frame stiffness on the spins of the change and the path
    (:func:`spin_change_path`), as a ``run_type`` (:class:`~quadmodes.runs.simulate.SpinupRun`)."""
    import time

    from quadmodes.case import CaseError
    from quadmodes.runs.validity import Validity

    sp, formulation = run.spinup, run.reduced.formulation
    if formulation in ("rigid", "QM"):
        raise CaseError(f'reduced.formulation = "{formulation}": a spin change takes Q, P, L '
                        "or Q4", field="reduced.formulation")  # fmt: skip
    try:
        if model is None:
            model = spin_change_model(model_case, int(run.reduced.modes), float(sp.omega_0))
        check_hub(model)
    except ValueError as exc:
        field = "reduced.modes" if str(exc).startswith("reduced.modes") else "model"
        raise CaseError(str(exc), field=field) from None
    start = time.perf_counter()
    result = spin_change(model, float(sp.omega_0), float(sp.omega_s), float(sp.ramp_time),
                         float(sp.duration), formulation, rtol=float(sp.rtol),
                         atol=float(sp.rtol) * 1e-2, n_out=int(sp.samples))  # fmt: skip
    wall = time.perf_counter() - start
    path = spin_change_path(model, result, model_case, formulation)
    lost = None if path.min_stiffness > 0.0 else float(path.left_spin)
    validity = Validity(formulation, float(sp.omega_s), float(path.min_stiffness), lost)
    return run_type(run, model_case, result, validity, wall, path)
