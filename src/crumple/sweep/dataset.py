"""Reading a sweep store into an :class:`xarray.Dataset` (:func:`load`, also ``crumple.load``).

Named ``dataset`` rather than ``load`` so that the module does not shadow the function
``crumple.sweep.load``.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from .. import stage_observables
from ..model import Wire
from ..storage import read_arrays
from .store import _h5, _read_manifest

_TERMS = ("bending", "stretching", "confinement", "hard_core", "total")
_COUNTS = ("iterations", "evaluations", "hessian_evaluations")


class IncompleteSweepWarning(UserWarning):
    """:func:`load` found runs that are missing, failed or damaged (their values are NaN)."""


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------


def load(path, *, positions: bool = False):
    """The stage-level results of a sweep store as an :class:`xarray.Dataset`.

    Dimensions: one per swept parameter (the grid, in the order of the sweep file; points as
    one dimension, named after its key or ``point`` with one coordinate per key), then
    ``replica`` and ``lam`` (every stage λ of any run; NaN where a run has no such stage).
    Data variables over all of them: ``E_bending``, ``E_stretching``, ``E_confinement``,
    ``E_hard_core``, ``E_total`` ``[energy]`` (and ``E_wall`` when a run has a cavity),
    ``gamma`` (E_s/E_b), ``converged`` (bool),
    ``max_force`` ``[energy/length]``, ``iterations``, ``evaluations``,
    ``hessian_evaluations`` (float, NaN where no stage), and every per-stage observable of
    :data:`crumple.stage_observables.OBSERVABLES` (``r_max``, ``radius_of_gyration``,
    ``contacts``, ``contacts_interior``, ``max_turning_angle``, ``contour_length``,
    ``n_loops``, ``n_loops_nested``, ``loop_contacts``; float, NaN where no stage; their
    ``units`` and ``doc`` in the variable's attributes); per run (no ``lam``): ``done``,
    ``seconds``, ``n_stages``, ``run_id``. With ``positions=True``, ``positions`` (…,
    ``replica``, ``lam``, ``node``, ``xy``) ``[length]``, NaN-padded when N is swept.

    ``gamma`` is NaN where it is undefined: at a straight stage (every joint turns by less
    than :data:`crumple.stage_observables.STRAIGHT` rad, where E_b is round-off and E_s/E_b
    would read 1e15-1e21), where E_b = 0, and where there is no stage. This is the report's
    convention (:func:`crumple.stage_observables.gamma`, one definition for both).

    The observables are computed once, when a run is executed, and read from its file. A run
    file written before an observable existed (an older store) lacks it: ``load`` computes
    it from the stored positions (the same function, so the same numbers), and counts such
    runs in the attribute ``observables_computed_on_load``.

    Runs that are missing, failed or whose file is damaged are NaN (``done`` false) and an
    :class:`IncompleteSweepWarning` says how many; a damaged file is never read as data.
    See ``docs/sweeps.md``.

    A store of injections (``[protocol] kind = "injection"``) has the stage dimension
    ``L_in`` (the injected length) in place of ``lam``, and the variables of
    :func:`crumple.sweep.injection_dataset.load_injection_store`.
    """
    import xarray as xr

    out = Path(path)
    m = _read_manifest(out, for_load=True)
    if m.get("protocol") == "injection":
        from .injection_dataset import load_injection_store

        return load_injection_store(out, m, positions=positions)
    lam = np.asarray(m["lambdas"], dtype=float)
    coords, names, shape = _grid_coords(m["dims"])
    n_rep = int(m["replicas"])
    run_shape = (*shape, n_rep)
    data, per_run, pos_arrays, bad, recomputed = _read_runs(out, m, lam, run_shape, positions)
    done = per_run[0]
    data["gamma"] = stage_observables.gamma(
        data["E_stretching"], data["E_bending"], data["max_turning_angle"]
    )
    variables = _variables(names, data, per_run)
    if positions:
        sdims = (*names, "replica", "lam")
        variables["positions"] = ((*sdims, "node", "xy"), _positions(pos_arrays, run_shape, lam))
        coords["xy"] = ["x", "y"]
    coords["replica"] = np.arange(n_rep)
    coords["lam"] = lam
    ds = xr.Dataset(variables, coords=coords)
    ds["gamma"].attrs["long_name"] = "E_stretching / E_bending (NaN at straight stages)"
    for k, o in stage_observables.OBSERVABLES.items():
        ds[k].attrs.update(units=o.units, doc=o.doc)
    ds["lam"].attrs["long_name"] = "trap strength λ of the stage"
    ds.attrs.update(
        store=str(out),
        sweep=json.dumps(m["sweep"]),
        runs=len(m["runs"]),
        runs_done=int(done.sum()),
        observables_computed_on_load=recomputed,
    )
    if bad:
        warnings.warn(
            f"{out}: {bad} of {len(m['runs'])} runs are missing, failed or damaged; their values "
            "are NaN (done = False); see `crumple status`",
            IncompleteSweepWarning,
            stacklevel=2,
        )
    return ds


def _grid_coords(dims: list) -> tuple[dict[str, Any], list[str], list[int]]:
    """The coordinates of the manifest's ``dims`` (a ``point`` MultiIndex where the grid is a
    list of points), their names and sizes."""
    import pandas as pd
    import xarray as xr

    coords: dict[str, Any] = {}
    names: list[str] = []
    shape: list[int] = []
    for d in dims:
        if "levels" in d:
            mi = pd.MultiIndex.from_tuples([tuple(v) for v in d["values"]], names=d["levels"])
            coords.update(xr.Coordinates.from_pandas_multiindex(mi, d["name"]))
        else:
            coords[d["name"]] = d["values"]
        names.append(d["name"])
        shape.append(len(d["values"]))
    return coords, names, shape


def _variables(names: list[str], data: dict, per_run: tuple) -> dict:
    """The data variables: per stage over (*names, replica, lam), per run over (*names,
    replica)."""
    done, seconds, n_stages, ids = per_run
    sdims = (*names, "replica", "lam")
    rdims = (*names, "replica")
    variables = {k: (sdims, v) for k, v in data.items()}
    variables.update(
        done=(rdims, done),
        seconds=(rdims, seconds),
        n_stages=(rdims, n_stages),
        run_id=(rdims, ids.astype(str)),
    )
    return variables


def _positions(pos_arrays: dict, run_shape: tuple, lam: np.ndarray) -> np.ndarray:
    """Every run's positions in one array (*run_shape, lam, node, xy), NaN-padded to the
    largest wire."""
    n_max = max((p.shape[-2] for _, p in pos_arrays.values()), default=0)
    pos = np.full((*run_shape, len(lam), n_max, 2), np.nan)
    for at, (j, p) in pos_arrays.items():
        pos[(*at, j, slice(0, p.shape[-2]))] = p
    return pos


def _read_runs(out: Path, m: dict, lam: np.ndarray, run_shape: tuple, positions: bool):
    """Every run file of the manifest ``m`` into arrays over (*run_shape, lam); the runs that
    are missing, damaged or on other stages than ``lam`` are counted in ``bad`` and left NaN."""
    stage_shape = (*run_shape, len(lam))
    data = {f"E_{t}": np.full(stage_shape, np.nan) for t in _TERMS}
    data["converged"] = np.zeros(stage_shape, dtype=bool)
    data["max_force"] = np.full(stage_shape, np.nan)
    for c in _COUNTS:
        data[c] = np.full(stage_shape, np.nan)
    for k in stage_observables.OBSERVABLES:
        data[k] = np.full(stage_shape, np.nan)
    recomputed = 0
    done = np.zeros(run_shape, dtype=bool)
    seconds = np.full(run_shape, np.nan)
    n_stages = np.zeros(run_shape, dtype=np.int64)
    ids = np.full(run_shape, "", dtype=object)
    pos_arrays: dict[tuple, np.ndarray] = {}
    bad = 0
    for entry in m["runs"]:
        rid = entry["id"]
        at = (*entry["index"], entry["replica"])
        ids[at] = rid
        h5 = _h5(out, rid)
        if not h5.exists():
            bad += 1
            continue
        try:
            a = read_arrays(h5, positions=positions, run_id=rid)
        except ValueError:
            bad += 1
            continue
        j = np.searchsorted(lam, a["lambda"])
        if np.any(j >= len(lam)) or not np.array_equal(
            lam[np.minimum(j, len(lam) - 1)], a["lambda"]
        ):
            bad += 1
            continue
        for t in _TERMS:
            data[f"E_{t}"][(*at, j)] = a[f"energy/{t}"][0]
        if "energy/wall" in a:  # a cavity's wall term: a variable only for stores that have one
            data.setdefault("E_wall", np.full(stage_shape, np.nan))[(*at, j)] = a["energy/wall"][0]
        data["max_force"][(*at, j)] = a["solver/max_force"][0]
        ran = np.arange(len(j)) < int(a["n_stages"][0])
        data["converged"][(*at, j)] = a["solver/converged"][0] & ran
        for c in _COUNTS:
            data[c][(*at, j)] = np.where(ran, a[f"solver/{c}"][0], np.nan)
        obs, computed = _observables(h5, rid, a)
        recomputed += computed
        for k, v in obs.items():
            data[k][(*at, j)] = v
        done[at] = True
        seconds[at] = a["seconds"][0]
        n_stages[at] = a["n_stages"][0]
        if positions:
            pos_arrays[at] = (j, a["positions"][0])
    return data, (done, seconds, n_stages, ids), pos_arrays, bad, recomputed


def _observables(h5: Path, rid: str, a: dict) -> tuple[dict[str, np.ndarray], bool]:
    """The per-stage observables of one run file (replica 0): read where stored, computed
    from its positions where the file predates them. Returns (name → (S,), any computed)."""
    out = {}
    for k in stage_observables.OBSERVABLES:
        v = a.get(f"observables/{k}")
        if v is not None:
            out[k] = v[0]
    missing = [k for k in stage_observables.OBSERVABLES if k not in out]
    if missing:
        pos = (
            a["positions"]
            if "positions" in a
            else read_arrays(h5, positions=True, run_id=rid)["positions"]
        )
        wire = Wire.from_dict(a["attrs"]["wire"])
        out.update(stage_observables.compute(pos[0], wire, missing))
    return out, bool(missing)
