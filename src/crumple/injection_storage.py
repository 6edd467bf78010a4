"""Injections on disk: the replicas of one injection as an HDF5 file readable without crumple.

Layout (R replicas, S planned stages, n nodes; stages a replica did not run, after jamming,
are NaN), beside :mod:`crumple.storage`'s ramp files:

=================================  ============  ===========================================
dataset                            shape         meaning
=================================  ============  ===========================================
``injected_length``                (S,)          L_in of each planned stage [length]
``positions``                      (R, S, n, 2)  equilibrium node positions [length]
``free``                           (R, S, n)     nodes not held by the channel
``released``                       (R, S)        nodes released during the stage's push
``initial``                        (R, n, 2)     starting configuration (all in the channel)
``n_stages``, ``seconds``          (R,)          stages run, wall time
``stop_reason``, ``stop_message``  (R,)          ``length`` or ``jammed``, and why (UTF-8)
``energy/<term>``                  (R, S)        bending, stretching, hard_core, wall, total
``solver/<field>``                 (R, S)        converged, max_force, iterations,
                                                 evaluations, hessian_evaluations, message
``observables/<name>``             (R, S)        :data:`crumple.injection_observables.
                                                 INJECTION_OBSERVABLES` (units, doc attrs)
``rest_angles`` (imperfect wires)  (R, n - 2)    quenched rest angles
=================================  ============  ===========================================

Root attributes: ``format`` (``"crumple-injections"``), ``format_version``, ``protocol``
(``"injection"``), ``wire`` and ``injection`` (JSON), ``seed``, ``versions``, ``created``,
extra attributes, and ``complete`` last. Written atomically (:func:`crumple.storage.
atomic_path`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np

from .energy import EnergyTerms
from .injection import Injection, InjectionResult, InjectionStage
from .injection_observables import INJECTION_OBSERVABLES, measure_injection
from .minimize import MinimizeResult
from .model import Wire
from .storage import atomic_path, write_run_attrs

__all__ = [
    "FORMAT",
    "load_injections",
    "planned_lengths",
    "read_injection_arrays",
    "save_injections",
    "verify_injections",
]

FORMAT = "crumple-injections"
FORMAT_VERSION = 2
#: Version 1 stored the rigid clamp's reaction as ``feed_force`` (issue 13, referee's B1).
_OLDEST = 2
_TERMS = ("bending", "stretching", "hard_core", "wall", "total")
_COUNTS = ("iterations", "evaluations", "hessian_evaluations")


def planned_lengths(wire: Wire, injection: Injection) -> np.ndarray:
    """L_in of every planned stage, shape (S,) ``[length]``: δ, 2δ, … up to the stop length."""
    push, stop, _ = injection.resolve(wire)
    n = max(1, math.ceil(stop / push - 1e-9))
    return np.minimum(stop, push * np.arange(1, n + 1))


def _arrays(results: list[InjectionResult], n_stage: int) -> dict:
    wire = results[0].wire
    n_rep, n = len(results), wire.n_nodes
    a = {
        "positions": np.full((n_rep, n_stage, n, 2), np.nan),
        "free": np.zeros((n_rep, n_stage, n), dtype=bool),
        "released": np.zeros((n_rep, n_stage), dtype=np.int64),
        **{f"energy/{t}": np.full((n_rep, n_stage), np.nan) for t in _TERMS},
        "solver/converged": np.zeros((n_rep, n_stage), dtype=bool),
        "solver/max_force": np.full((n_rep, n_stage), np.nan),
        **{f"solver/{c}": np.zeros((n_rep, n_stage), dtype=np.int64) for c in _COUNTS},
        "solver/message": np.full((n_rep, n_stage), "", dtype=object),
    }
    for r, res in enumerate(results):
        for s, st in enumerate(res.stages):
            a["positions"][r, s] = st.positions
            a["free"][r, s] = st.free
            a["released"][r, s] = st.released
            for t, v in st.energy.to_dict().items():
                if t in _TERMS:
                    a[f"energy/{t}"][r, s] = v
            a["solver/converged"][r, s] = st.result.converged
            a["solver/max_force"][r, s] = st.result.max_force
            for c in _COUNTS:
                a[f"solver/{c}"][r, s] = getattr(st.result, c)
            a["solver/message"][r, s] = st.result.message
    return a


def save_injections(path, results: list[InjectionResult], *, seed=None,
                    attrs: dict | None = None) -> Path:  # fmt: skip
    """Write the replicas of one injection (same wire and protocol) to ``path``, atomically,
    with their per-stage observables (:func:`crumple.injection_observables.measure_injection`).
    """
    if not results:
        raise ValueError("no results to save")
    wire, inj = results[0].wire, results[0].injection
    if any(r.wire != wire or r.injection != inj for r in results):
        raise ValueError("all replicas in one file must share the wire and the injection")
    lengths = planned_lengths(wire, inj)
    a = _arrays(results, len(lengths))
    obs = {k: np.full((len(results), len(lengths)), np.nan) for k in INJECTION_OBSERVABLES}
    for r, res in enumerate(results):
        for k, v in measure_injection(res).items():
            obs[k][r, : len(v)] = v
    path = Path(path)
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs.update(format=FORMAT, format_version=FORMAT_VERSION, protocol="injection")
        write_run_attrs(f, wire=wire, seed=seed, attrs=attrs, injection=inj.to_dict())
        f.create_dataset("injected_length", data=lengths)
        f.create_dataset("initial", data=np.array([r.initial for r in results]))
        f.create_dataset("n_stages", data=np.array([len(r.stages) for r in results]))
        f.create_dataset("seconds", data=np.array([r.seconds for r in results]))
        text = h5py.string_dtype("utf-8")
        f.create_dataset("stop_reason", data=np.array([r.stop_reason for r in results],
                                                      dtype=object), dtype=text)  # fmt: skip
        f.create_dataset("stop_message", data=np.array([r.stop_message for r in results],
                                                       dtype=object), dtype=text)  # fmt: skip
        for name, v in a.items():
            kw = {"compression": "gzip", "shuffle": True} if name == "positions" else {}
            f.create_dataset(name, data=v, dtype=text if name == "solver/message" else None, **kw)
        rest = [r.rest_angles for r in results]
        if any(x is not None for x in rest):
            f.create_dataset(
                "rest_angles",
                data=np.array(
                    [np.full(wire.n_nodes - 2, np.nan) if x is None else x for x in rest]
                ),
            )
        g = f.create_group("observables")
        for k, v in obs.items():
            d = g.create_dataset(k, data=v)
            d.attrs["units"], d.attrs["doc"] = INJECTION_OBSERVABLES[k]
        f.attrs["complete"] = True
    return path


def verify_injections(path, *, run_id: str | None = None) -> dict:
    """Check that ``path`` is a complete injection file (of run ``run_id``); returns its root
    attributes, JSON-decoded. Raises ``ValueError`` naming what is wrong."""
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ValueError(f"{path} is not a readable HDF5 file ({exc})") from None
    try:
        with f:
            attrs = {k: _decode(v) for k, v in f.attrs.items()}
            if attrs.get("format") != FORMAT:
                raise ValueError(f"{path} is not a crumple injection file")
            if attrs.get("format_version", 0) < _OLDEST:
                raise ValueError(
                    f"{path} is format version {attrs.get('format_version')}: its feed_force is "
                    "the rigid clamp's reaction, not the injection force; run it again"
                )
            if attrs.get("complete") is not True:
                raise ValueError(f"{path} is incomplete (no 'complete' marker)")
            if run_id is not None and attrs.get("run_id") != run_id:
                raise ValueError(f"{path} holds run {attrs.get('run_id')!r}, not {run_id!r}")
            n_stage = f["injected_length"].shape[0]
            n_rep = f["n_stages"].shape[0]
            if f["positions"].shape[:2] != (n_rep, n_stage):
                raise ValueError(f"{path}: positions do not match the stages and replicas")
    except (OSError, KeyError, RuntimeError) as exc:
        raise ValueError(f"{path} is damaged ({exc})") from None
    return attrs


def read_injection_arrays(path, *, positions: bool = False, run_id: str | None = None) -> dict:
    """The arrays of a complete injection file as NumPy arrays (``attrs`` JSON-decoded)."""
    attrs = verify_injections(path, run_id=run_id)
    with h5py.File(path, "r") as f:
        out: dict = {"attrs": attrs}

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and (positions or name != "positions"):
                out[name] = obj.asstr()[()] if obj.dtype.kind == "O" else obj[()]

        try:
            f.visititems(visit)
        except (OSError, KeyError, RuntimeError) as exc:
            raise ValueError(f"{path} is damaged ({exc})") from None
    return out


def _decode(v):
    if isinstance(v, str):
        try:
            return json.loads(v)
        except ValueError:
            return v
    return v.item() if isinstance(v, np.generic) else v


def load_injections(path) -> list[InjectionResult]:
    """Read a file written by :func:`save_injections` back into :class:`InjectionResult`."""
    a = read_injection_arrays(path, positions=True)
    wire = Wire.from_dict(a["attrs"]["wire"])
    inj = Injection.from_dict(a["attrs"]["injection"])
    out = []
    for r in range(a["positions"].shape[0]):
        stages = []
        for s in range(int(a["n_stages"][r])):
            terms = {t: float(a[f"energy/{t}"][r, s]) for t in _TERMS}
            energy = EnergyTerms(terms["bending"], terms["stretching"], 0.0, terms["hard_core"],
                                 wall=terms["wall"])  # fmt: skip
            res = MinimizeResult(
                x=a["positions"][r, s], energy=terms["total"],
                max_force=float(a["solver/max_force"][r, s]),
                **{c: int(a[f"solver/{c}"][r, s]) for c in _COUNTS},
                converged=bool(a["solver/converged"][r, s]), ftol=inj.ftol,
                message=str(a["solver/message"][r, s]), method="newton",
            )  # fmt: skip
            stages.append(InjectionStage(
                injected_length=float(a["injected_length"][s]), positions=a["positions"][r, s],
                energy=energy, result=res,
                feed_force=float(a["observables/feed_force"][r, s]), free=a["free"][r, s],
                released=int(a["released"][r, s]),
                clamp_reaction=float(a["observables/clamp_reaction"][r, s]),
                release_drop=float(a["observables/release_drop"][r, s]),
            ))  # fmt: skip
        rest = a.get("rest_angles")
        out.append(InjectionResult(
            wire=wire, injection=inj, initial=a["initial"][r], stages=tuple(stages),
            seconds=float(a["seconds"][r]), stop_reason=str(a["stop_reason"][r]),
            stop_message=str(a["stop_message"][r]),
            rest_angles=None if rest is None or np.isnan(rest[r]).all() else rest[r],
        ))  # fmt: skip
    return out
