"""A membrane annulus clamped to a rigid hub (issue 26, second increment) against the membrane
equation with the clamped annulus's Lamé prestress (tests/reference/spinning_annulus.py): every
rotating-frame branch below ``--below`` × Ω at two spins and on several meshes, the plane-stress
equilibrium, and the convergence figure of docs/sails.md.

    OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg python -m benchmarks.studies.bench_spinning_annulus \\
        [--meshes 10,20,40] [--spins 1,3] [--below 3.2] [--figure docs/figures/spinning-annulus-convergence.png]

Branches compared: n ≥ 2 (the hub feels no net force or moment: the reference holds it),
n = 0 (the hub's axial translation with its mass) from the modes of the rotating-frame
stiffness, and n = 1 (the hub's tilt with its inertia and the gyroscopic coupling) from the full
order's rotating-frame roots (Coriolis included: the frame conditions of the stiffness modes are
not those of a tilting hub). The model is the built-in ``spinning-annulus`` with its edge length
set to R/k.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.common import mesh_convergence_figure
from quadmodes.case import load_case
from quadmodes.case.editing import edit
from quadmodes.structure.pipeline import build_modal_model

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from reference.spinning_annulus import (  # noqa: E402
    frequency_ratios,
    hub_parameters,
    radial_displacement,
    stresses,
)


def model_at(k: int, spin: float, count: int, base=None):
    """Modal model of spinning-annulus (or ``base``) with edge R/k at ``spin`` rad/s."""
    base = base or load_case("spinning-annulus")
    radius = 0.5 * base.geometry.diameter
    changes = {"mesh.edge_length": f"{radius / k} m", "spin.rate": f"{spin} rad/s",
               "modes.count": count}  # fmt: skip
    return build_modal_model(edit(base, changes, "bench"))


def reference_branches(case, below: float) -> dict[tuple[int, int], float]:
    """``{(n, s): ω/Ω}`` of the reference: held hub for n ≥ 2, the hub's mass for n = 0; n = 1
    as ``(1, s)`` over the distinct |ω|/Ω of the gyroscopic problem (the whole body's tilt at
    exactly Ω left out)."""
    g, m, h = case.geometry, case.material, case.hub
    beta, nu = g.inner_diameter / g.diameter, m.poisson_ratio
    p = hub_parameters(h.mass, h.inertia_x, h.inertia_z, m.density, m.thickness, 0.5 * g.diameter)
    out = {}
    for n in range(0, 16):
        hub = ("axial", p) if n == 0 else (("tilt", {**p, "gyro": 1}) if n == 1 else None)
        roots = np.abs(frequency_ratios(n, beta, nu, below, hub))
        roots = np.sort(roots[np.abs(roots - 1.0) > 1e-6])
        # a forward-backward pair closer than 1e-3 (the n = 1 pair near 2.6 Ω) is one branch
        roots = [r for i, r in enumerate(roots) if i == 0 or r - roots[i - 1] > 1e-3 * r]
        for s, r in enumerate(roots):
            out[n, s] = float(r)
    return out


def fe_branches(model, below: float) -> dict[tuple[int, int], float]:
    """``{(n, s): ω/Ω}`` of the FE model: n ≠ 1 from its labelled stiffness modes (pairs
    averaged), n = 1 from the full order's rotating-frame roots (non-tilt, ascending)."""
    eq = model.spinning
    out: dict[tuple[int, int], list[float]] = {}
    for f, lab in zip(model.modes.frequencies_hz, model.labels, strict=True):
        ns = tuple(int(v) for v in re.findall(r"\d+", lab))
        if ns and ns[0] != 1:
            out.setdefault(ns, []).append(2 * np.pi * f / eq.spin)
    ratios = np.sort([r for r in n1_roots(model) if r < below])
    distinct = [r for i, r in enumerate(ratios) if i == 0 or r - ratios[i - 1] > 1e-3 * r]
    for s, r in enumerate(distinct):
        out[1, s] = [float(r)]
    return {ns: float(np.mean(v)) for ns, v in out.items()}


def n1_roots(model) -> list[float]:
    """ω/Ω of the full order's rotating-frame roots with one nodal diameter (the whole
    body's tilt at exactly Ω left out)."""
    from quadmodes.analysis.rotating_modes import rotating_roots
    from quadmodes.structure.disc_labels import disc_mode_numbers

    st, eq = model.structure, model.spinning
    targets = list(eq.spin / (2 * np.pi) * np.array([0.5, 1.05, 2.6]))
    roots = rotating_roots(st, eq.x, eq.spin, eq.axis, targets)
    idx = st.groups["membrane"]
    weights = np.asarray(st.mass_scalar.sum(axis=1)).ravel()[idx]
    out = []
    for f, kind, shape in zip(roots.frequency_hz, roots.kind, roots.shapes, strict=True):
        n, _, share = disc_mode_numbers(eq.x[idx], shape[idx].real, weights, eq.axis, np.zeros(3))
        if kind != "tilt" and n == 1 and share > 0.5:
            out.append(2 * np.pi * f / eq.spin)
    return out


