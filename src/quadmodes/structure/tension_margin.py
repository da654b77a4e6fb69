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
