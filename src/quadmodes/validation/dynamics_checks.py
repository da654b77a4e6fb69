"""Validation suite, dynamics part: the reduced model and the full-order reference against
published numbers (``../shared/references.md``) and against each other.

Each check returns :class:`quadmodes.validation.report.Row` values; ``quadmodes validate`` runs
them (``--suite``) and writes the tables to docs/validation.md. ``FAST`` names the checks cheap
enough for the test suite.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from quadmodes.rom import integrators as integ
from quadmodes.rom import system as rsys
from quadmodes.validation.report import Check, Row

REF2 = "references §2 (one mode, ζ = 0.02, Δt = 2.5 ms)"
REF3 = "references §3 (Kane et al. spin-up)"


def _one_mode_system(f_hz: float, zeta: float) -> rsys.ReducedSystem:
    """A single damped mode on a rigid unit-inertia body (no coupling): the references §2 case."""
    from quadmodes.rom.reduced import ReducedModel

    w = 2 * math.pi * f_hz
    z = np.zeros
    model = ReducedModel(
        mass=1.0, free=True, frequencies_hz=np.array([f_hz]), damping_ratio=np.array([zeta]),
        labels=("mode",), J0=np.eye(3), J1=z((1, 3, 3)), J2u=z((1, 1, 3, 3)),
        J2g=z((1, 1, 3, 3)), c=z((1, 3)), Cuu=z((1, 1, 3)), Cxg=z((1, 1, 3)), S1=z((1, 3)),
        S2=z((1, 1, 3)), mu=np.eye(1), Lam=np.array([[w * w]]), C=np.array([[2 * zeta * w]]),
        X=z((1, 3)), translational=np.ones(1, bool), weights=np.ones(1), Phi=z((1, 1, 3)),
        G=z((1, 1, 1, 3)),
    )
    return rsys.reduced_system(model, "Q")


def one_step_damping(method: str, f_hz: float, zeta: float, dt: float) -> tuple[float, float]:
    """(ζ_eff, f_num in Hz) of the one-step map of one damped mode, through the stepping code:
    the map's eigenvalue z gives λ = ln z / Δt, ζ_eff = −Re λ/|λ|, f_num = |Im λ|/2π."""
    w = 2 * math.pi * f_hz
    sys = _one_mode_system(f_hz, zeta)
    cols = []
    for s0, sd0 in ((1.0, 0.0), (0.0, w)):
        sol = integ.integrate(sys, rsys.pack_state(sys, s=[s0], sdot=[sd0]), (0, dt), method, dt=dt)
        cols.append(sol.y[-1, 7:9] / [1.0, w])
    z = np.linalg.eigvals(np.array(cols).T)[0]
    lam = np.log(z) / dt
    return float(-lam.real / abs(lam)), float(abs(lam.imag) / (2 * math.pi))


def check_backward_euler() -> list[Row]:
    """Numerical damping and frequency of backward Euler and midpoint at the seed's step."""
    rows = []
    for method, zeta_ref, f_ref in (("backward-euler", 0.289, 33.9), ("midpoint", 0.0189, 36.92)):
        zeta, f = one_step_damping(method, 38.0, 0.02, 2.5e-3)
        rows += [
            Row(f"{method} 2.5 ms, 38 Hz mode: ζ_eff", zeta, zeta_ref, 0.03, source=REF2),
            Row(f"{method} 2.5 ms, 38 Hz mode: f_num", f, f_ref, 0.01, "Hz", source=REF2),
        ]
    return rows


def check_kane_reduced() -> list[Row]:
    """Kane spin-up with formulation Q (20 ANCF elements, 4 in-plane modes): peaks and times."""
    from quadmodes.models.beam import kane_model
    from quadmodes.runs.spinup import KANE_REFERENCE_PEAKS, kane_spinup

    model = kane_model(n_modes=4, n_elements=20)
    rows = []
    for ws, (v_ref, t_ref) in KANE_REFERENCE_PEAKS.items():
        r = kane_spinup(ws, model=model)
        rows += [
            Row(f"Kane Q, Ωs = {ws:g} rad/s: peak tip deflection", r.peak_deflection, v_ref,
                0.03, "m", source=REF3),
            Row(f"Kane Q, Ωs = {ws:g} rad/s: time of peak", r.peak_time, t_ref, 0.2, "s",
                absolute=True, source=REF3),
        ]
    lin = kane_spinup(6.0, model=model, formulation="L")
    rows.append(
        Row("Kane L, Ωs = 6 rad/s: diverges (1 = diverged)", float(lin.status != "ok"), 1.0, 0.0,
            absolute=True, source=REF3 + ": linear modes diverge above 3.80 rad/s")
    )
    return rows


