"""The free spinning membrane disc (issue 26) against Lamb & Southwell's closed form: every
rotating-frame branch below ``--below`` × Ω at two spins and on three meshes, the plane-stress
equilibrium, and the convergence figure of docs/sails.md.

    OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg python -m benchmarks.studies.bench_spinning_disc \\
        [--meshes 10,20,40] [--spins 1,3] [--below 3.2] [--figure docs/figures/spinning-disc-convergence.png]

The model is the built-in ``spinning-disc`` (10 m diameter, 7.5 µm polyimide) with its edge
length set to R/k for each k of ``--meshes``; the reference (tests/reference/spinning_disc.py)
imports no quadmodes code. About 30 s on one core for the default meshes (R/40: 4921 nodes).
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
from quadmodes.fe.membrane import MembraneSet
from quadmodes.structure.pipeline import build_modal_model

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from reference.spinning_disc import frequency_ratio, hoop_stress, radial_stress  # noqa: E402


def model_at(k: int, spin: float, count: int):
    """Modal model of spinning-disc with edge R/k at ``spin`` rad/s, ``count`` modes."""
    base = load_case("spinning-disc")
    radius = 0.5 * base.geometry.diameter
    changes = {"mesh.edge_length": f"{radius / k} m", "spin.rate": f"{spin} rad/s",
               "modes.count": count}  # fmt: skip
    return build_modal_model(edit(base, changes, "bench")), radius


def branches(model) -> tuple[dict[tuple[int, int], float], float]:
    """``({(n, s): ω/Ω}, largest relative split of a pair)`` of a disc modal model (a pair's
    members averaged; the hexagonal mesh splits n = 3, 6, … slightly)."""
    spin = model.spinning.spin
    out: dict[tuple[int, int], list[float]] = {}
    for f, lab in zip(model.modes.frequencies_hz, model.labels, strict=True):
        ns = tuple(int(v) for v in re.findall(r"\d+", lab))
        out.setdefault(ns, []).append(2 * np.pi * f / spin)
    split = max(np.ptp(v) / np.mean(v) for v in out.values())
    return {ns: float(np.mean(v)) for ns, v in out.items()}, float(split)


def stress_error(model, radius: float) -> float:
    """Largest error of the principal stress resultants against the closed form, over the
    centre's hoop resultant."""
    m, eq = model.case.material, model.spinning
    mem = next(e for e in model.structure.elements if isinstance(e, MembraneSet))
    res = mem.principal_stress_resultants(eq.x)
    rc = np.hypot(*model.structure.reference[mem.conn].mean(axis=1)[:, :2].T)
    args = (radius, m.density, eq.spin, m.poisson_ratio)
    ref = np.stack([radial_stress(rc, *args), hoop_stress(rc, *args)], 1) * m.thickness
    return float(np.abs(res - ref).max() / (m.thickness * hoop_stress(0.0, *args)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", default="10,20,40")
    ap.add_argument("--spins", default="1,3")
    ap.add_argument("--below", type=float, default=3.2)
    ap.add_argument("--figure", default=None)
    a = ap.parse_args()
    ks = [int(v) for v in a.meshes.split(",")]
    spins = [float(v) for v in a.spins.split(",")]
    nu = load_case("spinning-disc").material.poisson_ratio
    expected = sorted((frequency_ratio(n, s, nu), n, s) for n in range(20) for s in range(8)
                      if (n, s) not in ((0, 0), (1, 0)) and frequency_ratio(n, s, nu) < a.below)  # fmt: skip
    count = sum(1 if n == 0 else 2 for _, n, _ in expected) + 2
    found: dict[tuple[int, float], dict] = {}
    for k in ks:
        for spin in spins:
            t0 = time.perf_counter()
            model, radius = model_at(k, spin, count)
            found[k, spin], split = branches(model)
            print(f"R/{k} ({model.structure.n} nodes) at {spin:g} rad/s: {time.perf_counter() - t0:.1f} s, "
                  f"stress error {100 * stress_error(model, radius):.2f} % of σ_θ(0), "
                  f"largest pair split {100 * split:.3f} %")  # fmt: skip
    head = "| (n, s) | closed form ω/Ω | " + " | ".join(
        f"R/{k}, {s:g} rad/s" for k in ks for s in spins) + " |"  # fmt: skip
    print(head + "\n|" + "---|" * (2 + len(ks) * len(spins)))
    errors = {}
    for ref, n, s in expected:
        cells = []
        for k in ks:
            for spin in spins:
                r = found[k, spin].get((n, s), np.nan)
                errors.setdefault(k, {})[(n, s)] = r / ref - 1
                cells.append(f"{r:.4f} ({100 * (r / ref - 1):+.2f} %)")
        print(f"| ({n}, {s}) | {ref:.4f} | " + " | ".join(cells) + " |")
    for k in ks:
        worst = max(abs(v) for v in errors[k].values())
        print(f"R/{k}: largest error {100 * worst:.2f} % over {len(expected)} branches")
    ratio_spread = max(abs(found[k, spins[-1]][ns] / found[k, spins[0]][ns] - 1)
                       for k in ks for ns in found[k, spins[0]] if ns in found[k, spins[-1]])  # fmt: skip
    print(
        f"ω/Ω at {spins[-1]:g} vs {spins[0]:g} rad/s: largest relative difference {ratio_spread:.1e}"
    )
    if a.figure:
        plot(ks, expected, errors, a.figure)


def plot(ks, expected, errors, path) -> None:
    """Error against the closed form vs mesh size, one line per branch."""
    series = {f"({n}, {s})": [errors[k][(n, s)] for k in ks] for _, n, s in expected}
    mesh_convergence_figure(ks, series, 0.4, "edge length / radius", "|ω/Ω − closed form| (%)",
                            "spinning membrane disc vs Lamb & Southwell (1921)", path)  # fmt: skip


if __name__ == "__main__":
    main()
