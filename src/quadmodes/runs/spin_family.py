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
from quadmodes.rom.diagnostics import Diagnostics, diagnostics
from quadmodes.rom.solution import Solution
from quadmodes.runs import chunked
from quadmodes.runs import family_checkpoint as fck
from quadmodes.runs.family_prefetch import Prefetcher
from quadmodes.runs.family_spacing import (  # noqa: F401  (the family's switching, re-exported)
    DEFAULT_TOLERANCE,
    HYSTERESIS,
    SPIN_RESOLUTION_HZ,
    SwitchMonitor,
    grid_spin,
    member_hz,
    member_spin,
    neighbour_errors,
    spacing_from,
)
from quadmodes.runs.family_validity import family_path_validity, measured_limit  # noqa: F401
from quadmodes.runs.manifold_system import run_system
from quadmodes.runs.step_chunks import integrate_run
from quadmodes.runs.step_chunks import start as controlled_start

#: Gauss–Newton iterations of the chart fit (the charts are 1 % apart: 3 reach round-off).
FIT_ITERATIONS = 8


@dataclass(frozen=True)
class Switch:
    """One switch: time (s) and step, spins from and to (rad/s), the relative change of |H|
    the map made, the energy defect (J: T + V + Π(X_k) of the new member's state minus the old
    one's, module docstring), the path's energy there (J), and the old member measured at the
    new one's spin against it (:func:`~quadmodes.runs.family_spacing.neighbour_errors`): the
    coning rate's and the rotating-frame frequencies' relative errors (NaN: not measured)."""

    time: float
    step: int
    spin_from: float
    spin_to: float
    h_change: float
    energy_defect: float
    energy: float
    sink_error: float = math.nan
    frequency_error: float = math.nan

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
    m1 = dyn.mass_matrix(sys1, s1)  # its rotational rows: h = J̃ω + Aᵀṡ (the manifold's for QM)
    w1 = np.linalg.solve(m1[:3, :3], h - m1[:3, 3:] @ sd1)
    return np.concatenate([y[:4], w1, s1, sd1])


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
    system = run_system(run, model, setup.model_case)  # "QM": from the case's structure
    return dataclasses.replace(setup, model=model, system=system, validity=None)


def _potential_at(structure, model) -> float:
    """Π(X) (J): the FE model's potential at a member's reference."""
    from quadmodes.fe.model import strain_energy

    return float(strain_energy(structure, np.asarray(model.X, float)))


def _energy(system, y: np.ndarray) -> float:
    return float(dyn.kinetic_energy(system, y) + dyn.potential_energy(system, y))


def _segment_chunks(integ, max_chunks: int, last: Segment | None, d_next: float) -> int:
    """The chunk count parameter of the next segment: the run's ``max_chunks``, more where the
    segment ahead is short (a quarter of its expected time, from the rate the last segment's
    spin changed over ``d_next``, its range in ln Ω): a switch cuts its chunk, and the rest of
    the chunk is integrated for nothing."""
    if last is None or len(last.solution.t) < 2 or not d_next > 0:
        return max_chunks
    t, y = last.solution.t, last.solution.y
    spins = member_spin(last.setup.system, y[[0, -1]])
    rate = abs(math.log(spins[-1] / spins[0])) / max(float(t[-1] - t[0]), 1e-12)
    if not rate > 0:
        return max_chunks
    expected = 2.0 * d_next / rate
    return int(min(max(max_chunks, math.ceil(4.0 * integ.duration / expected)), 100 * max_chunks))


def _segment_progress(integ, final, y: np.ndarray, t: float, steps: int, chunk: int,
                      e_d: float) -> chunked.ChunkProgress:  # fmt: skip
    """A chunk progress that starts a new member at time t (s), step ``steps``, from state y:
    the fixed step's chunk of ``chunk`` steps, or (a controlled step) the step the last segment
    proposed, its last chunk kept in the grid (the next step's energy-balance bound)."""
    shown = final.shown if final is not None else 0.0  # the progress shown goes on from there
    if getattr(integ, "step_tolerance", None) is None:
        start = chunked.ChunkProgress.start(y, chunk)
        return dataclasses.replace(start, steps=steps, e_d_offset=e_d, shown=shown)
    start = controlled_start(y, final.h_next if final is not None else integ.dt)
    return dataclasses.replace(start, steps=steps, e_d_offset=e_d, t_done=t, shown=shown,
                               grid=final.grid[-1:] if final is not None else ())  # fmt: skip


