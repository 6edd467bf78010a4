"""The content-addressed store of a sweep: run ids, run files, status, lock, failure records.

A run's id (:func:`run_id`) is the SHA-256 of its canonical parameters (``1`` and ``1.0`` are
the same run), so a store is a directory of files named by what they hold. Layout (``OUT``)::

    OUT/sweep.json            the sweep, its dimensions and its runs (JSON, readable anywhere)
    OUT/runs/<id>.h5          one finished run (crumple.storage format, one replica)
    OUT/runs/<id>.failed.json a run that raised: error, message, traceback, parameters
    OUT/.lock                 held while a sweep writes to the store

Every file is written atomically (:func:`crumple.storage.atomic_write_text`, ``save_ramps``):
an interrupted sweep leaves whole files or none. :func:`sweep_status` classifies each run as
done, failed, damaged or missing; :func:`crumple.sweep.run_sweep` recomputes all but the first.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import functools
import hashlib
import json
import os
import socket
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model import Wire
from ..protocol import Ramp, replica_seeds, run_ramp
from ..relax import resolve_fallback
from ..storage import atomic_write_text, verify_ramps, versions

if TYPE_CHECKING:  # the manifest describes a Sweep; spec imports this module
    from .spec import Sweep

MANIFEST = "sweep.json"
MANIFEST_FORMAT = "crumple-sweep"
MANIFEST_VERSION = 1
#: Version tag hashed into every run id; change it only to orphan every stored run on purpose.
RUN_ID_SCHEMA = "crumple-run-1"
#: Integer-valued parameters (everything else numeric is canonicalised to float).
_INT_KEYS = frozenset({"n_segments", "maxiter", "replica", "seed", "n"})


# --------------------------------------------------------------------------------------------
# Canonical parameters and run ids
# --------------------------------------------------------------------------------------------


def _canonical(value, key: str | None = None):
    """Numbers to float (integer-valued keys to int), -0.0 to 0.0, tuples to lists, recursively."""
    if isinstance(value, Mapping):
        return {str(k): _canonical(v, str(k)) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_canonical(v) for v in value]
    if isinstance(value, bool | np.bool_) or value is None or isinstance(value, str):
        return bool(value) if isinstance(value, np.bool_) else value
    if isinstance(value, int | float | np.integer | np.floating):
        if key in _INT_KEYS:
            if value != int(value):
                raise ValueError(f"{key} must be an integer, got {value!r}")
            return int(value)
        v = float(value)
        return 0.0 if v == 0.0 else v
    return value


def canonical_json(obj) -> str:
    """Canonical JSON: sorted keys, no spaces, numbers canonicalised (``1`` and ``1.0`` alike).

    >>> canonical_json({"k_b": 1, "n_segments": 20.0, "x": [-0.0, 2]})
    '{"k_b":1.0,"n_segments":20,"x":[0.0,2.0]}'
    """
    return json.dumps(_canonical(obj), sort_keys=True, separators=(",", ":"), allow_nan=False)


def run_id(wire: Wire, ramp: Ramp, replica: int, seed: int) -> str:
    """The content address of one run: 16 hex digits of the SHA-256 of its canonical JSON.

    The hash covers every parameter of the wire and of the ramp (as :meth:`Wire.to_dict` and
    :meth:`Ramp.to_dict` give them, less those of :data:`ID_NEUTRAL` at their neutral value),
    the replica index, the base seed and :data:`RUN_ID_SCHEMA`. It does not cover the number
    of replicas: replica ``r`` is the same run in a sweep of 3 or of 30 replicas.

    >>> from crumple.protocol import Ramp
    >>> a = run_id(Wire(k_b=5, k_s=5e5, n_segments=20), Ramp(lambdas=(1, 10)), 0, 0)
    >>> b = run_id(Wire(k_b=5.0, k_s=500000, n_segments=20), Ramp(lambdas=(1.0, 10.0)), 0, 0)
    >>> a == b, len(a)
    (True, 16)
    """
    cw, cr = _canonical_params(wire, ramp)
    # an injection's id names its protocol; a ramp's keeps the document it always had
    table = "injection" if _is_injection(ramp) else "ramp"
    doc = {
        "schema": RUN_ID_SCHEMA,
        "wire": cw,
        table: cr,
        "replica": int(replica),
        "seed": int(seed),
    }
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


#: Parameters added to Wire or Ramp after run ids were first stored, with the value that
#: reproduces the runs made before they existed bit for bit (same random draws, same floats).
#: At that value they are left out of the id, so that adding a parameter does not orphan the
#: stored results. Enter a parameter here only if that is exactly true; otherwise let the ids
#: change (the pinned ids in tests/test_sweep.py then fail, on purpose).
ID_NEUTRAL = MappingProxyType(
    {
        "wire": {"rest_angle_sd": 0.0, "cavity_radius": None},
        # "auto" enters the id as what it resolves to for the wire (_canonical_params)
        "ramp": {"powell_rtol": None, "curved_steps": False, "fallback": "projected", "coarsen": 1},
    }
)


def _is_injection(protocol) -> bool:
    return type(protocol).__name__ == "Injection"


@functools.lru_cache(maxsize=1024)
def _canonical_params(wire: Wire, ramp: Ramp) -> tuple[dict, dict]:
    # cached: the replicas of a point share their wire and ramp (read-only results)
    out = []
    rd = ramp.to_dict()
    if rd.get("fallback") == "auto" and rd.get("method") == "newton":
        rd["fallback"] = resolve_fallback("auto", wire)  # the path the run takes
    elif rd.get("fallback") == "auto":  # Powell has no fallback
        del rd["fallback"]
    for table, params in (("wire", wire.to_dict()), ("ramp", rd)):
        neutral = ID_NEUTRAL[table] if not _is_injection(ramp) or table == "wire" else {}
        out.append(_canonical({k: v for k, v in params.items()
                               if not (k in neutral and v == neutral[k])}))  # fmt: skip
    return out[0], out[1]


@dataclass(frozen=True, slots=True, kw_only=True)
class Run:
    """One run of a sweep: a wire, a protocol, a replica index and the sweep's base seed.

    ``ramp`` is the protocol: a :class:`~crumple.protocol.Ramp` or an
    :class:`~crumple.injection.Injection` (``[protocol] kind = "injection"``).

    ``coords`` are the values of the swept parameters at this run's point, as
    ``((name, value), ...)``; ``index`` its position on the sweep's dimensions.
    """

    wire: Wire
    ramp: Ramp | Any
    replica: int
    seed: int
    coords: tuple[tuple[str, Any], ...] = ()
    index: tuple[int, ...] = ()
    _id: str = field(default="", init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "_id", run_id(self.wire, self.ramp, self.replica, self.seed))

    @property
    def id(self) -> str:
        """:func:`run_id` of this run."""
        return self._id

    def rng(self) -> np.random.Generator:
        """The run's random generator: ``replica_seeds(seed, n)[replica]`` for any n > replica."""
        return np.random.default_rng(replica_seeds(self.seed, self.replica + 1)[self.replica])

    @property
    def protocol(self) -> str:
        """``"ramp"`` or ``"injection"``."""
        return "injection" if _is_injection(self.ramp) else "ramp"

    @property
    def stages(self) -> tuple[float, ...]:
        """The planned stage coordinates: λ of a ramp, L_in of an injection."""
        if self.protocol == "ramp":
            return self.ramp.lambdas
        from ..injection_storage import planned_lengths

        return tuple(planned_lengths(self.wire, self.ramp).tolist())

    def compute(self, progress=None):
        """Run the protocol (:func:`crumple.protocol.run_ramp` or
        :func:`crumple.injection.run_injection`) and return its result.
        ``progress(i, n_stages, stage)`` after every stage, as :func:`run_ramp`'s."""
        if self.protocol == "injection":
            from ..injection import run_injection

            return run_injection(self.wire, self.ramp, seed=self.rng(), progress=progress)
        return run_ramp(self.wire, self.ramp, seed=self.rng(), progress=progress)

    def to_task(self) -> dict:
        """Plain data for a worker (no pickled objects cross the wire)."""
        return {
            "id": self.id,
            "wire": self.wire.to_dict(),
            self.protocol: self.ramp.to_dict(),
            "replica": self.replica,
            "seed": self.seed,
            "coords": dict(self.coords),
        }

    @classmethod
    def from_task(cls, task: Mapping) -> Run:
        return cls(
            wire=Wire.from_dict(task["wire"]),
            ramp=Ramp.from_dict(task["ramp"]) if "ramp" in task else _injection(task),
            replica=int(task["replica"]),
            seed=int(task["seed"]),
            coords=tuple(task.get("coords", {}).items()),
        )


