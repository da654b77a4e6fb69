"""The IKAROS-like sail's largest stress, at its tip masses' corners: is the largest principal
stress resultant, which sits inside a tip mass's patch near a right-angled free corner, a
singularity or first-order convergence of constant-strain triangles? (issue 26, docs/sails.md
"The tip-mass corner".)

    OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg python -m benchmarks.studies.bench_ikaros_corner \\
        [--meshes 0.35,0.25,0.177,0.125,0.088] [--patch 0.5]

For each mesh (edge length, m) of the built-in ``ikaros-sail`` at 2.5 rpm (``--patch``: the
tip masses' patch radius, m): the largest major principal resultant (N/m) and its distance from
the nearest corner; the largest outside the patches (elements whose centroid is farther than
the patch radius from every corner) and outside twice that; the largest of the nodal values
recovered by area-weighted averaging over the elements around each node; the area-weighted mean
over the four patches; the resultant of the element
containing fixed points on the diagonals (0.25, 0.5, 1, 2 m from each corner, mean of the four
corners); and the first-order (Richardson) extrapolation of each from the two finest meshes.
About 1.5 minutes on one core for the defaults (0.088 m: 36 000 DOFs).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from quadmodes.case import load_case
from quadmodes.case.editing import edit
from quadmodes.structure.pipeline import reference_state, structure_for_case

HALF = 7.0  # m, half the side
DISTANCES = (0.25, 0.5, 1.0, 2.0)  # m from a corner, along its diagonal


def case_at(edge: float, patch: float):
    """ikaros-sail with edge ``edge`` (m) and every tip mass's patch ``patch`` (m)."""
    changes = [(("mesh", "edge_length"), f"{edge} m")]
    changes += [(("tip_mass", k, "patch"), f"{patch} m") for k in range(4)]
    return edit(load_case("ikaros-sail"), changes, "bench")


def _elements(st, x):
    """(major resultant (ne,), centroid (ne, 2), corner triangles (ne, 3, 2)) of every membrane
    element (hub-ring triangles through their virtual nodes) at state ``x``."""
    sets = [e for e in st.elements if hasattr(e, "principal_stress_resultants")]
    res = np.concatenate([e.principal_stress_resultants(x)[:, 1] for e in sets])
    tri = np.concatenate([
        e._virtual(st.reference).reshape(len(e.conn), -1, 3)[..., :2] if hasattr(e, "inner")
        else st.reference[e.conn][..., :2] for e in sets])  # fmt: skip
    return res, tri.mean(axis=1), tri


def _nodal_max(tri: np.ndarray, res: np.ndarray, area: np.ndarray) -> float:
    """Largest nodal value of the element values ``res`` averaged over the elements around each
    node, weighted by area (the usual recovery of a smooth field from constant-strain
    triangles); nodes found by their reference position (hub-ring corners included)."""
    pts = np.round(tri.reshape(-1, 2), 9)
    _, node = np.unique(pts, axis=0, return_inverse=True)
    node = node.reshape(-1)
    w = np.repeat(area, 3)
    num = np.bincount(node, w * np.repeat(res, 3))
    den = np.bincount(node, w)
    return float((num / den).max())


def _containing(tri: np.ndarray, p: np.ndarray) -> int:
    """Index of the triangle (ne, 3, 2) that contains the point p (2,) (barycentric test)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    m = np.stack([b - a, c - a], axis=-1)  # (ne, 2, 2)
    lam = np.linalg.solve(m, (p - a)[..., None])[..., 0]
    inside = (lam >= -1e-12).all(axis=1) & (lam.sum(axis=1) <= 1 + 1e-12)
    return int(np.flatnonzero(inside)[0])


def figures(edge: float, patch: float) -> dict:
    """The corner figures of one mesh."""
    t0 = time.perf_counter()
    case = case_at(edge, patch)
    st = structure_for_case(case)
    x, _ = reference_state(case, st)
    res, cen, tri = _elements(st, x)
    corners = np.array([[sx * HALF, sy * HALF] for sx in (1, -1) for sy in (1, -1)])
    d = np.linalg.norm(cen[:, None, :] - corners[None], axis=2).min(axis=1)
    k = int(np.argmax(res))
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    inside = d <= patch
    out = {"edge": edge, "dofs": st.n, "max": res[k], "max_d": d[k],
           "nodal_max": _nodal_max(tri, res, area),
           "patch_mean": float((res * area)[inside].sum() / area[inside].sum()),
           "off_patch": res[d > patch].max(), "off_2patch": res[d > 2 * patch].max()}  # fmt: skip
    for dist in DISTANCES:
        s = dist / np.sqrt(2.0)
        vals = [res[_containing(tri, c - np.sign(c) * s)] for c in corners]
        out[f"at {dist:g} m"] = float(np.mean(vals))
    out["seconds"] = time.perf_counter() - t0
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", default="0.35,0.25,0.177,0.125,0.088")
    ap.add_argument("--patch", type=float, default=0.5)
    a = ap.parse_args()
    rows = [figures(float(h), a.patch) for h in a.meshes.split(",")]
    keys = ["max", "nodal_max", "patch_mean", "off_patch", "off_2patch",
            *(f"at {d:g} m" for d in DISTANCES)]
    print(f"patch {a.patch:g} m; major principal resultant (N/m)")
    print("| edge (m) | DOFs | largest (distance from corner, m) | largest nodal average | "
          "patch mean | off the patches | off 2 × patch | "
          + " | ".join(f"on the diagonal {d:g} m" for d in DISTANCES) + " |")
    print("|---" * (7 + len(DISTANCES)) + "|")
    for r in rows:
        print(f"| {r['edge']:g} | {r['dofs']} | {r['max']:.4f} ({r['max_d']:.2f}) | "
              + " | ".join(f"{r[k]:.4f}" for k in keys[1:]) + " |")  # fmt: skip
    fine, coarse = rows[-1], rows[-2]
    ratio = coarse["edge"] / fine["edge"]
    print("| first-order extrapolation | | "
          + " | ".join(f"{(ratio * fine[k] - coarse[k]) / (ratio - 1):.4f}" for k in keys) + " |")
    print("| change between the two finest | | "
          + " | ".join(f"{100 * (fine[k] / coarse[k] - 1):+.2f} %" for k in keys) + " |")
    print("seconds: " + ", ".join(f"{r['seconds']:.1f}" for r in rows))


if __name__ == "__main__":
    main()
