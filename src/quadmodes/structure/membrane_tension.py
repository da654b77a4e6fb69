"""Where the membrane of a state is not taut: the cause named when a full-order Newton step
fails on a membrane that has lost its tension, and the taut-regime check of a reduced run's path
(docs/sails.md, "Full-order comparisons in time on the hub-mounted bodies").

A membrane has no bending stiffness. Where its minor principal stress is negative (a St
Venant–Kirchhoff membrane in compression) its tangent has a negative geometric stiffness with
nothing to hold it, so short waves grow at a rate ∝ 1/element size and the full order's step
matrix ``M + (Δt²/2)K`` loses definiteness (measured on ``spinning-annulus-nutation``, docs);
where the tension-field law relaxes it (wrinkled or slack) the residual is not smooth on the
iteration's scale and the iteration stalls. Either way the Newton failure is the membrane's loss
of tension, not the step or the tolerance, and the error message says so. A reduced model whose
quadratic modes are the SVK membrane's carries the same compression without knowing it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.fe.model import Structure

#: A state is said to have lost its tension when its area not taut exceeds the reference
#: state's by more than this fraction of the membrane's area (a square sail is slack at its
#: corners already in its reference state: 2–4 %).
LOSS_MARGIN = 0.01


@dataclass(frozen=True)
class TensionState:
    """How taut the membranes of a state are: the fraction of their (stress-free) area where
    the minor principal stress resultant is ≤ 0 (compressed, wrinkled or slack), the least
    minor resultant (N/m) and the centroid (3,) m of its element."""

    not_taut_fraction: float
    least_resultant: float
    position: tuple[float, float, float]


def membrane_sets(structure: Structure) -> list:
    """The element sets of ``structure`` with principal stress resultants (membranes, and the
    hub-clamped triangles of :class:`~quadmodes.fe.hub_membrane.ImageSet`)."""
    return [e for e in structure.elements if hasattr(e, "principal_stress_resultants")]


def tension_state(structure: Structure, x: np.ndarray) -> TensionState | None:
    """:class:`TensionState` of the state x (n,3) m, or None for a structure without
    membranes."""
    sets = membrane_sets(structure)
    if not sets:
        return None
    minor = np.concatenate([e.principal_stress_resultants(x)[:, 0] for e in sets])
    area = np.concatenate([(e.inner if hasattr(e, "inner") else e).area0 for e in sets])
    centres = np.concatenate([_centroids(e, x) for e in sets])
    k = int(np.argmin(minor))
    return TensionState(float(area[minor <= 0.0].sum() / area.sum()), float(minor[k]),
                        tuple(float(c) for c in centres[k]))  # fmt: skip


def _centroids(element_set, x: np.ndarray) -> np.ndarray:
    """Element centroids (ne, 3) m of a membrane set or an image set at x (n,3)."""
    if hasattr(element_set, "inner"):  # an ImageSet: its virtual node positions
        return element_set._virtual(x).reshape(len(element_set.conn), -1, 3).mean(axis=1)
    return x[element_set.conn].mean(axis=1)


def loss_of_tension(structure: Structure, x: np.ndarray, x_ref: np.ndarray) -> str:
    """One clause naming the membrane's loss of tension at x (n,3) m against the reference
    state x_ref (n,3) m (empty when its area not taut has not grown by :data:`LOSS_MARGIN`, or
    without membranes): the cause of a full-order Newton failure."""
    now, ref = tension_state(structure, x), tension_state(structure, x_ref)
    if now is None or now.not_taut_fraction <= ref.not_taut_fraction + LOSS_MARGIN:
        return ""
    where = ", ".join(f"{c:.3g}" for c in now.position)
    return (
        f"the membrane has lost its tension: not taut on {100 * now.not_taut_fraction:.0f} % of "
        f"its area ({100 * ref.not_taut_fraction:.0f} % in the reference state), least principal "
        f"stress resultant {now.least_resultant:.3g} N/m at ({where}) m; a membrane has no "
        "stable state in compression: the motion is too large for it to stay taut (a smaller "
        "initial.cone_angle or deformation keeps it taut; docs/sails.md)"
    )
