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
                                                         hard_core, total [energy]; and
                                                         wall, only for a wire with a cavity
``solver/converged``                  (R, S)             equilibrium reached (max force <= ftol)
``solver/max_force``                  (R, S)             largest node force at the end
``solver/<count>``                    (R, S)             ``iterations``, ``evaluations``,
                                                         ``hessian_evaluations``
``solver/message``                    (R, S)             why the minimiser stopped (UTF-8)
``rest_angles`` (imperfect wires)     (R, n - 2)         each replica's quenched rest angles
``observables/<name>`` (optional)     (R, S)             per-stage observables (a sweep's run
                                                         files: :mod:`crumple.stage_observables`),
                                                         attributes ``units`` and ``doc``
====================================  =================  ======================================

Root attributes: ``format`` (``"crumple-ramps"``), ``format_version``, ``wire`` and ``ramp`` (the
parameters as JSON), ``seed`` (JSON), ``versions`` (JSON: crumple, numpy, scipy, numba, h5py),
``created`` (ISO 8601), any extra attributes given to :func:`save_ramps` (JSON; a sweep's run
files add ``run_id``, ``replica`` and ``coords``, see :mod:`crumple.sweep`), and last
``complete`` (true). Files are written to a temporary name in the same directory, flushed to
disk and then renamed, so a crash never leaves a half-written file under the final name;
:func:`verify_ramps` checks a file before it is trusted (files written before the
``complete`` marker existed load with :func:`load_ramps` but do not pass it).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import functools
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

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "atomic_path",
    "atomic_write_text",
    "load_ramps",
    "read_arrays",
    "read_attrs",
    "save_ramps",
    "verify_ramps",
    "versions",
]

FORMAT = "crumple-ramps"
FORMAT_VERSION = 1
_TERMS = ("bending", "stretching", "confinement", "hard_core", "total")
_COUNTS = ("iterations", "evaluations", "hessian_evaluations")
_SOLVER = ("converged", "max_force", *_COUNTS, "message")
#: Every dataset a complete file holds, with its dimensions (R replicas, S stages, n nodes).
_LAYOUT = {
    "lambda": ("S",),
    "positions": ("R", "S", "n", 2),
    "initial": ("R", "n", 2),
    "n_stages": ("R",),
    "seconds": ("R",),
    **{f"energy/{t}": ("R", "S") for t in _TERMS},
    **{f"solver/{c}": ("R", "S") for c in _SOLVER},
}


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


