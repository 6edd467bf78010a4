"""A sweep's specification: a TOML file or a dict -> parameter points x replicas -> runs.

:class:`Sweep` checks every key where it is given (an error names the table, the key and the
point, and suggests the nearest known key) and expands the grid and the explicit points into
:class:`crumple.sweep.store.Run` objects, each with its content address. See ``docs/sweeps.md``
for the file format.
"""

from __future__ import annotations

import difflib
import itertools
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from ..injection import Injection
from ..model import Plasticity, Wire
from ..protocol import Ramp, default_schedule, initial_state
from ..protocol_coarse import check_coarsen
from .store import Run, _canonical, canonical_json

_FACTORY_KEYS = ("young", "radius", "bending", "stretching")
_WIRE_KEYS = (*Wire.__dataclass_fields__, *_FACTORY_KEYS)
_RAMP_KEYS = (*Ramp.__dataclass_fields__, "schedule")
#: The [protocol] table of an injection sweep: ``kind`` and the Injection's parameters.
_INJECTION_KEYS = tuple(Injection.__dataclass_fields__)
_KINDS = ("ramp", "injection")
#: Parameters given as a table; their entries are swept one by one.
_TABLES = {"plasticity": ("s", "theta_p"), "schedule": ("lam_min", "lam_max", "n")}
#: Parameters whose value is itself a list: a list of lists sweeps over them.
_LIST_VALUED = ("lambdas", "trap_center")
#: Coordinate names of table entries (the paper's symbols where it has one).
_COORD = {
    ("plasticity", "s"): "s",
    ("plasticity", "theta_p"): "theta_p",
    ("schedule", "lam_min"): "lam_min",
    ("schedule", "lam_max"): "lam_max",
    ("schedule", "n"): "schedule_n",
}


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
        ``stage_noise``, ``stop_tol``, ``method``, ``ftol``, ``maxiter``, ``max_step``,
        ``powell_rtol``), or
        ``schedule = {lam_min, lam_max, n}`` for :func:`crumple.protocol.default_schedule`.
    protocol : mapping
        ``kind = "ramp"`` (default; the ramp's parameters in ``ramp``) or ``kind =
        "injection"`` with the parameters of :class:`crumple.injection.Injection` (``push``,
        ``stop_length``, ``angle``, ``jam_force``, ``max_push``, ``noise``, ``ftol``,
        ``maxiter``, ``max_step``), which may be lists as ``ramp``'s. The wire then needs a
        ``cavity_radius``; its ``hard_core`` is the wire's thickness.
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
    protocol: Mapping[str, Any] = field(default_factory=dict)
    points: tuple[Mapping[str, Any], ...] = ()
    replicas: int = 1
    seed: int = 0
    _plan: _Plan | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        for name in ("wire", "ramp", "protocol"):
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
        if self.kind not in _KINDS:
            raise ValueError(f"[protocol] kind must be 'ramp' or 'injection', got {self.kind!r}")
        if self.kind == "ramp" and set(self.protocol) - {"kind"}:
            key = sorted(set(self.protocol) - {"kind"})[0]
            raise ValueError(f"[protocol] unknown key {key!r} for kind = 'ramp' (the ramp's "
                             "parameters go in [ramp])")  # fmt: skip
        if self.kind == "injection" and self.ramp:
            raise ValueError("[ramp] with [protocol] kind = 'injection': the injection's "
                             "parameters go in [protocol]")  # fmt: skip
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
        tables = ["sweep", "wire", "ramp", "protocol", "point"]
        unknown = set(d) - set(tables)
        if unknown:
            key = sorted(unknown)[0]
            raise ValueError(
                f"unknown table [{key}]{_suggest(key, tables)}; "
                "use [sweep], [wire], [ramp], [protocol] and [[point]]"
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
            protocol=d.get("protocol", {}),
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
        if self.protocol:
            d["protocol"] = _thaw(self.protocol)
        if self.points:
            d["point"] = [_thaw(p) for p in self.points]
        return d

    # ---- expansion --------------------------------------------------------------------------

    @property
    def kind(self) -> str:
        """The protocol: ``"ramp"`` or ``"injection"`` (``[protocol] kind``)."""
        return self.protocol.get("kind", "ramp")

    def _protocol_table(self) -> tuple[str, Mapping, tuple[str, ...]]:
        """(table name, its entries, its known keys) of the protocol's parameters."""
        if self.kind == "injection":
            params = {k: v for k, v in self.protocol.items() if k != "kind"}
            return "protocol", params, _INJECTION_KEYS
        return "ramp", self.ramp, _RAMP_KEYS

    def _grid(self) -> tuple[list[_Dim], dict[str, dict]]:
        """The swept dimensions of [wire] and [ramp], and the values they fix."""
        dims: list[_Dim] = []
        ptable, pspec, pknown = self._protocol_table()
        base: dict[str, dict] = {"wire": {}, ptable: {}}
        for table, spec, known in (("wire", self.wire, _WIRE_KEYS), (ptable, pspec, pknown)):
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
        return dims, base

    def _make_plan(self) -> _Plan:
        dims, base = self._grid()
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
                        table = "wire" if key in _WIRE_KEYS else self._protocol_table()[0]
                        if isinstance(value, Mapping):
                            spec[table][key] = {**spec[table].get(key, {}), **value}
                        else:
                            spec[table][key] = value
                    coords += zip(point_names, point_values[p], strict=True)
                where = ", ".join(f"{n} = {_fmt(v)}" for n, v in coords)
                wire, ramp = _build(spec, where)
                index = (*combo, p) if self.points else combo
                lambdas.update(Run(wire=wire, ramp=ramp, replica=0, seed=self.seed).stages)
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
                _check_key(f"{where}:", key, _WIRE_KEYS + self._protocol_table()[2])
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
        """Every stage λ of every run, sorted (the ``lam`` coordinate of :func:`load`); for an
        injection, every planned injected length (the ``L_in`` coordinate)."""
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


def _build(spec: dict, where: str) -> tuple[Wire, Ramp | Injection]:
    """Wire and protocol of one parameter point, with errors naming the point."""
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
    if "protocol" in spec:
        try:
            inj = Injection.from_dict(_canonical(spec["protocol"]))
            inj.resolve(wire)  # checked against the wire before anything is submitted
        except (ValueError, TypeError) as exc:
            raise ValueError(f"[protocol]{at}: {exc}") from None
        return wire, inj
    try:
        r = _canonical(spec["ramp"])
        if "lambdas" in r and "schedule" in r:
            raise ValueError("give lambdas or schedule, not both")
        if "lambdas" not in r:
            r["lambdas"] = default_schedule(**r.pop("schedule", {}))
        ramp = Ramp.from_dict(_canonical(Ramp(**r).to_dict()))
        # what run_ramp checks only when it starts, on the worker (initial_noise < 0.5 keeps
        # the first configuration free of crossings): checked here by the model's own code,
        # so that a bad value stops the sweep before anything is submitted
        initial_state(wire, ramp.initial_noise, seed=0)
        check_coarsen(wire, ramp.coarsen)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"[ramp]{at}: {exc}") from None
    return wire, ramp