def _injection(task: Mapping):
    from ..injection import Injection

    return Injection.from_dict(task["injection"])


# --------------------------------------------------------------------------------------------
# The store
# --------------------------------------------------------------------------------------------


def _runs_dir(out: Path) -> Path:
    return out / "runs"


def _h5(out: Path, rid: str) -> Path:
    return _runs_dir(out) / f"{rid}.h5"


def _failed(out: Path, rid: str) -> Path:
    return _runs_dir(out) / f"{rid}.failed.json"


def _manifest(sweep: Sweep) -> dict:
    plan = sweep._plan
    dims = [{"name": n, "values": list(v)} for n, v in sweep.dims.items()]
    if plan.point_names and len(plan.point_names) > 1:
        dims[-1] = {
            "name": "point",
            "levels": list(plan.point_names),
            "values": [list(v) for v in plan.point_labels],
        }
    return {
        "format": MANIFEST_FORMAT,
        "format_version": MANIFEST_VERSION,
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "versions": versions(),
        "sweep": sweep.to_dict(),
        "replicas": sweep.replicas,
        "dims": dims,
        "lambdas": list(sweep.lambdas),
        "protocol": sweep.kind,
        "runs": [{"id": r.id, "replica": r.replica, "index": list(r.index)} for r in sweep.runs()],
    }


