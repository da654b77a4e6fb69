"""The validity of a spin family's path (:mod:`quadmodes.runs.spin_family`): each segment
judged against its own member, and the modal amplitudes of every segment that could leave the
potential's range checked against its member's FE model.

Why every segment and not the last one only: a path that grows its cone reaches its largest
amplitudes in its last members, but the potential's range can end many members earlier
(paper-41hz-coarse to 60°: from about 31°, 30 members before the end). Why every segment, and
not those of the largest ‖s‖ until one passes (the rule before): the error at a given ‖s‖ is
not the same in every member, nor along every direction of s. Measured on that path
(docs/path-validity.md, "The amplitude check on every member"): the member about 29.35 Hz passed
at its largest ‖s‖ (1.82 %, 6.86×10⁻⁴) and so "covered" twelve members of smaller largest ‖s‖
that each fail at theirs (2.14–2.83 %, from 35.25 Hz, cone 31°), and the last member, 4.65 % at
6.15×10⁻⁴. So each segment is checked at its own largest ‖s‖ (one FE solve each: 0.3–1 s on the
coarse mesh), and the earliest failing one located by the one-model check's bisections (its
solve at the largest ‖s‖ is the scan's, not repeated). Within a segment the error also moves
with the direction of s at one ‖s‖ (1.8–3.1 % over the 8 samples of largest ‖s‖ of the 29.35 Hz
member): the check is at one sample per segment, a spot check of that resolution.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from quadmodes.rom import system as rsys
from quadmodes.rom.diagnostics import Diagnostics


def measured_limit(switches, k: int) -> tuple[float | None, str]:
    """(the measured limit of the spin part of δ of segment k, how) from the neighbours'
    measurements (``Switch.sink_error``, ``frequency_error``: the old member at the new one's
    spin, |ln Ω| = x apart): the switch out of segment k (its member measured), else the one
    into it (its neighbour's, the sensitivity being smooth along the path); as
    :func:`quadmodes.runs.spin_check.spin_limit` does with a rebuilt model: x if both are within
    their tolerances (2 %, 1 %), else where the worse reaches its tolerance (linear in x); in δ
    (in Ω²) 1 − e^{−2x}. None: nothing measured."""
    from quadmodes.runs.spin_check import FREQUENCY_TOLERANCE, SINK_TOLERANCE

    sw = switches[k] if k < len(switches) else (switches[k - 1] if k else None)
    if sw is None or not (math.isfinite(sw.sink_error) and math.isfinite(sw.frequency_error)):
        return None, ""
    x = abs(math.log(sw.spin_to / sw.spin_from))
    scale = min(1.0, SINK_TOLERANCE / max(sw.sink_error, 1e-300),
                FREQUENCY_TOLERANCE / max(sw.frequency_error, 1e-300))  # fmt: skip
    basis = (f"measured between the members about {sw.spin_from / (2 * math.pi):.5g} and "
             f"{sw.spin_to / (2 * math.pi):.5g} Hz: {100 * sw.sink_error:.2g} % in the coning rate, "
             f"{100 * sw.frequency_error:.2g} % in the frequencies")  # fmt: skip
    return float(-math.expm1(-2.0 * x * scale)), basis


def family_path_validity(segments, diag, switches=()):
    """The path's :class:`~quadmodes.runs.path_validity.PathValidity`: each segment checked
    against its own member (centrifugal load, rotating-frame stiffness; where the a-priori
    centrifugal bound fails, the spin part judged by the range measured between neighbouring
    members, :func:`measured_limit`, the tilt's part by the a-priori bound, as a one-model run's
    :func:`~quadmodes.runs.path_validity.with_measured_range` does with a rebuilt model), the
    first to leave its member's range gives where the path leaves; with the FE checks
    (``setup.fe_checks``, as ``quadmodes run``) the modal amplitudes of every segment that
    could fail against its member's FE condensed energy (:func:`checked_amplitudes`)."""
    from quadmodes.runs import path_validity as pv

    parts, k0 = [], 0
    for k, seg in enumerate(segments):
        n = len(seg.solution.t) - (1 if k else 0)
        sub = Diagnostics(**{key: v[k0 : k0 + n] for key, v in diag.as_dict().items()})
        sol = seg.solution if not k else dataclasses.replace(
            seg.solution, t=seg.solution.t[1:], y=seg.solution.y[1:],
            dissipated=seg.solution.dissipated[1:])  # fmt: skip
        path = pv.path_validity(seg.setup, sol, sub)
        limit, basis = measured_limit(switches, k)
        if path.centrifugal_max > path.centrifugal_limit and limit is not None:
            path = pv.path_validity(seg.setup, sol, sub, limit, basis)
        parts.append((seg.setup, sol, sub, path))
        k0 += n
    paths = [p[3] for p in parts]
    if parts and parts[-1][0].fe_checks:
        paths = checked_amplitudes(parts)
    found = None
    for path in paths:
        found = path if found is None or (path.left_at is not None and found.left_at is None) else found
        found = dataclasses.replace(found, centrifugal_max=max(found.centrifugal_max, path.centrifugal_max),
                                    checked=path.checked, unchecked=path.unchecked)  # fmt: skip
    if found is None:
        return None
    errors = [p.amplitude_error for p in paths if math.isfinite(p.amplitude_error)]
    failures = tuple(sorted({f for p in paths for f in p.failures}))
    return dataclasses.replace(found, amplitude_error=max(errors) if errors else found.amplitude_error,
                               failures=failures)  # fmt: skip


def checked_amplitudes(parts) -> list:
    """The segments' paths (``parts``: (setup, solution, diagnostics, PathValidity) per
    segment) with their modal amplitudes checked: every segment at its largest ‖s‖ (module
    docstring: a segment of smaller amplitude is not covered by one that passed); the earliest
    failing segment by the one-model check
    (:func:`~quadmodes.runs.path_validity.with_amplitude_check`, which locates where it leaves),
    the later failing ones marked failing at their largest ‖s‖."""
    from quadmodes.runs import deformation_check as dc
    from quadmodes.runs import path_validity as pv

    paths = [p[3] for p in parts]
    failing = []
    for k, (setup, sol, _, path) in enumerate(parts):
        if "modal amplitudes" not in path.unchecked or len(sol.t) == 0:
            continue
        y = np.asarray(sol.y, float)
        peak = int(np.argmax(np.linalg.norm(rsys.split_state(setup.system, y)[2], axis=1)))
        if pv.is_round_off_state(setup, y[peak]):
            found, structure = (0.0, None), None
        else:
            structure = dc.deformation_structure(setup)
            found = pv.amplitude_error(setup, y[peak], structure)
        err = float(found[0])
        if err <= pv.DEFORMATION_ENERGY_TOLERANCE:
            paths[k] = dataclasses.replace(path, checked=(*path.checked, "modal amplitudes"),
                                           unchecked=(), amplitude_error=err)  # fmt: skip
        else:
            failing.append((k, err, structure, found, peak))
    if failing:
        k, _, structure, found, _ = failing[0]
        setup, sol, sub, path = parts[k]
        paths[k] = pv.with_amplitude_check(path, setup, sol, sub, structure, peak_error=found)
        for j, err, _, _, _ in failing[1:]:
            paths[j] = dataclasses.replace(paths[j], checked=(*paths[j].checked, "modal amplitudes"),
                                           unchecked=(), amplitude_error=err)  # fmt: skip
        if len(failing) > 1:  # the later ones, one entry (from the first of them)
            j, peak = failing[1][0], failing[1][4]
            sol, sub = parts[j][1], parts[j][2]
            paths[j] = pv.with_failures(paths[j], [(peak, later_failures(parts, failing[1:]))], sol.t, sub)
    return paths


def later_failures(parts, failing) -> str:
    """One reason for the failing segments after the earliest (``failing``: (segment index,
    error, …) each): how many, their errors and members' spins."""
    errs = [f[1] for f in failing if math.isfinite(f[1])]
    spins = [parts[f[0]][0].model.reference_spin / (2 * math.pi) for f in failing]
    members = (f"the member about {spins[0]:.6g} Hz" if len(failing) == 1 else
               f"{len(failing)} later members (about {spins[0]:.6g} to {spins[-1]:.6g} Hz)")  # fmt: skip
    unsolved = len(failing) - len(errs)
    if not errs:
        return f"the FE model's condensed energy did not converge at the largest modal amplitude of {members}"
    size = f"{100 * errs[0]:.3g} %" if len(errs) == 1 else f"{100 * min(errs):.3g}–{100 * max(errs):.3g} %"
    return (f"the reduced potential is {size} off the FE model's condensed energy at the largest "
            f"modal amplitude of {members}"
            + (f" (of {unsolved} of them the condensed energy did not converge)" if unsolved else ""))
