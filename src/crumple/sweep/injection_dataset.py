"""Reading a store of injections into an :class:`xarray.Dataset` (through :func:`crumple.load`).

The injection's counterpart of :mod:`crumple.sweep.dataset`: the same grid dimensions and
``replica``, with the stage dimension ``L_in`` (every planned injected length of any run).
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from .. import stage_observables
from ..injection_observables import INJECTION_OBSERVABLES
from ..injection_storage import read_injection_arrays
from .store import _h5

__all__ = ["load_injection_store"]

_TERMS = ("bending", "stretching", "hard_core", "wall", "total")
_COUNTS = ("iterations", "evaluations", "hessian_evaluations")


def load_injection_store(out: Path, m: dict, *, positions: bool = False):
    """The stage-level results of an injection sweep (manifest ``m``) as a Dataset.

    Per stage, over (*grid, ``replica``, ``L_in``): ``E_bending``, ``E_stretching``,
    ``E_hard_core``, ``E_wall``, ``E_total`` ``[energy]``, ``gamma`` (E_s/E_b, NaN where
    undefined), ``converged``, ``max_force``, ``iterations``, ``evaluations``,
    ``hessian_evaluations``, ``released`` and every entry of
    :data:`crumple.injection_observables.INJECTION_OBSERVABLES` (``packing_fraction``,
    ``feed_force`` (the injection force), ``clamp_reaction``, ``release_drop``, ``contacts``,
    ``wall_contacts``, ``n_loops``, ``D_M_center``,
    ``D_M_com``, ``r_max``, ``injected_length``), their units and meaning in the attributes.
    Per run: ``done``, ``seconds``, ``n_stages``, ``run_id``, ``stop_reason``. With
    ``positions=True``, ``positions`` (…, ``replica``, ``L_in``, ``node``, ``xy``).
    Missing or damaged runs are NaN (``done`` false), with an
    :class:`~crumple.sweep.dataset.IncompleteSweepWarning`.
    """
    import xarray as xr

    from .dataset import IncompleteSweepWarning, _grid_coords

    L = np.asarray(m["lambdas"], dtype=float)
    coords, names, shape = _grid_coords(m["dims"])
    run_shape = (*shape, int(m["replicas"]))
    data, per_run, pos, bad = _read(out, m, L, run_shape, positions)
    data["gamma"] = stage_observables.gamma(
        data["E_stretching"], data["E_bending"], np.full(data["E_bending"].shape, 1.0)
    )
    sdims, rdims = (*names, "replica", "L_in"), (*names, "replica")
    variables = {k: (sdims, v) for k, v in data.items()}
    variables.update({k: (rdims, v) for k, v in per_run.items()})
    if positions:
        variables["positions"] = ((*sdims, "node", "xy"), pos)
        coords["xy"] = ["x", "y"]
    coords["replica"] = np.arange(run_shape[-1])
    coords["L_in"] = L
    ds = xr.Dataset(variables, coords=coords)
    for k, (units, doc) in INJECTION_OBSERVABLES.items():
        ds[k].attrs.update(units=units, doc=doc)
    ds["L_in"].attrs["long_name"] = "injected length L_in of the stage [length]"
    ds.attrs.update(store=str(out), sweep=json.dumps(m["sweep"]), protocol="injection",
                    runs=len(m["runs"]), runs_done=int(per_run["done"].sum()))  # fmt: skip
    if bad:
        warnings.warn(
            f"{out}: {bad} of {len(m['runs'])} runs are missing, failed or damaged; their values "
            "are NaN (done = False); see `crumple status`",
            IncompleteSweepWarning,
            stacklevel=3,
        )
    return ds


def _read(out: Path, m: dict, L: np.ndarray, run_shape: tuple, positions: bool):
    stage_shape = (*run_shape, len(L))
    data = {f"E_{t}": np.full(stage_shape, np.nan) for t in _TERMS}
    data["converged"] = np.zeros(stage_shape, dtype=bool)
    for k in ("max_force", *_COUNTS, "released", *INJECTION_OBSERVABLES):
        data[k] = np.full(stage_shape, np.nan)
    per_run = {
        "done": np.zeros(run_shape, dtype=bool),
        "seconds": np.full(run_shape, np.nan),
        "n_stages": np.zeros(run_shape, dtype=np.int64),
        "run_id": np.full(run_shape, "", dtype=object),
        "stop_reason": np.full(run_shape, "", dtype=object),
    }
    pos_arrays: dict[tuple, tuple] = {}
    bad = 0
    for entry in m["runs"]:
        rid = entry["id"]
        at = (*entry["index"], entry["replica"])
        per_run["run_id"][at] = rid
        try:
            a = read_injection_arrays(_h5(out, rid), positions=positions, run_id=rid)
        except (ValueError, FileNotFoundError):
            bad += 1
            continue
        j = np.searchsorted(L, a["injected_length"])
        if np.any(j >= len(L)) or not np.allclose(L[np.minimum(j, len(L) - 1)],
                                                  a["injected_length"]):  # fmt: skip
            bad += 1
            continue
        ran = np.arange(len(j)) < int(a["n_stages"][0])
        for t in _TERMS:
            data[f"E_{t}"][(*at, j)] = a[f"energy/{t}"][0]
        data["converged"][(*at, j)] = a["solver/converged"][0] & ran
        data["max_force"][(*at, j)] = a["solver/max_force"][0]
        for c in _COUNTS:
            data[c][(*at, j)] = np.where(ran, a[f"solver/{c}"][0], np.nan)
        data["released"][(*at, j)] = np.where(ran, a["released"][0], np.nan)
        for k in INJECTION_OBSERVABLES:
            data[k][(*at, j)] = a[f"observables/{k}"][0]
        per_run["done"][at] = True
        per_run["seconds"][at] = a["seconds"][0]
        per_run["n_stages"][at] = a["n_stages"][0]
        per_run["stop_reason"][at] = str(a["stop_reason"][0])
        if positions:
            pos_arrays[at] = (j, a["positions"][0])
    per_run["run_id"] = per_run["run_id"].astype(str)
    per_run["stop_reason"] = per_run["stop_reason"].astype(str)
    pos = None
    if positions:  # NaN-padded to the largest wire when N is swept
        n_max = max((p.shape[-2] for _, p in pos_arrays.values()), default=0)
        pos = np.full((*stage_shape, n_max, 2), np.nan)
        for at, (j, p) in pos_arrays.items():
            pos[(*at, j, slice(0, p.shape[-2]))] = p
    return data, per_run, pos, bad