def _read_manifest(out: Path, *, for_load: bool = False) -> dict:
    """The manifest of a store, checked (:func:`_check_manifest`); ``for_load``: also the keys
    that only ``load`` needs (``dims``, ``lambdas``, ``replicas``, ``sweep``, each run's
    ``index``), which ``status`` can do without."""
    path = Path(out) / MANIFEST
    if not path.is_file():
        raise ValueError(f"{out} is not a sweep store (no {MANIFEST})")
    try:
        m = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path} is not valid JSON ({exc})") from None
    if not isinstance(m, dict) or m.get("format") != MANIFEST_FORMAT:
        raise ValueError(f"{path} is not a crumple sweep manifest")
    version = m.get("format_version", 0)
    if not isinstance(version, int) or version > MANIFEST_VERSION:
        raise ValueError(f"{path} has format version {version!r}; upgrade crumple")
    _check_manifest(path, m, for_load=for_load)
    return m


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _check_manifest(path: Path, m: dict, *, for_load: bool = False) -> None:
    """The keys that status and load read, with their types and ranges: a hand-edited or
    truncated manifest is a one-line ValueError here, never a KeyError, TypeError or
    IndexError later. Keys only ``load`` reads are checked where present, and required with
    ``for_load``."""

    def bad(what: str) -> ValueError:
        return ValueError(f"{path} is damaged: {what}")

    runs = m.get("runs")
    if not isinstance(runs, list):
        raise bad("'runs' is missing or not a list")
    if for_load:
        for key in ("dims", "lambdas", "replicas", "sweep"):
            if key not in m:
                raise bad(f"{key!r} is missing")
    for key, kind in (("dims", list), ("lambdas", list), ("sweep", dict)):
        if key in m and not isinstance(m[key], kind):
            raise bad(f"{key!r} is not a {kind.__name__}")
    if "replicas" in m and not (_is_int(m["replicas"]) and m["replicas"] >= 1):
        raise bad(f"'replicas' is not a whole number >= 1 ({m['replicas']!r})")
    lams = m.get("lambdas", [])
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in lams) or not (
        np.isfinite(np.asarray(lams, dtype=float)).all()
    ):
        raise bad("'lambdas' holds something other than finite numbers")
    if np.any(np.diff(np.asarray(lams, dtype=float)) <= 0):
        raise bad("'lambdas' is not increasing")
    sizes = [_check_dim(bad, i, d) for i, d in enumerate(m.get("dims", []))]
    for i, r in enumerate(runs):
        if not isinstance(r, dict) or not isinstance(r.get("id"), str):
            raise bad(f"runs[{i}] has no 'id'")
        rep = r.get("replica", 0)
        if not _is_int(rep) or not 0 <= rep < m.get("replicas", rep + 1):
            raise bad(f"runs[{i}] has a 'replica' that is not an index of the replicas ({rep!r})")
        if "index" in r or (for_load and "dims" in m):
            idx = r.get("index")
            if not (
                isinstance(idx, list)
                and len(idx) == len(sizes)
                and all(_is_int(k) and 0 <= k < n for k, n in zip(idx, sizes, strict=False))
            ):
                raise bad(f"runs[{i}] has an 'index' that is not a point of 'dims' ({idx!r})")


def _check_dim(bad, i: int, d) -> int:
    """One entry of ``dims``: ``{"name": str, "values": list[, "levels": list]}``; its size."""
    if not isinstance(d, dict) or not isinstance(d.get("name"), str):
        raise bad(f"dims[{i}] has no 'name'")
    values = d.get("values")
    if not isinstance(values, list) or not values:
        raise bad(f"dims[{i}] ({d['name']}) has no list of 'values'")
    if "levels" in d:
        levels = d["levels"]
        if not isinstance(levels, list) or not all(
            isinstance(v, list) and len(v) == len(levels) for v in values
        ):
            raise bad(f"dims[{i}] ({d['name']}): 'values' do not match its 'levels'")
    return len(values)


