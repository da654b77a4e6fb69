"""A controlled step for the midpoint between chunks (``integration.step_tolerance``): a long
path (10⁷ steps) takes the step its answer needs where it is, not the smallest it ever needs.

The midpoint step (:mod:`quadmodes.rom.midpoint`) is a map (ν₀, s₀, q₀) → (ν₁, s₁, q₁) of its own
step Δt: ``h₁ = exp(−Δt ω̂½) h₀`` and ``q₁ = q₀ ⊗ exp(Δt ω½/2)`` hold whatever the Δt of the
step before, so R h, hence |H|, is conserved to round-off across a change of step too; the
discrete energy balance ``E₁ − E₀ = −Δt ṡ½ᵀCṡ½`` (exact for the quadratic part) holds step by
step; a change of step changes only the O(Δt²) energy error of the kinetic terms (bounded
without damping, a drift with the dissipation: :func:`balance_step`) from its size at one step to
its size at the other.

The chunk loop stays compiled: each chunk is one call of the fixed-step kernel
(:mod:`quadmodes.rom.midpoint_kernel`) at its own step. Before a chunk, its step h is **probed**
by step doubling from the chunk's first state: ``n`` steps of h against ``n/2`` steps of 2h over
the same probe time T_p. The midpoint is second order, so the difference of the two is 3× the
error of the run at h (Richardson, 2² − 1):

* a damped body: the relative error of the energy dissipated over the probe,
  ``|E_d(h) − E_d(2h)| / (3 E_d(h))`` — the dissipated power is the secular answer's driver (the
  cone grows by the energy-sink law), and its error is what a too-coarse step does to a run
  (near a resonance of the nutation with a mode, the forced response and its power are the
  quantities most sensitive to the midpoint's frequency warping);
* an undamped body (or one dissipating nothing over the probe): the relative difference of the
  body-frame state (ω, and (s, ṡ) in the energy-weighted norm), / 3.

T_p: four relaxation times of the slowest damped mode (2 / the smallest rate of μ⁻¹C), at least 10
periods of the spin, at most a quarter of the chunk: both legs start from the same state, which
is on the forced response of the run's own step; the 2h leg's forced response settles to its own
within a few relaxation times, and the probe's average power then measures the steady error.

The step is accepted when the estimate is ≤ the tolerance, else shrunk and probed again; a
step well inside the tolerance is grown and probed again before the chunk (:func:`choose_step`;
:func:`next_step`: ``h·clip(0.8 (tol/err)^(1/2), ¼, 2)``: the error measured is that of a run
over a fixed time, O(h²), not a local error per step); the next chunk starts from the accepted
step grown or shrunk by the same rule, and no longer than the energy balance allows
(:func:`balance_step`): the midpoint's discrete balance ``E₁ − E₀ = −Δt ṡ½ᵀCṡ½`` is exact for
the quadratic part only for formulations Q, P, L, Q4 (the quadratic modes' kinetic energy is
not quadratic, and the balance defect, O(h²), drifts with the dissipation); formulation QM's
step uses a discrete gradient of its kinetic energy and keeps the balance to the Newton
tolerance, so for it this bound does not bind (docs/manifold-formulation.md). After each chunk the change of E + E_d over it is
compared with :data:`BALANCE` × the larger of the energy it dissipated and E₀ × its time / the
run's duration (over the run at most BALANCE (E_d + E₀) ≤ 1e-6 E₀), and the next step is cut
by the square root of the excess. (A probe cannot measure that drift: over a probe the bounded
oscillation of the energy error hides it.)
Bounds: ``dt/64 ≤ h ≤ 64 dt`` (dt the case's step) and at least :data:`MIN_STEPS_PER_TURN`
steps a period of the body's angular velocity |ω|.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from quadmodes.rom import dynamics as dyn
from quadmodes.rom import integrators
from quadmodes.rom.system import ReducedSystem

#: Order of the midpoint (the error of a run over a fixed time is O(h^ORDER)).
ORDER = 2
#: Safety factor of the step proposed from an estimate.
SAFETY = 0.8
#: Largest growth and shrink factors of the step between two probes.
GROW_MAX, SHRINK_MIN = 2.0, 0.25
#: The step never exceeds one of this many per period of |ω| (the spin and its coning: the
#: Lie-group step is exact for a rigid rotation, but the forcing of the modes is at that rate).
MIN_STEPS_PER_TURN = 10.0
#: The step stays within [dt / RANGE, dt · RANGE] of the case's dt.
RANGE = 64.0
#: The energy balance E + E_d the step keeps: the midpoint's discrete balance is exact for the
#: quadratic part only, and its defect (O(h²), a drift that follows the dissipation: 4e-7 of it
#: at 0.5 ms on paper-41hz-coarse, 1.5e-4 at 40 ms on hub-booms) may be this times the larger of
#: the energy dissipated and E₀ × the time / the run's duration, over each chunk: over the run at
#: most BALANCE × (E_d + E₀) ≤ 1e-6 E₀ (checked after every chunk: :func:`balance_step`).
BALANCE = 5e-7
#: Probes of one chunk before the step is accepted as it is (the last shrink is then used).
MAX_PROBES = 6


@dataclass(frozen=True)
class StepEstimate:
    """The probe of one step: ``h`` (s), the error estimate ``err`` (relative, of the run at h),
    what it measures (``"dissipated power"`` or ``"body state"``), the probe's ``n_probe``
    steps of h and its work counters ``stats`` (n_steps, n_newton, n_jac: both legs)."""

    h: float
    err: float
    measure: str
    n_probe: int
    stats: dict


def relaxation_time(sys: ReducedSystem) -> float:
    """2 / (smallest positive eigenvalue of μ⁻¹C) (s): 1 / (ζω) of the slowest decaying mode;
    inf without damping."""
    if sys.n_modes == 0:
        return math.inf
    rate = np.linalg.eigvals(np.linalg.solve(sys.mu, sys.C)).real
    rate = rate[rate > 1e-12 * max(1.0, float(np.abs(rate).max()))]
    return 2.0 / float(rate.min()) if len(rate) else math.inf


def spin_period(y: np.ndarray) -> float:
    """2π/|ω| (s) of the state y (7+2N,); inf at rest."""
    w = float(np.linalg.norm(y[4:7]))
    return 2 * math.pi / w if w > 0 else math.inf


def probe_time(sys: ReducedSystem, y: np.ndarray) -> float:
    """T_p (s) of a probe from the state y: 4 relaxation times, at least 10 spin periods (10
    spin periods for an undamped body)."""
    tp = 4.0 * relaxation_time(sys)
    return max(tp, 10.0 * spin_period(y)) if math.isfinite(tp) else 10.0 * spin_period(y)


def probe_steps(sys: ReducedSystem, y: np.ndarray, h: float, chunk_time: float) -> int:
    """Steps of h (even, ≥ 8) of the probe: :func:`probe_time`, at most a quarter of
    ``chunk_time`` (s)."""
    tp = min(probe_time(sys, y), 0.25 * chunk_time)
    n = int(math.ceil(tp / h))
    return max(8, n + (n % 2))


def _leg(sys, y, h, n, newton_tol):
    """(end state, dissipated energy, stats, ok) of n midpoint steps of h from y."""
    sol = integrators.integrate(sys, y, (0.0, n * h), "midpoint", dt=h, save_every=n,
                                newton_tol=newton_tol)  # fmt: skip
    return sol.y[-1], float(sol.dissipated[-1]), sol.stats, sol.status == 0


def _state_difference(sys: ReducedSystem, ya: np.ndarray, yb: np.ndarray) -> float:
    """Relative difference of two body-frame states: max of |Δω|/|ω| and the modal
    (s, ṡ) difference in the norm √(Σ|Λ_kk| s_k² + Σ μ_kk ṡ_k²) relative to ya's."""
    n = sys.n_modes
    w = np.linalg.norm(ya[4:7])
    d = float(np.linalg.norm(ya[4:7] - yb[4:7]) / w) if w > 0 else 0.0
    if n:
        wt = np.concatenate([np.sqrt(np.abs(np.diag(sys.Lam))), np.sqrt(np.diag(sys.mu))])
        za, zb = ya[7:] * wt, yb[7:] * wt
        ref = float(np.linalg.norm(za))
        if ref > 0:
            d = max(d, float(np.linalg.norm(za - zb)) / ref)
    return d