@dataclass(eq=False)
class _Family:
    """The state of :func:`integrate_family` between segments (what its checkpoint holds)."""

    setup: object
    spacing: object
    structure: object
    segments: list
    switches: list
    member: object
    y0: np.ndarray
    offset: float
    pi_k: float
    chunks: int
    spins: list  # the spins (rad/s) the members were asked for (the first: the run's)
    wall: float = 0.0

    def pack(self) -> dict:
        return fck.pack(self.segments, self.switches, self.spins, self.offset,
                        self.spacing.state(), self.y0, self.chunks)  # fmt: skip


def _start_family(setup, max_chunks: int, resume, progress):
    """(the :class:`_Family` at its start or at a checkpoint's segment, its resume or None)."""
    from quadmodes.runs.deformation_check import deformation_structure

    structure = deformation_structure(setup)
    spin0 = setup.model.reference_spin
    fam = resume[0].family if resume is not None else None
    if fam is None:
        return _Family(setup, spacing_from(setup.run, spin0), structure, [], [], setup,
                       setup.initial.y0, 0.0, _potential_at(structure, setup.model),
                       max_chunks, [spin0]), resume  # fmt: skip
    members = [setup if k == 0 else _member(setup, float(w), progress)
               for k, w in enumerate(fam["spins"])]  # fmt: skip
    sols = fck.unpack_solutions(fam, setup.run.integration.method,
                                None if setup.run.integration.step_tolerance else
                                setup.run.integration.duration / setup.run.integration.n_steps)  # fmt: skip
    segments = [Segment(m, sol, float(off))
                for m, sol, off in zip(members, sols, fam["offsets"], strict=False)]  # fmt: skip
    state = _Family(setup, spacing_from(setup.run, spin0, fam["spacing"]), structure, segments,
                    [Switch(float(r[0]), int(r[1]), *map(float, r[2:])) for r in fam["switches"]], members[-1], np.asarray(fam["y0"], float),
                    float(fam["offsets"][-1]), _potential_at(structure, members[-1].model),
                    int(fam["chunks"]), [float(w) for w in fam["spins"]], float(resume[1]))  # fmt: skip
    return state, (dataclasses.replace(resume[0], family=None), resume[1])


def _switch(fam: _Family, part, monitor, prefetch, progress) -> tuple:
    """Map the end of the segment ``part`` onto the member ``monitor.spin``: the switch
    recorded, the family moved on; returns the next segment's resume."""
    member, integ = fam.member, fam.setup.run.integration
    y_end, t_end = part.solution.y[-1], float(part.solution.t[-1])
    prefetch.wait(monitor.spin, progress)
    nxt = _member(member, monitor.spin, progress)
    y1 = mapped_state(member.system, member.model, nxt.system, nxt.model, y_end)
    e_before, e_after = _energy(member.system, y_end), _energy(nxt.system, y1)
    pi_next = _potential_at(fam.structure, nxt.model)
    h0 = np.linalg.norm(dyn.momentum_inertial(member.system, y_end))
    h1 = np.linalg.norm(dyn.momentum_inertial(nxt.system, y1))
    final = monitor.final
    step = final.steps if final is not None else int(round(t_end / (integ.duration / integ.n_steps)))
    last = Solution(part.solution.t[-1:], y_end[None, :], "", {}, 0, "")
    cone = float(diagnostics(member.system, last, spin_axis=fam.setup.initial.spin_axis).cone_angle[-1])
    eps_c, eps_f = neighbour_errors(member.system, nxt.system, cone)
    jump = abs(math.log(nxt.model.reference_spin / member.model.reference_spin))
    fam.spacing.switched(eps_c / jump if jump > 0 else math.nan)
    fam.switches.append(Switch(t_end, step, member.model.reference_spin, nxt.model.reference_spin,
                               abs(h1 / h0 - 1.0), (e_after + pi_next) - (e_before + fam.pi_k),
                               e_before + fam.offset, eps_c, eps_f))  # fmt: skip
    fam.offset, fam.pi_k = fam.offset + e_before - e_after, pi_next  # E continuous at the switch
    fam.member, fam.y0 = nxt, y1
    fam.spins.append(float(monitor.spin))
    fam.chunks = _segment_chunks(integ, fam.chunks, fam.segments[-1], fam.spacing.limit())
    chunk = chunked._chunk_steps(integ.n_steps, integ.save_every, fam.chunks)
    return (_segment_progress(integ, final, y1, t_end, step, chunk,
                              float(part.solution.dissipated[-1])), fam.wall)  # fmt: skip


