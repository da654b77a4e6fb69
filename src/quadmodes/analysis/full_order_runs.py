"""Full-order runs of run cases (as ``quadmodes run`` sets them up), the hub-driven Kane spin-up,
and the wall-time estimate printed before a long run.

The glue between a run case and the full order: it sets the run up as the reduced path does
(:func:`quadmodes.runs.simulate.prepare`: modes, reduced model, initial state) and integrates it
with :func:`quadmodes.fullorder.integrate_full_order`. It sits above both; the full-order core
(:mod:`quadmodes.fullorder`) imports nothing from :mod:`quadmodes.runs`, the two stand side by
side on :mod:`quadmodes.models`."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from quadmodes.case import CaseError, RunCase, load_case, load_run_case
from quadmodes.fe.model import Structure, centre_of_mass
from quadmodes.fullorder import damping as fdamp
from quadmodes.fullorder.integrator import FullOrderSolution, integrate_full_order
from quadmodes.fullorder.kinematics import (
    HubDrive,
    centrifugal_stretch,
    initial_state_from_reduced,
    kane_hub,
)
from quadmodes.fullorder.options import FullOrderOptions
from quadmodes.fullorder.setup import step_count
from quadmodes.rom.reduced import ReducedModel
from quadmodes.rotations import rotation_matrix
from quadmodes.structure import pipeline
from quadmodes.structure.damping import damping_state

Progress = Callable[[str, float], None]

#: Default time step (s) of the full-order Kane spin-up (bending period ≈ 1.65 s).
KANE_DT = 5e-3


@dataclass(frozen=True, eq=False)
class FullOrderSetup:
    """What a full-order run of a run case integrates: the structure, its reference state x_ref
    (n,3) m, the reduced model (modes, damping), the initial state (x0, v0) (n,3), the hub drive
    (spin-up) or None, the nominal spin axis (body frame) and the run's time step/sampling;
    damping_choice ("independent", "retained" or "none") and, for "independent", its basis
    ``damping`` (None when the case's damping ratio is 0: undamped). x_rest (n,3) m: the
    prestressed state at rest, about which the independent damping modes are taken (None: x_ref;
    differs from x_ref when the reduced model is expanded about a spinning state, whose
    relative equilibrium is then x_ref)."""

    run: RunCase
    structure: Structure
    x_ref: np.ndarray
    model: ReducedModel
    x0: np.ndarray
    v0: np.ndarray
    hub: HubDrive | None
    spin_axis: np.ndarray | None
    duration: float
    sample_interval: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    damping_choice: str = "retained"
    damping: fdamp.DampingModes | None = None
    x_rest: np.ndarray | None = None
    start: str = ""  # where on a reduced path (x0, v0) was taken (path_point); "": t = 0

    def integrator_damping(self) -> bool | fdamp.DampingModes:
        """The ``damping`` argument of :func:`integrate_full_order` for this setup."""
        if self.damping_choice == "independent":
            return self.damping if self.damping is not None else False
        return self.damping_choice == "retained"


def damping_choice(damping) -> str:
    """``damping`` as one of :data:`~quadmodes.fullorder.damping.CHOICES` (True: independent,
    False/None: none). Raises ValueError naming the choices."""
    if damping is True:
        return "independent"
    if damping is False or damping is None:
        return "none"
    if damping not in fdamp.CHOICES:
        raise ValueError(f"damping: {damping!r}; choose from {', '.join(fdamp.CHOICES)}")
    return str(damping)


def with_damping(st: FullOrderSetup, damping="independent", cutoff_hz: float | None = None):
    """``st`` with its full-order damping chosen (:func:`damping_choice`): for "independent"
    every FE mode of the setup's structure about x_ref below ``cutoff_hz`` (Hz; default
    :func:`~quadmodes.fullorder.damping.default_cutoff` of the spin and the retained modes),
    with the case's damping ratio, from the cache (:func:`~quadmodes.fullorder.damping.
    independent_damping_for`); a note names the basis."""
    from quadmodes.models.build import damping_ratio_of

    choice = damping_choice(damping)
    case = st.run.model_case()
    zeta = damping_ratio_of(case)
    notes = tuple(n for n in st.notes if not n.startswith("full-order damping"))
    if choice != "independent" or zeta == 0.0:
        modes = fdamp.retained_damping(st.model) if choice == "retained" else None
        line = modes.describe() if modes is not None else "full-order damping: none"
        return replace(st, damping_choice=choice, damping=None, notes=(*notes, line))
    if cutoff_hz is None:
        spin = st.run.spinup.omega_s if st.run.spinup is not None else st.run.initial.spin_rate
        cutoff_hz = fdamp.default_cutoff(float(spin) / (2 * np.pi), st.model.frequencies_hz)
    x_rest = st.x_ref if st.x_rest is None else st.x_rest
    x_d, state = x_rest, "rest"
    if st.model.reference_spin:  # the reduced model's own rule (rom.spinning_reduction)
        ref = float(st.model.reference_spin)
        x_d, state = damping_state(st.structure, x_rest, st.x_ref, ref)
        state = state if state == "rest" else f"spinning {ref!r} rad/s"
    modes = fdamp.independent_damping_for(case, st.structure, x_d, float(cutoff_hz), zeta,
                                          state=state)  # fmt: skip
    return replace(st, damping_choice=choice, damping=modes, notes=(*notes, modes.describe()))


def setup_for_run(
    run: RunCase | str, model: ReducedModel | None = None, stretch: bool = True, *,
    damping="independent", damping_cutoff: float | None = None,
) -> FullOrderSetup:  # fmt: skip
    """Structure, inflated reference, reduced model (from the cache) and initial state of a run
    case exactly as ``quadmodes run`` builds them (:func:`quadmodes.runs.simulate.prepare`), mapped to
    the full order by :func:`initial_state_from_reduced` (centre of mass at the reference's).

    ``stretch`` (free-body runs): add the quasi-static centrifugal displacement of the initial
    spin outside the retained modes (:func:`~quadmodes.fullorder.kinematics.centrifugal_stretch`),
    rotated with the body, and its rigid-rotation velocity ω × u_c; the retained modal
    coordinates are those of the reduced state. ``damping``, ``damping_cutoff`` (Hz): the
    full order's damping (:func:`with_damping`; default the independent basis)."""
    st = _setup_for_run(run, model, stretch)
    return with_damping(st, damping, damping_cutoff)


def _setup_for_run(run, model, stretch) -> FullOrderSetup:
    """:func:`setup_for_run` without the damping choice."""
    from quadmodes.runs import simulate

    run = load_run_case(run) if isinstance(run, str) else run
    case = run.model_case()
    structure = pipeline.structure_for_case(case)
    if run.spinup is not None:
        sp = run.spinup
        if sp.omega_0 > 0.0:  # docs/sails.md, "A spin-rate change"
            raise CaseError("a spin change of a body on a hub (spinup.omega_0 > 0) has no "
                            "full-order comparison yet (the full order's hub torque is not "
                            "built); compare a free-body run instead", field="spinup.omega_0")  # fmt: skip
        model = model if model is not None else simulate.spinup_model(run, case)
        x_ref = structure.reference
        hub = kane_hub(float(sp.omega_s), float(sp.ramp_time))
        y0 = np.zeros(7 + 2 * model.n_modes)
        y0[0] = 1.0  # identity attitude, at rest
        x0, v0 = initial_state_from_reduced(model, y0)
        return FullOrderSetup(run, structure, x_ref, model, x0, v0, hub, None,
                              float(sp.duration), float(sp.duration) / max(int(sp.samples) - 1, 1))  # fmt: skip
    x_ref, _ = pipeline.reference_state(case, structure)
    structure = pipeline.with_gas_law(case, structure, x_ref)
    setup = simulate.prepare(run, model, model_case=case)
    y0 = setup.initial.y0
    x_rest, centre = x_ref, centre_of_mass(structure, x_ref)
    if setup.model.reference_spin:  # the model's reference is the spinning relative equilibrium
        x_ref = np.asarray(setup.model.X) + np.outer(structure.translational, centre)
    stiffless = spin_stiffened(case, structure, x_rest, x_ref, setup.model.reference_spin)
    x0, v0, mapped = full_state_from_reduced(structure, x_ref, setup.model, y0, centre,
                                             stretch and not stiffless)  # fmt: skip
    notes = (*setup.initial.notes, *mapped)
    if stiffless and stretch and np.any(y0[4:7]):
        what = "a flat membrane" if case.kind == "membrane" else "a spin-stiffened body"
        notes = (*notes, f"full order: {what} about its spinning state, no centrifugal "
                         "stretch added")  # fmt: skip
    integ = run.integration
    return FullOrderSetup(run, structure, x_ref, setup.model, x0, v0, None,
                          setup.initial.spin_axis, float(integ.duration),
                          float(integ.dt) * int(integ.save_every), notes, x_rest=x_rest)  # fmt: skip


def spin_stiffened(case, structure: Structure, x_rest: np.ndarray, x_ref: np.ndarray,
                   spin: float | None) -> bool:  # fmt: skip
    """True for a body whose stiffness is its spin's, expanded about its spinning state
    ``x_ref`` (n,3) m at ``spin`` (rad/s; None/0: about rest): a flat membrane without pressure
    (a sail), or a structure with no stiffness at rest ``x_rest`` on the spin's scale (string
    blades: :func:`~quadmodes.structure.damping.damping_state`). Such a state has the
    centrifugal stretch of the spin already, and the quasi-static stretch of a coning ω (off a
    principal axis) is not small there — its out-of-plane stiffness scales with the spin: the
    string-blade rotor with a tall hub from 0.5° swung its blades into compression at t = 0
    and its Newton failed in the first step (docs/sails.md) — so it is not added."""
    if case.kind == "membrane":
        return case.pressure is None
    if not spin:
        return False
    return damping_state(structure, x_rest, x_ref, float(spin))[1] == "spinning"


def full_state_from_reduced(
    structure: Structure, x_ref: np.ndarray, model: ReducedModel, y: np.ndarray,
    centre: np.ndarray, stretch: bool = True,
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:  # fmt: skip
    """The full order's state ``(x, v, notes)`` (n,3) m, m/s of the reduced state ``y = [q, ω,
    s, ṡ]`` (7+2N,) of ``model`` (reference ``x_ref`` (n,3) of ``structure``), centre of mass
    ``centre`` (3,) m at rest: the seed paper's kinematics (x = p + R[X + Σ s_m u^m + Σ s_m s_n
    g^{mn}], v likewise: :func:`initial_state_from_reduced`) with the part outside the
    retained modes relaxed:

    * the deformation ``s``: the static condensation ``y_c(s)`` of every other DOF
      (:func:`relaxed_deformation`), rotated with the body, its velocity ω × y_c and, where
      ṡ ≠ 0, its rate (∂y_c/∂s) ṡ (a central difference of two more condensations along ṡ);
    * with ``stretch``: the quasi-static centrifugal displacement of ω outside the retained
      modes (:func:`~quadmodes.fullorder.kinematics.centrifugal_stretch`) and ω × u_c.

    The same map starts a run at t = 0 (ṡ = 0 there) and at any point of a reduced path
    (:mod:`quadmodes.analysis.path_point`); ``notes`` says which parts were added."""
    n_modes = model.n_modes
    x, v = initial_state_from_reduced(model, y, p=centre)
    rot, w = rotation_matrix(y[:4]), y[4:7]
    s, sd = y[7 : 7 + n_modes], y[7 + n_modes :]
    notes: tuple[str, ...] = ()
    if np.any(s):
        yc = relaxed_deformation(structure, x_ref, model, s)
        rate = np.zeros_like(yc)
        if np.any(sd):  # the relaxed part follows s quasi-statically: its rate (∂y_c/∂s) ṡ
            eps = 1e-3 * float(np.linalg.norm(s)) / float(np.linalg.norm(sd))
            rate = (relaxed_deformation(structure, x_ref, model, s + eps * sd)
                    - relaxed_deformation(structure, x_ref, model, s - eps * sd)) / (2 * eps)  # fmt: skip
        x = x + yc @ rot.T
        v = v + (np.cross(w, yc) + rate) @ rot.T
        notes = ("full order: deformation relaxed outside the retained modes (statically "
                 "condensed)",)  # fmt: skip
    if stretch and np.any(w):
        u_c = centrifugal_stretch(structure, x_ref, w, model)
        x = x + u_c @ rot.T
        v = v + np.cross(w, u_c) @ rot.T
        notes = (*notes, "full order: centrifugal stretch outside the retained modes added")
    return x, v, notes


def relaxed_deformation(
    structure: Structure, x_ref: np.ndarray, model: ReducedModel, s0: np.ndarray
) -> np.ndarray:
    """Body-frame correction ``y`` (n,3) m that relaxes the quadratic-manifold point of the
    modal coordinates ``s0`` (N,) √kg·m statically in every direction outside the retained and
    rigid modes: the minimiser of the total potential over ``[Φ Ψ]ᵀ M y = 0``
    (:func:`quadmodes.rom.manifold_energy.condensed_energy`).

    Why: the manifold point ``X + Φs + Σ s s g`` of a large initial bending is far stiffer than
    the structure (0.5 in on ``paper-membrane``: 0.61 J against 0.25 J condensed, mostly in the
    stiff end-body ties), so a full order started there rings in its stiffest modes and its
    Newton iteration fails within a few steps. The condensed state is the physical meaning of
    "an initial deformation in these modes", and the energy every reduced potential
    approximates."""
    from quadmodes.rom import manifold_energy as me

    ctx = me.energy_context(structure, x_ref, model)
    result = me.condensed_energy_along_ray(ctx, s0)
    if not result.converged:
        raise ValueError(
            "initial.bending_amplitude: the full order's relaxed initial deformation did not "
            "converge; use a smaller amplitude"
        )
    return result.unknowns.reshape(-1, 3)


def checkpoint_key(st: FullOrderSetup) -> str:
    """What a full-order checkpoint of the set-up run ``st`` is of: a SHA-256 of its run case
    (SI TOML without ``integration.duration``: a resume may extend the window), its model case
    and the reduced model's content key. A checkpoint with another key is not resumed."""
    import hashlib
    import json
    import tomllib

    run = tomllib.loads(st.run.to_toml())
    run.get("integration", {}).pop("duration", None)
    model = getattr(st, "model", None)
    text = "\n".join([
        json.dumps(run, sort_keys=True, default=str), st.run.model_case().to_toml(),
        str(getattr(model, "provenance", {}).get("content_key", "")),
        *([st.start] if getattr(st, "start", "") else []),  # a start on a reduced path
    ])  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def full_order_for_run(
    run: RunCase | str,
    *,
    dt: float | None = None,
    window: float | None = None,
    damping: bool | str = "independent",
    damping_cutoff: float | None = None,
    save_every: int | None = None,
    model: ReducedModel | None = None,
    stretch: bool = True,
    progress: Progress | None = None,
    setup: FullOrderSetup | None = None,
    **options,
) -> FullOrderSolution:
    """Full-order transient of run case ``run`` (name or :class:`RunCase`) over ``[0, window]``
    (default: the run's duration) with step ``dt`` (default: the run's ``integration.dt``; a
    spin-up: :data:`KANE_DT`), from the run's initial state (:func:`setup_for_run`).

    Samples are taken at the run's sampling interval (``dt × save_every`` of the run) unless
    ``save_every`` is given. ``stretch``: see :func:`setup_for_run`. ``progress(stage, fraction)`` with stage "full order". Other
    keyword ``options`` go to :func:`integrate_full_order` (newton_tol, checkpoint, ...).
    ``setup``: a :func:`setup_for_run` result already built for ``run`` (skips the inflation and
    the initial-state mapping). ``damping``: "independent" (default: every FE mode below
    ``damping_cutoff`` Hz, :func:`with_damping`), "retained" (the reduced model's modal damping
    on its retained modes, the old reference, a baseline) or "none" (True/False: independent /
    none); a ``setup`` built with another choice or cutoff gets this one."""
    if setup is None:
        st = setup_for_run(run, model, stretch, damping=damping, damping_cutoff=damping_cutoff)
    else:
        st = setup
        choice = damping_choice(damping)
        same_cut = damping_cutoff is None or (
            st.damping is not None and st.damping.cutoff_hz == float(damping_cutoff)
        )
        if choice != st.damping_choice or not same_cut:
            st = with_damping(st, choice, damping_cutoff)
    run = st.run
    if dt is None:
        dt = KANE_DT if st.hub is not None else float(run.integration.dt)
    window = st.duration if window is None else float(window)
    if save_every is None:
        save_every = max(1, int(round(st.sample_interval / dt)))
    frac = (lambda f: progress("full order", f)) if progress else None
    on_sample = options.pop("on_sample", None)
    options.setdefault("checkpoint_key", checkpoint_key(st))
    return integrate_full_order(
        st.structure, st.x_ref, st.x0, st.v0, (0.0, window), dt, FullOrderOptions(
            model=st.model, damping=st.integrator_damping(), save_every=save_every, hub=st.hub,
            spin_axis=st.spin_axis).updated(**options),
        progress=frac, on_sample=on_sample,
    )  # fmt: skip


def estimate_wall_time(
    structure: Structure, x_ref: np.ndarray, x0: np.ndarray, v0: np.ndarray,
    t_span: tuple[float, float], dt: float, n_probe: int = 8, **options,
) -> dict:  # fmt: skip
    """Time ``n_probe`` steps from the initial state and extrapolate to ``t_span`` (the
    arguments before ``n_probe`` as for :func:`integrate_full_order`).

    Returns ``{"estimate_s", "per_step_s", "first_step_s", "n_steps", "newton_per_step",
    "factor_per_step"}`` (s; the first step carries the setup and first factorisation and is
    counted once). ``options`` as for :func:`integrate_full_order` (checkpoint options are
    dropped)."""
    for key in ("checkpoint", "resume", "progress", "checkpoint_every"):
        options.pop(key, None)
    n_steps = step_count(t_span, dt)[0]
    t0 = float(t_span[0])
    start = time.perf_counter()
    integrate_full_order(structure, x_ref, x0, v0, (t0, t0 + dt), dt,
                         FullOrderOptions().updated(**options))  # fmt: skip
    first = time.perf_counter() - start
    k = max(1, min(n_probe, n_steps))
    start = time.perf_counter()
    sol = integrate_full_order(
        structure, x_ref, x0, v0, (t0, t0 + (k + 1) * dt), dt,
        FullOrderOptions().updated(save_every=k + 1, **options),
    )
    elapsed = time.perf_counter() - start
    # on a busy machine the (k+1)-step run can take less than the first step did alone: then
    # the mean over its k+1 steps (never zero) is the per-step estimate
    per = (elapsed - first) / k if elapsed > first else elapsed / (k + 1)
    return {
        "estimate_s": first + per * (n_steps - 1),
        "per_step_s": per,
        "first_step_s": first,
        "n_steps": n_steps,
        "newton_per_step": sol.stats["newton_per_step"],
        "factor_per_step": sol.stats["factor_per_step"],
    }


def estimate_for_run(
    run: RunCase | str, *, dt: float | None = None, window=None, n_probe=8,
    setup: FullOrderSetup | None = None,
) -> dict:  # fmt: skip
    """:func:`estimate_wall_time` of :func:`full_order_for_run` (same arguments)."""
    st = setup if setup is not None else setup_for_run(run)
    if dt is None:
        dt = KANE_DT if st.hub is not None else float(st.run.integration.dt)
    window = st.duration if window is None else float(window)
    return estimate_wall_time(st.structure, st.x_ref, st.x0, st.v0, (0.0, window), dt,
                              n_probe, model=st.model, hub=st.hub, spin_axis=st.spin_axis,
                              damping=st.integrator_damping())  # fmt: skip


# ---------------------------------------------------------------------------------------------
# Kane spin-up
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class KaneFullOrder:
    """Full-order Kane spin-up: Ωs (rad/s), ramp T (s), the solution, the in-plane tip peak
    (m, signed) and its time (s) refined by a parabola through the extreme sample and its
    neighbours, and the wall time (s)."""

    omega_s: float
    t_ramp: float
    solution: FullOrderSolution
    peak_deflection: float
    peak_time: float
    wall_s: float

    @property
    def complete(self) -> bool:
        return self.solution.status == 0


def refined_extreme(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """``(t*, y*)`` of the largest |y| sample refined by the parabola through it and its two
    neighbours (the sample itself at an end of the series)."""
    k = int(np.nanargmax(np.abs(y)))
    if 0 < k < len(y) - 1:
        t3, y3 = t[k - 1 : k + 2], y[k - 1 : k + 2]
        a, b, c = np.polyfit(t3 - t[k], y3, 2)
        if a != 0.0:
            tau = float(np.clip(-b / (2 * a), t3[0] - t[k], t3[2] - t[k]))
            return float(t[k] + tau), float(c + b * tau + a * tau * tau)
    return float(t[k]), float(y[k])


def kane_full_order(
    omega_s: float = 6.0,
    t_ramp: float = 15.0,
    duration: float = 9.0,
    dt: float = KANE_DT,
    n_elements: int | None = None,
    save_every: int = 2,
    **options,
) -> KaneFullOrder:
    """Full-order (ANCF cable, inertial frame, hub-driven clamp) Kane spin-up 0 → ``omega_s``
    (rad/s) in ``t_ramp`` (s) over ``duration`` (s; the published peaks are at 6.4–7 s) with
    step ``dt``; the beam of the built-in ``kane-beam`` case (``n_elements`` overrides its
    element count). Returns the in-plane tip peak (hub-frame y) — compare with
    :data:`quadmodes.runs.spinup.KANE_REFERENCE_PEAKS`."""
    from quadmodes.models.beam import kane_model

    case = load_case("kane-beam")
    if n_elements is not None:
        beam = case.beam.model_copy(update={"elements": int(n_elements)})
        case = case.model_copy(update={"beam": beam})
    structure = pipeline.structure_for_case(case)
    model = kane_model(4, n_elements=case.beam.elements, structure=structure)
    x_ref = structure.reference
    x0, v0 = x_ref.copy(), np.zeros_like(x_ref)
    start = time.perf_counter()
    sol = integrate_full_order(
        structure, x_ref, x0, v0, (0.0, duration), dt, FullOrderOptions(
            model=model, damping=False, save_every=save_every,
            hub=kane_hub(omega_s, t_ramp)).updated(**options),
    )  # fmt: skip
    wall = time.perf_counter() - start
    tp, vp = refined_extreme(sol.t, sol.tip[:, 1])
    return KaneFullOrder(float(omega_s), float(t_ramp), sol, vp, tp, wall)


__all__ = [
    "FullOrderSetup",
    "KaneFullOrder",
    "estimate_for_run",
    "estimate_wall_time",
    "full_order_for_run",
    "full_state_from_reduced",
    "kane_full_order",
    "refined_extreme",
    "damping_choice",
    "setup_for_run",
    "with_damping",
]