def probe(sys: ReducedSystem, y: np.ndarray, h: float, n: int,
          newton_tol: float = 1e-13) -> StepEstimate:  # fmt: skip
    """The step-doubling estimate of the run's error at step h (s) from the state y (7+2N,):
    n steps of h against n/2 of 2h (module docstring). A leg whose Newton fails gives err = inf
    (the step is too long)."""
    ya, eda, sa, oka = _leg(sys, y, h, n, newton_tol)
    yb, edb, sb, okb = _leg(sys, y, 2.0 * h, n // 2, newton_tol)
    stats = {k: int(sa.get(k, 0)) + int(sb.get(k, 0)) for k in ("n_steps", "n_newton", "n_jac")}
    if not (oka and okb and np.all(np.isfinite(ya)) and np.all(np.isfinite(yb))):
        return StepEstimate(h, math.inf, "failed", n, stats)
    energy = abs(float(dyn.energy(sys, y[None, :])[0]))
    denom = (2**ORDER) - 1
    if eda > 1e-12 * energy:  # a body that dissipates: the relative error of the power
        return StepEstimate(h, abs(eda - edb) / (denom * eda), "dissipated power", n, stats)
    return StepEstimate(h, _state_difference(sys, ya, yb) / denom, "body state", n, stats)


def step_bounds(dt: float, y: np.ndarray) -> tuple[float, float]:
    """(h_min, h_max) (s) about the case's step ``dt`` at the state y (module docstring)."""
    h_max = min(RANGE * dt, spin_period(y) / MIN_STEPS_PER_TURN)
    return dt / RANGE, max(h_max, dt / RANGE)


def next_step(h: float, err: float, tol: float, h_min: float, h_max: float) -> float:
    """The step proposed after an estimate ``err`` at h (s) for the tolerance ``tol``:
    ``h·clip(SAFETY (tol/err)^(1/ORDER), SHRINK_MIN, GROW_MAX)`` within [h_min, h_max]."""
    if not math.isfinite(err):
        factor = SHRINK_MIN
    elif err <= 0.0:
        factor = GROW_MAX
    else:
        factor = min(GROW_MAX, max(SHRINK_MIN, SAFETY * (tol / err) ** (1.0 / ORDER)))
    return float(min(h_max, max(h_min, h * factor)))


def balance_step(h: float, defect: float, allowed: float) -> float:
    """The step (s) after a chunk at step h whose energy balance E + E_d changed by ``defect``
    (J) where ``allowed`` (J) was allowed (:data:`BALANCE`; the defect is O(h²)):
    ``h·clip(SAFETY (allowed/|defect|)^(1/2), SHRINK_MIN, GROW_MAX)``."""
    defect = abs(defect)
    if defect <= 0.0:
        return GROW_MAX * h
    return h * min(GROW_MAX, max(SHRINK_MIN, SAFETY * math.sqrt(allowed / defect)))


def choose_step(sys: ReducedSystem, y: np.ndarray, h: float, dt: float, tol: float,
                chunk_time: float, newton_tol: float = 1e-13,
                h_cap: float = math.inf):  # fmt: skip
    """(accepted step h (s), its :class:`StepEstimate`, next proposed step, summed probe
    stats) for a chunk of ``chunk_time`` (s) from y, starting from the proposal h.

    A passing probe (estimate ≤ ``tol``) is grown and probed again while the rule proposes a
    step at least 1.5× longer (the first chunk does not wait for the next to grow); a failing
    one is shrunk and probed again, and once a step has passed, the longest that passed is
    taken. At most :data:`MAX_PROBES` probes; at h_min the step is taken as it is. ``h_cap``
    (s): a longest step from elsewhere (the energy balance, :func:`balance_step`)."""
    h_min, h_max = step_bounds(dt, y)
    h_max = max(h_min, min(h_max, h_cap))
    h = float(min(h_max, max(h_min, h)))
    stats = {"n_steps": 0, "n_newton": 0, "n_jac": 0}
    best = None  # (h, estimate) of the longest passing step
    est = None
    for _ in range(MAX_PROBES):
        est = probe(sys, y, h, probe_steps(sys, y, h, chunk_time), newton_tol)
        stats = {k: stats[k] + est.stats[k] for k in stats}
        proposal = next_step(h, est.err, tol, h_min, h_max)
        if est.err <= tol or h <= h_min:
            best = (h, est)
            if proposal < 1.5 * h:
                break
        elif best is not None:
            break
        h = proposal
    if best is None:  # every probe failed: the last shrink, not probed
        return h, est, h, stats
    h, est = best
    return h, est, next_step(h, est.err, tol, h_min, h_max), stats