def integrate_family(setup, progress=None, max_chunks: int = chunked.MAX_CHUNKS, *,
                     checkpoint=None, resume=None):  # fmt: skip
    """(segments, switches, ChunkedRun of the last segment, wall time s, spacing) of a prepared
    run (:class:`~quadmodes.runs.simulate.RunSetup` about a spinning state) integrated by a
    family of members (module docstring), each segment at the run's fixed or controlled step
    (:func:`quadmodes.runs.step_chunks.integrate_run`). Times and steps are the run's global
    ones. ``checkpoint`` (the run's :class:`~quadmodes.runs.run_checkpoint.RunCheckpoint`):
    saved at each segment's start and whenever due; ``resume``: its (progress, wall) of this
    run, the family continued where it stood (:mod:`quadmodes.runs.family_checkpoint`)."""
    fam, resume = _start_family(setup, max_chunks, resume, progress)
    ckpt = None if checkpoint is None else fck.FamilyCheckpoint(checkpoint, fam.pack)
    prefetch = Prefetcher(setup)
    try:
        return _segments(fam, resume, ckpt, prefetch, progress)
    finally:
        prefetch.close()


def _segments(fam: _Family, resume, ckpt, prefetch: Prefetcher, progress):
    """The loop of :func:`integrate_family`, segment after segment, the next member built
    ahead (:mod:`quadmodes.runs.family_prefetch`) in the direction of the last switch."""
    from quadmodes.runs.events import run_event

    run = fam.setup.run
    # the run's progress counts from the path's start, not the segment's (events.EventMonitor.start)
    first = run_event(fam.setup.system, fam.setup.initial, run)
    while True:
        member = fam.member
        if fam.switches:
            sign = 1.0 if fam.switches[-1].spin_to > fam.switches[-1].spin_from else -1.0
            prefetch.ahead(fam.spacing.predicted(float(np.linalg.norm(member.system.reference_omega)), sign))
        event = run_event(member.system, dataclasses.replace(member.initial, y0=fam.y0), run)
        if event is not None:
            event = dataclasses.replace(event, start=first.start)
        t0 = float(fam.switches[-1].time) if fam.switches else 0.0
        monitor = SwitchMonitor(member.system, fam.spacing, event, t0)
        start = time.perf_counter()
        try:
            part = integrate_run(member.system, fam.y0, run.integration, progress, run.name,
                                 fam.chunks, checkpoint=ckpt, resume=resume, event=monitor)  # fmt: skip
        except chunked.Interrupted as stop:  # Ctrl-C: the path so far, raised by run_family
            fam.segments.append(Segment(member, stop.partial.solution, fam.offset))
            raise Stopped(fam, stop.partial, stop.reason, stop.saved) from None
        fam.wall += time.perf_counter() - start
        done = float(part.solution.t[-1]) >= run.integration.duration * (1.0 - 1e-12)
        if monitor.spin is None or part.reason or done:  # (a switch at the very end: none)
            fam.segments.append(Segment(member, part.solution, fam.offset))
            return fam, part
        segment = Segment(member, part.solution, fam.offset)
        fam.segments.append(segment)
        resume = _switch(fam, part, monitor, prefetch, progress)
        if ckpt is not None:  # the new segment's start: a resume continues from here
            ckpt.save(resume[0], fam.wall)


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
             "n_newton", "n_jac", "n_probe_steps", "n_chunks")}  # fmt: skip
    for key, pick in (("dt_min_s", min), ("dt_max_s", max)):  # a controlled step's range
        found = [s.stats[key] for s in sols if s.stats.get(key) is not None]
        if found:
            stats[key] = pick(found)
    stats["wall_s"] = last.wall_s
    return Solution(np.concatenate([cut(k, s.t) for k, s in enumerate(sols)]),
                    np.concatenate([cut(k, s.y) for k, s in enumerate(sols)]),
                    last.solution.method, stats, last.solution.status, last.solution.message,
                    np.concatenate([cut(k, s.dissipated) for k, s in enumerate(sols)]),
                    last.solution.dt)  # fmt: skip


