"""Is the run's initial deformation inside the reduced potential's range? One static check
against the finite-element model, before a run with an initial modal deformation.

At the initial modal coordinates ``s0`` the reduced potential ``V(s0)`` is set beside the FE
model's own statically condensed energy ``W_c(s0)`` — the total potential minimised over every
degree of freedom outside the retained and rigid modes
(:func:`quadmodes.rom.manifold_energy.condensed_energy`), which is what the full order starts
from (:func:`quadmodes.analysis.full_order_runs.relaxed_deformation`). Both are taken without the work
of the reference state's constant force ``f(x_ref)`` (zero about the state at rest; the
centrifugal load about a spinning state), so they agree to second order by construction and
their difference is the reduced potential's error at that amplitude.

Why energy: a relative energy error ε at the peak of an oscillation shifts its frequency by
about ε/2, so the 2 % tolerance (:data:`~quadmodes.runs.validity.DEFORMATION_ENERGY_TOLERANCE`)
stands for a frequency error of about 1 %. Measured on ``paper-membrane`` (docs/full-order.md):
0.5 in of initial bending is at 2.7 %, 1 in far beyond (the membrane wrinkles).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from quadmodes.rom import dynamics as dyn
from quadmodes.rom import manifold_energy as me
from quadmodes.rom import system as rsys
from quadmodes.structure import pipeline
from quadmodes.structure.tension_margin import manifold_slack_onset, slack_onset

#: Below this fraction of the initial deformation at which the membrane first loses tension
#: (the deformation at least 10 × the linearised onset of wrinkling) ``W_c`` is attempted once,
#: without continuation along the ray: that far beyond the onset an SVK membrane's condensed
#: state buckles at the scale of the mesh (docs/full-order.md, "Where the membrane loses
#: tension"), so even a converged continuation is no reference, and on a fine mesh it takes
#: many minutes.
SLACK_CONTINUATION_LIMIT = 0.1


def deformation_structure(setup):
    """The FE structure of a prepared run's model case, with its gas law at the model's
    reference state (what both checks below evaluate; built once per check)."""
    case = setup.model_case
    return pipeline.with_gas_law(case, pipeline.structure_for_case(case), setup.model.X)


def initial_deformation_energies(
    setup, progress=None, continuation: bool = True, structure=None
) -> tuple[float, float] | None:
    """``(V(s0), W_c(s0))`` (J) of a prepared run (:class:`~quadmodes.runs.simulate.RunSetup`)
    whose initial state has a modal deformation, both without the work of ``f(x_ref)``; None
    when ``s0 = 0``. ``W_c`` is NaN when its Newton iteration does not converge (reached by
    continuation along the ray, or in one go if not ``continuation``)."""
    system, model = setup.system, setup.model
    s0 = rsys.split_state(system, setup.initial.y0)[2]
    if not np.any(s0):
        return None
    structure = structure or deformation_structure(setup)
    ctx = me.energy_context(structure, model.X, model)
    if continuation:
        condensed = me.condensed_energy_along_ray(ctx, s0, progress)
    else:
        condensed = me.condensed_energy(ctx, s0)
    y = np.zeros(7 + 2 * system.n_modes)
    y[0] = 1.0
    y[7 : 7 + system.n_modes] = s0
    # V(s0) − f(x_ref)·u_QM(s0): the reduced counterpart of the condensed Π̃ (its F1·s0 and
    # the quadratic modes' share f·Σ s s g of Λ are that work).
    work = float(ctx.f0 @ me.manifold_displacement(ctx, s0))
    reduced = float(dyn.potential_energy(system, y)) - work
    return reduced, condensed.value if condensed.converged else float("nan")


def manifold_parts(model, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The linear and quadratic parts ``(Φs, Σ s_m s_n g^{mn})`` ``(n, 3)`` (m) of the manifold
    displacement of ``model`` (a :class:`~quadmodes.rom.reduced.ReducedModel`) at ``s`` (N,)."""
    n_modes = len(s)
    phi = np.asarray(model.Phi, float).reshape(n_modes, -1)
    g = np.asarray(model.G, float).reshape(n_modes * n_modes, -1)
    return (s @ phi).reshape(-1, 3), (np.outer(s, s).ravel() @ g).reshape(-1, 3)


