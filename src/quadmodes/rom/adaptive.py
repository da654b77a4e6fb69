"""Adaptive integration of the reduced equations with scipy's Runge–Kutta solvers (the classes
behind ``solve_ivp``), stepped here so that steps are counted and dense output is sampled at
the requested times. ``E_d`` (J) is integrated as an extra state, dE_d/dt = ṡᵀCṡ."""

from __future__ import annotations

import numpy as np
from scipy import integrate as _ode

from quadmodes.rom.dynamics import rhs
from quadmodes.rom.solution import work_counters
from quadmodes.rom.system import ReducedSystem

ADAPTIVE_SOLVERS = {"DOP853": _ode.DOP853, "Radau": _ode.Radau, "RK45": _ode.RK45}


def _augmented_rhs(sys: ReducedSystem, counter: list):
    """d/dt [y, E_d] (8+2N,) of the free body, counting its evaluations in ``counter[0]``."""
    n = sys.n_modes
    c_mat = sys.C

    def fun(t, z):
        counter[0] += 1
        dz = np.empty_like(z)
        dz[:-1] = rhs(sys, t, z[:-1])
        sd = z[7 + n : 7 + 2 * n]
        dz[-1] = sd @ c_mat @ sd
        return dz

    return fun


class _DenseSamples:
    """Samples of an adaptive run at the times ``t_eval`` (s), from each step's dense output;
    ``t_eval`` None: every ``save_every``-th accepted step plus the last."""

    def __init__(self, t0, z0, t_eval, save_every):
        self.t_eval = None if t_eval is None else np.asarray(t_eval, float)
        self.save_every = save_every
        self.k = 0
        self.ts, self.zs = [t0], [z0]
        if self.t_eval is not None:
            te = self.t_eval
            while self.k < len(te) and te[self.k] <= t0:
                self.k += 1
            self.ts, self.zs = ([t0], [z0]) if (len(te) and te[0] <= t0) else ([], [])

    def after_step(self, ode, n_steps):
        """Record what the step just accepted (``n_steps`` so far) contributes."""
        te = self.t_eval
        if te is None:
            if n_steps % self.save_every == 0 or ode.status == "finished":
                self.ts.append(ode.t)
                self.zs.append(ode.y.copy())
            return
        j = self.k
        while j < len(te) and te[j] <= ode.t:
            j += 1
        if j > self.k:
            vals = ode.dense_output()(te[self.k : j])
            self.ts.extend(te[self.k : j])
            self.zs.extend(vals.T)
            self.k = j


def run_adaptive(sys: ReducedSystem, y0, t_span, solver, rtol, atol, t_eval, save_every):
    """Integrate from ``y0`` (7+2N,) over ``t_span`` (s) with ``solver`` in ADAPTIVE_SOLVERS.
    Returns (t (K,), ys (K, 7+2N), dissipated (K,), stats, status, message); on failure the
    last sample is the solver's last state."""
    counter = [0]
    z0 = np.append(y0, 0.0)
    if np.ndim(atol):
        atol = np.append(np.asarray(atol, float), np.min(atol))
    t0, t1 = t_span
    ode = ADAPTIVE_SOLVERS[solver](_augmented_rhs(sys, counter), t0, z0, t1, rtol=rtol, atol=atol)
    samples = _DenseSamples(t0, z0, t_eval, save_every)
    n_steps = 0
    status, msg = 0, "ok"
    while ode.status == "running":
        m = ode.step()
        if ode.status == "failed":
            status, msg = 1, f"{solver} failed at step {n_steps + 1} (t = {ode.t:.6g} s): {m}"
            break
        n_steps += 1
        samples.after_step(ode, n_steps)
    if status:
        samples.ts.append(ode.t)
        samples.zs.append(ode.y.copy())
    z = np.array(samples.zs).reshape(-1, len(z0))
    stats = work_counters(n_steps, counter[0], 0, int(ode.njev))
    if hasattr(ode, "nlu"):
        stats["n_lu"] = int(ode.nlu)
    return np.asarray(samples.ts, float), z[:, :-1], z[:, -1], stats, status, msg
