"""Initial state of a free-body run: a deformation in the first bending mode and the coning
angular velocity about the minor principal axis of the deformed body, or about
``initial.spin_axis`` (a principal axis of the deformed inertia, exactly the axis given for equal
moments: :mod:`quadmodes.rom.spin_axis`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadmodes.case import CaseError, RunCase
from quadmodes.rom import dynamics as dyn
from quadmodes.rom import reduced as red
from quadmodes.rom import system as rsys
from quadmodes.rom.spin_axis import AXIS_TOL, axis_for_inertia
from quadmodes.structure.labels import PAIR_TOLERANCE


def bending_pair(labels, frequencies_hz) -> tuple[int, ...]:
    """Indices of the first bending mode and its partner (same label, frequency within
    :data:`PAIR_TOLERANCE`); ``()`` if no retained mode is labelled bending."""
    labels = list(labels)
    found = [k for k, lab in enumerate(labels) if "bending" in str(lab).lower()]
    if not found:
        return ()
    first = found[0]
    pair = [first]
    nxt = first + 1
    f = np.asarray(frequencies_hz, float)
    if nxt < len(labels) and labels[nxt] == labels[first]:
        if abs(f[nxt] - f[first]) <= PAIR_TOLERANCE * f[first]:
            pair.append(nxt)
    return tuple(pair)


def _lowest_pair(model: red.ReducedModel, notes: list[str]) -> tuple[int, ...]:
    """The lowest retained mode and its partner (:func:`bending_pair`'s rule) for the initial
    deformation of a model about a spinning state without a mode labelled bending (a membrane
    held taut by its spin: its modes are "disc (n, s)" …), with a note naming it."""
    labels = [str(lab) for lab in model.labels]
    pair = bending_pair([lab if lab != labels[0] else "bending" for lab in labels],
                        model.frequencies_hz)  # fmt: skip
    notes.append(f"initial.bending_amplitude: no mode is labelled bending; the lowest, "
                 f"{labels[0]}, is deformed")  # fmt: skip
    return pair


def largest_nodal_displacement(model: red.ReducedModel, mode: int) -> float:
    """Largest nodal displacement (m) of mode ``mode`` per unit modal coordinate (√kg·m)."""
    u = np.asarray(model.Phi[mode])[np.asarray(model.translational, bool)]
    return float(np.max(np.linalg.norm(u, axis=1)))


@dataclass(frozen=True, eq=False)
class InitialState:
    """Initial state of a run.

    y0 (7+2N,): [q, ω, s, ṡ]. spin_axis (3,): body-frame minor principal axis of J̃(s0) (sign:
    largest component positive), or the axis of ``initial.spin_axis``. inertia (3,3) kg m²: J̃(s0). bending_modes: indices of the
    first bending pair (may be empty). notes: remarks (e.g. an ignored deformation)."""

    y0: np.ndarray
    spin_axis: np.ndarray
    inertia: np.ndarray
    bending_modes: tuple[int, ...]
    notes: tuple[str, ...] = ()


def _initial_deformation(
    model: red.ReducedModel, n: int, pair: tuple[int, ...], amplitude: float, notes: list[str]
) -> np.ndarray:
    """s0 (N,) √kg·m: ``amplitude`` (m, largest nodal displacement) in the first bending mode
    ``pair[0]``; zero if ``amplitude`` is 0 (or with no elastic modes, noted in ``notes``)."""
    s0 = np.zeros(n)
    if amplitude > 0.0:
        if n == 0:
            notes.append("initial.bending_amplitude ignored: no elastic modes (rigid)")
        elif not pair:
            labels = ", ".join(model.labels)
            raise CaseError(
                "initial.bending_amplitude: no retained mode is a bending mode "
                f'(labels: {labels}); set it to "0 in" or '
                "keep more modes in [reduced]",
                field="initial.bending_amplitude",
            )
        else:
            s0[pair[0]] = amplitude / largest_nodal_displacement(model, pair[0])
    return s0


def coning_about(jt: np.ndarray, e: np.ndarray, spin: float, cone_angle: float) -> np.ndarray:
    """Body angular velocity (3,) rad/s spinning at ``spin`` about the principal axis ``e`` (3,)
    of ``jt`` (3, 3) kg m² with cone angle ``cone_angle`` (rad) between H = J ω and e
    (tan θ = I_t ω⊥ / (I_a ω_a)); the transverse part lies along the transverse principal
    direction of smaller moment (for the minor axis: the intermediate axis, as
    :func:`quadmodes.rom.dynamics.coning_omega`)."""
    basis = np.linalg.svd(np.eye(3) - np.outer(e, e))[0][:, :2]  # plane across e
    lam_t, vec_t = np.linalg.eigh(basis.T @ jt @ basis)
    et = basis @ vec_t[:, 0]
    i_a = float(e @ jt @ e)
    return spin * e + np.tan(cone_angle) * i_a * spin / lam_t[0] * et


def _spin_axis(model: red.ReducedModel, jt: np.ndarray, run: RunCase) -> np.ndarray | None:
    """The axis of ``initial.spin_axis`` for J̃(s0) ``jt`` (None when not given); a model
    expanded about a spinning state must spin about the axis it was expanded about."""
    if run.initial.spin_axis is None:
        return None
    e = axis_for_inertia(jt, run.initial.spin_axis, "initial.spin_axis")
    ref = model.reference_axis
    if model.reference_spin and ref is not None and abs(e @ ref) < np.cos(AXIS_TOL):
        raise CaseError(
            "initial.spin_axis: the reduced model is expanded about the spinning state about "
            f"({ref[0]:.4g}, {ref[1]:.4g}, {ref[2]:.4g}); remove spin_axis or set "
            'reduced.reference = "rest"',
            field="initial.spin_axis",
        )
    return e


def initial_state(system: rsys.ReducedSystem, model: red.ReducedModel, run: RunCase) -> InitialState:
    """Initial state of ``run``: modal displacement s0 in the first bending mode (largest nodal
    displacement = ``initial.bending_amplitude``), ṡ0 = 0, q0 = identity, and the body angular
    velocity of :func:`quadmodes.rom.dynamics.coning_omega` for J̃(s0): spin ``initial.spin_rate``
    about the minor principal axis of J̃(s0) (or ``initial.spin_axis``, :func:`coning_about`),
    cone angle ``initial.cone_angle`` between H = J̃(s0) ω and that axis."""
    n = system.n_modes
    notes: list[str] = []
    pair = bending_pair(model.labels, model.frequencies_hz) if n else ()
    if n and not pair and model.reference_spin and run.initial.bending_amplitude > 0.0:
        pair = _lowest_pair(model, notes)
    s0 = _initial_deformation(model, n, pair, run.initial.bending_amplitude, notes)
    jt = dyn.inertia_tensor(system, s0, "rot")
    jt = 0.5 * (jt + jt.T)
    axis = _spin_axis(model, jt, run)
    if axis is None:
        omega = dyn.coning_omega(jt, run.initial.spin_rate, run.initial.cone_angle)
        lam, vec = np.linalg.eigh(jt)
        axis = vec[:, 0] * np.sign(vec[np.argmax(np.abs(vec[:, 0])), 0])
    else:
        omega = coning_about(jt, axis, run.initial.spin_rate, run.initial.cone_angle)
    y0 = rsys.pack_state(system, omega=omega, s=s0)
    return InitialState(y0, axis, jt, pair, tuple(notes))
