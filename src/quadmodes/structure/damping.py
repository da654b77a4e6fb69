"""The modal damping of a structure: ζ of critical on every prestressed FE mode below a cutoff,
the definition shared by the full-order reference (:mod:`quadmodes.fullorder.damping`) and by a
reduced model whose basis is not a set of those modes (expanded about a spinning state,
:func:`projected_damping`). The modes are those of the prestressed state at rest, or for a
structure with no stiffness at rest (stiffened by its spin alone) those of its spinning state
(:func:`damping_state`).

With the damping modes ``φ_k`` (mass-normalised, ω_k below the cutoff) the damping operator is
``C_FE = Σ_k 2ζω_k (Mφ_k)(Mφ_k)ᵀ`` (N s/m); a reduced basis Φ (mass-normalised) sees
``C = Aᵀ diag(2ζω) A``, ``A = Φ_dᵀ M Φ`` (1/s) — its Galerkin projection, equal to ``diag(2ζω)``
when Φ is a subset of the damping modes.
"""

from __future__ import annotations

import hashlib

import numpy as np

from quadmodes.fe.model import Structure, mass_matrix, tangent_stiffness
from quadmodes.structure.labels import DEGENERATE_TOLERANCE, PAIR_TOLERANCE, label_modes
from quadmodes.structure.modes import compute_modes

#: Default cutoff: this factor times the larger of the spin and the highest retained frequency.
CUTOFF_FACTOR = 3.0
#: A structure whose lowest elastic frequency at rest is below this fraction of the spin (its own
#: stiffness then below 1 % of the spin's) has no stiffness at rest on the scale of its motion
#: (blades, strings, webs stiffened by the spin alone): its damping modes are those of its
#: spinning state (:func:`damping_state`).
STIFFLESS_RATIO = 0.1


def damping_state(structure: Structure, x_rest: np.ndarray, x_spin: np.ndarray, spin: float,
                  memo: SolvedModes | None = None):  # fmt: skip
    """``(x, "rest" | "spinning")``: the state whose tangent's modes carry the modal damping.
    At rest (``x_rest`` (n,3) m, the prestressed state: the definition of every inflated body),
    unless the structure has no stiffness there on the scale of the spin ``spin`` (rad/s): its
    lowest elastic frequency at rest below :data:`STIFFLESS_RATIO` × the spin (a spin-stiffened
    blade: its modes at rest are all ≈ 0 Hz and a damping ζ·2ω on them would vanish); then the
    spinning state ``x_spin`` (its tangent includes the centrifugal prestress). A membrane
    without pressure never has a state at rest (its x_rest is its spinning state already).
    ``memo``: the solved modes at rest (:class:`SolvedModes`), if any."""
    if not spin or x_rest is x_spin or np.array_equal(x_rest, x_spin):
        return x_rest, "rest"
    solved = memo.modes(structure, x_rest, 1)[0] if memo is not None else compute_modes(structure, x_rest, 1)
    lowest = np.asarray(solved.frequencies_hz, float)
    if lowest.size and 2.0 * np.pi * lowest[0] >= STIFFLESS_RATIO * abs(float(spin)):
        return x_rest, "rest"
    return x_spin, "spinning"

def default_cutoff(spin_hz: float, retained_hz) -> float:
    """Default cutoff (Hz): :data:`CUTOFF_FACTOR` × max(spin, highest retained frequency)."""
    top = float(np.max(retained_hz)) if len(retained_hz) else 0.0
    return CUTOFF_FACTOR * max(abs(float(spin_hz)), top)

def pairs_whole(frequencies_hz, labels, cutoff_hz: float) -> int:
    """Number K of the ascending modes to keep: all below ``cutoff_hz`` plus the partner of a
    pair that the cutoff would split. Modes are grouped from the bottom into pairs by the
    reduced models' rule (same label within :data:`~quadmodes.runs.PAIR_TOLERANCE`,
    or any two within :data:`~quadmodes.runs.DEGENERATE_TOLERANCE`)."""
    f = np.asarray(frequencies_hz, float)
    k, i = 0, 0
    while i < len(f) and f[i] <= cutoff_hz:
        size = 1
        if i + 1 < len(f):
            gap = abs(f[i + 1] - f[i])
            same = labels[i] == labels[i + 1] and gap <= PAIR_TOLERANCE * f[i]
            size = 2 if same or gap <= DEGENERATE_TOLERANCE * f[i] else 1
        i += size
        k = i
    return k

