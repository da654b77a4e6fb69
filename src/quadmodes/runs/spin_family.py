"""A family of reduced models along a run's path (issue 29 item 2, docs/path-validity.md): the
members are the models of the same case and modes expanded about the spinning equilibria at the
spins of a geometric grid Ω₀(1 + spacing)^k (Ω₀ the run's reference spin, ``spacing`` its
``reduced.path_switch``), and the run is integrated by the member nearest its spin.

Why the spin (measured, ``benchmarks/studies/bench_path_model.py``): along the coning path of
paper-41hz-coarse the reduced model's cone growth departs from the full order's by about 1.1 ×
the relative departure of the path's spin from the spin its model is expanded about; a member
about the path's spin restores the model's own accuracy (× 0.976–0.979 at 12–20° against
× 0.957–0.906 for the one 41 Hz model), where more modes or a higher-order potential do not.

A switch, at the first saved sample whose spin about the member's axis is nearer another grid
point (by :data:`HYSTERESIS` × half a spacing: the spin departs from its member's by at most
about 0.55 × the spacing, 0.41 % by default), the chunk cut there:

* the new member: :func:`quadmodes.models.build.reduced_model_for` about that grid spin (rounded
  to :data:`SPIN_RESOLUTION_HZ`; the grid makes members shared by paths, cached), the same axis
  request and modes;
* the state (:func:`mapped_state`): the attitude kept; the displacement field of the old chart,
  X₀ + Φ₀s + Σ s_m s_n g₀^{mn}, matched on the new chart in the least-squares sense (lumped mass
  norm, Gauss–Newton); the deformation velocity Φ₀ṡ + 2Σ s_m ṡ_n g₀^{mn} fitted the same way on
  the new chart's tangent; ω then solved from the body-frame angular momentum h = J̃ω + Aᵀṡ of
  the old state, so that H is the same to round-off;
* the energy: each member's potential is the strain energy about its own reference, defined up
  to a constant; the path's energy takes each new member's constant so that E is continuous at
  the switch (so E + E_d stays constant to the integrator's accuracy through the switches).
  What the two members' energies of the same state differ by, each referred to the FE model's
  potential Π at its reference (T + V + Π(X_k)), is the switch's **energy defect**, reported:
  first order in the spin step (the centrifugal load's work on the part of the reference
  change that lies outside the old member's basis, which the old member could not carry;
  1.5e-6 of the energy per 0.75 % switch on paper-41hz-coarse).

Samples keep each member's own modal coordinates (``results.nc`` ``modal_coordinates`` are in
the chart of the member that integrated them; the run's notes list the members and switch times).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from quadmodes.case import CaseError
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import system as rsys
from quadmodes.rom.diagnostics import Diagnostics, diagnostics
from quadmodes.rom.solution import Solution
from quadmodes.runs import chunked

#: Default spacing of the members' spins (relative): 0.75 %, so the spin departs from its
#: member's by at most about 0.41 % (the centrifugal load by 0.83 %, inside the path check's
#: 2 %; the cone growth by about 0.45 %, docs/path-validity.md).
DEFAULT_TOLERANCE = 0.0075
#: Members are expanded about spins rounded to this (Hz), so that paths share cached members.
SPIN_RESOLUTION_HZ = 1e-4
#: A switch waits until the spin is nearer another grid point by this factor on half a spacing.
HYSTERESIS = 1.1
#: Gauss–Newton iterations of the chart fit (the charts are 1 % apart: 3 reach round-off).
FIT_ITERATIONS = 8


@dataclass(frozen=True)
class Switch:
    """One switch: time (s) and step, spins from and to (rad/s), the relative change of |H|
    the map made, the energy defect (J: T + V + Π(X_k) of the new member's state minus the old
    one's, module docstring) and the path's energy there (J)."""

    time: float
    step: int
    spin_from: float
    spin_to: float
    h_change: float
    energy_defect: float
    energy: float

    def describe(self) -> str:
        return (f"t = {self.time:.6g} s: {self.spin_from / (2 * math.pi):.5g} → "
                f"{self.spin_to / (2 * math.pi):.5g} Hz (|H| {self.h_change:.1e}, energy defect "
                f"{self.energy_defect / self.energy:+.1e} relative)")  # fmt: skip


# ---------------------------------------------------------------------------------------------
# the state map between members
# ---------------------------------------------------------------------------------------------


def manifold_field(model, s: np.ndarray) -> np.ndarray:
    """Body-frame positions X + Φs + Σ s_m s_n g^{mn} (n,3) m of modal coordinates s (N,)."""
    return (model.X + np.einsum("k,kia->ia", s, model.Phi)
            + np.einsum("m,n,mnia->ia", s, s, model.G))  # fmt: skip


def _tangent(model, s: np.ndarray) -> np.ndarray:
    """∂x/∂s = Φ + 2Σ s_n g^{·n} (N, n, 3)."""
    return model.Phi + 2.0 * np.einsum("n,mnia->mia", s, model.G)


def _normal(jac: np.ndarray, w: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Least-squares coefficients of ``r`` (n,3) on the columns ``jac`` (N,n,3), weights w."""
    a = np.einsum("mia,i,nia->mn", jac, w, jac)
    return np.linalg.solve(a, np.einsum("mia,i,ia->m", jac, w, r))


def chart_fit(model, x: np.ndarray, s: np.ndarray | None = None,
              iterations: int = FIT_ITERATIONS) -> np.ndarray:  # fmt: skip
    """Modal coordinates s (N,) of ``model`` whose field is nearest ``x`` (n,3) in the lumped
    mass norm (weights: the model's nodal masses, kg), Gauss–Newton from ``s`` (default 0)."""
    w = np.asarray(model.weights, float)
    s = np.zeros(model.n_modes) if s is None else np.array(s, float)
    for _ in range(iterations):
        s = s + _normal(_tangent(model, s), w, x - manifold_field(model, s))
    return s


def mapped_state(sys0, model0, sys1, model1, y: np.ndarray) -> np.ndarray:
    """The state (7+2N₁,) of member ``model1`` (system ``sys1``) matching ``y`` of ``model0``:
    fields matched (module docstring), ω such that h = J̃ω + Aᵀṡ is the old state's."""
    n0 = model0.n_modes
    s, sd = y[7 : 7 + n0], y[7 + n0 :]
    x = manifold_field(model0, s)
    v = np.einsum("mia,m->ia", _tangent(model0, s), sd)
    s1 = chart_fit(model1, x)
    sd1 = _normal(_tangent(model1, s1), np.asarray(model1.weights, float), v)
    h = dyn.body_momentum(sys0, y)
    jt = dyn.inertia_tensor(sys1, s1, "rot")
    rows = dyn.coupling_rows(sys1, s1, "rot")
    w1 = np.linalg.solve(jt, h - sd1 @ rows)
    return np.concatenate([y[:4], w1, s1, sd1])


# ---------------------------------------------------------------------------------------------
# when to switch
# ---------------------------------------------------------------------------------------------


def member_hz(spin: float) -> float:
    """The spin (Hz) a member about ``spin`` (rad/s) is expanded about: rounded to
    :data:`SPIN_RESOLUTION_HZ`."""
    return round(spin / (2 * math.pi) / SPIN_RESOLUTION_HZ) * SPIN_RESOLUTION_HZ


def member_spin(system, y: np.ndarray) -> np.ndarray:
    """Spin about the member's reference axis ω·e (k,) rad/s of states y (k, 7+2N)."""
    w_ref = np.asarray(system.reference_omega, float)
    return rsys.split_state(system, np.atleast_2d(y))[1] @ (w_ref / np.linalg.norm(w_ref))


def grid_spin(spin: float, spin0: float, spacing: float) -> float:
    """The member spin (rad/s) for ``spin``: the point of the geometric grid
    Ω₀(1 + spacing)^k nearest it (in ln Ω), rounded to :data:`SPIN_RESOLUTION_HZ`."""
    k = round(math.log(spin / spin0) / math.log1p(spacing))
    return 2 * math.pi * member_hz(spin0 * (1.0 + spacing) ** k)


class SwitchMonitor:
    """``after_chunk`` of :func:`quadmodes.runs.chunked.integrate_in_chunks`: the run's
    ``until`` event first (``event``, or None), then the switch: at the first new sample whose
    spin about the member's axis is nearer another point of the grid of member spins
    (:func:`grid_spin`; by :data:`HYSTERESIS` × half a spacing, so a spin hovering at a midpoint
    does not switch back and forth) the chunk is cut there and the segment stopped
    (``spin``: the new member's)."""

    def __init__(self, system, spin0: float, spacing: float, event=None):
        self.system, self.spin0, self.spacing, self.event = system, spin0, spacing, event
        self.spin_ref = float(np.linalg.norm(system.reference_omega))
        self.limit = HYSTERESIS * 0.5 * math.log1p(spacing)
        self.spin: float | None = None

    def after_resume(self, state, integ, h: float):
        return state

    def after_chunk(self, state, integ, h: float):
        if self.event is not None:
            state = self.event.after_chunk(state, integ, h)
            if state.stop is not None:
                return state
        if not state.t or not len(state.y[-1]):
            return state
        t_new, y_new, ed_new = state.t[-1], state.y[-1], state.e_d[-1]
        spins = member_spin(self.system, y_new)
        hits = np.flatnonzero(np.abs(np.log(spins / self.spin_ref)) > self.limit)
        if not len(hits):
            return state
        j = int(hits[0])
        target = grid_spin(float(spins[j]), self.spin0, self.spacing)
        if abs(target - self.spin_ref) < 0.5 * 2 * math.pi * SPIN_RESOLUTION_HZ:
            return state  # the member about that spin is this one
        self.spin = target
        pieces = dict(t=(*state.t[:-1], t_new[: j + 1]), y=(*state.y[:-1], y_new[: j + 1]),
                      e_d=(*state.e_d[:-1], ed_new[: j + 1]))  # fmt: skip
        return dataclasses.replace(state, steps=int(round(t_new[j] / h)), y_last=y_new[j].copy(),
                                   e_d_offset=float(ed_new[j]), stop=chunked._Stop(0, "switch", ""),
                                   **pieces)  # fmt: skip


# ---------------------------------------------------------------------------------------------
# the run
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Segment:
    """The part of the path one member integrated: its setup (model, system) and solution."""

    setup: object
    solution: Solution
    reference_energy: float  # the member's energy constant on the path (J; 0 for the first)


def _member(setup, spin: float, progress=None):
    """The setup of the member of ``setup``'s run about the grid spin ``spin`` (rad/s)."""
    from quadmodes.models.build import reduced_model_for

    run = setup.run
    model = reduced_model_for(setup.model_case, run.reduced.modes, progress, spin=spin,
                              axis=run.reference_axis)  # fmt: skip
    system = rsys.reduced_system(model, run.reduced.formulation)
    return dataclasses.replace(setup, model=model, system=system, validity=None)


def _potential_at(structure, model) -> float:
    """Π(X) (J): the FE model's potential at a member's reference."""
    from quadmodes.fe.model import strain_energy

    return float(strain_energy(structure, np.asarray(model.X, float)))


def _energy(system, y: np.ndarray) -> float:
    return float(dyn.kinetic_energy(system, y) + dyn.potential_energy(system, y))


def _segment_progress(y: np.ndarray, steps: int, chunk: int, e_d: float) -> chunked.ChunkProgress:
    """A chunk progress that starts a new member at step ``steps`` from state ``y``."""
    start = chunked.ChunkProgress.start(y, chunk)
    return dataclasses.replace(start, steps=steps, e_d_offset=e_d)


def integrate_family(setup, tolerance: float = DEFAULT_TOLERANCE, progress=None,
                     max_chunks: int = chunked.MAX_CHUNKS):  # fmt: skip
    """(segments, switches, ChunkedRun of the last segment, wall time s) of a prepared run
    (:class:`~quadmodes.runs.simulate.RunSetup` about a spinning state) integrated by a family
    of members (module docstring). Times and steps are the run's global ones."""
    from quadmodes.runs.deformation_check import deformation_structure
    from quadmodes.runs.events import run_event

    run, integ = setup.run, setup.run.integration
    h = integ.duration / integ.n_steps
    chunk = chunked._chunk_steps(integ.n_steps, integ.save_every, max_chunks)
    structure = deformation_structure(setup)
    pi0 = _potential_at(structure, setup.model)
    segments, switches, resume, wall = [], [], None, 0.0
    member, y0, offset, pi_k = setup, setup.initial.y0, 0.0, pi0
    while True:
        event = run_event(member.system, dataclasses.replace(member.initial, y0=y0), run)
        monitor = SwitchMonitor(member.system, setup.model.reference_spin, tolerance, event)
        start = time.perf_counter()
        try:
            part = chunked.integrate_in_chunks(member.system, y0, integ, progress, run.name,
                                               max_chunks, resume=resume, event=monitor)  # fmt: skip
        except chunked.Interrupted as stop:  # Ctrl-C: the path so far, raised by run_family
            segments.append(Segment(member, stop.partial.solution, offset))
            raise Stopped(segments, switches, stop.partial, wall, stop.reason) from None
        wall += time.perf_counter() - start
        segments.append(Segment(member, part.solution, offset))
        if monitor.spin is None or part.reason:
            return segments, switches, part, wall
        y_end, t_end = part.solution.y[-1], float(part.solution.t[-1])
        nxt = _member(member, monitor.spin, progress)
        y1 = mapped_state(member.system, member.model, nxt.system, nxt.model, y_end)
        e_before = _energy(member.system, y_end)
        e_after = _energy(nxt.system, y1)
        pi_next = _potential_at(structure, nxt.model)
        defect = (e_after + pi_next) - (e_before + pi_k)
        h0 = np.linalg.norm(dyn.momentum_inertial(member.system, y_end))
        h1 = np.linalg.norm(dyn.momentum_inertial(nxt.system, y1))
        step = int(round(t_end / h))
        switches.append(Switch(t_end, step, member.model.reference_spin, nxt.model.reference_spin,
                               abs(h1 / h0 - 1.0), defect, e_before + offset))  # fmt: skip
        offset, pi_k = offset + e_before - e_after, pi_next  # E continuous at the switch
        resume = (_segment_progress(y1, step, chunk, float(part.solution.dissipated[-1])), wall)
        member, y0 = nxt, y1


def merged_diagnostics(segments, spin_axis) -> Diagnostics:
    """The path's :class:`Diagnostics`: each segment's with its own system, its member's
    energy constant added (``Segment.reference_energy``: E continuous at the switches), the first
    sample of every later segment (the mapped switch state) dropped."""
    parts = []
    for k, seg in enumerate(segments):
        d = diagnostics(seg.setup.system, seg.solution, spin_axis=spin_axis).as_dict()
        d["E"] = d["E"] + seg.reference_energy
        d["V"] = d["V"] + seg.reference_energy
        d["E_balance"] = d["E"] + d["E_d"]
        parts.append({key: v[1:] if k else v for key, v in d.items()})
    return Diagnostics(**{key: np.concatenate([p[key] for p in parts]) for key in parts[0]})


def merged_solution(segments, last) -> Solution:
    """The path's :class:`Solution`: every segment's samples (each in its member's chart), the
    first sample of every later segment dropped; status and message of the last segment."""
    def cut(k, a):
        return a[1:] if k else a

    sols = [seg.solution for seg in segments]
    stats = {key: sum(s.stats.get(key, 0) for s in sols) for key in ("n_steps", "n_rhs",
             "n_newton", "n_jac")}  # fmt: skip
    stats["wall_s"] = last.wall_s
    return Solution(np.concatenate([cut(k, s.t) for k, s in enumerate(sols)]),
                    np.concatenate([cut(k, s.y) for k, s in enumerate(sols)]),
                    last.solution.method, stats, last.solution.status, last.solution.message,
                    np.concatenate([cut(k, s.dissipated) for k, s in enumerate(sols)]),
                    last.solution.dt)  # fmt: skip


def check_family_run(run, resume) -> None:
    """Refuse what a spin-family run does not support yet (one line, the field named)."""
    if run.reduced.reference != "spinning":
        raise CaseError('reduced.path_model = "spin-family" needs reduced.reference = "spinning"; '
                        "set it, or drop path_model", field="reduced.path_model")  # fmt: skip
    if run.reduced.formulation not in ("Q", "P", "L"):
        raise CaseError(f'reduced.path_model = "spin-family" takes formulation Q, P or L, not '
                        f'{run.reduced.formulation}', field="reduced.formulation")  # fmt: skip
    if resume is not None:
        raise CaseError('--resume: a reduced.path_model = "spin-family" run cannot be resumed '
                        "yet; run it again without --resume", field="--resume")  # fmt: skip


def family_path_validity(segments, diag):
    """The path's :class:`~quadmodes.runs.path_validity.PathValidity`: each segment checked
    against its own member (centrifugal load, rotating-frame stiffness), the first to leave its
    member's range gives where the path leaves; with the FE checks (``setup.fe_checks``, as
    ``quadmodes run``) the modal amplitudes of the last segment against its member's FE
    condensed energy."""
    from quadmodes.runs import path_validity as pv

    k0, found = 0, None
    for k, seg in enumerate(segments):
        n = len(seg.solution.t) - (1 if k else 0)
        sub = Diagnostics(**{key: v[k0 : k0 + n] for key, v in diag.as_dict().items()})
        sol = seg.solution if not k else dataclasses.replace(
            seg.solution, t=seg.solution.t[1:], y=seg.solution.y[1:],
            dissipated=seg.solution.dissipated[1:])  # fmt: skip
        path = pv.path_validity(seg.setup, sol, sub)
        if k == len(segments) - 1 and seg.setup.fe_checks:
            path = pv.with_amplitude_check(path, seg.setup, sol, sub)
        found = path if found is None or (path.left_at is not None and found.left_at is None) else found
        worst = max(found.centrifugal_max, path.centrifugal_max)
        found = dataclasses.replace(found, centrifugal_max=worst,
                                    amplitude_error=path.amplitude_error,
                                    checked=path.checked, unchecked=path.unchecked)  # fmt: skip
        k0 += n
    return found


@dataclass(frozen=True, eq=False)
class FamilyRun:
    """A path integrated by a family: the merged solution (each sample in its member's
    chart) and diagnostics, the path validity, notes, the switches, the last segment's
    ChunkedRun (reason, event) and the integration wall time (s)."""

    solution: Solution
    diagnostics: Diagnostics
    path: object
    notes: tuple[str, ...]
    switches: tuple[Switch, ...]
    last: object
    wall_s: float


class Stopped(KeyboardInterrupt):
    """Ctrl-C inside :func:`integrate_family`: the segments, switches, last ChunkedRun and
    wall time (s) so far and the reason (turned into a
    :class:`~quadmodes.runs.chunked.Interrupted` carrying the :class:`FamilyRun` by
    :func:`run_family`)."""

    def __init__(self, segments, switches, last, wall, reason: str):
        super().__init__(reason)
        self.parts = (segments, switches, last, wall)


def run_family(setup, progress=None, max_chunks: int = chunked.MAX_CHUNKS) -> FamilyRun:
    """:func:`integrate_family` of a prepared run with the tolerance of its
    ``reduced.path_switch``, merged (:class:`FamilyRun`). Ctrl-C raises
    :class:`~quadmodes.runs.chunked.Interrupted` whose ``partial`` is the :class:`FamilyRun`
    so far (not checkpointed: a family run is not resumed yet)."""
    tolerance = setup.run.reduced.path_switch or DEFAULT_TOLERANCE
    try:
        return _merged(setup, tolerance, *integrate_family(setup, tolerance, progress, max_chunks))
    except Stopped as stop:
        raise chunked.Interrupted(_merged(setup, tolerance, *stop.parts), False, str(stop)) from None


def _merged(setup, tolerance, segments, switches, last, wall) -> FamilyRun:
    diag = merged_diagnostics(segments, setup.initial.spin_axis)
    spins = ", ".join(f"{seg.setup.model.reference_spin / (2 * math.pi):.5g}" for seg in segments)
    notes = [f"spin family (members {100 * tolerance:.3g} % apart in spin): {len(segments)} "
             f"members about {spins} Hz"]  # fmt: skip
    if switches:
        worst_h = max(sw.h_change for sw in switches)
        worst_e = max(abs(sw.energy_defect / sw.energy) for sw in switches)
        notes.append(f"spin family: {len(switches)} switches, |H| changed by ≤ {worst_h:.1e}, "
                     f"energy defect ≤ {worst_e:.1e} relative (against the FE potential; E kept continuous)")  # fmt: skip
    return FamilyRun(merged_solution(segments, last), diag, family_path_validity(segments, diag),
                     tuple(notes), tuple(switches), last, wall)  # fmt: skip
