"""Helpers shared by more than one benchmark script (one home each, instead of scripts importing
each other). Run the scripts from the repository root as modules, e.g.
``python -m benchmarks.studies.bench_wrinkled_rom --help`` (benchmarks/README.md).

* :data:`CASES`: the benchmark-only case files (``benchmarks/cases/``);
* large-amplitude runs: :func:`variant` (a run case with an initial bending amplitude), the
  bending frequency from zero crossings (:func:`upward_crossings`, :func:`crossing_frequency`,
  :data:`EARLY_PERIODS`);
* the full order's body-frame displacements (:func:`body_displacements`,
  :func:`recorded_full_order`);
* the static gate's energies along a ray (:func:`run_case_with_modes`, :func:`modal_scale`,
  :func:`one_ray`, :func:`compressed_fraction`; docs/potentials.md).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

import quadmodes.fullorder.kinematics as kin
from quadmodes.analysis.full_order_runs import full_order_for_run, setup_for_run
from quadmodes.case import load_run_case, run_case_from_dict
from quadmodes.experimental import candidate_potentials as cand
from quadmodes.rom import manifold_energy as me
from quadmodes.runs import simulate as sim

#: The benchmark-only case files (run and model cases used by the studies).
CASES = Path(__file__).resolve().parent / "cases"


# ---------------------------------------------------------------------------------------------
# Large-amplitude runs: the bending frequency from zero crossings
# ---------------------------------------------------------------------------------------------

#: Periods of the large-amplitude part of a decaying transient over which the early frequency is
#: taken (at 0.5 in on the coarse tension-field mesh the bending amplitude falls below a tenth of
#: its initial value within about three periods).
EARLY_PERIODS = 3


def upward_crossings(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times (s) of the upward zero crossings of ``y(t)`` (linear interpolation between samples).

    About zero, the coordinate's value at the relative equilibrium, not about the signal's mean:
    a wrinkling transient leaves a mean offset of the order of the late amplitude, and crossings
    of ``y - mean`` stop once the decaying signal no longer reaches it (before session 10 the
    0.5 in tension-field figure, 31.94 Hz, so averaged only over 0–0.55 s)."""
    i = np.flatnonzero((y[:-1] < 0.0) & (y[1:] >= 0.0))
    return t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])


def crossing_frequency(t: np.ndarray, y: np.ndarray, periods: int | None = None) -> float:
    """Frequency (Hz) from the mean spacing of the upward zero crossings of ``y(t)``
    (:func:`upward_crossings`), over the first ``periods`` periods only if given (the
    large-amplitude part of a decaying transient); NaN with fewer than two crossings."""
    tc = upward_crossings(np.asarray(t, float), np.asarray(y, float))
    if periods is not None:
        tc = tc[: periods + 1]
    if len(tc) < 2:
        return float("nan")
    return float((len(tc) - 1) / (tc[-1] - tc[0]))


def variant(run, amplitude_in: float, reference: str, modes):
    """``run`` with the initial bending amplitude (in) and the reduced-model choice."""
    red = run.reduced.model_copy(update={"reference": reference, "modes": modes})
    ini = run.initial.model_copy(update={"bending_amplitude": amplitude_in * 0.0254})
    return run.model_copy(update={"reduced": red, "initial": ini,
                                  "name": f"{run.name}-{amplitude_in:g}in"})  # fmt: skip


# ---------------------------------------------------------------------------------------------
# The full order's body-frame displacements
# ---------------------------------------------------------------------------------------------


def body_displacements(st, positions: np.ndarray) -> np.ndarray:
    """Mean-axes body-frame displacements ``(k, n, 3)`` m of sampled positions ``(k, n, 3)``
    relative to the reference about the centre of mass."""
    tr = st.structure.translational
    x_ref = np.asarray(st.model.X, float)
    body = kin.make_body(st.structure.mass_scalar, tr, x_ref, None, False)
    out = np.empty_like(positions)
    for i, x in enumerate(positions):  # diagnostics on ~10^3 samples, not a hot path
        c = kin.centre(body, x)
        out[i] = (x - np.outer(tr, c)) @ kin.best_fit_rotation(body, x, c) - x_ref
    return out