def check_kane_campbell() -> list[Row]:
    """First chordwise rotating-frame frequency of the Kane beam at steady spin (Q)."""
    from quadmodes.analysis.campbell import campbell
    from quadmodes.models.beam import kane_model
    from quadmodes.runs.spinup import KANE_REFERENCE_CHORDWISE

    beam = kane_model(n_modes=4, out_of_plane=True)
    spins = sorted(KANE_REFERENCE_CHORDWISE)
    r = campbell(beam, spins, axis=[0, 0, 1], formulation="Q")
    b = r.branch("in-plane bending 1")
    return [
        Row(f"Kane chordwise frequency at Ωs = {w:g} rad/s (Q)", float(r.frequency[i, b]),
            KANE_REFERENCE_CHORDWISE[w], 0.01, "rad/s", source=REF3)
        for i, w in enumerate(spins)
    ]


def _paper_run(name: str, **overrides):
    from quadmodes.case import load_run_case
    from quadmodes.runs import simulate
    from quadmodes.runs.results import summary, to_dataset

    run = simulate.apply_overrides(load_run_case(name), **overrides)
    result = simulate.simulate(run)
    return result, summary(to_dataset(result))


def check_paper_slow_spin() -> list[Row]:
    """paper-0.5hz (Q, midpoint 0.5 ms, 4 s): log decrement of the first bending pair, |H|."""
    result, s = _paper_run("paper-0.5hz")
    src = "references §1: δ = 2πζ/√(1−ζ²)"
    return [
        Row("paper-0.5hz: log decrement of the bending pair", s["log_decrement"], 0.1257, 0.05,
            source=src),
        Row("paper-0.5hz: |H| relative drift", s["H_relative_drift"], 0.0, 1e-10, absolute=True,
            source="conservation (midpoint)"),
        Row("paper-0.5hz: cone angle change", s["cone_angle_end_deg"] - s["cone_angle_start_deg"],
            0.0, 0.01, "deg", absolute=True, source="references §1: nearly constant"),
    ]


def check_paper_fast_spin() -> list[Row]:
    """paper-41hz (Q, 120 s): |H|, coning growth and its Δt convergence (dt, dt/2, dt/4), and
    backward Euler at the seed's 2.5 ms beside it."""
    from quadmodes.case import load_run_case
    from quadmodes.runs import simulate
    from quadmodes.runs.dt_convergence import dt_convergence

    run = load_run_case("paper-41hz")
    setup = simulate.prepare(run)
    first = simulate.execute(setup)
    rows_dt = dt_convergence(setup, first)["rows"]
    d = first.diagnostics
    h_drift = float(np.max(np.abs(d.H_norm - d.H_norm[0])) / d.H_norm[0])
    grow = math.degrees(d.cone_angle[-1] - d.cone_angle[0])
    out = [
        Row("paper-41hz: |H| relative drift (120 s)", h_drift, 0.0, 1e-10, absolute=True,
            source="conservation (midpoint)"),
        Row("paper-41hz: cone angle growth over 120 s", grow, 0.0, 0.0, "deg", absolute=True,
            source="seed: cone angle grows", report_only=True),
    ]
    for r in rows_dt[1:]:
        out.append(
            Row(f"paper-41hz: cone-growth rate change, Δt → {r['dt_s'] * 1e3:g} ms",
                r["rel_change_cone_growth_rate_deg_per_s"], 0.0, 0.02, absolute=True,
                source="issue 28: halving Δt changes the cone-growth rate < 2 %")
        )
    be = simulate.execute(
        simulate.prepare(simulate.apply_overrides(run, method="backward-euler", dt="2.5 ms",
                                                  save_every=1))
    )
    be_end = math.degrees(be.diagnostics.cone_angle[-1])
    ref_end = rows_dt[-1]["cone_angle_deg"]
    out.append(
        Row("paper-41hz: backward Euler 2.5 ms final cone angle vs converged midpoint", be_end,
            ref_end, 0.0, "deg", source="seed's integrator, shown beside the converged result",
            report_only=True)
    )
    return out


def check_full_order_kane() -> list[Row]:
    """Full-order (ANCF, hub-driven, inertial frame) Kane spin-up peaks: checks references §3."""
    from quadmodes.analysis.full_order_runs import kane_full_order
    from quadmodes.runs.spinup import KANE_REFERENCE_PEAKS

    rows = []
    for ws, (v_ref, t_ref) in KANE_REFERENCE_PEAKS.items():
        r = kane_full_order(ws)
        rows += [
            Row(f"Kane full order, Ωs = {ws:g} rad/s: peak tip deflection", r.peak_deflection,
                v_ref, 0.02, "m", source=REF3),
            Row(f"Kane full order, Ωs = {ws:g} rad/s: time of peak", r.peak_time, t_ref, 0.2,
                "s", absolute=True, source=REF3),
        ]
    return rows


