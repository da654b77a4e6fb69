"""Checkpoints of a reduced run: the :class:`~quadmodes.runs.chunked.ChunkProgress` after a whole
chunk in one .npz, written atomically (temporary file, fsync, ``os.replace``), and its checks
on resume.

Entries (format :data:`CHECKPOINT_FORMAT`, version :data:`CHECKPOINT_VERSION`): ``format``,
``version``, ``case_toml`` (the run case, SI, with the options applied and ``modes = "auto"``
resolved), ``model_key`` (the reduced model's content key), ``y0`` (7+2N,) the initial state,
``steps``, ``chunk``, ``n_total`` (steps done, per chunk, in all), ``t`` (s), ``y``, ``e_d``
(J): the samples kept so far, ``y_last`` (7+2N,), ``e_d_offset`` (J), ``stat_<name>`` (work
counters), ``wall_s`` (s of integration so far); a run with a controlled step
(:mod:`quadmodes.runs.step_chunks`) adds ``t_done`` (s), ``h_next`` (s) and ``grid`` (chunks, 4:
t start s, steps before, step s, estimate, the energy balance's longest next step s); a
spin-family run adds the family so far (``family_*``, :mod:`quadmodes.runs.family_checkpoint`).

The same (run, model, initial state) is required to resume: a different one is refused with a
message that names the settings that differ.
"""

from __future__ import annotations

import time
import tomllib
import zipfile
from pathlib import Path

import numpy as np

from quadmodes.errors import QuadmodesError
from quadmodes.io.atomic import atomic_path
from quadmodes.runs.chunked import ChunkProgress

CHECKPOINT_FORMAT = "quadmodes-run-checkpoint"
CHECKPOINT_VERSION = 1

#: Default wall time between two periodic checkpoints (s).
CHECKPOINT_EVERY_S = 10.0

_STATS = ("n_steps", "n_rhs", "n_newton", "n_jac", "n_probe_steps")


class CheckpointError(QuadmodesError, ValueError):
    """A checkpoint that cannot be resumed (damaged, or made for another run); one line."""


def _flat(data: dict, prefix: str = "") -> dict:
    """Dotted keys of a nested TOML table."""
    out = {}
    for key, value in data.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def differing_settings(toml_a: str, toml_b: str) -> list[str]:
    """The dotted keys whose values differ between two run-case TOML texts (sorted)."""
    a, b = _flat(tomllib.loads(toml_a)), _flat(tomllib.loads(toml_b))
    return sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))


class RunCheckpoint:
    """The checkpoint file of one prepared run (a :class:`~quadmodes.runs.simulate.RunSetup`):
    a :class:`~quadmodes.runs.chunked.Checkpointer` that saves at most every ``every_s`` s of
    wall time (0: after every chunk), and the loader of a resume."""

    def __init__(self, path: Path, setup, every_s: float = CHECKPOINT_EVERY_S):
        self.path = Path(path)
        self.case_toml = setup.run.to_toml()
        self.model_key = str(setup.model.provenance.get("content_key", ""))
        self.y0 = np.asarray(setup.initial.y0, float)
        self.n_total = int(setup.run.integration.n_steps)
        self.every_s = float(every_s)
        self._last = time.monotonic()

    def due(self) -> bool:
        """True once ``every_s`` s of wall time have passed since the last save (or start)."""
        return time.monotonic() - self._last >= self.every_s

    def save(self, progress: ChunkProgress, wall_s: float) -> None:
        """Write ``progress`` (after ``wall_s`` s of integration) atomically."""
        t, y, e_d = progress.merged(self.y0, len(self.y0))
        if not progress.t:  # a spin family's segment at its start: no samples yet
            t, y, e_d = np.zeros(0), np.zeros((0, len(progress.y_last))), np.zeros(0)
        data = {
            "format": CHECKPOINT_FORMAT, "version": CHECKPOINT_VERSION,
            "case_toml": self.case_toml, "model_key": self.model_key, "y0": self.y0,
            "steps": progress.steps, "chunk": progress.chunk, "n_total": self.n_total,
            "t": t, "y": y, "e_d": e_d, "y_last": progress.y_last,
            "e_d_offset": progress.e_d_offset, "wall_s": float(wall_s),
        }  # fmt: skip
        for key in _STATS:
            data[f"stat_{key}"] = int(progress.stats.get(key, 0))
        if progress.t_done is not None:  # a controlled step: where it stands, what comes next
            data.update(t_done=progress.t_done, h_next=progress.h_next,
                        grid=np.array(progress.grid, float).reshape(-1, 5))  # fmt: skip
        if progress.family is not None:  # a spin-family run (runs.family_checkpoint)
            data.update({f"family_{k}": v for k, v in progress.family.items()})
        with atomic_path(self.path, fsync=True) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **data)
        self._last = time.monotonic()

    def _read(self) -> dict:
        try:
            with np.load(self.path, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
            if str(data["format"]) != CHECKPOINT_FORMAT:
                raise KeyError("format")
            return data
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            raise CheckpointError(
                f"--resume: {self.path} is damaged or not a quadmodes run checkpoint "
                f"({type(exc).__name__}); start again with --restart"
            ) from None

    def load(self) -> tuple[ChunkProgress, float]:
        """(progress, wall time before, s) saved in the checkpoint; raises
        :class:`CheckpointError` if it is damaged or was made for another run."""
        data = self._read()
        if int(data["version"]) != CHECKPOINT_VERSION:
            raise CheckpointError(
                f"--resume: {self.path} has checkpoint format version {int(data['version'])}, "
                f"this quadmodes reads {CHECKPOINT_VERSION}; start again with --restart"
            )
        differ = differing_settings(str(data["case_toml"]), self.case_toml)
        if not differ and str(data["model_key"]) != self.model_key:
            differ = ["the reduced model"]
        same_start = data["y0"].shape == self.y0.shape and np.array_equal(data["y0"], self.y0)
        if not differ and (not same_start or int(data["n_total"]) != self.n_total):
            differ = ["the initial state"]
        if differ:
            raise CheckpointError(
                f"--resume: {self.path} was made for another run ({', '.join(differ)} "
                f"{'differs' if len(differ) == 1 else 'differ'}); resume with the same case and options, or start again with --restart"
            )
        controlled = "t_done" in data
        stats = {k: int(data[f"stat_{k}"]) for k in _STATS if f"stat_{k}" in data}
        if not controlled:
            stats.pop("n_probe_steps", None)
        progress = ChunkProgress(
            steps=int(data["steps"]), chunk=int(data["chunk"]), stats=stats,
            **(dict(t=(data["t"],), y=(data["y"],), e_d=(data["e_d"],)) if len(data["t"])
               else dict(t=(), y=(), e_d=())),
            y_last=data["y_last"].copy(), e_d_offset=float(data["e_d_offset"]),
            t_done=float(data["t_done"]) if controlled else None,
            h_next=float(data["h_next"]) if controlled else None,
            grid=(tuple((float(a), int(b), float(c), float(d), float(e))
                        for a, b, c, d, e in data["grid"]) if controlled else ()),
            family={k[7:]: v for k, v in data.items() if k.startswith("family_")} or None,
        )  # fmt: skip
        return progress, float(data["wall_s"])
