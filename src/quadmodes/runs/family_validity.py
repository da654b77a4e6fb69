"""The validity of a spin family's path (:mod:`quadmodes.runs.spin_family`): each segment
judged against its own member, and the modal amplitudes of every segment that could leave the
potential's range checked against its member's FE model.

Why every segment and not the last one only: a path that grows its cone reaches its largest
amplitudes in its last member, but the potential's range can end several members earlier
(paper-41hz-coarse to 60°: the amplitude check fails from about 45°, 15 members before the
end). The segments are checked in order of their largest ‖s‖ until one passes; those with a
smaller largest ‖s‖ are then covered by it (the error grows with the amplitude, the assumption
the one-model bisection makes too), so the cost is one FE solve per failing segment plus one,
and the bisections of the one-model check in the earliest failing segment only (its solve at
the largest ‖s‖ is the scan's, not repeated).
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
    segment) with their modal amplitudes checked: in order of the segments' largest ‖s‖, each
    at its largest ‖s‖ until one passes (the rest are covered by it: marked checked, with that
    error as a bound); the earliest failing segment by the one-model check
    (:func:`~quadmodes.runs.path_validity.with_amplitude_check`, which locates where it leaves),
    the later failing ones marked failing at their largest ‖s‖."""
    from quadmodes.runs import deformation_check as dc
    from quadmodes.runs import path_validity as pv

    def peak(part):
        setup, sol = part[0], part[1]
        if len(sol.t) == 0:
            return 0.0, 0
        amp = np.linalg.norm(rsys.split_state(setup.system, np.asarray(sol.y, float))[2], axis=1)
        return float(amp.max()), int(np.argmax(amp))

    peaks = [peak(p) for p in parts]
    paths = [p[3] for p in parts]
    failing, covered_by = [], None
    for k in sorted(range(len(parts)), key=lambda k: -peaks[k][0]):
        setup, sol, sub, path = parts[k]
        if "modal amplitudes" not in path.unchecked or len(sol.t) == 0:
            continue
        if covered_by is not None:  # a segment of larger amplitude passed
            paths[k] = dataclasses.replace(path, checked=(*path.checked, "modal amplitudes"),
                                           unchecked=(), amplitude_error=covered_by)  # fmt: skip
            continue
        structure = dc.deformation_structure(setup)
        y = np.asarray(sol.y[peaks[k][1]], float)
        found = (0.0, None) if pv.is_round_off_state(setup, y) else pv.amplitude_error(setup, y, structure)
        err = float(found[0])
        if err <= pv.DEFORMATION_ENERGY_TOLERANCE:
            covered_by = err
            paths[k] = dataclasses.replace(path, checked=(*path.checked, "modal amplitudes"),
                                           unchecked=(), amplitude_error=err)  # fmt: skip
        else:
            failing.append((k, err, structure, found))
    if failing:
        k, _, structure, found = min(failing, key=lambda f: f[0])
        setup, sol, sub, path = parts[k]
        paths[k] = pv.with_amplitude_check(path, setup, sol, sub, structure, peak_error=found)
        for j, err, _, _ in failing:
            if j != k:
                setup, sol, sub, path = parts[j]
                reason = (f"the reduced potential is {100 * err:.3g} % off the FE model's condensed "
                          f"energy at the largest modal amplitude of the member about "
                          f"{setup.model.reference_spin / (2 * math.pi):.6g} Hz")
                done = dataclasses.replace(path, checked=(*path.checked, "modal amplitudes"),
                                           unchecked=(), amplitude_error=err)  # fmt: skip
                paths[j] = pv.with_failures(done, [(peaks[j][1], reason)], sol.t, sub)
    return paths