def recorded_full_order(run, dt: float):
    """``(sol, st, u)``: the full order of ``run`` at step ``dt`` (s), its setup and its
    body-frame displacements ``(k, 3n)`` m at the samples (:func:`body_displacements`)."""
    st = setup_for_run(run)
    samples: list[np.ndarray] = []
    sol = full_order_for_run(run, dt=dt, setup=st, on_sample=lambda t, x: samples.append(x.copy()))
    return sol, st, body_displacements(st, np.array(samples)).reshape(len(samples), -1)


# ---------------------------------------------------------------------------------------------
# The static gate: energies along a ray (docs/potentials.md)
# ---------------------------------------------------------------------------------------------


def run_case_with_modes(name: str, modes: int, duration: str):
    """The run case ``name`` with ``reduced.modes = modes``, formulation Q4, ``duration``."""
    run = sim.apply_overrides(load_run_case(name), duration=duration, formulation="Q4")
    data = tomllib.loads(run.to_toml())
    data["reduced"]["modes"] = int(modes)
    return run_case_from_dict(data, source="bench_potentials")


def modal_scale(model) -> np.ndarray:
    """``D`` (N,): largest nodal displacement (m) per unit modal coordinate of each mode."""
    t = np.asarray(model.translational, bool)
    return np.array([np.max(np.linalg.norm(p[t], axis=1)) for p in model.Phi])


def one_ray(ctx, model, q4, scale, d, radii, minimisers=None):
    """Energies ``(len(radii), 5)`` [Q, Q4, QE, W_red, W_c] (J) along ``s = r D⁻¹ d``, and
    ``(len(radii), 2)`` [W_c converged, Newton iterations]; the W_c minimisers y are appended
    to the list ``minimisers`` if given."""
    out = np.zeros((len(radii), 5))
    info = np.zeros((len(radii), 2))
    ys, rs, eta = [], [], None
    for j, r in enumerate(radii):
        s = r * d / scale
        wr = cand.condensed_quadratic_mode_energy(ctx, s, eta)
        eta = wr.unknowns
        cands = [ctx.g_perp @ wr.unknowns] + ys[-1:]
        if len(ys) >= 2:
            cands.append(ys[-1] + (r - rs[-1]) * (ys[-1] - ys[-2]) / (rs[-1] - rs[-2]))
        wc = me.condensed_energy(ctx, s, cand.best_start(ctx, s, cands))
        ys.append(wc.unknowns)
        rs.append(r)
        out[j] = [
            cand.quadratic_potential(model, s),
            cand.quartic_potential(q4, s),
            cand.manifold_energy(ctx, s),
            wr.value,
            wc.value,
        ]
        info[j] = [wc.converged and wr.converged, wc.iterations]
    if minimisers is not None:
        minimisers.extend(ys)
    return out, info


def compressed_fraction(structure, x) -> float:
    """Fraction of membrane elements whose minor principal stress resultant is ≤ 0 at ``x``."""
    from quadmodes.fe.membrane import MembraneSet

    mem = [e for e in structure.elements if isinstance(e, MembraneSet)]
    minor = np.concatenate([e.principal_stress_resultants(x)[:, 0] for e in mem])
    return float(np.mean(minor <= 0.0))


# ---------------------------------------------------------------------------------------------
# Mesh convergence of branch frequencies against a closed form (the spinning disc and annulus)
# ---------------------------------------------------------------------------------------------


def mesh_convergence_figure(ks, series: dict, h2_coefficient: float, xlabel: str, ylabel: str,
                            title: str, path) -> None:  # fmt: skip
    """Relative error (fractions, one list per branch label in ``series``, in the order of
    ``ks``) against the mesh size 1/k on log axes, with an h² guide of ``h2_coefficient``
    and the 1 % line; written to ``path`` (PNG)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    h = np.array([1.0 / k for k in ks])
    for label, errors in series.items():
        ax.loglog(h, 100 * np.abs(np.asarray(errors)), "o-", lw=1, ms=3, label=label)
    ax.loglog(h, 100 * h2_coefficient * h**2, "k--", lw=1, label="∝ h²")
    ax.axhline(1.0, color="0.5", lw=0.8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=6, ncol=3)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    print(f"figure: {path}")