class SolvedModes:
    """The modes (:func:`compute_modes`) and labels of the eigenproblems already solved about
    the states of one structure, by the problem's content (:func:`problem_key`), the last
    :data:`SIZE` used last kept. Owned by what they belong to, never global: the modal model at rest
    (:class:`quadmodes.structure.pipeline.ModalModel`), whose spinning models (every member of a
    spin family, the spin check's neighbours) share its damping modes at rest."""

    #: Problems kept, the least recently used dropped first (at rest: the stiffness check's
    #: one mode and the damping modes' requests 16, 32, 64, ...).
    SIZE = 8

    def __init__(self):
        self.solved: dict[str, tuple] = {}

    def modes(self, structure: Structure, x: np.ndarray, count: int):
        """(:func:`compute_modes` of ``structure`` about ``x`` (n,3) m, their labels)."""
        key = problem_key(structure, x, count)
        found = self.solved.pop(key, None)
        if found is None:
            m = compute_modes(structure, x, count)
            found = (m, label_modes(structure, x, m.shapes))
            if len(self.solved) >= self.SIZE:
                self.solved.pop(next(iter(self.solved)))
        self.solved[key] = found  # the most recently used last
        return found


def problem_key(structure: Structure, x: np.ndarray, count: int) -> str:
    """A digest of the eigenproblem of :func:`compute_modes` (stiffness at x, mass, free DOFs)."""
    k, m = tangent_stiffness(structure, x).tocsr(), mass_matrix(structure).tocsr()
    h = hashlib.sha256()
    for a in (x, k.data, k.indices, k.indptr, m.data, m.indices, structure.free_dofs):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(str(count).encode())
    return h.hexdigest()


def _solve(structure: Structure, x: np.ndarray, count: int, memo: SolvedModes | None):
    """(:func:`compute_modes`, labels): from ``memo`` when given, else solved here."""
    if memo is not None:
        return memo.modes(structure, x, count)
    m = compute_modes(structure, x, count)
    return m, label_modes(structure, x, m.shapes)


def modes_below(
    structure: Structure, x: np.ndarray, cutoff_hz: float, count: int = 16,
    memo: SolvedModes | None = None,
) -> tuple[np.ndarray, np.ndarray, list[str]]:  # fmt: skip
    """Every elastic mode of ``structure`` about ``x`` (n,3) below ``cutoff_hz`` (pairs whole):
    ``(frequencies Hz (K,), shapes (K,n,3), labels)``. :func:`compute_modes` with a request
    doubled from ``count`` until a mode beyond the kept ones is found (from ``memo`` when given:
    the members of a spin family share their damping modes at rest)."""
    n_free = structure.free_dofs.size
    while True:
        m, labels = _solve(structure, x, count, memo)
        f = np.asarray(m.frequencies_hz, float)
        k = pairs_whole(f, labels, cutoff_hz)
        if k < len(f) or count >= n_free - 12:
            return f[:k], m.shapes[:k], labels[:k]
        count *= 2


def projected_damping(
    structure: Structure, shapes: np.ndarray, damping_hz: np.ndarray, damping_shapes: np.ndarray,
    zeta: float,
) -> np.ndarray:  # fmt: skip
    """Modal damping matrix ``C = Aᵀ diag(2ζω_d) A`` (N, N) 1/s of the basis ``shapes`` (N, n, 3)
    (1/√kg), ``A = Φ_dᵀ M Φ`` (K, N), for the damping modes ``damping_shapes`` (K, n, 3) at
    ``damping_hz`` (K,) Hz with ratio ``zeta``."""
    m = mass_matrix(structure)
    phi = shapes.reshape(shapes.shape[0], -1).T
    a = damping_shapes.reshape(damping_shapes.shape[0], -1) @ (m @ phi)
    c = a.T @ (2.0 * float(zeta) * 2.0 * np.pi * np.asarray(damping_hz, float)[:, None] * a)
    return 0.5 * (c + c.T)
