"""Resource guards: the size of a case's finite-element model, estimated before any meshing,
and the refusal of a model too large to build (unless the user insists with ``--yes``).

A membrane of revolution gets its node count from the ring placement of the mesher
(:func:`quadmodes.mesh.estimate.revolution_node_count`, exact for the rings, microseconds to
milliseconds); a beam has ``elements + 1`` nodes; a mesh file is read anyway and not estimated.
Memory and time are rough fits of ``quadmodes modes`` on paper-membrane meshed at 1, 0.5 and
0.3 in (3000, 12 000 and 33 000 nodes: 0.2, 0.43 and 0.98 GB peak; 4, 11 and 50 s on one
core); the issue that asked for this guard saw a ``MemoryError`` at 0.2 in (75 000 nodes),
hence :data:`MAX_NODES`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from quadmodes.case import Case, CaseError
from quadmodes.case.plausibility import MIN_STRAIN, check_mass, check_strain_scale
from quadmodes.limits import OUTPUT_BYTES, REDUCED_MODES, LimitError
from quadmodes.mesh.estimate import revolution_node_count
from quadmodes.mesh.flat import disc_node_count
from quadmodes.mesh.hub_flat import hub_surface_node_count
from quadmodes.structure.pipeline import revolution_profile

__all__ = ["MIN_STRAIN", "MAX_NODES", "check_model_size", "check_reduced_size", "estimate_size"]

#: Above this many nodes a model is refused unless ``--yes`` (the built-in cases have < 5000).
MAX_NODES = 50_000
#: Peak memory ≈ BASE_BYTES + BYTES_PER_NODE × nodes.
BASE_BYTES, BYTES_PER_NODE = 0.1e9, 27e3
#: Build time ≈ SECONDS_PER_NODE × nodes × sqrt(nodes / TIME_REFERENCE_NODES) (sparse fill-in).
SECONDS_PER_NODE, TIME_REFERENCE_NODES = 1.5e-3, 33_000


@dataclass(frozen=True)
class SizeEstimate:
    """Estimated size of a case's model: ``nodes``, peak ``memory_gb`` (GB) and build
    ``time_s`` (s) of inflation and modes, and the ``field`` that sets the size."""

    nodes: int
    memory_gb: float
    time_s: float
    field: str


def estimate_size(case: Case) -> SizeEstimate | None:
    """The :class:`SizeEstimate` of ``case``, or None for a mesh-file geometry (or a profile
    that cannot be built: the build reports that itself)."""
    if case.kind == "beam":
        nodes, field = int(case.beam.elements) + 1, "beam.elements"
    elif case.kind == "spacecraft":
        nodes, field = 1 + sum(int(b.elements) for b in case.boom), "boom.elements"
    elif getattr(case.geometry, "shape", "file") == "file":
        return None
    elif case.geometry.shape == "disc":
        nodes = disc_node_count(0.5 * case.geometry.diameter, case.mesh.edge_length)
        field = "mesh.edge_length"
    elif case.geometry.shape == "strip":
        g, h = case.geometry, case.mesh.edge_length
        nx, ny = max(2, math.ceil(g.length / h - 1e-9)), max(2, math.ceil(g.width / h - 1e-9))
        nodes, field = 4 + (g.blades or 4) * (nx + 1) * (ny + 1), "mesh.edge_length"
    elif case.geometry.shape in ("annulus", "square"):
        g = case.geometry
        outer = 0.5 * g.diameter if g.shape == "annulus" else g.side_length
        nodes = 4 + hub_surface_node_count(g.shape, outer, 0.5 * g.inner_diameter,
                                           case.mesh.edge_length)  # fmt: skip
        field = "mesh.edge_length"
    else:
        try:
            profile, refine = revolution_profile(case)
        except ValueError:
            return None
        m = case.mesh
        nodes = revolution_node_count(profile, m.edge_length, m.elements_per_radius, refine)
        field = "mesh.edge_length"
    memory_gb = (BASE_BYTES + BYTES_PER_NODE * nodes) / 1e9
    time_s = SECONDS_PER_NODE * nodes * (nodes / TIME_REFERENCE_NODES) ** 0.5
    return SizeEstimate(nodes, memory_gb, time_s, field)


def _duration(seconds: float) -> str:
    """``seconds`` as "40 s", "12 min", "3.5 h" or "20 days"."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 172800:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.0f} days"


def _fix(case: Case, size: SizeEstimate) -> str:
    """What to change so that ``case`` fits under :data:`MAX_NODES`."""
    if size.field in ("beam.elements", "boom.elements"):
        return f"use at most {MAX_NODES - 1} {size.field} in all"
    edge = case.mesh.edge_length * (size.nodes / MAX_NODES) ** 0.5
    return f"use mesh.edge_length of at least {edge:.3g} m ({edge / 0.0254:.3g} in)"