def comparison_rows(payload: dict, tolerance: float = 0.05) -> list[Row]:
    """Rows from a ``quadmodes compare --json`` payload: Q and Q4 against full order within
    ``tolerance`` on the modal envelope and the cone angle; the rest reported."""
    case, window = payload["case"], payload["window_s"]
    rows = []
    src = f"issue 4: {case}, {window:g} s window, vs full order"
    for name, row in payload["formulations"].items():
        for metric in ("envelope_error", "cone_angle_error", "cone_angle_change_error",
                       "spin_rate_error"):
            asserted = name in ("Q", "Q4") and metric in ("envelope_error", "cone_angle_error")
            value = row[metric] if row[metric] is not None else float("nan")
            rows.append(
                Row(f"{case} {name}: {metric.replace('_', ' ')}", value, 0.0, tolerance,
                    absolute=True, source=src, report_only=not asserted)
            )
        rows.append(
            Row(f"{case} {name}: speed-up over full order", row["speedup"] or float("nan"), 1e4, 0.0,
                source="goal ≥ 1e4", report_only=True)
        )
    return rows


def check_compare_coarse(window: float = 1.0) -> list[Row]:
    """``quadmodes compare paper-41hz-coarse --window 1 s``: rigid, L, P, Q, Q4 vs full order."""
    from quadmodes.analysis.compare import compare
    from quadmodes.case import load_run_case

    cmp = compare(load_run_case("paper-41hz-coarse"), window, full_order_dt=2.5e-4)
    return comparison_rows(cmp.as_json())


def rotating_frame_rows(
    table, n_modes: int, asserted: bool, tolerance: float = 0.02, near_zero_hz: float = 0.05
) -> list[Row]:
    """Rows of a :class:`quadmodes.analysis.rotating_comparison.ComparisonTable`: Q against full order per branch
    (asserted within ``tolerance`` if ``asserted``; a branch below a tenth of the spin rate,
    where a relative error is ill-conditioned, within ``near_zero_hz`` absolute), L reported."""
    rows = []
    src = f"issue 4: full-order linearisation about the spinning equilibrium, N = {n_modes}"
    for r in table.rows:
        if r.spin_hz == 0.0 or not np.isfinite(r.full_hz):
            continue
        near_zero = r.full_hz < 0.1 * r.spin_hz
        for f in table.formulations:
            name = f"{table.case} {r.spin_hz:g} Hz, {r.label}, {f} (N = {n_modes})"
            if near_zero:
                rows.append(Row(name, r.rom_hz[f], r.full_hz, near_zero_hz, "Hz",
                                absolute=True, source=src + " (near-zero branch: abs. tol.)",
                                report_only=not (asserted and f == "Q")))
            else:
                rows.append(Row(name, r.rom_hz[f], r.full_hz, tolerance, "Hz", source=src,
                                report_only=not (asserted and f == "Q")))
    return rows


def check_rotating_frame() -> list[Row]:
    """Rotating-frame frequencies, full order vs reduced (Q, L), paper model at 0, 20, 41 Hz:
    with the seed's 5 modes (reported) and with 8 modes (asserted within 2 %)."""
    from quadmodes.analysis.rotating_comparison import rotating_frequency_comparison

    rows = []
    for n_modes, asserted in ((5, False), (8, True)):
        table = rotating_frequency_comparison("paper-membrane", (0.0, 20.0, 41.0), n_modes)
        rows += rotating_frame_rows(table, n_modes, asserted)
    return rows


def check_rotating_frame_spinning() -> list[Row]:
    """Rotating-frame frequencies of the default reduced model (``paper-41hz``: Q about the
    spinning state, ``modes = "auto"``) against the full order's linearisation, paper model at
    20 and 41 Hz: every branch asserted within 1 % (issue 9)."""
    from quadmodes.analysis.rotating_comparison import rotating_frequency_comparison
    from quadmodes.case import load_run_case
    from quadmodes.models.build import reduced_model_for
    from quadmodes.runs.mode_choice import resolve_modes
    from quadmodes.runs.simulate import apply_overrides

    rows = []
    for spin_hz in (20.0, 41.0):
        run, choice = resolve_modes(apply_overrides(load_run_case("paper-41hz"),
                                                    spin_rate=f"{spin_hz} Hz"))  # fmt: skip
        case, n_modes = run.model_case(), choice.n_modes
        rom = reduced_model_for(case, n_modes, spin=run.reference_spin, axis=run.reference_axis)
        table = rotating_frequency_comparison(case, (spin_hz,), n_modes, ("Q",), model=rom)
        for row in rotating_frame_rows(table, n_modes, True, tolerance=0.01):
            rows.append(replace(row, check=row.check.replace(" (N =", " about the spin (N ="),
                                source=row.source.replace("issue 4", "issue 9")))  # fmt: skip
    return rows


ROM_CHECKS: dict[str, Check] = {
    "backward-euler": check_backward_euler,
    "kane-reduced": check_kane_reduced,
    "kane-campbell": check_kane_campbell,
    "paper-0.5hz": check_paper_slow_spin,
    "paper-41hz": check_paper_fast_spin,
}

FULL_ORDER_CHECKS: dict[str, Check] = {
    "kane-full-order": check_full_order_kane,
    "compare-41hz-coarse": check_compare_coarse,
    "rotating-frame": check_rotating_frame,
    "rotating-frame-spinning": check_rotating_frame_spinning,
}

#: Checks cheap enough to run in the test suite (seconds).
FAST = ("backward-euler", "kane-campbell", "paper-0.5hz")
