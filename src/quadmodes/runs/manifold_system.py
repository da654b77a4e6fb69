"""The reduced system of a run's formulation, with formulation "QM" (docs/manifold-formulation.md)
built here: its arrays need the structure's scalar mass matrix, which the model file does not
hold, so they are computed from the run's model case (one FE assembly, O(K² n) products; K =
1 + N + N(N+1)/2). Damping: the model's own modes on the manifold velocity
(:func:`~quadmodes.rom.manifold_kinetics.retained_damping`; C(0) = the model's C)."""

from __future__ import annotations

import numpy as np

from quadmodes.case import CaseError
from quadmodes.rom import manifold_kinetics as mk
from quadmodes.rom import system as rsys


def run_system(run, model, model_case) -> rsys.ReducedSystem:
    """The :class:`~quadmodes.rom.system.ReducedSystem` of ``run.reduced.formulation`` for
    ``model`` (already restricted to the run's modes) built from ``model_case``."""
    if run.reduced.formulation != "QM":
        return rsys.reduced_system(model, run.reduced.formulation)
    return qm_system(model, model_case)


def linear_formulation(formulation: str) -> str:
    """The formulation whose arrays an analysis of the linearised motion about a spin uses
    (rotating-frame frequencies, the energy-sink rate): "Q4" for "QM" (its kinetic energy to
    second order is Q's, its potential Q4's), else ``formulation``."""
    return "Q4" if formulation == "QM" else formulation


def qm_system(model, model_case) -> rsys.ReducedSystem:
    """Formulation "QM" of ``model``; a :class:`CaseError` (field ``reduced.formulation``) for a
    model without the manifold potential or whose modes are not mass-normalised by the case's
    structure (a model of another mesh)."""
    if not getattr(model, "manifold_potential", False):
        raise CaseError('formulation "QM" needs the manifold potential (V3, V4) of the reduced '
                        "model, which this model does not have (a gas-law pressure, or an old "
                        "model file); use Q", field="reduced.formulation")  # fmt: skip
    arrays = mk.manifold_arrays(model, _mass(model_case), mk.retained_damping(model))
    n = model.n_modes
    gram = arrays.gram  # ΦᵀMΦ: the identity for the model's own mesh
    if np.max(np.abs(gram - np.eye(n))) > 1e-6:
        raise CaseError('formulation "QM": the model\'s modes are not mass-normalised by the '
                        "case's structure (another mesh?); rebuild the model",
                        field="reduced.formulation")  # fmt: skip
    return mk.manifold_system(model, arrays)


_MASS: dict[str, object] = {}  # the last model case's scalar mass matrix (a family's members share it)


def _mass(model_case):
    """The scalar mass matrix (n, n) kg of ``model_case``'s structure, assembled once per case
    (the members of a spin family are models of one structure: the same mass)."""
    from quadmodes.structure import pipeline

    key = model_case.to_toml()
    if key not in _MASS:
        _MASS.clear()
        _MASS[key] = pipeline.structure_for_case(model_case).mass_scalar
    return _MASS[key]
