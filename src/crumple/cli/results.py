"""Reading a results file (``ramps.h5``) for ``export``, ``plot`` and ``animate``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .inputs import CLIError, floats

__all__ = ["pick_stage", "read_results", "stage_index"]


def read_results(path) -> dict:
    """The arrays of a verified ramp file (:func:`crumple.storage.read_arrays`), positions
    included."""
    from ..storage import read_arrays

    path = Path(path)
    if not path.is_file():
        raise CLIError(f"no such results file: {path}")
    try:
        return read_arrays(path, positions=True)
    except ValueError as exc:
        raise CLIError(str(exc)) from None


def replica_index(res: dict, path, replica: int) -> int:
    n_rep = res["positions"].shape[0]
    if not -n_rep <= replica < n_rep:
        raise CLIError(f"{path} has {n_rep} replica(s) (0 … {n_rep - 1}), not replica {replica}")
    return replica % n_rep


def stage_index(res: dict, path, r: int, lam: float) -> int:
    """The stage at trap strength ``lam`` (to 1e-9 relative) that replica ``r`` ran."""
    lams = np.asarray(res["lambda"], float)
    n_run = int(res["n_stages"][r])
    hits = np.flatnonzero(np.isclose(lams, lam, rtol=1e-9, atol=0.0))
    if hits.size == 0:
        shown = ", ".join(f"{v:g}" for v in lams)
        raise CLIError(f"{path} has no stage at λ = {lam:g}; its stages: {shown}")
    s = int(hits[0])
    if s >= n_run:
        raise CLIError(f"replica {r} of {path} stopped before λ = {lam:g} (after {n_run} stages)")
    return s


def pick_stage(res: dict, path, *, replica: int, lam=None, stage=None) -> tuple[int, int]:
    """(replica, stage) indices from ``--replica`` and ``--lam`` or ``--stage`` (default: the
    replica's last stage)."""
    r = replica_index(res, path, replica)
    n_run = int(res["n_stages"][r])
    if lam is not None:
        return r, stage_index(res, path, r, floats(lam, "--lam", 1)[0])
    if stage is None:
        return r, n_run - 1
    if not -n_run <= stage < n_run:
        raise CLIError(f"replica {r} of {path} has {n_run} stages (0 … {n_run - 1}), not {stage}")
    return r, stage % n_run