def check_family_run(run) -> None:
    """Refuse what a spin-family run does not support yet (one line, the field named)."""
    if run.reduced.reference != "spinning":
        raise CaseError('reduced.path_model = "spin-family" needs reduced.reference = "spinning"; '
                        "set it, or drop path_model", field="reduced.path_model")  # fmt: skip
    if run.reduced.formulation not in ("Q", "P", "L", "QM"):
        raise CaseError(f'reduced.path_model = "spin-family" takes formulation Q, P, L or QM, not '
                        f'{run.reduced.formulation}', field="reduced.formulation")  # fmt: skip


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
    """Ctrl-C inside :func:`integrate_family`: the family so far (its segments, switches and
    wall time), the last segment's partial ChunkedRun, the reason and whether a checkpoint holds
    it (turned into a :class:`~quadmodes.runs.chunked.Interrupted` carrying the
    :class:`FamilyRun` by :func:`run_family`)."""

    def __init__(self, fam, last, reason: str, saved: bool = False):
        super().__init__(reason)
        self.parts, self.saved = (fam, last), saved


def run_family(setup, progress=None, max_chunks: int = chunked.MAX_CHUNKS, *, checkpoint=None,
               resume=None) -> FamilyRun:  # fmt: skip
    """:func:`integrate_family` of a prepared run (members by its ``reduced.path_switch`` or
    ``reduced.path_tolerance``), merged (:class:`FamilyRun`); ``checkpoint``, ``resume``: as
    there. Ctrl-C raises :class:`~quadmodes.runs.chunked.Interrupted` whose ``partial`` is the
    :class:`FamilyRun` so far (saved to the checkpoint, if any)."""
    try:
        return _merged(*integrate_family(setup, progress, max_chunks, checkpoint=checkpoint,
                                         resume=resume))  # fmt: skip
    except Stopped as stop:
        raise chunked.Interrupted(_merged(*stop.parts), stop.saved, str(stop)) from None


def _merged(fam: _Family, last) -> FamilyRun:
    setup, segments, switches = fam.setup, fam.segments, fam.switches
    diag = merged_diagnostics(segments, setup.initial.spin_axis)
    spins = ", ".join(f"{w / (2 * math.pi):.7g}" for w in fam.spins)
    notes = [f"spin family ({fam.spacing.describe()}): {len(segments)} members about {spins} Hz"]
    if switches:
        worst_h = max(sw.h_change for sw in switches)
        worst_e = max(abs(sw.energy_defect / sw.energy) for sw in switches)
        notes.append(f"spin family: {len(switches)} switches, |H| changed by ≤ {worst_h:.1e}, "
                     f"energy defect ≤ {worst_e:.1e} relative (against the FE potential; E kept continuous)")  # fmt: skip
        sink = [sw.sink_error for sw in switches if math.isfinite(sw.sink_error)]
        freq = [sw.frequency_error for sw in switches if math.isfinite(sw.frequency_error)]
        if sink:
            notes.append(f"spin family: neighbouring members differ by {100 * min(sink):.2g}–"
                         f"{100 * max(sink):.2g} % in the coning rate and ≤ {100 * max(freq, default=0):.2g} % "
                         "in the rotating-frame frequencies, each at the next one's spin")  # fmt: skip
    return FamilyRun(merged_solution(segments, last), diag, family_path_validity(segments, diag, switches),
                     tuple(notes), tuple(switches), last, fam.wall)  # fmt: skip