def write_run_attrs(f, *, wire: Wire, seed, attrs=None, **protocol) -> None:
    """The attributes every run file carries: the wire, the protocol (``ramp=`` or
    ``injection=``, a dict), the seed, the versions, the time of writing, and ``attrs`` (each
    JSON-encoded)."""
    f.attrs["wire"] = json.dumps(wire.to_dict())
    for k, v in protocol.items():
        f.attrs[k] = json.dumps(v)
    f.attrs["seed"] = json.dumps(_jsonable_seed(seed))
    f.attrs["versions"] = json.dumps(versions())
    f.attrs["created"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    for k, v in (attrs or {}).items():
        f.attrs[k] = json.dumps(v)


def _jsonable_seed(seed):
    if seed is None or isinstance(seed, int | str):
        return seed
    if isinstance(seed, np.integer):
        return int(seed)
    return repr(seed)


def save_ramps(
    path,
    results: list[RampResult],
    *,
    seed=None,
    attrs: dict | None = None,
    observables: dict | None = None,
) -> Path:
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
    observables : dict, optional
        name → ``(values, meta)``: per-stage values of shape (R, S) (NaN where no stage) and
        a dict of string attributes (``units``, ``doc``), written to ``observables/<name>``.

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
    # the cavity's wall energy only for a wire with a cavity: files without one keep the layout
    terms = (*_TERMS, "wall") if wire.cavity_radius is not None else _TERMS
    energy = {t: np.full((n_rep, n_stage), np.nan) for t in terms}
    conv = np.zeros((n_rep, n_stage), dtype=bool)
    fmax = np.full((n_rep, n_stage), np.nan)
    counts = {c: np.zeros((n_rep, n_stage), dtype=np.int64) for c in _COUNTS}
    msgs = np.full((n_rep, n_stage), "", dtype=object)
    for r, res in enumerate(results):
        for s, st in enumerate(res.stages):
            pos[r, s] = st.positions
            d = st.energy.to_dict()
            for t in terms:
                energy[t][r, s] = d[t]
            conv[r, s] = st.result.converged
            fmax[r, s] = st.result.max_force
            for c in _COUNTS:
                counts[c][r, s] = getattr(st.result, c)
            msgs[r, s] = st.result.message
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            f.attrs["format"] = FORMAT
            f.attrs["format_version"] = FORMAT_VERSION
            write_run_attrs(f, wire=wire, seed=seed, attrs=attrs, ramp=ramp.to_dict())
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
            rest = [getattr(r, "rest_angles", None) for r in results]
            if any(a is not None for a in rest):
                ra = np.full((n_rep, n_node - 2), np.nan)
                for r, a in enumerate(rest):
                    if a is not None:
                        ra[r] = a
                f.create_dataset("rest_angles", data=ra)
            if observables:
                g = f.create_group("observables")
                for name, (values, meta) in observables.items():
                    v = np.asarray(values, dtype=float)
                    if v.shape != (n_rep, n_stage):
                        raise ValueError(
                            f"observable {name!r} has shape {v.shape}, not {(n_rep, n_stage)}"
                        )
                    d = g.create_dataset(name, data=v)
                    for k, text in (meta or {}).items():
                        d.attrs[k] = str(text)
            f.attrs["complete"] = True  # last: only a file written to the end carries it
    return path


def _fsync(path) -> None:
    """Flush a file's data to the disk, so that a rename never publishes unwritten blocks."""
    with open(path, "rb+") as fh:
        os.fsync(fh.fileno())


@functools.cache
def _umask() -> int:
    mask = os.umask(0o022)  # read it (there is no other portable way) and put it back
    os.umask(mask)
    return mask


def _publish(tmp, path) -> None:
    """Give a temporary file (mkstemp makes it 0600) the usual permissions, then rename it."""
    os.chmod(tmp, 0o666 & ~_umask())
    os.replace(tmp, path)


@contextlib.contextmanager
def atomic_path(path, suffix: str = ".tmp"):
    """Yield a temporary name beside ``path`` (``.NAME.<pid>.XXXX<suffix>``: unique, and the
    pid says which process left it); when the block succeeds, flush that file to disk and
    rename it to ``path``; when it fails, delete it. Readers never see a partial file.

    The one write-then-rename of the package: ``crumple run``'s outputs, ``export``, ``plot``
    and ``animate`` all write through it. ``suffix`` matters to writers that pick the format
    from the name (``np.save`` appends ``.npy``, matplotlib reads ``.png``/``.mp4``).
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(
        prefix=f".{path.name}.{os.getpid()}.", suffix=suffix, dir=path.parent or "."
    )
    os.close(fd)
    try:
        yield tmp
        _fsync(tmp)
        _publish(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically: temporary file, fsync, rename."""
    path = Path(path)
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return path


def _decode_attrs(attrs) -> dict:
    out = {}
    for k, v in attrs.items():
        v = v.decode() if isinstance(v, bytes) else v
        try:
            out[k] = json.loads(v) if isinstance(v, str) else v
        except json.JSONDecodeError:
            out[k] = v
    return out


def _check_layout(f, path) -> None:
    """Every dataset of :data:`_LAYOUT` present, with consistent shapes; ValueError if not."""
    sizes: dict[str, int] = {}
    for name, dims in _LAYOUT.items():
        obj = f.get(name)
        if not isinstance(obj, h5py.Dataset):
            raise ValueError(f"{path}: dataset {name!r} is missing")
        if len(obj.shape) != len(dims):
            raise ValueError(f"{path}: dataset {name!r} has shape {obj.shape}")
        for dim, size in zip(dims, obj.shape, strict=True):
            if isinstance(dim, int):
                ok = size == dim
            else:
                ok = sizes.setdefault(dim, size) == size
            if not ok:
                raise ValueError(f"{path}: dataset {name!r} has inconsistent shape {obj.shape}")
    obs = f.get("observables")
    if obs is not None:  # optional (files before it, and files of `crumple run`, lack it)
        want = (sizes["R"], sizes["S"])
        for name, obj in obs.items():
            if not isinstance(obj, h5py.Dataset) or obj.shape != want:
                raise ValueError(f"{path}: observables/{name} is not an array of shape {want}")


def verify_ramps(path, *, run_id: str | None = None, read_data: bool = False) -> dict:
    """Check that ``path`` is a complete crumple ramp file before trusting it.

    A file fails when it cannot be opened as HDF5 (truncated, garbage), is not a
    ``crumple-ramps`` file, lacks the ``complete`` marker written last by :func:`save_ramps`,
    lacks a dataset or has inconsistent shapes, holds another run than ``run_id``, or (with
    ``read_data``) has a dataset that cannot be read back.

    Returns
    -------
    dict
        The root attributes, JSON-decoded.

    Raises
    ------
    ValueError
        Naming the file and what is wrong with it.
    """
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ValueError(f"{path} is not a readable HDF5 file ({exc})") from None
    try:
        with f:
            attrs = _decode_attrs(f.attrs)
            if attrs.get("format") != FORMAT:
                raise ValueError(f"{path} is not a crumple ramp file")
            complete = attrs.get("complete")
            if not (isinstance(complete, bool | np.bool_) and complete):
                raise ValueError(f"{path} is incomplete (no 'complete' marker)")
            if run_id is not None and attrs.get("run_id") != run_id:
                raise ValueError(f"{path} holds run {attrs.get('run_id')!r}, not {run_id!r}")
            _check_layout(f, path)
            if read_data:
                for name in _LAYOUT:
                    f[name][()]
    except (OSError, KeyError, RuntimeError) as exc:  # h5py's errors on damaged contents
        raise ValueError(f"{path} is damaged ({exc})") from None
    return attrs


def read_arrays(path, *, positions: bool = False, run_id: str | None = None) -> dict:
    """The arrays of a verified ramp file, as a dict of NumPy arrays, without building objects.

    Keys: ``lambda`` (S,), ``n_stages``, ``seconds`` (R,), ``energy/<term>`` and
    ``solver/<field>`` (R, S) (``solver/message`` as str; ``energy/wall`` only for a wire with a
    cavity), ``observables/<name>`` (R, S) for
    each per-stage observable the file holds, ``positions`` (R, S, n, 2) when asked for, and
    ``attrs`` (the root attributes, JSON-decoded), and ``rest_angles`` (R, n - 2) for an
    imperfect wire's file (NaN rows: replicas without). Raises ``ValueError`` for a
    file :func:`verify_ramps` rejects or whose data cannot be read: never returns partial data.
    """
    attrs = verify_ramps(path, run_id=run_id)
    out: dict = {"attrs": attrs}
    try:
        with h5py.File(path, "r") as f:
            for name in _LAYOUT:
                if name == "positions" and not positions:
                    continue
                ds = f[name]
                out[name] = ds.asstr()[()] if name == "solver/message" else ds[()]
            for name, ds in f.get("observables", {}).items():
                out[f"observables/{name}"] = ds[()]
            if "wall" in f["energy"]:  # only a wire with a cavity has a wall term
                out["energy/wall"] = f["energy"]["wall"][()]
            if "rest_angles" in f:
                out["rest_angles"] = f["rest_angles"][()]
    except (OSError, KeyError, RuntimeError) as exc:
        raise ValueError(f"{path} is damaged ({exc})") from None
    return out


def read_attrs(path) -> dict:
    """The root attributes of a results file, JSON-decoded where they are JSON."""
    with h5py.File(path, "r") as f:
        return _decode_attrs(f.attrs)


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
        ramp = json.loads(f.attrs["ramp"])
        ramp.setdefault("curved_steps", False)  # a file from before the switch: straight steps
        ramp.setdefault("fallback", "projected")  # from before the choice: always projected
        ramp = Ramp.from_dict(ramp)
        lams = f["lambda"][()]
        pos = f["positions"][()]
        initial = f["initial"][()]
        n_stages = f["n_stages"][()]
        seconds = f["seconds"][()]
        energy = {t: f["energy"][t][()] for t in _TERMS}
        if "wall" in f["energy"]:
            energy["wall"] = f["energy"]["wall"][()]
        solver = f["solver"]
        conv = solver["converged"][()]
        fmax = solver["max_force"][()]
        counts = {c: solver[c][()] for c in _COUNTS}
        msgs = solver["message"].asstr()[()]
        rest = f["rest_angles"][()] if "rest_angles" in f else None
    out = []
    for r in range(pos.shape[0]):
        stages = []
        for s in range(int(n_stages[r])):
            terms = EnergyTerms(
                *(float(energy[t][r, s]) for t in _TERMS[:4]),
                wall=float(energy["wall"][r, s]) if "wall" in energy else 0.0,
            )
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
        extra = {}
        if rest is not None and "rest_angles" in RampResult.__dataclass_fields__:
            extra["rest_angles"] = None if np.isnan(rest[r]).all() else rest[r]
        out.append(
            RampResult(
                wire=wire,
                ramp=ramp,
                initial=initial[r],
                stages=tuple(stages),
                seconds=float(seconds[r]),
                **extra,
            )
        )
    return out