def equilibrium_errors(model) -> tuple[float, float]:
    """Largest errors of the principal stress resultants (over the largest reference
    resultant) and of the radial displacement (over its largest) against the closed form."""
    case, eq, st = model.case, model.spinning, model.structure
    g, m = case.geometry, case.material
    a, b = 0.5 * g.diameter, 0.5 * g.inner_diameter
    res, centres = [], []
    for e in st.elements:
        if hasattr(e, "principal_stress_resultants"):
            res.append(e.principal_stress_resultants(eq.x))
            xv = e._virtual(st.reference) if hasattr(e, "_virtual") else st.reference
            centres.append(xv[e.inner.conn if hasattr(e, "inner") else e.conn].mean(axis=1))
    res, rc = np.concatenate(res), np.hypot(*np.concatenate(centres)[:, :2].T)
    sr, sth = stresses(rc, a, b, m.density, eq.spin, m.poisson_ratio)
    ref = np.sort(np.stack([sr, sth], 1), axis=1) * m.thickness
    stress = float(np.abs(res - ref).max() / np.abs(ref).max())
    x0 = st.reference[st.groups["membrane"]]
    r0 = np.hypot(*x0[:, :2].T)
    u = np.einsum("ij,ij->i", (eq.x - st.reference)[st.groups["membrane"], :2], x0[:, :2]) / r0
    u_ref = radial_displacement(r0, a, b, m.density, eq.spin, m.poisson_ratio, m.youngs_modulus)
    return stress, float(np.abs(u - u_ref).max() / np.abs(u_ref).max())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", default="10,20,40")
    ap.add_argument("--spins", default="1,3")
    ap.add_argument("--below", type=float, default=3.2)
    ap.add_argument("--figure", default=None)
    a = ap.parse_args()
    ks, spins = [int(v) for v in a.meshes.split(",")], [float(v) for v in a.spins.split(",")]
    base = load_case("spinning-annulus")
    expected = reference_branches(base, a.below)
    count = sum(1 if n == 0 else 2 for n, _ in expected) + 2
    found = {}
    for k in ks:
        for spin in spins:
            t0 = time.perf_counter()
            model = model_at(k, spin, count, base)
            found[k, spin] = fe_branches(model, a.below)
            es, eu = equilibrium_errors(model)
            print(f"R/{k} ({model.structure.n} DOFs) at {spin:g} rad/s: "
                  f"{time.perf_counter() - t0:.1f} s, stress error {100 * es:.2f} %, "
                  f"displacement error {100 * eu:.2f} %")  # fmt: skip
    print("| (n, s) | reference ω/Ω | " + " | ".join(
        f"R/{k}, {s:g} rad/s" for k in ks for s in spins) + " |")  # fmt: skip
    print("|" + "---|" * (2 + len(ks) * len(spins)))
    errors: dict[int, dict] = {}
    for ns, ref in sorted(expected.items(), key=lambda kv: kv[1]):
        cells = []
        for k in ks:
            for spin in spins:
                r = found[k, spin].get(ns, np.nan)
                errors.setdefault(k, {})[ns] = r / ref - 1
                cells.append(f"{r:.4f} ({100 * (r / ref - 1):+.2f} %)")
        print(f"| {ns} | {ref:.4f} | " + " | ".join(cells) + " |")
    for k in ks:
        worst = max(abs(v) for v in errors[k].values())
        print(f"R/{k}: largest error {100 * worst:.2f} % over {len(expected)} branches")
    spread = max(abs(found[k, spins[-1]][ns] / found[k, spins[0]][ns] - 1)
                 for k in ks for ns in found[k, spins[0]] if ns in found[k, spins[-1]])  # fmt: skip
    print(f"ω/Ω at {spins[-1]:g} vs {spins[0]:g} rad/s: largest relative difference {spread:.1e}")
    if a.figure:
        plot(ks, expected, errors, a.figure)


def plot(ks, expected, errors, path) -> None:
    """Error against the reference vs mesh size, one line per branch."""
    series = {str(ns): [errors[k][ns] for k in ks] for ns in expected}
    mesh_convergence_figure(ks, series, 1.0, "edge length / outer radius", "|ω/Ω − reference| (%)",
                            "membrane annulus on a rigid hub vs the membrane equation", path)  # fmt: skip


if __name__ == "__main__":
    main()
