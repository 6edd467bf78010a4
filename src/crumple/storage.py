"""Results on disk: ramps as HDF5 files readable without crumple.

One file holds the replicas of one ramp (same wire, same protocol). Layout (R replicas,
S stages, n nodes; stages a replica did not run, after an early stop, are NaN):

====================================  =================  ======================================
dataset                               shape              meaning
====================================  =================  ======================================
``lambda``                            (S,)               trap strength of each stage
``positions``                         (R, S, n, 2)       equilibrium node positions [length]
``initial``                           (R, n, 2)          starting configuration [length]
``n_stages``                          (R,)               stages actually run
``seconds``                           (R,)               wall time of each replica
``energy/<term>``                     (R, S)             bending, stretching, confinement,
                                                         hard_core, total [energy]
``solver/converged``                  (R, S)             equilibrium reached (max force <= ftol)
``solver/max_force``                  (R, S)             largest node force at the end
``solver/iterations``, ``evaluations``, ``hessian_evaluations``  (R, S)
``solver/message``                    (R, S)             why the minimiser stopped (UTF-8)
====================================  =================  ======================================

Root attributes: ``format`` (``"crumple-ramps"``), ``format_version``, ``wire`` and ``ramp`` (the
parameters as JSON), ``seed`` (JSON), ``versions`` (JSON: crumple, numpy, scipy, numba, h5py),
``created`` (ISO 8601). Files are written to a temporary name in the same directory and then
renamed, so a crash never leaves a half-written file under the final name.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import tempfile
from pathlib import Path

import h5py
import numpy as np

from . import __version__
from .energy import EnergyTerms
from .minimize import MinimizeResult
from .model import Wire
from .protocol import Ramp, RampResult, Stage

__all__ = ["FORMAT", "FORMAT_VERSION", "load_ramps", "read_attrs", "save_ramps", "versions"]

FORMAT = "crumple-ramps"
FORMAT_VERSION = 1
_TERMS = ("bending", "stretching", "confinement", "hard_core", "total")
_COUNTS = ("iterations", "evaluations", "hessian_evaluations")


def versions() -> dict[str, str]:
    """Versions of crumple and of the libraries that determine its numbers."""
    import numba
    import scipy

    return {
        "crumple": __version__,
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "h5py": h5py.__version__,
    }


def _jsonable_seed(seed):
    if seed is None or isinstance(seed, int | str):
        return seed
    if isinstance(seed, np.integer):
        return int(seed)
    return repr(seed)


def save_ramps(path, results: list[RampResult], *, seed=None, attrs: dict | None = None) -> Path:
    """Write the replicas of one ramp to an HDF5 file, atomically.

    Parameters
    ----------
    path : str or Path
        Destination (``.h5``); its directory must exist.
    results : list of RampResult
        Replicas of the same wire and ramp.
    seed : int, optional
        The base seed, stored for provenance.
    attrs : dict, optional
        Extra JSON-able root attributes.

    Returns
    -------
    Path
    """
    if not results:
        raise ValueError("no results to save")
    wire, ramp = results[0].wire, results[0].ramp
    if any(r.wire != wire or r.ramp != ramp for r in results):
        raise ValueError("all replicas in one file must share the wire and the ramp")
    path = Path(path)
    n_rep, n_stage, n_node = len(results), len(ramp.lambdas), wire.n_nodes
    pos = np.full((n_rep, n_stage, n_node, 2), np.nan)
    energy = {t: np.full((n_rep, n_stage), np.nan) for t in _TERMS}
    conv = np.zeros((n_rep, n_stage), dtype=bool)
    fmax = np.full((n_rep, n_stage), np.nan)
    counts = {c: np.zeros((n_rep, n_stage), dtype=np.int64) for c in _COUNTS}
    msgs = np.full((n_rep, n_stage), "", dtype=object)
    for r, res in enumerate(results):
        for s, st in enumerate(res.stages):
            pos[r, s] = st.positions
            for t, v in st.energy.to_dict().items():
                energy[t][r, s] = v
            conv[r, s] = st.result.converged
            fmax[r, s] = st.result.max_force
            for c in _COUNTS:
                counts[c][r, s] = getattr(st.result, c)
            msgs[r, s] = st.result.message
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
    os.close(fd)
    try:
        with h5py.File(tmp, "w") as f:
            f.attrs["format"] = FORMAT
            f.attrs["format_version"] = FORMAT_VERSION
            f.attrs["wire"] = json.dumps(wire.to_dict())
            f.attrs["ramp"] = json.dumps(ramp.to_dict())
            f.attrs["seed"] = json.dumps(_jsonable_seed(seed))
            f.attrs["versions"] = json.dumps(versions())
            f.attrs["created"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
            for k, v in (attrs or {}).items():
                f.attrs[k] = json.dumps(v)
            f.create_dataset("lambda", data=np.asarray(ramp.lambdas))
            f.create_dataset("positions", data=pos, compression="gzip", shuffle=True)
            f.create_dataset("initial", data=np.array([r.initial for r in results]))
            f.create_dataset("n_stages", data=np.array([len(r.stages) for r in results]))
            f.create_dataset("seconds", data=np.array([r.seconds for r in results]))
            g = f.create_group("energy")
            for t, v in energy.items():
                g.create_dataset(t, data=v)
            g = f.create_group("solver")
            g.attrs["method"] = ramp.method
            g.attrs["ftol"] = ramp.ftol
            g.create_dataset("converged", data=conv)
            g.create_dataset("max_force", data=fmax)
            for c, v in counts.items():
                g.create_dataset(c, data=v)
            g.create_dataset("message", data=msgs, dtype=h5py.string_dtype("utf-8"))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def read_attrs(path) -> dict:
    """The root attributes of a results file, JSON-decoded where they are JSON."""
    with h5py.File(path, "r") as f:
        out = {}
        for k, v in f.attrs.items():
            v = v.decode() if isinstance(v, bytes) else v
            try:
                out[k] = json.loads(v) if isinstance(v, str) else v
            except json.JSONDecodeError:
                out[k] = v
        return out


def load_ramps(path) -> list[RampResult]:
    """Read a file written by :func:`save_ramps` back into :class:`RampResult` objects.

    Raises ``ValueError`` for a file that is not a crumple ramp file or is incomplete.
    """
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ValueError(f"{path} is not a readable HDF5 file ({exc})") from None
    with f:
        if f.attrs.get("format") != FORMAT:
            raise ValueError(f"{path} is not a crumple ramp file")
        wire = Wire.from_dict(json.loads(f.attrs["wire"]))
        ramp = Ramp.from_dict(json.loads(f.attrs["ramp"]))
        lams = f["lambda"][()]
        pos = f["positions"][()]
        initial = f["initial"][()]
        n_stages = f["n_stages"][()]
        seconds = f["seconds"][()]
        energy = {t: f["energy"][t][()] for t in _TERMS}
        solver = f["solver"]
        conv = solver["converged"][()]
        fmax = solver["max_force"][()]
        counts = {c: solver[c][()] for c in _COUNTS}
        msgs = solver["message"].asstr()[()]
    out = []
    for r in range(pos.shape[0]):
        stages = []
        for s in range(int(n_stages[r])):
            terms = EnergyTerms(*(float(energy[t][r, s]) for t in _TERMS[:4]))
            res = MinimizeResult(
                x=pos[r, s],
                energy=float(energy["total"][r, s]),
                max_force=float(fmax[r, s]),
                iterations=int(counts["iterations"][r, s]),
                evaluations=int(counts["evaluations"][r, s]),
                hessian_evaluations=int(counts["hessian_evaluations"][r, s]),
                converged=bool(conv[r, s]),
                ftol=ramp.ftol,
                message=str(msgs[r, s]),
                method=ramp.method,
            )
            stages.append(Stage(lam=float(lams[s]), positions=pos[r, s], energy=terms, result=res))
        out.append(
            RampResult(
                wire=wire,
                ramp=ramp,
                initial=initial[r],
                stages=tuple(stages),
                seconds=float(seconds[r]),
            )
        )
    return out
