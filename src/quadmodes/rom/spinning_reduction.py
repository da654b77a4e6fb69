"""A reduced model expanded about the spinning state instead of the state at rest.

At 41 Hz the centrifugal stretch of the seed's membrane is as large as its inflation strain; a
model expanded about the inflated state at rest must carry that stretch in its modal
coordinates, where its truncated potential is least accurate. Expanded about the finite-element
model's own centrifugal relative equilibrium at the run's nominal spin, the steady stretch is in
the reference and the coordinates carry only the vibration about it (and the slow change of
the spin). Stages::

    structure, x at rest ──spinning_modes──▶ relative equilibrium x_Ω, modes of K_T(x_Ω) − Ω²MP̂
                          ──reduce_spinning──▶ ReducedModel (X = x_Ω, F1 = Φᵀ f(x_Ω), Λ, damping)

The kinetic energy stays the exact floating-frame one (it supplies the centrifugal and Coriolis
terms at whatever ω the body has); only the reference, the basis and the potential's expansion
point change (:class:`~quadmodes.rom.reduced.ReducedModel`). At the nominal spin, s = 0 is a
relative equilibrium of the reduced equations and their linearisation is the Galerkin
projection of the full order's rotating-frame linearisation on the basis
(:mod:`quadmodes.analysis.rotating_modes`).

Damping: the basis is not a set of the structure's modes at rest, so the modal damping is the
projection of the structure's own (:func:`quadmodes.structure.damping.projected_damping`): ζ on
every mode at rest below the cutoff, the definition the full-order reference uses.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from quadmodes.fe.model import Structure, inertia_tensor
from quadmodes.rom.reduced import ReducedModel, SpinningReference, reduce
from quadmodes.structure.damping import (
    SolvedModes,
    damping_state,
    default_cutoff,
    modes_below,
    projected_damping,
)
from quadmodes.structure.labels import label_modes
from quadmodes.structure.modes import ModalResult, compute_modes
from quadmodes.structure.spinning import (
    SpinningEquilibrium,
    centrifugal_softening,
    neutral_modes,
    relative_equilibrium,
)


def minor_axis(structure: Structure, x: np.ndarray) -> np.ndarray:
    """Minor principal axis (3,) of the inertia of state ``x`` (n,3) about its centre of mass,
    sign: largest component positive (the spin axis of a free-body run)."""
    _, vec = np.linalg.eigh(inertia_tensor(structure, x))
    v = vec[:, 0]
    return v * np.sign(v[np.argmax(np.abs(v))])


def spinning_modes(
    structure: Structure, x_rest: np.ndarray, count: int, spin: float, axis=None,
    start: SpinningEquilibrium | None = None,
) -> tuple[SpinningEquilibrium, ModalResult, list[str]]:  # fmt: skip
    """The relative equilibrium of the free ``structure`` at ``spin`` (rad/s) about ``axis``
    (default :func:`minor_axis` of ``x_rest`` (n,3) m, the prestressed state at rest), and the
    lowest ``count`` modes of its rotating-frame stiffness ``K_T(x_Ω) − Ω²MP̂`` with the frame
    conditions (no Coriolis term: that is the reduced equations' own), with their labels.

    ``start``: a relative equilibrium at another (or the same) spin to continue from instead of
    ``x_rest`` (a membrane without stiffness at rest: :mod:`quadmodes.structure.flat_spin`); its
    axis is then the spin axis."""
    if not structure.is_free:
        raise ValueError(
            'reduced.reference = "spinning" is for free bodies; a hub-driven body is expanded '
            'about its state at rest (use reference = "rest")'
        )
    if start is not None:
        e = start.axis
        eq = start if start.spin == spin else relative_equilibrium(
            structure, start.x, spin, e, start_spin=start.spin, reference=x_rest,
            rtol=max(1e-10, 10.0 * start.residual),
        )  # fmt: skip
    else:
        e = minor_axis(structure, x_rest) if axis is None else np.asarray(axis, float)
        eq = relative_equilibrium(structure, x_rest, spin, e)
    modes = compute_modes(structure, eq.x, count, softening=centrifugal_softening(structure, spin, e))
    neutral = neutral_modes(modes.frequencies_hz, spin)
    if np.any((modes.frequencies_hz < 0.0) & ~neutral):
        shown = ", ".join(f"{round(float(v), 6) + 0.0:.3g}" for v in e)  # no -0, no 1e-17
        raise ValueError(
            f"the rotating-frame stiffness at {spin / (2 * np.pi):.4g} Hz about the body axis "
            f"({shown}) is not positive definite (the spin is beyond a "
            "divergence speed of the body, e.g. slack blades along the spin axis); a spinning "
            'reference needs a stable spin: use reference = "rest"'
        )
    labels = label_modes(structure, eq.x, modes.shapes)
    if np.any(neutral):  # kept as coordinates with zero stiffness (docs/sails.md, "The hub")
        modes = replace(modes, frequencies_hz=np.where(neutral, 0.0, modes.frequencies_hz))
        labels = [f"{lab} (neutral)" if n else lab for lab, n in zip(labels, neutral, strict=True)]
    return eq, modes, labels


def reduce_spinning(
    structure: Structure,
    x_rest: np.ndarray,
    eq: SpinningEquilibrium,
    frequencies_hz: np.ndarray,
    shapes: np.ndarray,
    labels,
    zeta: float,
    progress=None,
    provenance: dict | None = None,
    damping_cutoff_hz: float | None = None,
    memo: SolvedModes | None = None,
) -> ReducedModel:
    """:func:`~quadmodes.rom.reduced.reduce` about the relative equilibrium ``eq`` with the
    retained modes (frequencies Hz (N,), shapes (N,n,3) 1/√kg, labels) of :func:`spinning_modes`
    and the projected modal damping of ratio ``zeta`` on every mode of ``x_rest`` (of ``eq.x``
    for a structure without stiffness at rest,
    :func:`~quadmodes.structure.damping.damping_state`) below
    ``damping_cutoff_hz`` (Hz; default
    :func:`~quadmodes.structure.damping.default_cutoff` of the spin and the retained modes).
    ``memo``: the modes solved about ``x_rest`` so far (the modal model's
    :class:`~quadmodes.structure.damping.SolvedModes`: the damping modes at rest solved once for
    all the spins a structure is expanded about)."""
    spin_hz = abs(float(eq.spin)) / (2.0 * np.pi)
    cutoff = damping_cutoff_hz or default_cutoff(spin_hz, frequencies_hz)
    c, where = None, "at rest"
    if zeta > 0.0:
        x_d, state = damping_state(structure, x_rest, eq.x, float(eq.spin), memo)
        where = "at rest" if state == "rest" else "of the spinning state"
        f_d, phi_d, _ = modes_below(structure, x_d, cutoff, memo=memo)
        c = projected_damping(structure, shapes, f_d, phi_d, zeta)
    info = dict(provenance or {})
    info.update(reference="spinning", reference_spin_hz=spin_hz,
                damping=f"projected: zeta = {zeta:g} on every mode {where} below {cutoff:.4g} Hz",
                reference_volume_change=eq.volume_change)  # fmt: skip
    return reduce(
        structure, eq.x, frequencies_hz, shapes, labels, zeta, progress, info,
        spinning=SpinningReference(float(eq.spin), eq.axis), damping_matrix=c,
    )  # fmt: skip
