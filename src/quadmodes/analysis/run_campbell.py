"""The Campbell diagram of a run's own reduced model, for its report (issue 28, item 5).

A model expanded about the state at rest (``reduced.reference = "rest"``, the default of a
user's run case) holds from rest up, so its Campbell diagram from 0 to 1.25 × the run's spin
(21 points: 1.7 s for 16 modes of paper-membrane-coarse, where 41 take 5–8 s of MAC tracking;
0.3 s for 5; the run's formulation and spin axis, undamped) is drawn beside the run's figures
as ``campbell.png``. A model expanded about the spinning state holds only near that spin (its
range: docs/path-validity.md), so none is drawn; ``quadmodes campbell MODEL`` draws the body's
diagram from its model at rest. The figure is attached to the run's result as a drawing
(``RunResult.figures``) that :mod:`quadmodes.runs.run_folder` calls: the runs layer draws it
without importing the analyses above it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from quadmodes.analysis.campbell import campbell
from quadmodes.analysis.campbell_figure import plot_campbell

__all__ = ["CAMPBELL_PICTURE", "SPAN", "run_campbell", "with_campbell"]

#: The file of the diagram in the run's folder.
CAMPBELL_PICTURE = "campbell.png"
#: The diagram spans 0 to SPAN × the run's spin, in POINTS spin rates.
SPAN, POINTS = 1.25, 21


def run_campbell(result):
    """The :class:`~quadmodes.analysis.campbell.CampbellResult` of ``result``'s reduced model
    from 0 to :data:`SPAN` × its initial spin (rad/s), or None (a model about a spinning
    state, no elastic mode, no spin)."""
    run, model = result.run, result.model
    spin = float(run.initial.spin_rate) if run.initial is not None else 0.0
    if float(getattr(model, "reference_spin", 0.0)) != 0.0 or result.system.n_modes == 0 or spin <= 0:
        return None
    spins = np.linspace(0.0, SPAN * spin, POINTS)
    return campbell(model, spins, run.initial.spin_axis, formulation=run.reduced.formulation,
                    axis_option="initial.spin_axis")  # fmt: skip


def with_campbell(result):
    """``result`` with the drawing of its Campbell diagram in ``figures`` (file
    :data:`CAMPBELL_PICTURE`), if :func:`run_campbell` gives one; a model whose diagram cannot
    be computed keeps none and a note saying why."""
    try:
        diagram = run_campbell(result)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return dataclasses.replace(result, notes=(*result.notes, f"no Campbell diagram: {exc}"))
    if diagram is None:
        return result
    title = f"{result.run.name}: Campbell diagram of the run's model (formulation {diagram.formulation})"

    def draw(path):
        plot_campbell(diagram, path, title=title)

    return dataclasses.replace(result, figures=(*result.figures, (CAMPBELL_PICTURE, draw)))