def check_model_size(case: Case, *, allow_large: bool = False) -> SizeEstimate | None:
    """The size estimate of ``case``; raises :class:`CaseError` (naming the field that sets the
    size, the estimate and the fix) when it exceeds :data:`MAX_NODES` and not ``allow_large``,
    or when its pressure is too low to inflate it (:func:`check_pressure`)."""
    check_pressure(case)
    size = estimate_size(case)
    if size is None or size.nodes <= MAX_NODES or allow_large:
        return size
    if size.field == "mesh.edge_length":
        edge = case.mesh.edge_length
        shown = f"{edge:.4g} m ({edge / 0.0254:.4g} in)"
    elif size.field == "boom.elements":
        shown = str(sum(int(b.elements) for b in case.boom))
    else:
        shown = str(case.beam.elements)
    raise CaseError(
        f"{size.field} = {shown} gives about {size.nodes:,} nodes (estimated "
        f"{size.memory_gb:.3g} GB and {_duration(size.time_s)} to build; the limit is "
        f"{MAX_NODES:,}): {_fix(case, size)}, or pass --yes to build it anyway",
        field=size.field,
    )


# ------------------------------------------------------------------------- inputs that cannot work

#: Largest reduced model refused without ``--yes``: the quadratic modes G (N² × nodes × 3) and
#: the quartic potential V4 (N⁴) in bytes.
MAX_REDUCED_BYTES = 4e9
#: More modes than this are refused without ``--yes``: the quartic terms cost ~N⁴ (kane-beam:
#: 60 modes 16 s, 120 modes several minutes); the paper cases use 5, "auto" about 10.
MAX_MODES = 60


def check_pressure(case: Case) -> None:
    """Raise :class:`CaseError` if the strain scale of a membrane of revolution is too low to
    tension it (names ``pressure.value``) or implausibly high, or if a beam's mass is
    implausible (:mod:`quadmodes.case.plausibility`; mesh files are checked once read)."""
    check_mass(case)
    if case.kind != "membrane" or case.geometry.shape == "file" or case.pressure is None:
        return
    g = case.geometry
    check_strain_scale(case, max(g.cap_radius("front") or 0.0, g.cap_radius("rear") or 0.0))


def vector_dofs_per_node(case: Case) -> int:
    """Vector DOFs per node: 1 (membranes), 2 (cable beam: r, r'), 4 (3-D beam: r, r', d₂, d₃)."""
    if case.kind == "beam":
        return 2 if case.beam.element == "cable" else 4
    return 4 if case.kind == "spacecraft" else 1


def check_can_spin(case: Case, what: str = "spin") -> None:
    """Raise :class:`CaseError` (``beam.support``) for a free beam asked to ``what``: the beam
    model has no torsion and no polar inertia, so its reduced mass matrix is singular about
    its own axis. The 3-D beam (``element = "beam3d"``) spins free."""
    if case.kind == "beam" and case.beam.support == "free" and case.beam.element == "cable":
        raise CaseError(
            f'beam.element = "cable": a free cable beam cannot {what} (it has no torsion '
            "or polar inertia, so its reduced mass matrix is singular); use the 3-D beam "
            '(element = "beam3d") or a clamped beam',
            field="beam.element",
        )


def check_reduced_size(case: Case, n_modes: int, *, allow_large: bool = False) -> None:
    """Raise :class:`CaseError` (``reduced.modes``) if ``n_modes`` exceeds the degrees of
    freedom of the model, or (unless ``allow_large``) its reduced arrays would exceed
    :data:`MAX_REDUCED_BYTES`."""
    size = estimate_size(case)
    n_modes = int(n_modes)
    if n_modes < 1:
        return
    dofs = 3 * size.nodes * vector_dofs_per_node(case) - 6 if size is not None else n_modes
    if n_modes > dofs:
        raise CaseError(
            f"reduced.modes = {n_modes}: the model has about {size.nodes} nodes, at most "
            f"{max(dofs, 0)} elastic modes; use fewer modes (the paper cases use 5)",
            field="reduced.modes",
        )
    if size is None:
        check_reduced_modes(n_modes)
        return
    nbytes = 8.0 * (n_modes**2 * 3 * size.nodes + n_modes**4)
    if n_modes > MAX_MODES and nbytes <= MAX_REDUCED_BYTES and not allow_large:
        minutes = 16.0 * (n_modes / 60.0) ** 4 / 60.0
        raise CaseError(
            f"reduced.modes = {n_modes}: more than {MAX_MODES} modes; the quartic terms (N⁴) "
            f"would take about {minutes:.2g} min or more to build; use fewer modes (the paper "
            "cases use 5), or pass --yes to build it anyway",
            field="reduced.modes",
        )
    if nbytes > MAX_REDUCED_BYTES and not allow_large:
        raise CaseError(
            f"reduced.modes = {n_modes}: the reduced model would need about {nbytes / 1e9:.3g} "
            f"GB (quadratic modes N² × nodes, quartic terms N⁴); use fewer modes (the paper "
            "cases use 5), or pass --yes to build it anyway",
            field="reduced.modes",
        )
    check_reduced_modes(n_modes)


