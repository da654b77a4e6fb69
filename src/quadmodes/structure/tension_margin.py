"""How far a prestressed membrane can be deformed before it first loses tension (wrinkles).

An inflated membrane carries no compression: where its minor principal stress reaches zero it
wrinkles (or, as an St Venant–Kirchhoff membrane without bending stiffness, buckles at the
scale of the mesh). Beyond that amplitude the taut model's Taylor expansion — the modes, the
quadratic modes and every smooth reduced potential built from them — no longer describes the
structure. This module gives that amplitude along a displacement direction ``u``: the smallest
``|a|`` for which the linearised stress of ``x0 + a u`` has a non-positive principal value in
some membrane element off the bonded end-body patches.

Linearised stress: the Green strain of ``x0 + a u`` is ``E0 + a E1 + a² E2`` with
``E1 = sym(F0ᵀF1)``; the onset uses ``S0 + a S1`` with ``S1 = D E1`` (the plane-stress SVK law
of the taut state, also for a tension-field membrane, whose taut branch it is), so the minor
principal stress vanishes where ``det(S0 + a S1) = 0`` — a quadratic in ``a`` per element. It is
the first-order estimate of where the nonlinearity of wrinkling starts, not a wrinkling analysis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.fe.membrane import MembraneSet, _voigt_stress, green_strain
from quadmodes.fe.model import Structure


def _det2(s: np.ndarray) -> np.ndarray:
    return s[:, 0, 0] * s[:, 1, 1] - s[:, 0, 1] * s[:, 1, 0]


def element_slack_onset(membrane: MembraneSet, x0: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Per element ``(ne,)``: the smallest ``|a|`` at which the linearised 2nd Piola–Kirchhoff
    stress of ``x0 + a u`` (``x0``, ``u`` ``(n, 3)`` m, ``a`` dimensionless) stops being positive
    definite; ``inf`` where it never does, ``0`` where it is not positive definite at ``x0``."""
    f0, e0 = green_strain(membrane.gradients, x0[membrane.conn])
    f1 = np.einsum("eai,eaj->eij", u[membrane.conn], membrane.gradients)  # F of u, (ne, 3, 2)
    e1 = 0.5 * (np.einsum("eki,ekj->eij", f0, f1) + np.einsum("eki,ekj->eij", f1, f0))
    s0, s1 = _voigt_stress(membrane.d, e0), _voigt_stress(membrane.d, e1)
    # det(S0 + a S1) = c0 + c1 a + c2 a²
    c0, c2 = _det2(s0), _det2(s1)
    c1 = s0[:, 0, 0] * s1[:, 1, 1] + s0[:, 1, 1] * s1[:, 0, 0] - 2.0 * s0[:, 0, 1] * s1[:, 0, 1]
    taut = (c0 > 0.0) & (s0[:, 0, 0] + s0[:, 1, 1] > 0.0)
    onset = np.full(len(c0), np.inf)
    disc = c1**2 - 4.0 * c0 * c2
    real = taut & (disc >= 0.0)
    root = np.sqrt(np.where(real, disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        # the cancellation-free pair q/c2, c0/q (the textbook form loses the small root when
        # c0 c2 ≪ c1², e.g. for a nearly strain-free direction, and returns 0 for it)
        q = -0.5 * (c1 + np.where(c1 >= 0.0, 1.0, -1.0) * root)
        r1 = q / c2
        r2 = c0 / q
    roots = np.stack([np.abs(r1), np.abs(r2)], -1)
    roots[~np.isfinite(roots)] = np.inf
    onset[real] = roots[real].min(axis=1)
    onset[~taut] = 0.0
    return onset


def bonded_elements(structure: Structure, membrane: MembraneSet) -> np.ndarray:
    """``(ne,)`` bool: membrane elements whose three nodes are all tied to an end body (the
    rigid patch: bonded, it neither stretches nor wrinkles)."""
    tied = np.zeros(len(structure.reference), bool)
    for name, nodes in structure.groups.items():
        if name.startswith("attach:"):
            tied[nodes] = True
    return tied[membrane.conn].all(axis=1)


@dataclass(frozen=True)
class SlackOnset:
    """First loss of tension along one displacement direction.

    fraction: the smallest ``a`` (dimensionless, in units of the direction given) at which an
    element off the bonded patches loses tension (inf: none does along the linearised path);
    element: that element's index in its membrane set (-1 if none); position ``(3,)`` m: its
    centroid in ``x0``; slack_at_unit: fraction of the off-patch membrane area (reference) already
    slack at ``a = 1`` (linearised); slack_at_rest: off-patch elements not taut at ``x0``."""

    fraction: float
    element: int
    position: np.ndarray
    slack_at_unit: float
    slack_at_rest: int


def slack_onset(structure: Structure, x0: np.ndarray, u: np.ndarray) -> SlackOnset | None:
    """:class:`SlackOnset` of ``structure`` at ``x0`` ``(n, 3)`` m along ``u`` ``(n, 3)`` m (the
    first membrane set; None for a structure without one)."""
    membrane = next((e for e in structure.elements if isinstance(e, MembraneSet)), None)
    if membrane is None:
        return None
    x0 = np.asarray(x0, float).reshape(-1, 3)
    u = np.asarray(u, float).reshape(-1, 3)
    onset = element_slack_onset(membrane, x0, u)
    off_patch = ~bonded_elements(structure, membrane)
    at_rest = off_patch & (onset == 0.0)
    candidates = np.where(off_patch & ~at_rest, onset, np.inf)
    k = int(np.argmin(candidates))
    first = float(candidates[k])
    position = x0[membrane.conn[k]].mean(axis=0) if np.isfinite(first) else np.full(3, np.nan)
    return SlackOnset(
        fraction=first,
        element=k if np.isfinite(first) else -1,
        position=position,
        slack_at_unit=float(np.average(candidates[off_patch] <= 1.0,
                                       weights=membrane.area0[off_patch])),  # fmt: skip
        slack_at_rest=int(at_rest.sum()),
    )


# ---------------------------------------------------------------------------------------------
# Exact (nonlinear) slack onset along a manifold displacement
# ---------------------------------------------------------------------------------------------
#
# The linearised onset above is blind where the linear strain change F0ᵀF1 vanishes: a flat
# membrane deflected out of its plane (F0 in the plane, F1 out of it). Its tension changes at
# second order, through the stretch ½F1ᵀF1 and the in-plane motion of the quadratic modes, so
# the check below evaluates the Green strain of x0 + U exactly per element, U = a u1 + a² u2 the
# reduced model's manifold displacement (u1 = Φs, u2 = Σ s_m s_n g^{mn}) scaled by a.

#: Along a ray the onset is sought up to this many times the displacement given (beyond: inf).
RAY_LIMIT = 4.0
#: Points of the scan of the ray (quadratic in a: finest near a = 0) before the bisection.
RAY_SCAN = 96
#: Bisections of the first bracket found by the scan (the onset to 2⁻⁴⁰ of its bracket).
RAY_BISECTIONS = 40
#: Scan points evaluated together (one batched pass; the scan stops at the first slack block).
RAY_BLOCK = 16


def _inner(element_set):
    """The membrane set of ``element_set`` (itself, or the one an image set wraps) or None."""
    inner = getattr(element_set, "inner", element_set)
    return inner if isinstance(inner, MembraneSet) else None


def _element_positions(element_set, x: np.ndarray) -> np.ndarray:
    """Node positions ``(ne, 3, 3)`` (m) of the elements of ``element_set`` at the state ``x``
    ``(n, 3)`` (an image set's: its virtual nodes, images of the hub's DOFs)."""
    if hasattr(element_set, "inner"):
        return element_set._virtual(x)[element_set.inner.conn]
    return x[element_set.conn]


def _element_positions_many(element_set, xs: np.ndarray) -> np.ndarray:
    """:func:`_element_positions` at ``K`` states ``xs`` ``(K, n, 3)``: ``(K, ne, 3, 3)`` (m)."""
    if hasattr(element_set, "inner"):
        virtual = np.einsum("eab,kebi->keai", element_set.images, xs[:, element_set.conn])
        return virtual.reshape(len(xs), -1, 3)[:, element_set.inner.conn]
    return xs[:, element_set.conn]


def minor_resultant(membrane: MembraneSet, xe: np.ndarray) -> np.ndarray:
    """Minor principal Cauchy stress resultant ``(ne,)`` (N/m) of the SVK law (the taut branch,
    also of a tension-field membrane) at element node positions ``xe`` ``(ne, 3, 3)`` (m): the
    exact Green strain, no linearisation. Its sign is that of the 2nd Piola–Kirchhoff stress's
    minor eigenvalue (t F S Fᵀ / J is congruent to S)."""
    return _minor(membrane.gradients, membrane.d, membrane.thickness, xe)


def _minor(gradients: np.ndarray, d: np.ndarray, thickness, xe: np.ndarray) -> np.ndarray:
    """:func:`minor_resultant` of elements with shape-function ``gradients`` ``(ne, 3, 2)``,
    Voigt law ``d`` and ``thickness`` (m, scalar or ``(ne,)``) at ``xe`` ``(ne, 3, 3)``."""
    # by components (einsum on these 2×2 and 3×2 blocks was 3 times slower): F = Σ_a x_a ⊗ G_a,
    # C = FᵀF, E = (C − I)/2, S = D E; the resultant t F S Fᵀ / J, J = √det C, has the
    # eigenvalues of k A, A = S C, k = t/J (real: A is similar to C^½ S C^½), the minor one
    # tr A/2 − √(((A₀₀ − A₁₁)/2)² + A₀₁A₁₀), a discriminant free of cancellation at an
    # isotropic stress (the two resultants equal)
    f0 = xe[:, 0] * gradients[:, 0, 0, None] + xe[:, 1] * gradients[:, 1, 0, None] \
        + xe[:, 2] * gradients[:, 2, 0, None]  # fmt: skip
    f1 = xe[:, 0] * gradients[:, 0, 1, None] + xe[:, 1] * gradients[:, 1, 1, None] \
        + xe[:, 2] * gradients[:, 2, 1, None]  # fmt: skip
    c00, c11, c01 = (f0 * f0).sum(axis=1), (f1 * f1).sum(axis=1), (f0 * f1).sum(axis=1)
    sv = np.stack([0.5 * (c00 - 1.0), 0.5 * (c11 - 1.0), c01], -1) @ np.asarray(d).T
    s00, s11, s01 = sv[:, 0], sv[:, 1], sv[:, 2]
    a00, a01 = s00 * c00 + s01 * c01, s00 * c01 + s01 * c11
    a10, a11 = s01 * c00 + s11 * c01, s01 * c01 + s11 * c11
    k = thickness / np.sqrt(c00 * c11 - c01 * c01)
    disc = (0.5 * (a00 - a11)) ** 2 + a01 * a10
    return k * (0.5 * (a00 + a11) - np.sqrt(np.maximum(disc, 0.0)))


#: Element evaluations per batch of :meth:`TautSet.tensions_many` (bounds its temporaries; larger batches ran slower, out of cache) to
#: about 0.1 GB on any mesh).
BATCH_ELEMENTS = 20_000


def _minor_many(membrane: MembraneSet, xe: np.ndarray) -> np.ndarray:
    """:func:`minor_resultant` at ``K`` states at once: ``xe`` ``(K, ne, 3, 3)`` → ``(K, ne)``
    (N/m); the same arithmetic per element, so equal to ``K`` single calls."""
    k, ne = xe.shape[:2]
    grads = np.broadcast_to(membrane.gradients, (k, *membrane.gradients.shape))
    thick = np.asarray(membrane.thickness, float)
    if thick.ndim:
        thick = np.broadcast_to(thick, (k, ne)).reshape(-1)
    flat = _minor(grads.reshape(k * ne, 3, 2), membrane.d, thick, xe.reshape(k * ne, 3, 3))
    return flat.reshape(k, ne)


@dataclass(frozen=True)
class TautSet:
    """The membrane elements of a structure at a reference state ``x0`` (every membrane set, an
    image set's too, concatenated in the order of ``structure.elements``).

    sets: the element sets; area ``(ne,)`` m² (stress-free); centroid ``(ne, 3)`` m at x0;
    tension ``(ne,)`` N/m: minor principal resultant at x0; judged ``(ne,)`` bool: the elements
    whose loss of tension counts — taut at x0 (tension > 0) and off the bonded end-body patches.
    Elements already slack at x0 (an SVK membrane in compression there, e.g. near the corners of
    the IKAROS-like sail) are not judged: the reference is the model's, and its own slack area is
    reported apart (:attr:`reference_slack_area`)."""

    sets: tuple
    area: np.ndarray
    centroid: np.ndarray
    tension: np.ndarray
    judged: np.ndarray
    off_patch: np.ndarray

    @property
    def reference_slack_area(self) -> float:
        """Fraction of the off-patch membrane area not taut at the reference state."""
        off = self.off_patch
        return float(np.sum(self.area[off & ~self.judged]) / max(np.sum(self.area[off]), 1e-300))

    def tensions(self, x: np.ndarray) -> np.ndarray:
        """Minor principal resultants ``(ne,)`` (N/m) at the state ``x`` ``(n, 3)`` m."""
        return np.concatenate([minor_resultant(_inner(e), _element_positions(e, x))
                               for e in self.sets])  # fmt: skip

    def tensions_many(self, xs: np.ndarray) -> np.ndarray:
        """:meth:`tensions` at ``K`` states ``xs`` ``(K, n, 3)`` m: ``(K, ne)`` N/m, in batches
        of at most :data:`BATCH_ELEMENTS` element evaluations (one numpy pass per batch instead
        of one per state: the path's tension check and the slack onset's ray scan)."""
        xs = np.asarray(xs, float)
        per = max(1, BATCH_ELEMENTS // max(1, len(self.area)))
        out = [np.concatenate([_minor_many(_inner(e), _element_positions_many(e, xs[i:i + per]))
                               for e in self.sets], axis=1)
               for i in range(0, len(xs), per)]  # fmt: skip
        return np.concatenate(out) if out else np.zeros((0, len(self.area)))


def taut_set(structure: Structure, x0: np.ndarray) -> TautSet | None:
    """:class:`TautSet` of ``structure`` at ``x0`` ``(n, 3)`` m (None without a membrane)."""
    x0 = np.asarray(x0, float).reshape(-1, 3)
    sets = tuple(e for e in structure.elements if _inner(e) is not None)
    if not sets:
        return None
    area = np.concatenate([_inner(e).area0 for e in sets])
    centroid = np.concatenate([_element_positions(e, x0).mean(axis=1) for e in sets])
    off_patch = np.concatenate([~bonded_elements(structure, e) if e is _inner(e)
                                else np.ones(len(e.conn), bool) for e in sets])  # fmt: skip
    probe = TautSet(sets, area, centroid, np.zeros(len(area)), off_patch, off_patch)
    tension = probe.tensions(x0)
    return TautSet(sets, area, centroid, tension, off_patch & (tension > 0.0), off_patch)


def seam_bodies(structure: Structure, taut: TautSet, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(body, distance)`` ``(ne,)`` each: for every element of ``taut``, the end body whose
    bonded patch it lies next to — a node on the patch, or its centroid within the patch's
    radius (the largest distance of the patch's nodes from their centroid, at ``x0`` ``(n, 3)``
    m) of a patch node — and that distance (m); "" and inf elsewhere (and for an image set's elements). The seam of a rigid end
    fitting: its rim holds the hoop strain at zero, so the minor (hoop) tension of an inflated
    membrane is low there (paper-membrane-coarse at 41 Hz: 15–48 N/m against a median of 224
    N/m) and the end body's motion relative to the membrane changes it at first order: where a
    pressurised membrane's path goes slack first (docs/validation.md)."""
    x0 = np.asarray(x0, float).reshape(-1, 3)
    body = np.full(len(taut.area), "", dtype=object)
    distance = np.full(len(taut.area), np.inf)
    own = np.concatenate([np.full(len(e.conn), e is _inner(e)) for e in taut.sets])
    conn = np.concatenate([e.conn if e is _inner(e) else np.full((len(e.conn), 3), -1)
                           for e in taut.sets])  # fmt: skip
    for name, nodes in structure.groups.items():
        if not name.startswith("attach:") or len(nodes) == 0:
            continue
        patch = x0[np.asarray(nodes)]
        radius = float(np.max(np.linalg.norm(patch - patch.mean(axis=0), axis=1)))
        d = np.min(np.linalg.norm(taut.centroid[:, None, :] - patch[None], axis=2), axis=1)
        touching = np.isin(conn, nodes).any(axis=1)
        near = own & taut.off_patch & ((d <= radius) | touching) & (d < distance)
        body[near], distance[near] = name.partition(":")[2], d[near]
    return body, distance


def slack_place(structure: Structure, taut: TautSet, x0: np.ndarray, slack: np.ndarray) -> str:
    """Where the elements ``slack`` ``(ne,)`` bool of ``taut`` are, in words
    (:func:`seam_bodies`): "at the seam of end body 'front' (within 3.1 mm of its bonded
    patch)", "… and N elements off the seams", "off the end-body seams"; "" for a structure
    without end bodies or nothing slack."""
    if not slack.any() or not any(g.startswith("attach:") for g in structure.groups):
        return ""
    body, distance = seam_bodies(structure, taut, x0)
    names = sorted({str(b) for b in body[slack] if b})
    off = int(np.sum(slack & (body == "")))
    if not names:
        return "off the end-body seams"
    text = ("at the seam of end body " if len(names) == 1 else "at the seams of end bodies ")
    text += ", ".join(f"'{b}'" for b in names)
    text += f" (within {1e3 * float(np.max(distance[slack & (body != '')])):.3g} mm of the bonded patch)"
    return text + (f" and {off} element{'s' * (off > 1)} off the seams" if off else "")


@dataclass(frozen=True)
class ManifoldSlack:
    """First loss of tension along ``x0 + a u1 + a² u2`` (exact strain), among the elements taut
    at ``x0`` (:class:`TautSet`).

    fraction: the smallest ``a`` > 0 at which a judged element's minor resultant reaches 0 (inf:
    none up to :data:`RAY_LIMIT`); element: its index in the concatenated membrane elements (-1:
    none); position ``(3,)`` m: its centroid at x0; least_tension (N/m) at ``a = 1`` over the
    judged elements, at least_position ``(3,)`` m, whose tension at x0 was least_reference
    (N/m); slack_area: fraction of the judged area slack at ``a = 1``; reference_slack_area: of
    the off-patch area, the fraction not taut at x0 (not judged)."""

    fraction: float
    element: int
    position: np.ndarray
    least_tension: float
    least_position: np.ndarray
    least_reference: float
    slack_area: float
    reference_slack_area: float


def _first_slack(taut: TautSet, x0, u1, u2) -> tuple[float, int]:
    """(a, element) of the first loss of tension of a judged element along the ray (inf, -1)."""
    judged = taut.judged

    def least(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The least judged tension (N/m) and its element at each ``a`` ``(m,)``."""
        xs = x0 + a[:, None, None] * u1 + (a * a)[:, None, None] * u2
        t = np.where(judged, taut.tensions_many(xs), np.inf)
        k = np.argmin(t, axis=1)
        return t[np.arange(len(a)), k], k

    grid = RAY_LIMIT * np.linspace(0.0, 1.0, RAY_SCAN + 1)[1:] ** 2
    for b in range(0, RAY_SCAN, RAY_BLOCK):  # the scan in blocks: stops at the first slack one
        values, elements = least(grid[b:b + RAY_BLOCK])
        hit = np.flatnonzero(values <= 0.0)
        if not hit.size:
            continue
        j = b + int(hit[0])
        lo, hi, k = (grid[j - 1] if j else 0.0), grid[j], int(elements[hit[0]])
        for _ in range(RAY_BISECTIONS):
            mid = 0.5 * (lo + hi)
            value, element = least(np.array([mid]))
            if value[0] <= 0.0:
                hi, k = mid, int(element[0])
            else:
                lo = mid
        return hi, k
    return np.inf, -1


def manifold_slack_onset(structure: Structure, x0: np.ndarray, u1: np.ndarray,
                         u2: np.ndarray | None = None, taut: TautSet | None = None,
                         ) -> ManifoldSlack | None:  # fmt: skip
    """:class:`ManifoldSlack` of ``structure`` at ``x0`` ``(n, 3)`` m along the displacement
    ``a u1 + a² u2`` (``(n, 3)`` m each; ``u2`` None: a straight ray). ``taut``: the structure's
    :class:`TautSet` at ``x0`` when already made. None without a membrane or a judged element."""
    x0 = np.asarray(x0, float).reshape(-1, 3)
    u1 = np.asarray(u1, float).reshape(-1, 3)
    u2 = np.zeros_like(u1) if u2 is None else np.asarray(u2, float).reshape(-1, 3)
    taut = taut if taut is not None else taut_set(structure, x0)
    if taut is None or not taut.judged.any():
        return None
    fraction, k = _first_slack(taut, x0, u1, u2)
    t1 = np.where(taut.judged, taut.tensions(x0 + u1 + u2), np.inf)
    j = int(np.argmin(t1))
    slack = taut.judged & (t1 <= 0.0)
    return ManifoldSlack(
        fraction=fraction, element=k,
        position=taut.centroid[k] if k >= 0 else np.full(3, np.nan),
        least_tension=float(t1[j]), least_position=taut.centroid[j],
        least_reference=float(taut.tension[j]),
        slack_area=float(taut.area[slack].sum() / taut.area[taut.judged].sum()),
        reference_slack_area=taut.reference_slack_area,
    )  # fmt: skip
