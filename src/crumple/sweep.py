"""Parameter sweeps: grids or lists of parameter points × replicas, run on Dask, stored per run.

A **sweep** (:class:`Sweep`, or a TOML file, see ``docs/sweeps.md``) is a set of parameter
points (a cartesian grid over any model, protocol and minimiser parameter, and/or an explicit
list of points) times a number of replicas, with one base seed. A **run** (:class:`Run`) is
one point and one replica: one confinement ramp (:func:`crumple.protocol.run_ramp`).

* Runs are **content-addressed**: :func:`run_id` hashes the canonical parameters of the wire
  and the ramp, the replica index and the base seed (``1`` and ``1.0`` are the same run).
* Replica ``r`` of a point draws its randomness from
  ``replica_seeds(seed, n_replicas)[r]`` (:func:`crumple.protocol.replica_seeds`), whose spawn
  key is ``(r,)`` whatever ``n_replicas``: a sweep's replica equals
  ``run_replicas(wire, ramp, n_replicas=..., seed=seed)[r]`` bit for bit, raising the number
  of replicas keeps the runs already done, and the stored positions do not depend on the
  number of workers or on the order in which runs finish.
* :func:`run_sweep` executes the runs that are not yet done on a ``dask.distributed``
  cluster (a ``LocalCluster`` by default). Each task writes its own file, atomically, so an
  interruption loses at most the runs in flight; rerunning computes only what is missing,
  failed or damaged.
* :func:`load` reads a store into an :class:`xarray.Dataset`; :func:`sweep_status` says what
  is done, failed and missing.

Store layout (``OUT``)::

    OUT/sweep.json            the sweep, its dimensions and its runs (JSON, readable anywhere)
    OUT/runs/<id>.h5          one finished run (crumple.storage format, one replica)
    OUT/runs/<id>.failed.json a run that raised: error, message, traceback, parameters
    OUT/.lock                 held while a sweep writes to the store
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import difflib
import functools
import hashlib
import itertools
import json
import math
import os
import socket
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from .model import Plasticity, Wire
from .protocol import Ramp, default_schedule, replica_seeds, run_ramp
from .storage import atomic_write_text, read_arrays, save_ramps, verify_ramps, versions

__all__ = [
    "ID_NEUTRAL",
    "IncompleteSweepWarning",
    "Progress",
    "Run",
    "Sweep",
    "SweepReport",
    "SweepStatus",
    "canonical_json",
    "connect",
    "execute_run",
    "load",
    "run_id",
    "run_sweep",
    "sweep_status",
]

MANIFEST = "sweep.json"
MANIFEST_FORMAT = "crumple-sweep"
MANIFEST_VERSION = 1
#: Version tag hashed into every run id; change it only to orphan every stored run on purpose.
RUN_ID_SCHEMA = "crumple-run-1"

_FACTORY_KEYS = ("young", "radius", "bending", "stretching")
_WIRE_KEYS = (*Wire.__dataclass_fields__, *_FACTORY_KEYS)
_RAMP_KEYS = (*Ramp.__dataclass_fields__, "schedule")
#: Parameters given as a table; their entries are swept one by one.
_TABLES = {"plasticity": ("s", "theta_p"), "schedule": ("lam_min", "lam_max", "n")}
#: Parameters whose value is itself a list: a list of lists sweeps over them.
_LIST_VALUED = ("lambdas", "trap_center")
#: Integer-valued parameters (everything else numeric is canonicalised to float).
_INT_KEYS = frozenset({"n_segments", "maxiter", "replica", "seed", "n"})
#: Coordinate names of table entries (the paper's symbols where it has one).
_COORD = {
    ("plasticity", "s"): "s",
    ("plasticity", "theta_p"): "theta_p",
    ("schedule", "lam_min"): "lam_min",
    ("schedule", "lam_max"): "lam_max",
    ("schedule", "n"): "schedule_n",
}
_TERMS = ("bending", "stretching", "confinement", "hard_core", "total")
_COUNTS = ("iterations", "evaluations", "hessian_evaluations")


class IncompleteSweepWarning(UserWarning):
    """:func:`load` found runs that are missing, failed or damaged (their values are NaN)."""


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
    doc = {
        "schema": RUN_ID_SCHEMA,
        "wire": cw,
        "ramp": cr,
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
ID_NEUTRAL = MappingProxyType({"wire": {"rest_angle_sd": 0.0}, "ramp": {}})


@functools.lru_cache(maxsize=1024)
def _canonical_params(wire: Wire, ramp: Ramp) -> tuple[dict, dict]:
    # cached: the replicas of a point share their wire and ramp (read-only results)
    out = []
    for table, params in (("wire", wire.to_dict()), ("ramp", ramp.to_dict())):
        neutral = ID_NEUTRAL[table]
        out.append(_canonical({k: v for k, v in params.items()
                               if not (k in neutral and v == neutral[k])}))  # fmt: skip
    return out[0], out[1]


@dataclass(frozen=True, slots=True, kw_only=True)
class Run:
    """One run of a sweep: a wire, a ramp, a replica index and the sweep's base seed.

    ``coords`` are the values of the swept parameters at this run's point, as
    ``((name, value), ...)``; ``index`` its position on the sweep's dimensions.
    """

    wire: Wire
    ramp: Ramp
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

    def compute(self):
        """Run the ramp (:func:`crumple.protocol.run_ramp`) and return its ``RampResult``."""
        return run_ramp(self.wire, self.ramp, seed=self.rng())

    def to_task(self) -> dict:
        """Plain data for a worker (no pickled objects cross the wire)."""
        return {
            "id": self.id,
            "wire": self.wire.to_dict(),
            "ramp": self.ramp.to_dict(),
            "replica": self.replica,
            "seed": self.seed,
            "coords": dict(self.coords),
        }

    @classmethod
    def from_task(cls, task: Mapping) -> Run:
        return cls(
            wire=Wire.from_dict(task["wire"]),
            ramp=Ramp.from_dict(task["ramp"]),
            replica=int(task["replica"]),
            seed=int(task["seed"]),
            coords=tuple(task.get("coords", {}).items()),
        )


# --------------------------------------------------------------------------------------------
# The sweep description
# --------------------------------------------------------------------------------------------


def _freeze(value):
    if isinstance(value, Mapping):
        return MappingProxyType({str(k): _freeze(v) for k, v in value.items()})
    if isinstance(value, np.ndarray):
        return tuple(_freeze(v) for v in value.tolist())
    if isinstance(value, list | tuple):
        return tuple(_freeze(v) for v in value)
    if isinstance(value, np.generic):
        return value.item()
    return value


def _thaw(value):
    if isinstance(value, Mapping):
        return {k: _thaw(v) for k, v in value.items()}
    if isinstance(value, tuple | list):
        return [_thaw(v) for v in value]
    return value


def _is_seq(value) -> bool:
    return isinstance(value, list | tuple)


def _is_sweep(key: str, value) -> bool:
    """A list sweeps, except for list-valued parameters, where a list of lists sweeps."""
    if not _is_seq(value):
        return False
    if key in _LIST_VALUED:
        return len(value) > 0 and all(_is_seq(v) for v in value)
    return True


def _label(value, key: str | None = None):
    """A coordinate label: a number (int for integer parameters), a string, or list JSON."""
    v = _canonical(value, key)
    return json.dumps(v) if isinstance(v, list | dict) else v


def _fmt(value) -> str:
    return json.dumps(_thaw(value)) if isinstance(value, Mapping | tuple | list) else repr(value)


def _suggest(key: str, known: Sequence[str]) -> str:
    close = difflib.get_close_matches(key, known, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _check_key(where: str, key: str, known: Sequence[str]) -> None:
    if key not in known:
        raise ValueError(
            f"{where} unknown key {key!r}{_suggest(key, known)}; known: {', '.join(known)}"
        )


@dataclass(frozen=True, slots=True)
class _Dim:
    name: str
    path: tuple[str, ...]  # ("wire", "k_b") or ("wire", "plasticity", "s")
    values: tuple  # raw values, as given
    labels: tuple  # canonical coordinate labels


@dataclass(frozen=True, slots=True)
class _Plan:
    dims: tuple[_Dim, ...]
    point_names: tuple[str, ...]
    point_labels: tuple[tuple, ...]
    runs: tuple[Run, ...]
    lambdas: tuple[float, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class Sweep:
    """A parameter sweep: a grid and/or a list of points, times replicas, from one seed.

    Parameters
    ----------
    wire : mapping
        Parameters of :class:`crumple.model.Wire` (``k_b``, ``k_s``, ``n_segments``,
        ``length``, ``confinement``, ``hard_core``, ``hard_core_energy``, ``trap_center``,
        ``plasticity = {s, theta_p}``), or a material (``young``, ``radius``) or continuum
        stiffnesses (``bending``, ``stretching``) instead of ``k_b``, ``k_s``. Default
        ``k_b = 5``, ``k_s = 5e5`` as ``crumple run``.
    ramp : mapping
        Parameters of :class:`crumple.protocol.Ramp` (``lambdas``, ``initial_noise``,
        ``stage_noise``, ``stop_tol``, ``method``, ``ftol``, ``maxiter``, ``max_step``), or
        ``schedule = {lam_min, lam_max, n}`` for :func:`crumple.protocol.default_schedule`.
    points : sequence of mappings
        Explicit parameter points (wire and ramp keys mixed; each point sets the same keys),
        combined with the grid. Empty: the grid alone.
    replicas : int
        Replicas per point (>= 1).
    seed : int
        Base seed (>= 0); replica r uses ``replica_seeds(seed, replicas)[r]``.

    Any value in ``wire`` or ``ramp`` (or in their ``plasticity`` and ``schedule`` tables)
    may be a list: the sweep is the cartesian product of those lists. ``lambdas`` and
    ``trap_center`` are lists already: a list of lists sweeps over them.

    Examples
    --------
    >>> s = Sweep(wire={"k_b": [2, 5], "n_segments": 20, "plasticity": {"s": [0.2, 1],
    ...           "theta_p": 0.3}}, ramp={"lambdas": [1, 10, 100]}, replicas=3)
    >>> s.dims, len(s.runs())
    ({'k_b': (2.0, 5.0), 's': (0.2, 1.0)}, 12)
    >>> Sweep(wire={"k_b": [5, -1]})
    Traceback (most recent call last):
    ...
    ValueError: [wire] at k_b = -1.0: k_b must be a positive finite number, got -1.0
    >>> Sweep(wire={"kb": 5})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: [wire] unknown key 'kb' (did you mean 'k_b'?); known: ...
    """

    wire: Mapping[str, Any] = field(default_factory=dict)
    ramp: Mapping[str, Any] = field(default_factory=dict)
    points: tuple[Mapping[str, Any], ...] = ()
    replicas: int = 1
    seed: int = 0
    _plan: _Plan | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        for name in ("wire", "ramp"):
            value = getattr(self, name)
            if not isinstance(value, Mapping):
                raise ValueError(f"[{name}] must be a table (mapping), got {value!r}")
            object.__setattr__(self, name, _freeze(value))
        points = self.points
        if isinstance(points, Mapping) or not isinstance(points, Sequence):
            raise ValueError(f"points must be a list of tables, got {points!r}")
        for i, p in enumerate(points):
            if not isinstance(p, Mapping):
                raise ValueError(f"[[point]] {i + 1} must be a table, got {p!r}")
        object.__setattr__(self, "points", tuple(_freeze(p) for p in points))
        for name, low in (("replicas", 1), ("seed", 0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < low:
                raise ValueError(f"[sweep] {name} must be an integer >= {low}, got {v!r}")
            object.__setattr__(self, name, int(v))
        object.__setattr__(self, "_plan", self._make_plan())

    def __hash__(self):
        return hash(canonical_json(self.to_dict()))

    # ---- construction from files -------------------------------------------------------------

    @classmethod
    def from_dict(cls, d: Mapping) -> Sweep:
        """From the structure of a sweep file: ``sweep``, ``wire``, ``ramp`` and ``point``."""
        unknown = set(d) - {"sweep", "wire", "ramp", "point"}
        if unknown:
            key = sorted(unknown)[0]
            raise ValueError(
                f"unknown table [{key}]{_suggest(key, ['sweep', 'wire', 'ramp', 'point'])}; "
                "use [sweep], [wire], [ramp] and [[point]]"
            )
        head = d.get("sweep", {})
        if not isinstance(head, Mapping):
            raise ValueError(f"[sweep] must be a table, got {head!r}")
        for key in head:
            _check_key("[sweep]", key, ("replicas", "seed"))
        points = d.get("point", ())
        if isinstance(points, Mapping):
            raise ValueError("point must be an array of tables: write [[point]], not [point]")
        return cls(
            wire=d.get("wire", {}),
            ramp=d.get("ramp", {}),
            points=points,
            replicas=head.get("replicas", 1),
            seed=head.get("seed", 0),
        )

    @classmethod
    def from_toml(cls, path) -> Sweep:
        """Read a sweep file (``docs/sweeps.md``); errors name the file and the key."""
        import tomllib

        path = Path(path)
        try:
            with path.open("rb") as fh:
                d = tomllib.load(fh)
        except FileNotFoundError:
            raise ValueError(f"no such sweep file: {path}") from None
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: invalid TOML: {exc}") from None
        try:
            return cls.from_dict(d)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None

    def to_dict(self) -> dict:
        """The structure of a sweep file (JSON-able); ``Sweep.from_dict`` inverts it."""
        d: dict = {"sweep": {"replicas": self.replicas, "seed": self.seed}}
        d["wire"] = _thaw(self.wire)
        d["ramp"] = _thaw(self.ramp)
        if self.points:
            d["point"] = [_thaw(p) for p in self.points]
        return d

    # ---- expansion --------------------------------------------------------------------------

    def _make_plan(self) -> _Plan:
        dims: list[_Dim] = []
        base: dict[str, dict] = {"wire": {}, "ramp": {}}
        for table, spec, known in (
            ("wire", self.wire, _WIRE_KEYS),
            ("ramp", self.ramp, _RAMP_KEYS),
        ):
            for key, value in spec.items():
                _check_key(f"[{table}]", key, known)
                if key in _TABLES:
                    if _is_seq(value):
                        raise ValueError(
                            f"[{table}] {key} must be one table whose entries may be lists, "
                            f"got {_fmt(value)}; list several combinations as [[point]] tables"
                        )
                    if not isinstance(value, Mapping):
                        raise ValueError(f"[{table}] {key} must be a table, got {_fmt(value)}")
                    sub = {}
                    for sk, sv in value.items():
                        _check_key(f"[{table}] {key}:", sk, _TABLES[key])
                        if _is_sweep(sk, sv):
                            dims.append(self._dim(_COORD[key, sk], (table, key, sk), sv))
                        else:
                            sub[sk] = sv
                    base[table][key] = sub
                elif _is_sweep(key, value):
                    dims.append(self._dim(key, (table, key), value))
                else:
                    base[table][key] = value
        point_names, point_values = self._points(dims)
        names = [d.name for d in dims] + list(point_names)
        if len(set(names)) != len(names):
            dup = next(n for n in names if names.count(n) > 1)
            raise ValueError(f"{dup} is swept twice (in the grid and in [[point]]?)")

        runs: list[Run] = []
        lambdas: set[float] = set()
        seen: dict[str, str] = {}
        combos = itertools.product(*(range(len(d.values)) for d in dims))
        for combo in combos:
            for p in range(max(1, len(self.points))):
                spec = {
                    t: {k: dict(v) if isinstance(v, Mapping) else v for k, v in b.items()}
                    for t, b in base.items()
                }
                coords = []
                for d, i in zip(dims, combo, strict=True):
                    _assign(spec, d.path, d.values[i])
                    coords.append((d.name, d.labels[i]))
                if self.points:
                    for key, value in self.points[p].items():
                        table = "wire" if key in _WIRE_KEYS else "ramp"
                        if isinstance(value, Mapping):
                            spec[table][key] = {**spec[table].get(key, {}), **value}
                        else:
                            spec[table][key] = value
                    coords += zip(point_names, point_values[p], strict=True)
                where = ", ".join(f"{n} = {_fmt(v)}" for n, v in coords)
                wire, ramp = _build(spec, where)
                lambdas.update(ramp.lambdas)
                index = (*combo, p) if self.points else combo
                for r in range(self.replicas):
                    run = Run(
                        wire=wire,
                        ramp=ramp,
                        replica=r,
                        seed=self.seed,
                        coords=tuple(coords),
                        index=index,
                    )
                    if r == 0:
                        other = seen.setdefault(run.id, where)
                        if other != where:
                            raise ValueError(f"the points ({other}) and ({where}) are the same run")
                    runs.append(run)
        return _Plan(
            dims=tuple(dims),
            point_names=point_names,
            point_labels=tuple(point_values),
            runs=tuple(runs),
            lambdas=tuple(sorted(lambdas)),
        )

    @staticmethod
    def _dim(name: str, path: tuple[str, ...], values) -> _Dim:
        where = f"[{path[0]}] {' '.join(path[1:])}"
        if not values:
            raise ValueError(f"{where} = []: an empty list sweeps over nothing")
        labels = []
        for v in values:
            if isinstance(v, Mapping):
                raise ValueError(f"{where}: a swept value cannot be a table, got {_fmt(v)}")
            try:
                lab = _label(v, path[-1])
            except ValueError as exc:
                raise ValueError(f"{where} = {_fmt(v)}: {exc}") from None
            if lab in labels:
                raise ValueError(f"{where} lists the value {_fmt(v)} twice")
            labels.append(lab)
        return _Dim(name=name, path=path, values=tuple(values), labels=tuple(labels))

    def _points(self, dims) -> tuple[tuple[str, ...], list[tuple]]:
        if not self.points:
            return (), []
        swept = {d.path[1] if len(d.path) == 2 else d.path[1:] for d in dims}
        names_of_first: tuple[str, ...] | None = None
        values = []
        for i, point in enumerate(self.points):
            where = f"[[point]] {i + 1}"
            if not point:
                raise ValueError(f"{where} is empty")
            names, labels = [], []
            for key, value in point.items():
                _check_key(f"{where}:", key, _WIRE_KEYS + _RAMP_KEYS)
                if key in _TABLES:
                    if not isinstance(value, Mapping):
                        raise ValueError(f"{where}: {key} must be a table, got {_fmt(value)}")
                    for sk, sv in value.items():
                        _check_key(f"{where}: {key}:", sk, _TABLES[key])
                        if (key, sk) in swept or key in swept:
                            raise ValueError(f"{where}: {key}.{sk} is also swept as a grid")
                        if _is_seq(sv):
                            raise ValueError(
                                f"{where}: {key}.{sk} = {_fmt(sv)}: a point takes one value"
                            )
                        names.append(_COORD[key, sk])
                        labels.append(_label(sv, sk))
                    continue
                if key in swept:
                    raise ValueError(f"{where}: {key} is also swept as a grid in its table")
                if _is_sweep(key, value):
                    raise ValueError(f"{where}: {key} = {_fmt(value)}: a point takes one value")
                names.append(key)
                labels.append(_label(value, key))
            if names_of_first is None:
                names_of_first = tuple(names)
            elif sorted(names) != sorted(names_of_first):
                raise ValueError(
                    f"{where} sets {', '.join(sorted(names))} but [[point]] 1 sets "
                    f"{', '.join(sorted(names_of_first))}: every point must set the same keys"
                )
            order = {n: j for j, n in enumerate(names)}
            values.append(tuple(labels[order[n]] for n in names_of_first))
        if len(set(values)) != len(values):
            dup = next(v for v in values if values.count(v) > 1)
            raise ValueError(
                f"[[point]] lists the point {dict(zip(names_of_first, dup, strict=True))} twice"
            )
        return names_of_first, values

    # ---- public views ------------------------------------------------------------------------

    @property
    def dims(self) -> dict[str, tuple]:
        """The swept parameters and their values (canonical labels), in order: the grid, then
        the points (one dimension named after the key when points set one key, else
        ``point``)."""
        plan = self._plan
        out = {d.name: d.labels for d in plan.dims}
        if plan.point_names:
            if len(plan.point_names) == 1:
                out[plan.point_names[0]] = tuple(v[0] for v in plan.point_labels)
            else:
                out["point"] = plan.point_labels
        return out

    @property
    def shape(self) -> tuple[int, ...]:
        """Number of values along each swept dimension, then replicas."""
        return (*(len(v) for v in self.dims.values()), self.replicas)

    @property
    def lambdas(self) -> tuple[float, ...]:
        """Every stage λ of every run, sorted (the ``lam`` coordinate of :func:`load`)."""
        return self._plan.lambdas

    def runs(self) -> tuple[Run, ...]:
        """Every run, point by point (the grid in C order, then the points), replicas inside."""
        return self._plan.runs

    def __len__(self) -> int:
        return len(self._plan.runs)


def _assign(spec: dict, path: tuple[str, ...], value) -> None:
    table, key, *sub = path
    if sub:
        spec[table].setdefault(key, {})[sub[0]] = value
    else:
        spec[table][key] = value


def _build(spec: dict, where: str) -> tuple[Wire, Ramp]:
    """Wire and Ramp of one parameter point, with errors naming the point."""
    at = f" at {where}" if where else ""
    try:
        w = _canonical(spec["wire"])
        if isinstance(w.get("plasticity"), dict):
            w["plasticity"] = Plasticity(**w["plasticity"])
        given = {
            "k_b and k_s": [k for k in ("k_b", "k_s") if k in w],
            "young and radius": [k for k in ("young", "radius") if k in w],
            "bending and stretching": [k for k in ("bending", "stretching") if k in w],
        }
        used = [kind for kind, keys in given.items() if keys]
        if len(used) > 1:
            keys = ", ".join(k for kind in used for k in given[kind])
            raise ValueError(
                "give k_b and k_s, young and radius, or bending and stretching, not a mix: "
                f"got {keys}"
            )
        if used and used[0] != "k_b and k_s" and len(given[used[0]]) < 2:
            raise ValueError(f"give both {used[0]}, got only {given[used[0]][0]}")
        if "young" in w:
            wire = Wire.from_material(**w)
        elif "bending" in w:
            wire = Wire.from_continuum(**w)
        else:
            w.setdefault("k_b", 5.0)
            w.setdefault("k_s", 5e5)
            wire = Wire(**w)
        wire = Wire.from_dict(_canonical(wire.to_dict()))
    except (ValueError, TypeError) as exc:
        raise ValueError(f"[wire]{at}: {exc}") from None
    try:
        r = _canonical(spec["ramp"])
        if "lambdas" in r and "schedule" in r:
            raise ValueError("give lambdas or schedule, not both")
        if "lambdas" not in r:
            r["lambdas"] = default_schedule(**r.pop("schedule", {}))
        ramp = Ramp.from_dict(_canonical(Ramp(**r).to_dict()))
    except (ValueError, TypeError) as exc:
        raise ValueError(f"[ramp]{at}: {exc}") from None
    return wire, ramp


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
        "runs": [{"id": r.id, "replica": r.replica, "index": list(r.index)} for r in sweep.runs()],
    }


def _read_manifest(out: Path) -> dict:
    path = Path(out) / MANIFEST
    if not path.is_file():
        raise ValueError(f"{out} is not a sweep store (no {MANIFEST})")
    try:
        m = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path} is not valid JSON ({exc})") from None
    if m.get("format") != MANIFEST_FORMAT:
        raise ValueError(f"{path} is not a crumple sweep manifest")
    if m.get("format_version", 0) > MANIFEST_VERSION:
        raise ValueError(f"{path} has format version {m['format_version']}; upgrade crumple")
    return m


def _failure(path: Path) -> dict:
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
        return d if isinstance(d, dict) else {"message": str(d)}
    except (OSError, ValueError) as exc:
        return {"message": f"(unreadable failure record: {exc})"}


def _classify(out: Path, rid: str) -> tuple[str, str]:
    """("done" | "failed" | "corrupt" | "missing", detail) of one run in a store."""
    h5 = _h5(out, rid)
    if h5.exists():
        try:
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
# Execution
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
        "ramp": task["ramp"],
        "versions": versions(),
    }
    atomic_write_text(_failed(out, task["id"]), json.dumps(record, indent=2, default=str))


@functools.cache
def _undo_dask_malloc_trim() -> bool:
    """Give glibc's allocator back its large thresholds in a Dask worker process.

    Dask's nanny starts workers with ``MALLOC_TRIM_THRESHOLD_=65536`` (to hand freed memory
    back to the OS). Setting it pins glibc's mmap threshold at 128 KiB, so every array above
    that (a dense Hessian at N >= 60) is mmapped and page-faulted afresh at each allocation:
    a default ramp at N = 100 ran 2.4x slower in a worker than in a plain process (1.4 s vs
    3.4 s, measured). The runs of a sweep are CPU-bound and small in memory, so the worker
    process gets the thresholds glibc's own dynamic scheme grows to (32 MiB for mmap). Once
    per process; a no-op elsewhere than Linux with glibc or without that variable.
    """
    if not os.environ.get("MALLOC_TRIM_THRESHOLD_") or not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL("libc.so.6")
        m_trim_threshold, m_mmap_threshold = -1, -3  # <malloc.h>
        return bool(libc.mallopt(m_mmap_threshold, 32 << 20)) and bool(
            libc.mallopt(m_trim_threshold, 64 << 20)
        )
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False


def execute_run(task: Mapping, out: str) -> dict:
    """Compute one run on a worker and write ``OUT/runs/<id>.h5`` (or ``<id>.failed.json``).

    Never raises for an error of the run itself: the error is recorded and ``{"status":
    "failed"}`` returned, so that the sweep goes on. Returns a small summary dict.
    """
    _undo_dask_malloc_trim()
    out_path = Path(out)
    rid = task["id"]
    t0 = time.perf_counter()
    try:
        run = Run.from_task(task)
        if run.id != rid:
            raise RuntimeError(f"run id mismatch: task {rid}, parameters hash to {run.id}")
        result = run.compute()
        save_ramps(
            _h5(out_path, rid),
            [result],
            seed=run.seed,
            attrs={
                "run_id": rid,
                "replica": run.replica,
                "coords": task.get("coords", {}),
                "host": socket.gethostname(),
            },
        )
    except Exception as exc:  # recorded, with its traceback, for `crumple status`
        _record_failure(
            out_path,
            task,
            type(exc).__name__,
            f"{type(exc).__name__}: {exc}",
            traceback.format_exc(),
        )
        return {
            "id": rid,
            "status": "failed",
            "message": f"{type(exc).__name__}: {exc}",
            "seconds": time.perf_counter() - t0,
        }
    _failed(out_path, rid).unlink(missing_ok=True)
    return {"id": rid, "status": "done", "seconds": result.seconds, "converged": result.converged}


@dataclass(frozen=True, slots=True)
class Progress:
    """State of a running sweep, for a progress display.

    ``done`` counts every finished run of the sweep (``skipped`` of them were already in the
    store); ``running`` the runs in flight (at most one per worker thread); ``eta`` seconds
    (None until a run has finished).
    """

    total: int
    done: int
    failed: int
    running: int
    skipped: int
    elapsed: float
    eta: float | None


@dataclass(frozen=True, slots=True)
class SweepReport:
    """Outcome of :func:`run_sweep`."""

    path: Path
    total: int
    skipped: int
    computed: tuple[str, ...]
    failed: Mapping[str, str]
    seconds: float
    workers: int

    @property
    def complete(self) -> bool:
        return not self.failed

    def to_dict(self) -> dict:
        return {
            "store": str(self.path),
            "runs": self.total,
            "already_done": self.skipped,
            "computed": len(self.computed),
            "failed": len(self.failed),
            "failed_runs": [{"id": k, "message": v} for k, v in self.failed.items()],
            "workers": self.workers,
            "seconds": round(self.seconds, 3),
        }


@contextlib.contextmanager
def _connect(client, scheduler, workers, n_todo, quiet_logs):
    if client is not None:
        yield client
        return
    from distributed import Client, LocalCluster

    if scheduler is not None:
        with Client(scheduler, timeout="20s") as c:
            yield c
        return
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    if int(workers) < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    import logging

    with _sigint_ignored():  # inherited by the worker processes spawned now
        cluster = LocalCluster(
            n_workers=max(1, min(int(workers), n_todo)),
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port: never collides with another cluster
            silence_logs=logging.ERROR if quiet_logs else logging.WARNING,
        )
    with cluster, Client(cluster) as c:
        yield c


def connect(
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    max_workers: int | None = None,
    quiet_logs: bool = True,
):
    """A Dask client to pass to several :func:`run_sweep` calls (one cluster for all).

    With ``scheduler``: a client of that scheduler. Otherwise a ``LocalCluster`` of
    ``workers`` single-threaded worker processes (default one per core, at most
    ``max_workers``), shut down when the ``with`` block ends::

        with connect(workers=2) as client:
            run_sweep(sweep_a, "a", client=client)
            run_sweep(sweep_b, "b", client=client)
    """
    if workers is not None and scheduler is not None:
        raise ValueError("workers starts a local cluster; with a scheduler it is unused")
    n = max_workers if max_workers is not None else 1 << 30
    return _connect(None, scheduler, workers, max(1, int(n)), quiet_logs)


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while local workers start: they inherit it (through spawn), so Ctrl-C
    stops the sweep in this process, which shuts them down, instead of printing a traceback
    from every worker. Restored on exit; a no-op outside the main thread."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def run_sweep(
    sweep: Sweep,
    out,
    *,
    client=None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[Progress], None] | None = None,
    refresh: float = 1.0,
    quiet_logs: bool = True,
) -> SweepReport:
    """Run every run of ``sweep`` that ``out`` does not hold yet, on Dask.

    Parameters
    ----------
    sweep : Sweep
    out : str or Path
        The store (created if needed). It must be on a file system that every worker sees
        under the same path: each task writes its own run file.
    client : distributed.Client, optional
        Run on this client's cluster (left open).
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:8786``) to connect to.
    workers : int, optional
        Without ``client`` or ``scheduler``: a ``LocalCluster`` of this many single-threaded
        worker processes (default: one per core, at most one per run to compute).
    progress : callable, optional
        ``progress(Progress)`` every ``refresh`` seconds and whenever runs finish.

    Returns
    -------
    SweepReport

    Notes
    -----
    Resuming: runs whose file is present and passes :func:`crumple.storage.verify_ramps` are
    skipped; failed runs, damaged files (deleted first) and missing runs are computed. A run
    that raises is recorded in ``runs/<id>.failed.json`` and the sweep goes on. A worker that
    dies has its run rescheduled by the scheduler (up to ``distributed.scheduler.allowed-
    failures`` times, 3 by default); after that the run is recorded as failed. Runs that do
    not converge are not failures: they are stored, with ``converged`` false at the stages
    concerned.
    """
    if not isinstance(sweep, Sweep):
        raise TypeError(f"sweep must be a Sweep, got {type(sweep).__name__}")
    if client is not None and scheduler is not None:
        raise ValueError("give a client or a scheduler address, not both")
    if workers is not None and (client is not None or scheduler is not None):
        raise ValueError("workers starts a local cluster; with a client or scheduler it is unused")
    out = Path(out).resolve()
    _runs_dir(out).mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with _store_lock(out):
        for tmp in _runs_dir(out).glob(".*.tmp"):  # left by a run killed while writing
            tmp.unlink(missing_ok=True)
        atomic_write_text(out / MANIFEST, json.dumps(_manifest(sweep), indent=1))
        todo = []
        for run in sweep.runs():
            state, _ = _classify(out, run.id)
            if state == "corrupt":
                _h5(out, run.id).unlink(missing_ok=True)
            if state != "done":
                todo.append(run)
        total, skipped = len(sweep), len(sweep) - len(todo)
        failed: dict[str, str] = {}
        computed: list[str] = []
        n_workers = 0
        if todo:
            with _connect(client, scheduler, workers, len(todo), quiet_logs) as c:
                n_workers = len(c.scheduler_info().get("workers", {}))
                computed, failed = _execute(c, todo, out, total, skipped, progress, refresh, t0)
        elif progress is not None:
            progress(Progress(total, total, 0, 0, skipped, time.perf_counter() - t0, 0.0))
    return SweepReport(
        path=out,
        total=total,
        skipped=skipped,
        computed=tuple(computed),
        failed=MappingProxyType(failed),
        seconds=time.perf_counter() - t0,
        workers=n_workers,
    )


def _execute(client, todo, out, total, skipped, progress, refresh, t0):
    from distributed import as_completed

    token = os.urandom(4).hex()
    tasks = {}
    for run in todo:
        task = run.to_task()
        fut = client.submit(
            execute_run, task, str(out), key=f"crumple-run-{run.id}-{token}", pure=False
        )
        tasks[fut.key] = (fut, task)
    pending = as_completed([f for f, _ in tasks.values()])
    computed: list[str] = []
    failed: dict[str, str] = {}
    last = -math.inf
    threads = sum(client.nthreads().values()) or 1
    try:
        while not pending.is_empty():
            batch = pending.next_batch(block=False)
            for fut in batch:
                _, task = tasks.pop(fut.key)
                if fut.status == "finished":
                    summary = fut.result()
                else:  # the worker died too often (KilledWorker), or the cluster went away
                    exc = fut.exception() if fut.status == "error" else None
                    msg = f"{type(exc).__name__}: {exc}" if exc is not None else fut.status
                    msg = f"worker lost while computing this run ({msg})"
                    _record_failure(out, task, type(exc).__name__ if exc else "Cancelled", msg, "")
                    summary = {"id": task["id"], "status": "failed", "message": msg}
                if summary["status"] == "done":
                    computed.append(summary["id"])
                else:
                    failed[summary["id"]] = summary["message"]
                fut.release()
            now = time.perf_counter()
            if progress is not None and (batch or now - last >= refresh or pending.is_empty()):
                if now - last >= 5 * refresh:
                    threads = sum(client.nthreads().values()) or threads
                last = now
                finished = len(computed) + len(failed)
                remaining = len(todo) - finished
                elapsed = now - t0
                eta = elapsed / finished * remaining if finished else None
                progress(
                    Progress(
                        total=total,
                        done=skipped + len(computed),
                        failed=len(failed),
                        running=min(threads, remaining),
                        skipped=skipped,
                        elapsed=elapsed,
                        eta=eta,
                    )
                )
            if not batch:
                time.sleep(min(0.1, refresh))
    except BaseException:
        client.cancel([f for f, _ in tasks.values()])
        raise
    return computed, failed


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------


def load(path, *, positions: bool = False):
    """The stage-level results of a sweep store as an :class:`xarray.Dataset`.

    Dimensions: one per swept parameter (the grid, in the order of the sweep file; points as
    one dimension, named after its key or ``point`` with one coordinate per key), then
    ``replica`` and ``lam`` (every stage λ of any run; NaN where a run has no such stage).
    Data variables over all of them: ``E_bending``, ``E_stretching``, ``E_confinement``,
    ``E_hard_core``, ``E_total`` ``[energy]``, ``gamma`` (E_s/E_b), ``converged`` (bool),
    ``max_force`` ``[energy/length]``, ``iterations``, ``evaluations``,
    ``hessian_evaluations`` (float, NaN where no stage); per run (no ``lam``): ``done``,
    ``seconds``, ``n_stages``, ``run_id``. With ``positions=True``, ``positions`` (…,
    ``replica``, ``lam``, ``node``, ``xy``) ``[length]``, NaN-padded when N is swept.

    Runs that are missing, failed or whose file is damaged are NaN (``done`` false) and an
    :class:`IncompleteSweepWarning` says how many; a damaged file is never read as data.
    See ``docs/sweeps.md``.
    """
    import pandas as pd
    import xarray as xr

    out = Path(path)
    m = _read_manifest(out)
    lam = np.asarray(m["lambdas"], dtype=float)
    coords: dict[str, Any] = {}
    shape: list[int] = []
    names: list[str] = []
    for d in m["dims"]:
        if "levels" in d:
            mi = pd.MultiIndex.from_tuples([tuple(v) for v in d["values"]], names=d["levels"])
            coords.update(xr.Coordinates.from_pandas_multiindex(mi, d["name"]))
        else:
            coords[d["name"]] = d["values"]
        names.append(d["name"])
        shape.append(len(d["values"]))
    n_rep = int(m["replicas"])
    run_shape = (*shape, n_rep)
    stage_shape = (*run_shape, len(lam))
    data = {f"E_{t}": np.full(stage_shape, np.nan) for t in _TERMS}
    data["converged"] = np.zeros(stage_shape, dtype=bool)
    data["max_force"] = np.full(stage_shape, np.nan)
    for c in _COUNTS:
        data[c] = np.full(stage_shape, np.nan)
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
        data["max_force"][(*at, j)] = a["solver/max_force"][0]
        ran = np.arange(len(j)) < int(a["n_stages"][0])
        data["converged"][(*at, j)] = a["solver/converged"][0] & ran
        for c in _COUNTS:
            data[c][(*at, j)] = np.where(ran, a[f"solver/{c}"][0], np.nan)
        done[at] = True
        seconds[at] = a["seconds"][0]
        n_stages[at] = a["n_stages"][0]
        if positions:
            pos_arrays[at] = (j, a["positions"][0])
    with np.errstate(divide="ignore", invalid="ignore"):
        eb, es = data["E_bending"], data["E_stretching"]
        data["gamma"] = np.where(eb > 0, es / np.where(eb > 0, eb, 1.0), np.nan)
    sdims = (*names, "replica", "lam")
    rdims = (*names, "replica")
    variables = {k: (sdims, v) for k, v in data.items()}
    variables.update(
        done=(rdims, done),
        seconds=(rdims, seconds),
        n_stages=(rdims, n_stages),
        run_id=(rdims, ids.astype(str)),
    )
    if positions:
        n_max = max((p.shape[-2] for _, p in pos_arrays.values()), default=0)
        pos = np.full((*stage_shape, n_max, 2), np.nan)
        for at, (j, p) in pos_arrays.items():
            pos[(*at, j, slice(0, p.shape[-2]))] = p
        variables["positions"] = ((*sdims, "node", "xy"), pos)
        coords["xy"] = ["x", "y"]
    coords["replica"] = np.arange(n_rep)
    coords["lam"] = lam
    ds = xr.Dataset(variables, coords=coords)
    ds["gamma"].attrs["long_name"] = "E_stretching / E_bending"
    ds["lam"].attrs["long_name"] = "trap strength λ of the stage"
    ds.attrs.update(
        store=str(out),
        sweep=json.dumps(m["sweep"]),
        runs=len(m["runs"]),
        runs_done=int(done.sum()),
    )
    if bad:
        warnings.warn(
            f"{out}: {bad} of {len(m['runs'])} runs are missing, failed or damaged; their values "
            "are NaN (done = False); see `crumple status`",
            IncompleteSweepWarning,
            stacklevel=2,
        )
    return ds