def slack_along(model, structure, s: np.ndarray, taut=None):
    """``(onset, amplitude)`` along the manifold ray ``a ↦ Φ(a s) + Σ a² s_m s_n g^{mn}`` from the
    model's reference state (:func:`quadmodes.structure.tension_margin.manifold_slack_onset`,
    exact strain, the elements taut at the reference judged) and the largest nodal displacement
    (m) at the onset (NaN: none); None without a membrane or a deformation."""
    if not np.any(s):
        return None
    u1, u2 = manifold_parts(model, s)
    onset = manifold_slack_onset(structure, np.asarray(model.X, float), u1, u2, taut)
    if onset is None:
        return None
    a = onset.fraction
    amplitude = (float(np.max(np.linalg.norm(a * u1 + a * a * u2, axis=1)))
                 if np.isfinite(a) else float("nan"))  # fmt: skip
    return onset, amplitude


def initial_slack_onset(setup, structure=None):
    """Along a prepared run's initial deformation ``s0`` (:func:`slack_along`): ``(a, amplitude,
    onset)``: the fraction ``a`` of the deformation at which a membrane element taut at the
    reference first loses tension (exact strain of the manifold displacement; inf: not up to
    4 ×), that as the largest nodal displacement (m), and the whole
    :class:`~quadmodes.structure.tension_margin.ManifoldSlack`; None without a deformation or a
    membrane."""
    s0 = rsys.split_state(setup.system, setup.initial.y0)[2]
    if not np.any(s0):
        return None
    found = slack_along(setup.model, structure or deformation_structure(setup), s0)
    return None if found is None else (found[0].fraction, found[1], found[0])


def slack_judged(setup) -> bool:
    """Whether a loss of tension makes the run invalid: for a membrane held taut by its spin
    alone (no pressure: a sail, a disc, a blade), whose prestrain is tiny (3e-6 on ikaros-sail),
    so that an out-of-plane deflection stretches and compresses it at second order past its
    prestress. A pressurised membrane's onset is recorded only: its verdict is the energy check
    against the SVK FE model (docs/full-order.md, "Where the membrane loses tension")."""
    return not getattr(setup.model_case, "pressure", None)


def linear_slack_fraction(setup, structure) -> float:
    """The linearised onset (:func:`quadmodes.structure.tension_margin.slack_onset`) along the
    linear part ``Φ s0`` of the initial deformation (inf: none), which decides whether the
    condensed energy is reached by continuation (:data:`SLACK_CONTINUATION_LIMIT`)."""
    s0 = rsys.split_state(setup.system, setup.initial.y0)[2]
    onset = slack_onset(structure, np.asarray(setup.model.X, float),
                        manifold_parts(setup.model, s0)[0])  # fmt: skip
    return float("inf") if onset is None else onset.fraction


def with_deformation_check(setup, progress=None):
    """``setup`` with its validity carrying :func:`initial_deformation_energies` (unchanged
    when the run has no initial deformation or no validity), marked to check the path's modal
    amplitudes the same way (``fe_checks``, :mod:`quadmodes.runs.path_validity`)."""
    setup = dataclasses.replace(setup, fe_checks=True)
    if setup.validity is None or setup.system.n_modes == 0:
        return setup
    if not np.any(rsys.split_state(setup.system, setup.initial.y0)[2]):
        return setup  # no initial deformation: nothing to check (and no progress line)
    label = "initial deformation vs the FE model"
    step = (lambda f: progress(label, f)) if progress else None
    if step:
        step(0.0)
    structure = deformation_structure(setup)
    slack = initial_slack_onset(setup, structure)
    continuation = not linear_slack_fraction(setup, structure) < SLACK_CONTINUATION_LIMIT
    energies = initial_deformation_energies(setup, step, continuation, structure)
    if step:
        step(1.0)
    if energies is None:
        return setup
    validity = dataclasses.replace(setup.validity, deformation_energy_reduced=energies[0],
                                   deformation_energy_condensed=energies[1])  # fmt: skip
    if slack is not None:
        _, amplitude, onset = slack
        validity = dataclasses.replace(
            validity, slack_onset_fraction=onset.fraction, slack_onset_amplitude=amplitude,
            slack_fraction=onset.slack_area, reference_slack_fraction=onset.reference_slack_area,
            slack_onset_position=tuple(float(v) for v in onset.position),
            slack_judged=slack_judged(setup),
        )  # fmt: skip
    return dataclasses.replace(setup, validity=validity)
