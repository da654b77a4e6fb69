"""The modal-amplitude check's error along a spin-family path, in energy and in force, to set
beside the full order's envelope error at the same points (issue 29; the check's 2 % energy
threshold is not changed here).

At each path time given, the sample of largest ‖s‖ within ``--window`` seconds around it and
integrated by the same member (the coning response's peak there, as the check judges a
segment at its largest ‖s‖), in that member's chart:

* **energy**: :func:`quadmodes.runs.path_validity.amplitude_error`, |V − W_c| / W_c, the
  reduced potential against the FE model's statically condensed energy (both without the
  reference load's work), what the path check compares with its 2 %;
* **force**: the gradients of the same two energies with respect to s. The condensed energy's
  is, by the envelope theorem at its constrained minimum, the FE internal force at the relaxed
  state projected on the manifold's tangent, ∂W_c/∂s_k = (f(x0 + u*) − f0)·∂u_QM/∂s_k
  (u* = u_QM(s) + y*, the minimiser); the reduced one is ∇V − f0·∂u_QM/∂s. Reported as
  ‖∇V_red − ∇W_c‖ / ‖∇W_c‖ (modes of 1 kg modal mass: the Euclidean norm in s), and along s
  (the component that sets the response's amplitude by force balance, s·∇ / ‖s‖).

    OPENBLAS_NUM_THREADS=1 python -m benchmarks.studies.bench_amplitude_check \\
        benchmarks/cases/path-41hz-coarse-family-60.toml --results OUT/results.nc \\
        --times-from /work/wt/family60-out/fo/fo.jsonl /work/wt/family60-out/fo/fo2.jsonl

``--results``: a results.nc of that case written with the member of each sample
(``model_reference_spin``). Prints one JSON line a point, then a table. With ``--members K``
instead of ``--times-from``: every member's energy error at its K samples of largest ‖s‖ (what
the family's amplitude check sees at one of them), one JSON line a member.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from quadmodes.analysis.path_point import read_path_results
from quadmodes.case import load_run_case
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import manifold_energy as me
from quadmodes.rom import system as rsys
from quadmodes.runs import deformation_check as dc
from quadmodes.runs import path_validity as pv
from quadmodes.runs import simulate as sim
from quadmodes.runs.family_samples import Members, member_run


def manifold_jacobian(ctx: me.EnergyContext, s: np.ndarray) -> np.ndarray:
    """∂u_QM/∂s (N, m): φ_k + Σ_n s_n (g^{kn} + g^{nk})."""
    return ctx.phi + np.einsum("n,kni->ki", s, ctx.g) + np.einsum("n,nki->ki", s, ctx.g)


def force_errors(setup, y: np.ndarray, structure) -> dict:
    """The condensed and reduced energies' gradients at the modal coordinates of state ``y``:
    {"force_error": ‖Δ∇‖/‖∇W_c‖, "force_error_along_s": |s·Δ∇| / |s·∇W_c|, "energy_error":
    |V − W_c| / W_c from the same solve, "converged"}."""
    model, system = setup.model, setup.system
    s = rsys.split_state(system, y)[2]
    ctx = me.energy_context(structure, model.X, model)
    cond = me.condensed_energy_along_ray(ctx, s)
    jac = manifold_jacobian(ctx, s)
    u_star = me.manifold_displacement(ctx, s) + cond.unknowns
    grad_c = jac @ me.potential_force(ctx, u_star)
    grad_r = dyn.potential_gradient(system, s) - jac @ ctx.f0
    state = np.zeros(7 + 2 * system.n_modes)
    state[0], state[7 : 7 + system.n_modes] = 1.0, s
    v_red = float(dyn.potential_energy(system, state)) - float(ctx.f0 @ me.manifold_displacement(ctx, s))
    diff = grad_r - grad_c
    return {"force_error": float(np.linalg.norm(diff) / np.linalg.norm(grad_c)),
            "force_error_along_s": float(abs(s @ diff) / abs(s @ grad_c)),
            "energy_error_same_solve": abs(v_red - cond.value) / cond.value,
            "converged": bool(cond.converged)}  # fmt: skip


def point_row(members: Members, run, r: dict, t_point: float, window: float, setups: dict) -> dict:
    """The check's errors at the peak ‖s‖ near ``t_point`` (s) within its member's samples."""
    t, y, spins = r["t"], r["y"], r["spins"]
    k0 = int(np.argmin(np.abs(t - t_point)))
    spin = float(spins[k0])
    near = np.flatnonzero((np.abs(t - t_point) <= 0.5 * window) & (spins == spin))
    n = members.system(spin).n_modes
    amp = np.linalg.norm(y[near, 7 : 7 + n], axis=1)
    k = int(near[np.argmax(amp)])
    if spin not in setups:
        setup = sim.prepare(member_run(run, spin), members.model(spin), model_case=members.model_case)
        setups[spin] = (setup, dc.deformation_structure(setup))
    setup, structure = setups[spin]
    start = time.perf_counter()
    energy, _ = pv.amplitude_error(setup, y[k], structure)
    forces = force_errors(setup, y[k], structure)
    return {"t_point_s": t_point, "t_peak_s": float(t[k]), "member_hz": spin / (2 * math.pi),
            "amplitude": float(amp.max()), "energy_error": float(energy), **forces,
            "wall_s": time.perf_counter() - start}  # fmt: skip


def member_rows(members: Members, run, r: dict, top: int, cone_deg: np.ndarray):
    """Per member (in the path's order): its largest ‖s‖, the energy error there and the
    largest over its ``top`` samples of largest ‖s‖ (one JSON line each)."""
    t, y, spins = r["t"], r["y"], r["spins"]
    for spin in np.unique(spins)[::-1]:
        kk = np.flatnonzero(spins == spin)
        setup = sim.prepare(member_run(run, spin), members.model(spin), model_case=members.model_case)
        structure = dc.deformation_structure(setup)
        amp = np.linalg.norm(y[kk, 7 : 7 + setup.system.n_modes], axis=1)
        best = kk[np.argsort(-amp)[:top]]
        errs = [pv.amplitude_error(setup, y[j], structure)[0] for j in best]
        print(json.dumps({"member_hz": spin / (2 * math.pi), "cone_deg": [float(cone_deg[kk[0]]), float(cone_deg[kk[-1]])],
                          "peak_amplitude": float(amp.max()), "error_at_peak": float(errs[0]),
                          "error_max": float(max(errs)), "t_error_max": float(t[best[int(np.argmax(errs))]])}),
              flush=True)  # fmt: skip


def _times(files: list[str]) -> list[tuple[float, float]]:
    """(cone mark (deg), path time (s)) of the points in the JSON lines of ``files``."""
    rows = [json.loads(line) for f in files for line in open(f, encoding="utf-8") if line.strip()]
    return sorted((float(row["point_deg"]), float(row["t_s"])) for row in rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--results", required=True)
    ap.add_argument("--times-from", nargs="+")
    ap.add_argument("--members", type=int, default=0)
    ap.add_argument("--window", type=float, default=2.0)
    args = ap.parse_args()
    run = sim.prepare(load_run_case(args.case)).run  # its modes resolved
    members = Members(run)
    r = read_path_results(args.results, run, members.model(run.reference_spin), family=True)
    if args.members:
        import xarray as xr

        with xr.open_dataset(args.results) as ds:
            member_rows(members, run, r, args.members, ds["cone_angle_deg"].values)
        return
    rows, setups = [], {}
    for cone, t_point in _times(args.times_from):
        row = {"cone_mark_deg": cone, **point_row(members, run, r, t_point, args.window, setups)}
        print(json.dumps(row), flush=True)
        rows.append(row)
    print("| cone mark | t peak (s) | member (Hz) | ‖s‖ | energy error | force error | along s |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        print(f"| {row['cone_mark_deg']:g}° | {row['t_peak_s']:.2f} | {row['member_hz']:.4f} | "
              f"{row['amplitude']:.3g} | {100 * row['energy_error']:.2f} % | "
              f"{100 * row['force_error']:.2f} % | {100 * row['force_error_along_s']:.2f} % |")  # fmt: skip


if __name__ == "__main__":
    main()
