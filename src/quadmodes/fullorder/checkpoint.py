"""Checkpoints of a full-order transient: the run state, the sampled series and the predictor's
history in one .npz (written atomically), and the resume from one.

Entries (format :data:`CHECKPOINT_VERSION`): version, n, dt (s), t0 (s), step, x, v (n,3),
E_d_now (J), axis_prev (3,), n_newton, n_factor, wall_s (s), damped_modes (the size of the
damping basis; checked on resume), ``key`` (what the run is of: the run case and its model,
:attr:`~quadmodes.fullorder.options.FullOrderOptions.checkpoint_key`; checked on resume when
given), ``series_<name>`` per sampled
series (:data:`~quadmodes.fullorder.sampling.SERIES`), prev_c (3,), prev_R (3,3), prev_b (n,3):
the body frame of the previous state.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from quadmodes.fullorder.sampling import SERIES, SampledSeries
from quadmodes.fullorder.setup import FullOrderProblem, RunState
from quadmodes.io.atomic import atomic_path

#: Checkpoint file format version.
CHECKPOINT_VERSION = 1


def write_checkpoint(path: Path, data: dict) -> None:
    """Write ``data`` (arrays) to ``path`` (.npz) atomically: temporary file + ``os.replace``."""
    with atomic_path(path, fsync=True) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **data)


def read_checkpoint(path: Path) -> dict:
    """Arrays of a checkpoint written by :func:`write_checkpoint`."""
    with np.load(Path(path), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def checkpoint_data(
    problem: FullOrderProblem, state: RunState, samples: SampledSeries, wall_s: float,
    key: str = "",
) -> dict:  # fmt: skip
    """The checkpoint entries (module docstring) of ``state`` after ``wall_s`` s of wall time
    (``key``: what the run is of)."""
    data = {
        "key": str(key),
        "version": CHECKPOINT_VERSION, "n": problem.n, "dt": problem.h, "t0": problem.t0,
        "step": state.step, "x": state.x, "v": state.v, "E_d_now": state.e_d,
        "axis_prev": samples.axis_prev, "n_newton": state.n_newton, "n_factor": state.n_factor,
        "wall_s": wall_s, "damped_modes": _damped_modes(problem),
    }  # fmt: skip
    for k in SERIES:
        data[f"series_{k}"] = np.asarray(samples.series[k])
    for k, arr in zip(("prev_c", "prev_R", "prev_b"), state.frame_prev, strict=True):
        data[k] = arr  # the predictor's history
    return data


def _damped_modes(problem: FullOrderProblem) -> int:
    return 0 if problem.damping is None else problem.damping.n_modes


def resume_from(path: Path, problem: FullOrderProblem, samples: SampledSeries,
                key: str = "") -> RunState:  # fmt: skip
    """The :class:`RunState` saved in checkpoint ``path``; its series are restored into
    ``samples``. Raises ValueError for a checkpoint of another ``key`` (another run case or
    model, when given), model, t0 or time step, or one already past the end of the problem's
    time span."""
    data = read_checkpoint(path)
    if key and str(data.get("key", "")) != key:
        raise ValueError(
            f"checkpoint {path}: made for another run case or model (the case was edited since, "
            "or another case wrote it); start again with --restart"
        )
    if (
        int(data["n"]) != problem.n
        or not math.isclose(float(data["dt"]), problem.h, rel_tol=1e-12)
        or not math.isclose(float(data["t0"]), problem.t0, abs_tol=1e-12)
    ):
        raise ValueError(f"checkpoint {path}: made for another model, t0 or time step")
    if "damped_modes" in data and int(data["damped_modes"]) != _damped_modes(problem):
        raise ValueError(
            f"checkpoint {path}: made with {int(data['damped_modes'])} damped modes, this run "
            f"has {_damped_modes(problem)}; resume with the same damping cutoff"
        )
    state = RunState(
        step=int(data["step"]),
        x=data["x"].copy(),
        v=data["v"].copy(),
        e_d=float(data["E_d_now"]),
        frame_prev=(data["prev_c"].copy(), data["prev_R"].copy(), data["prev_b"].copy()),
        n_newton=int(data["n_newton"]),
        n_factor=int(data["n_factor"]),
        wall_before=float(data["wall_s"]),
    )
    samples.restore(data, data["axis_prev"].copy())
    if state.step > problem.n_steps:
        raise ValueError(f"checkpoint {path}: already past the end of t_span")
    return state