def check_reduced_modes(n_modes: int) -> None:
    """Raise :class:`CaseError` (``reduced.modes``) for more modes than the hard bound
    :data:`quadmodes.limits.REDUCED_MODES` (``--yes`` does not lift it; its variable does)."""
    try:
        bound = REDUCED_MODES.value()
    except LimitError as exc:
        raise CaseError(exc.detail, field=exc.field) from None
    if n_modes > bound:
        raise CaseError(
            f"reduced.modes = {n_modes}: more than the limit of {bound:,.0f} {REDUCED_MODES.what} "
            "(its quartic terms hold N⁴ numbers); use fewer modes (the paper cases use 5), "
            f"{REDUCED_MODES.raise_hint(n_modes)}",
            field="reduced.modes",
        )


#: Free-body runs with more steps than this are refused without ``--yes`` (20 × the longest
#: built-in run, paper-41hz: 120 s at 0.5 ms = 240,000 steps).
MAX_STEPS = 5_000_000


def check_run_length(run, *, allow_long: bool = False) -> None:
    """Raise :class:`CaseError` (``integration.duration``) if the free-body run case ``run``
    has more than :data:`MAX_STEPS` steps (samples for "adaptive"), unless ``allow_long``; then,
    even with ``allow_long``, if its results.nc would exceed the output bound
    (:func:`check_output_size`)."""
    if run.spinup is not None:
        return
    integ = run.integration
    steps = integ.n_steps
    if steps > MAX_STEPS and not allow_long:
        raise CaseError(
            f"integration.duration / integration.dt = {integ.duration:.4g} s / {integ.dt:.3g} s "
            f"= {steps:,} steps (the limit is {MAX_STEPS:,}; paper-41hz has 240,000): shorten "
            "the duration (--duration) or lengthen the step (--dt), or pass --yes to run it anyway",
            field="integration.duration",
        )
    check_output_size(run)


#: Modes assumed for the output estimate of ``reduced.modes = "auto"`` (paper-41hz keeps 16).
AUTO_MODES_ESTIMATE = 16
#: Numbers per saved sample of results.nc besides the 2N modal coordinates and velocities
#: (time, quaternion, angular velocity and momentum, principal axis, energies, spin, cone, ...,
#: the modal amplitude and the centrifugal departure of the path's validity check):
#: paper-0.5hz holds 288 bytes a sample with N = 5 (211 on disk, compressed) without those two.
SAMPLE_NUMBERS = 29


def output_bytes(run, n_modes: int | None = None) -> float:
    """Estimated bytes of the results.nc of the free-body run ``run`` with ``n_modes`` modes
    (default: ``reduced.modes``, :data:`AUTO_MODES_ESTIMATE` for "auto"): 8 bytes × numbers a
    sample × samples (steps / save_every + 1)."""
    integ = run.integration
    if n_modes is None:
        modes = run.reduced.modes
        n_modes = AUTO_MODES_ESTIMATE if not isinstance(modes, int) else modes
    if run.reduced.formulation == "rigid":
        n_modes = 0
    samples = integ.n_steps // max(1, int(integ.save_every)) + 1
    return 8.0 * samples * (2 * int(n_modes) + SAMPLE_NUMBERS)


def check_output_size(run, n_modes: int | None = None) -> None:
    """Raise :class:`CaseError` (``integration.save_every``, with the ``save_every`` that fits)
    if the results.nc of ``run`` is estimated (:func:`output_bytes`) above the bound
    :data:`quadmodes.limits.OUTPUT_BYTES`; ``--yes`` does not lift it, its variable does."""
    if run.spinup is not None:
        return
    estimate = output_bytes(run, n_modes)
    try:
        bound = OUTPUT_BYTES.value()
    except LimitError as exc:
        raise CaseError(exc.detail, field=exc.field) from None
    if estimate <= bound:
        return
    every = int(run.integration.save_every)
    suggested = math.ceil(every * estimate / bound)
    raise CaseError(
        f"integration.save_every = {every}: results.nc would hold about {estimate / 1e6:,.0f} MB "
        f"({run.integration.n_steps:,} steps, every {every} kept; the limit is "
        f"{bound / 1e6:,.0f} MB); keep fewer samples with save_every = {suggested} or more in "
        f"[integration], {OUTPUT_BYTES.raise_hint(estimate)}",
        field="integration.save_every",
    )