def _failure(path: Path) -> dict:
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
        return d if isinstance(d, dict) else {"message": str(d)}
    except (OSError, ValueError) as exc:
        return {"message": f"(unreadable failure record: {exc})"}


def _format(h5: Path) -> str | None:
    """The ``format`` attribute of a results file (None where it cannot be read)."""
    import h5py

    try:
        with h5py.File(h5, "r") as f:
            v = f.attrs.get("format")
            return v.decode() if isinstance(v, bytes) else v
    except OSError:
        return None


def _classify(out: Path, rid: str) -> tuple[str, str]:
    """("done" | "failed" | "corrupt" | "missing", detail) of one run in a store."""
    h5 = _h5(out, rid)
    if h5.exists():
        try:
            if _format(h5) == "crumple-injections":
                from ..injection_storage import verify_injections

                verify_injections(h5, run_id=rid)
            else:
                verify_ramps(h5, run_id=rid)
            return "done", ""
        except ValueError as exc:
            return "corrupt", str(exc)
    failed = _failed(out, rid)
    if failed.exists():
        return "failed", _failure(failed).get("message", "")
    return "missing", ""


@dataclass(frozen=True, slots=True)
class SweepStatus:
    """What a store holds for its sweep: run ids by state, with messages.

    ``failed`` and ``corrupt`` map run ids to the error message and to what is wrong with
    the file; ``stray`` counts run files that belong to no run of the current sweep (left by
    an earlier sweep written to the same store; harmless, and reused if asked for again).
    """

    path: Path
    total: int
    done: tuple[str, ...]
    failed: Mapping[str, str]
    corrupt: Mapping[str, str]
    missing: tuple[str, ...]
    stray: int

    @property
    def complete(self) -> bool:
        return len(self.done) == self.total

    def to_dict(self) -> dict:
        return {
            "store": str(self.path),
            "runs": self.total,
            "done": len(self.done),
            "failed": len(self.failed),
            "corrupt": len(self.corrupt),
            "missing": len(self.missing),
            "stray_files": self.stray,
            "failed_runs": [{"id": k, "message": v} for k, v in self.failed.items()],
            "corrupt_runs": [{"id": k, "problem": v} for k, v in self.corrupt.items()],
        }


def sweep_status(path) -> SweepStatus:
    """Done, failed, damaged and missing runs of the store at ``path`` (see :func:`run_sweep`)."""
    out = Path(path)
    manifest = _read_manifest(out)
    ids = [r["id"] for r in manifest["runs"]]
    groups: dict[str, dict[str, str]] = {"done": {}, "failed": {}, "corrupt": {}, "missing": {}}
    for rid in ids:
        state, detail = _classify(out, rid)
        groups[state][rid] = detail
    known = set(ids)
    stray = sum(1 for p in _runs_dir(out).glob("*.h5") if p.stem not in known)
    return SweepStatus(
        path=out,
        total=len(ids),
        done=tuple(groups["done"]),
        failed=MappingProxyType(groups["failed"]),
        corrupt=MappingProxyType(groups["corrupt"]),
        missing=tuple(groups["missing"]),
        stray=stray,
    )


@contextlib.contextmanager
def _store_lock(out: Path) -> Iterator[None]:
    """An exclusive lock on the store for the life of this process's sweep (released on crash)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock
        yield
        return
    fh = (out / ".lock").open("a")
    try:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise ValueError(
                f"another crumple sweep is writing to {out}; wait for it or use another --out"
            ) from None
        yield
    finally:
        fh.close()


# --------------------------------------------------------------------------------------------
# Failure records
# --------------------------------------------------------------------------------------------


def _record_failure(out: Path, task: Mapping, error: str, message: str, tb: str) -> None:
    record = {
        "id": task["id"],
        "error": error,
        "message": message,
        "traceback": tb,
        "host": socket.gethostname(),
        "pid": os.getpid(),
        "time": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "replica": task["replica"],
        "seed": task["seed"],
        "coords": task.get("coords", {}),
        "wire": task["wire"],
        "ramp": task.get("ramp", task.get("injection")),
        "versions": versions(),
    }
    atomic_write_text(_failed(out, task["id"]), json.dumps(record, indent=2, default=str))
