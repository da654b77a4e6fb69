"""The checkpoint of a spin-family run (:mod:`quadmodes.runs.spin_family`): the run's
checkpoint (:class:`~quadmodes.runs.run_checkpoint.RunCheckpoint`) of the segment under way, plus
the family so far in entries ``family_*``:

``spins`` (K+1,) rad/s: the members of the K finished segments and of the current one;
``offsets`` (K+1,) J: their energy constants on the path; ``lengths`` (K,): samples per finished
segment; ``t`` (s), ``y``, ``e_d`` (J): those samples, concatenated; ``stats`` (K, 5): their
work counters; ``switches`` (K, 9): :class:`~quadmodes.runs.spin_family.Switch` fields;
``spacing``: the spacing's state (:mod:`quadmodes.runs.family_spacing`); ``y0``: the current
segment's first state; ``chunks``: its chunk count parameter (``max_chunks``).

Saved when a segment starts (after its switch) and whenever the chunk loop saves; a resumed run
rebuilds the members from the model cache by their spins (the same arrays) and continues the
current segment from its chunk progress, so it takes the same steps and switches as the
uninterrupted run.
"""

from __future__ import annotations

import dataclasses

import numpy as np

STATS = ("n_steps", "n_rhs", "n_newton", "n_jac", "n_probe_steps", "n_chunks")


class FamilyCheckpoint:
    """A :class:`~quadmodes.runs.chunked.Checkpointer` for one segment: ``inner`` (the run's
    checkpoint) saves the progress with the family's entries (``family()``: the dict above)."""

    def __init__(self, inner, family):
        self.inner, self.family = inner, family

    def due(self) -> bool:
        return self.inner.due()

    def save(self, progress, wall_s: float) -> None:
        self.inner.save(dataclasses.replace(progress, family=self.family()), wall_s)


def pack(segments, switches, spins, offset_now: float, spacing_state: np.ndarray,
         y0_now: np.ndarray, chunks_now: int) -> dict:  # fmt: skip
    """The ``family_*`` entries (without the prefix) of the finished ``segments`` (each with
    ``solution`` and ``reference_energy``), the ``switches``, the spins (rad/s) every member
    so far was asked for (the current one last) and the current segment (its energy constant
    J, first state, chunks)."""
    sols = [seg.solution for seg in segments]
    n = len(y0_now)
    return {
        "spins": np.array(spins, float),
        "offsets": np.array([seg.reference_energy for seg in segments] + [offset_now]),
        "lengths": np.array([len(s.t) for s in sols], dtype=np.int64),
        "t": np.concatenate([s.t for s in sols]) if sols else np.zeros(0),
        "y": np.concatenate([s.y for s in sols]) if sols else np.zeros((0, n)),
        "e_d": np.concatenate([s.dissipated for s in sols]) if sols else np.zeros(0),
        "stats": np.array([[int(s.stats.get(k, 0)) for k in STATS] for s in sols],
                          dtype=np.int64).reshape(-1, len(STATS)),  # fmt: skip
        "switches": np.array([dataclasses.astuple(sw) for sw in switches], float).reshape(-1, 9),
        "spacing": np.asarray(spacing_state, float),
        "y0": np.asarray(y0_now, float),
        "chunks": np.int64(chunks_now),
    }


def unpack_solutions(family: dict, method: str, dt):
    """The finished segments' :class:`~quadmodes.rom.solution.Solution` list of ``family``."""
    from quadmodes.rom.solution import Solution

    out, k0 = [], 0
    for k, n in enumerate(np.asarray(family["lengths"], int)):
        sl = slice(k0, k0 + n)
        stats = {name: int(v) for name, v in zip(STATS, family["stats"][k], strict=True)}
        out.append(Solution(family["t"][sl].copy(), family["y"][sl].copy(), method, stats, 0, "",
                            family["e_d"][sl].copy(), dt))  # fmt: skip
        k0 += n
    return out
