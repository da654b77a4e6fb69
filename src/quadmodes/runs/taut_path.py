"""Does the membrane stay taut along a run's path? The exact tension of the reduced model's
deformed state at the path's samples (item 6 of issue 26).

At each checked sample the reduced model's deformation is its manifold displacement
``U = Φs + Σ s_m s_n g^{mn}`` from its reference state ``X`` (the state at rest, or the spinning
state); the minor principal stress resultant of every membrane element at ``X + U`` is taken from
the exact Green strain (:func:`quadmodes.structure.tension_margin.minor_resultant`), never
linearised: a flat membrane deflected out of its plane changes its strain at second order only,
which the linearised onset cannot see. Judged are the elements taut at ``X`` (the reference's
own slack area, e.g. near the IKAROS-like sail's corners, is reported apart). The path leaves
the taut range at the first checked sample where a judged element has lost tension; along the
ray of the sample of largest ‖s‖ the onset is also given as a fraction of that state
(:func:`quadmodes.runs.deformation_check.slack_along`).

A state whose deformation is below :data:`ROUND_OFF_DEFORMATION` × the body's size is no
deformation (the integration's round-off, e.g. the modes of a rigidly nutating flat disc at
1e-17): nothing there to check.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from quadmodes.rom import system as rsys

#: The tension is checked on at most this many samples of the path and the one of largest ‖s‖.
TENSION_SAMPLES = 200
#: Largest nodal displacement, relative to the body's size (largest distance of a node from the
#: centroid of the reference), below which a state is taken as undeformed (round-off).
ROUND_OFF_DEFORMATION = 1e-9


def deformation_scale(model, s: np.ndarray) -> tuple[float, float]:
    """(largest nodal displacement of the manifold displacement at ``s`` (N,), the body's size)
    (m), both over the position rows of ``model`` (not slopes nor a hub's axes)."""
    from quadmodes.runs.deformation_check import manifold_parts

    rows = np.asarray(model.translational, bool)
    x = np.asarray(model.X, float)[rows]
    u = np.add(*manifold_parts(model, s))[rows]
    return (float(np.max(np.linalg.norm(u, axis=1))),
            float(np.max(np.linalg.norm(x - x.mean(axis=0), axis=1))))  # fmt: skip


def manifold_displacements(model, s: np.ndarray) -> np.ndarray:
    """The manifold displacements ``Φs + Σ s_m s_n g^{mn}`` ``(K, n, 3)`` (m) of ``model`` at
    ``K`` modal states ``s`` ``(K, N)`` (:func:`quadmodes.runs.deformation_check.manifold_parts`
    of each, summed)."""
    s = np.atleast_2d(np.asarray(s, float))
    k, n_modes = s.shape
    phi = np.asarray(model.Phi, float).reshape(n_modes, -1)
    g = np.asarray(model.G, float).reshape(n_modes * n_modes, -1)
    quad = np.einsum("km,kn->kmn", s, s).reshape(k, -1)
    return (s @ phi + quad @ g).reshape(k, -1, 3)


def is_round_off(model, s: np.ndarray) -> bool:
    """The deformation at ``s`` is below :data:`ROUND_OFF_DEFORMATION` × the body's size."""
    largest, size = deformation_scale(model, s)
    return largest < ROUND_OFF_DEFORMATION * size


def sample_tensions(model, taut, s: np.ndarray):
    """At ``K`` modal states ``s`` ``(K, N)`` of ``model``, the membrane of ``taut`` (a
    :class:`~quadmodes.structure.tension_margin.TautSet` at ``model.X``) at the manifold point:
    ``(least (K,) N/m, element (K,), slack area (K,) m², ever (E,) bool)``, the least minor
    resultant of the judged elements, its element and their area not taut (inf, 0, 0 where the
    deformation is round-off: nothing to check), and which elements are slack at some state. The states are evaluated in batches (a numpy pass per batch
    of :data:`~quadmodes.structure.tension_margin.BATCH_ELEMENTS` element evaluations, not one
    per state)."""
    from quadmodes.structure.tension_margin import BATCH_ELEMENTS

    x_ref = np.asarray(model.X, float)
    rows = np.asarray(model.translational, bool)
    size = float(np.max(np.linalg.norm(x_ref[rows] - x_ref[rows].mean(axis=0), axis=1)))
    least, element, slack = np.full(len(s), np.inf), np.zeros(len(s), int), np.zeros(len(s))
    ever = np.zeros(len(taut.area), bool)
    per = max(1, BATCH_ELEMENTS // max(1, len(taut.area)))
    for b in range(0, len(s), per):
        u = manifold_displacements(model, s[b:b + per])
        deformed = np.max(np.linalg.norm(u[:, rows], axis=2), axis=1) >= ROUND_OFF_DEFORMATION * size
        if not deformed.any():
            continue
        k = b + np.flatnonzero(deformed)
        tension = np.where(taut.judged, taut.tensions_many(x_ref + u[deformed]), np.inf)
        element[k] = np.argmin(tension, axis=1)
        least[k] = tension[np.arange(len(k)), element[k]]
        slack[k] = (tension <= 0.0) @ taut.area
        ever |= np.any(tension <= 0.0, axis=0)
    return least, element, slack, ever


@dataclasses.dataclass(frozen=True)
class PathTension:
    """The membrane's tension along a path.

    least (N/m): the smallest minor principal resultant over the judged elements and the checked
    samples, at time least_time (s) and position least_position ``(3,)`` m (reference); slack_at
    (s): the first checked sample where a judged element is slack (None: none); slack_area: the
    largest fraction of the judged area slack at a checked sample; reference_slack_area: of the
    off-patch area, the fraction not taut at the reference (not judged); peak_fraction: the
    fraction of the state of largest ‖s‖ at which the first judged element loses tension along
    its manifold ray (inf: none up to 4 ×); slack_where: where the elements slack at any checked
    sample are (:func:`~quadmodes.structure.tension_margin.slack_place`, e.g. "at the seam of
    end body 'front'"; "": none, or no end bodies); samples: how many were checked; checked_times (s)
    and checked_least (N/m) ``(samples,)``: each checked sample's time and least tension of the
    judged elements (+inf where its deformation is round-off)."""

    least: float
    least_time: float
    least_position: np.ndarray
    slack_at: float | None
    slack_area: float
    reference_slack_area: float
    peak_fraction: float
    samples: int
    slack_where: str = ""
    checked_times: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    checked_least: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))


def path_tension(setup, solution, structure=None, peak_fraction: float | None = None,
                 ) -> PathTension | None:  # fmt: skip
    """:class:`PathTension` of a run (a prepared
    :class:`~quadmodes.runs.simulate.RunSetup` and its merged solution); None without a
    membrane or modes. ``peak_fraction``: the slack onset along the ray of the state of largest
    ‖s‖ when already known (the path's amplitude check finds it), else it is found here."""
    from quadmodes.runs import deformation_check as dc
    from quadmodes.structure.tension_margin import slack_place, taut_set

    system, model = setup.system, setup.model
    t, y = np.asarray(solution.t, float), np.asarray(solution.y, float)
    s = rsys.split_state(system, y)[2]
    if s.shape[1] == 0 or len(t) == 0:
        return None
    structure = structure or dc.deformation_structure(setup)
    x_ref = np.asarray(model.X, float)
    taut = taut_set(structure, x_ref)
    if taut is None or not taut.judged.any():
        return None
    amp = np.linalg.norm(s, axis=1)
    peak = int(np.argmax(amp))
    idx = np.unique(np.r_[np.linspace(0, len(t) - 1, min(len(t), TENSION_SAMPLES)).astype(int),
                          peak])  # fmt: skip
    per_sample, element, slack_per, ever = sample_tensions(model, taut, s[idx])
    least, least_k, least_e, slack_at, slack_area = math.inf, 0, 0, None, 0.0
    i = int(np.argmin(per_sample))  # the first sample of the least tension
    if math.isfinite(per_sample[i]):
        least, least_k, least_e = float(per_sample[i]), int(idx[i]), int(element[i])
    slack = per_sample <= 0.0
    if slack.any():
        slack_area = float(np.max(slack_per) / taut.area[taut.judged].sum())
        slack_at = float(t[idx[int(np.argmax(slack))]])
    if peak_fraction is None and math.isfinite(least):
        onset = dc.slack_along(model, structure, s[peak], taut)
        peak_fraction = math.inf if onset is None else float(onset[0].fraction)
    elif not math.isfinite(least):
        peak_fraction = math.inf
    return PathTension(
        least=least, least_time=float(t[least_k]),
        least_position=taut.centroid[least_e] if math.isfinite(least) else np.full(3, np.nan),
        slack_at=slack_at, slack_area=slack_area,
        reference_slack_area=taut.reference_slack_area,
        peak_fraction=peak_fraction,
        samples=len(idx), slack_where=slack_place(structure, taut, x_ref, ever),
        checked_times=t[idx], checked_least=per_sample,
    )  # fmt: skip


def tension_reason(tension: PathTension) -> str:
    """The path's reason for leaving the taut range (``tension.slack_at`` not None)."""
    where = ", ".join(f"{v:.3g}" for v in tension.least_position)
    rest = (f"; {100 * tension.reference_slack_area:.2g} % of the membrane already slack at "
            "the reference state, not judged" if tension.reference_slack_area > 0 else "")
    return (f"the membrane loses tension where it is taut at the reference (exact strain of the "
            f"manifold displacement Φs + Σ s s g): up to {100 * tension.slack_area:.3g} % of that "
            f"area slack{' ' + tension.slack_where if tension.slack_where else ''}, least tension {tension.least:.3g} N/m at ({where}) m, t = "
            f"{tension.least_time:.6g} s; the state of largest |s| is "
            f"{1 / tension.peak_fraction:.3g} × the onset along its own direction{rest}")  # fmt: skip
