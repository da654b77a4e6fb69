"""Spin axes: the body-frame axis a free body spins about, from a request (a body axis "x",
"y", "z", a principal axis "minor", "intermediate", "major" or its index 0, 1, 2, or three
numbers), checked against the principal axes of the reduced model's undeformed inertia J0;
shared by the reduced-model Campbell sweep, the full-order rotating-frame analysis and the
initial state of a run.

**The rule (equal principal moments).** A free body spins steadily only about a principal axis
of its inertia. The moments of J (kg m²) are grouped: two moments closer than
:data:`MOMENT_RTOL` × the largest moment are *equal*, and their eigenvectors span a degenerate
eigenspace (a plane for a body of revolution spun about a transverse axis or a free rod, all of
space for a sphere), in which every direction is principal. A requested axis e is accepted when
it lies within :data:`AXIS_TOL` rad of one group's eigenspace; the spin axis is then

* for a degenerate group: e projected onto the eigenspace and normalised (e itself when it lies
  in it), so round-off in the eigenvectors never decides which axis the body spins about;
* for a single moment: its eigenvector, with the sign of e (the exact principal axis).

The relative equilibrium of the deformed body (:func:`equilibrium_direction`, the inertia J̃(s)
of the centrifugal deformation s) keeps the axis of a degenerate group exactly while it stays
principal of J̃(s) to :data:`MOMENT_RTOL` (it does exactly for a body of revolution or a rod, by
reflection symmetry about the plane across the axis); otherwise, and for a single moment, it
takes the eigenvector of J̃(s) nearest the axis.

Otherwise the request is refused with one error naming the option and the principal axes with
their moments. A named principal axis ("minor" …) whose moment is one of a degenerate group is
the body axis x, y or z (the first, in that order, of those nearest the eigenspace) projected
onto it, so "major" of a rod along x is y. A body clamped to a hub spins about whatever axis the
hub turns about: no check.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from quadmodes.rom.reduced import ReducedModel
from quadmodes.rotations import unit_axis

#: Two principal moments closer than this, relative to the largest moment, are equal
#: (ordinary meshes of a body of revolution differ by ~1e-5; a rod or a sphere by round-off).
MOMENT_RTOL = 1e-4
#: A requested axis within this angle (rad) of a principal eigenspace is that principal axis.
AXIS_TOL = 1e-3

#: Names of the body axes and of the principal axes (index into ascending moments).
BODY_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
PRINCIPAL_NAMES = ("minor", "intermediate", "major")
AXIS_CHOICES = "x, y, z, minor, intermediate, major or three numbers such as 0,0,1"


def parse_axis(value, option: str = "axis"):
    """A spin-axis request from text or TOML: None, a name (``"x"`` … ``"major"``, lower case),
    an int principal index 0–2, or a unit vector (3,) from ``"0,0,1"`` or three numbers.
    Raises ValueError naming ``option`` otherwise."""
    if value is None:
        return None
    original = value
    if isinstance(value, bool):
        raise ValueError(f"{option}: {value!r} is not an axis; give {AXIS_CHOICES}")
    if isinstance(value, int | np.integer):
        if 0 <= int(value) <= 2:
            return int(value)
        raise ValueError(f"{option}: {value} is not a principal index (0, 1, 2); give {AXIS_CHOICES}")
    if isinstance(value, str):
        text = value.strip().lower()
        if text in BODY_AXES or text in PRINCIPAL_NAMES:
            return text
        parts = [p for p in text.replace(";", ",").replace(" ", ",").split(",") if p]
        try:
            value = [float(p) for p in parts]
        except ValueError:
            raise ValueError(f"{option}: {original!r} is not an axis; give {AXIS_CHOICES}") from None
    try:
        vec = np.asarray(value, float).ravel()
    except (TypeError, ValueError):
        raise ValueError(f"{option}: {original!r} is not an axis; give {AXIS_CHOICES}") from None
    if vec.size != 3 or not np.all(np.isfinite(vec)) or np.linalg.norm(vec) == 0.0:
        raise ValueError(
            f"{option}: {original!r} is not an axis (three finite numbers, not all zero); "
            f"give {AXIS_CHOICES}"
        )
    return vec / np.linalg.norm(vec)


def moment_groups(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[list[int]]]:
    """``(moments (3,) ascending kg m², eigenvectors (3, 3) columns, groups)`` of a symmetric
    inertia; groups: lists of indices of equal moments (within :data:`MOMENT_RTOL` × largest,
    chained)."""
    lam, vec = np.linalg.eigh(0.5 * (inertia + inertia.T))
    tol = MOMENT_RTOL * max(float(np.abs(lam).max()), 1e-300)
    groups = [[0]]
    for i in (1, 2):
        if lam[i] - lam[i - 1] <= tol:
            groups[-1].append(i)
        else:
            groups.append([i])
    return lam, vec, groups


def _signed(e: np.ndarray) -> np.ndarray:
    """``e`` with its largest component positive."""
    return e * np.sign(e[np.argmax(np.abs(e))])


def _in_group(vec: np.ndarray, group: Sequence[int], e: np.ndarray) -> np.ndarray:
    """The axis of request ``e`` in one group: the projection onto a degenerate eigenspace,
    normalised, or the single eigenvector with the sign of e."""
    basis = vec[:, list(group)]
    if len(group) == 1:
        v = basis[:, 0]
        return v if v @ e >= 0.0 else -v
    p = basis @ (basis.T @ e)
    return p / np.linalg.norm(p)


def in_degenerate_eigenspace(inertia: np.ndarray, e) -> bool:
    """True if ``e`` (3,) lies within :data:`AXIS_TOL` of the eigenspace of two or three equal
    moments of ``inertia`` (3, 3)."""
    e = unit_axis(e)
    _, vec, groups = moment_groups(inertia)
    for g in groups:
        if len(g) > 1 and np.arccos(min(float(np.linalg.norm(vec[:, g].T @ e)), 1.0)) <= AXIS_TOL:
            return True
    return False


def equilibrium_direction(inertia: np.ndarray, e, keep: bool = False) -> np.ndarray:
    """The principal axis (3,) of ``inertia`` (3, 3) (the deformed J̃(s)) for request ``e`` (3,)
    without the closeness check: with ``keep`` (e lies in an eigenspace of equal moments of the
    undeformed body) e itself while it is principal of ``inertia`` to :data:`MOMENT_RTOL`
    (``|e × J e| ≤ MOMENT_RTOL · max moment``: a body of revolution or a rod deformed by the
    spin about e keeps e principal by symmetry); otherwise the group (module docstring) whose
    eigenspace holds the largest share of e."""
    e = unit_axis(e)
    lam, vec, groups = moment_groups(inertia)
    if keep:
        torque = np.linalg.norm(np.cross(e, 0.5 * (inertia + inertia.T) @ e))
        if torque <= MOMENT_RTOL * max(float(np.abs(lam).max()), 1e-300):
            return e
    shares = [float(np.linalg.norm(vec[:, g].T @ e)) for g in groups]
    return _in_group(vec, groups[int(np.argmax(shares))], e)


def describe_principal_axes(inertia: np.ndarray) -> str:
    """``minor (0, 0, 1) 5.1e-04 kg m², …`` for error messages."""
    lam, vec, _ = moment_groups(inertia)
    parts = []
    for i, name in enumerate(PRINCIPAL_NAMES):
        v = _signed(vec[:, i])
        parts.append(f"{name} ({v[0]:.4g}, {v[1]:.4g}, {v[2]:.4g}) {lam[i]:.6g} kg m²")
    return "; ".join(parts)


def principal_direction(inertia: np.ndarray, e, option: str = "axis") -> np.ndarray:
    """The principal axis (3,) of ``inertia`` for request ``e`` (3,) by the module's rule;
    ValueError naming ``option`` when e is not within :data:`AXIS_TOL` of a principal
    eigenspace."""
    e = unit_axis(e)
    _, vec, groups = moment_groups(inertia)
    for g in groups:
        share = min(float(np.linalg.norm(vec[:, g].T @ e)), 1.0)
        if np.arccos(share) <= AXIS_TOL:
            return _in_group(vec, g, e)
    raise ValueError(
        f"{option}: ({e[0]:.4g}, {e[1]:.4g}, {e[2]:.4g}) is not a principal axis of the inertia "
        f"(a free body spins steadily only about one; principal axes: "
        f"{describe_principal_axes(inertia)}); give one of them, e.g. minor"
    )


def named_principal_axis(inertia: np.ndarray, index: int) -> np.ndarray:
    """Principal axis (3,) ``index`` into ascending moments (0 minor … 2 major): its
    eigenvector (largest component positive) or, when its moment is one of a degenerate
    group, the body axis x, y or z nearest the eigenspace projected onto it (module docstring)."""
    _, vec, groups = moment_groups(inertia)
    group = next(g for g in groups if index in g)
    if len(group) == 1:
        return _signed(vec[:, index])
    basis = vec[:, group]
    shares = np.linalg.norm(basis.T, axis=0)  # share of x, y, z in the eigenspace
    k = int(np.flatnonzero(shares >= shares.max() - 1e-9)[0])
    return _in_group(vec, group, np.eye(3)[k])


def principal_axis(model: ReducedModel, index: int) -> np.ndarray:
    """Principal axis (3,) of J0, ``index`` into ascending moments (0: minor, 2: major); see
    :func:`named_principal_axis`."""
    return named_principal_axis(model.J0, int(index))


def default_axis(model: ReducedModel) -> np.ndarray:
    """z for a hub-clamped body; the symmetry axis (the principal axis whose moment differs most
    from the other two) for a free body."""
    if not model.free:
        return np.array([0.0, 0.0, 1.0])
    lam = np.linalg.eigvalsh(0.5 * (model.J0 + model.J0.T))
    gaps = [min(abs(lam[i] - lam[j]) for j in range(3) if j != i) for i in range(3)]
    return principal_axis(model, int(np.argmax(gaps)))


def axis_for_inertia(inertia: np.ndarray, axis, option: str = "axis", check: bool = True):
    """Unit body-frame spin axis (3,) of a request (not None; :func:`parse_axis`) against
    ``inertia`` (3, 3) kg m² by the module's rule; ``check=False`` (a body clamped to a hub)
    takes body axes and vectors as given."""
    req = parse_axis(axis, option)
    if isinstance(req, str) and req in BODY_AXES:
        req = np.array(BODY_AXES[req])
    if isinstance(req, str):
        req = PRINCIPAL_NAMES.index(req)
    if isinstance(req, int):
        return named_principal_axis(inertia, req)
    return principal_direction(inertia, req, option) if check else req


def reference_axis(model: ReducedModel) -> np.ndarray | None:
    """The body axis (3,) of a model expanded about a spinning state (``reference_spin`` ≠ 0:
    e.g. a membrane without stiffness at rest, about its normal), None for a model about rest.
    Its modes exist about that axis only: the default of every spin-axis request."""
    if not model.reference_spin or model.reference_axis is None:
        return None
    e = np.asarray(model.reference_axis, float)
    return e / np.linalg.norm(e)


def resolve_axis(model: ReducedModel, axis, option: str = "axis", default=None) -> np.ndarray:
    """Unit body-frame spin axis (3,) of a request: None gives the model's spinning reference
    axis (:func:`reference_axis`), else ``default`` (a request) or :func:`default_axis`;
    otherwise :func:`axis_for_inertia` with J0 of a free model (``option`` names the request in
    errors)."""
    if axis is None:
        ref = reference_axis(model)
        if ref is not None:
            return axis_for_inertia(model.J0, ref, option, check=bool(model.free))
        if default is not None:
            return axis_for_inertia(model.J0, default, option, check=bool(model.free))
        return default_axis(model)
    return axis_for_inertia(model.J0, axis, option, check=bool(model.free))
