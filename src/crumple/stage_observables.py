"""Per-stage observables: what a sweep measures on every equilibrium and stores beside it.

One registry, :data:`OBSERVABLES` (name → :class:`StageObservable`: a pure function of the
stage's positions and the run's :class:`~crumple.model.Wire` returning one float, with its
units and meaning). :func:`crumple.sweep.execute_run` evaluates every entry at every stage
of a run and writes the values into the run's HDF5 file (``observables/<name>``, shape
``(1, S)``); :func:`crumple.load` returns each as a data variable over
``(params, replica, lam)``, and computes, from the stored positions, those a file written
before the entry existed lacks. Adding an observable is one :func:`_entry` line below.

It also holds the conventions that the report (:mod:`crumple.reproduce`) and ``load`` share:
the contact distance (:data:`CONTACT_FACTOR` hard-core widths), the interior of the wire
(:data:`END_FRACTION`), and when a wire is straight and γ = E_s/E_b is undefined
(:data:`STRAIGHT`, :func:`gamma`).

Lengths are in units of L0, angles in radians (``docs/observables.md``).
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from .geometry import close_segment_pairs, find_crossings, segment_lengths, turning_angles
from .loops import LoopStats, loops
from .model import Wire
from .observables import r_max, radius_of_gyration

__all__ = [
    "CONTACT_DISTANCE",
    "CONTACT_FACTOR",
    "END_FRACTION",
    "OBSERVABLES",
    "STRAIGHT",
    "StageObservable",
    "compute",
    "gamma",
    "is_straight",
    "loops_or_none",
]

#: A contact: two non-adjacent segments closer than this many hard-core widths ``d``. Also
#: the contact distance of the loops, ``c = 2 d`` (``docs/observables.md``).
CONTACT_FACTOR = 2.0
#: The contact distance of a wire with Table I's hard core (``d = 1e-5``): ``2e-5``
#: ``[length]``. ``crumple measure`` and :func:`crumple.observables.measure` count contacts
#: and loops at this distance by default, so that they agree with the stored ``contacts``.
CONTACT_DISTANCE = CONTACT_FACTOR * Wire.__dataclass_fields__["hard_core"].default
#: "Interior" contacts: both segments at least this fraction of the wire from either end.
END_FRACTION = 0.1
#: A wire whose joints all turn by less than this ``[rad]`` is straight: its bending energy
#: is round-off (E_b ~ 1e-24 at the start of a ramp) and γ = E_s/E_b is undefined (NaN).
STRAIGHT = 1e-3


@dataclass(frozen=True, slots=True, kw_only=True)
class StageObservable:
    """One per-stage observable: ``func(positions, wire) -> float``.

    ``positions`` has shape ``(n_nodes, 2)`` ``[length]`` and is finite; ``units`` is written
    as in the docstrings (``"length"``, ``"1"`` for a count, ``"rad"``); ``doc`` is one line.
    """

    name: str
    units: str
    doc: str
    func: Callable[[np.ndarray, Wire], float]


def _contacts(x: np.ndarray, wire: Wire) -> np.ndarray:
    pairs, _ = close_segment_pairs(x, CONTACT_FACTOR * wire.hard_core)
    return pairs


def _n_contacts(x: np.ndarray, wire: Wire) -> float:
    return float(_contacts(x, wire).shape[0])


def _n_contacts_interior(x: np.ndarray, wire: Wire) -> float:
    pairs = _contacts(x, wire)
    m = max(1, int(END_FRACTION * (x.shape[0] - 1)))
    far = (pairs.min(axis=1) >= m) & (pairs.max(axis=1) < x.shape[0] - 1 - m)
    return float(np.count_nonzero(far))


def _loops(x: np.ndarray, wire: Wire) -> LoopStats | None:
    """The loops at ``c = 2 d``; None (NaN) for a wire that crosses itself or whose contact
    graph round-off made non-plane (faces undefined).

    Several entries read the same stage's loops: the last few are cached by content."""
    x = np.ascontiguousarray(x, dtype=float)
    return _loops_of(x.tobytes(), x.shape[0], CONTACT_FACTOR * wire.hard_core)


@functools.lru_cache(maxsize=4)
def _loops_of(data: bytes, n: int, c: float) -> LoopStats | None:
    return loops_or_none(np.frombuffer(data, dtype=float).reshape(n, 2), c)


def loops_or_none(x: np.ndarray, contact_distance: float, *, boundaries: bool = False):
    """:func:`crumple.loops.loops` of one stage, or None where its faces are undefined: a
    wire that crosses itself, or a contact graph that round-off made non-plane (``loops``
    refuses it with ``RuntimeError``). The guarded path of every caller that must not fail
    for one bad stage: the stored observables (NaN) and the report's picture ("undefined").

    ``x`` has shape ``(n_nodes, 2)`` ``[length]``; ``contact_distance`` ``[length]``.
    """
    if find_crossings(x).shape[0]:
        return None
    try:
        return loops(x, contact_distance=contact_distance, boundaries=boundaries)
    except RuntimeError:  # the run (hours of minimisation) is still stored
        return None


def _loop_number(what: Callable[[LoopStats], float]) -> Callable[[np.ndarray, Wire], float]:
    def f(x: np.ndarray, wire: Wire) -> float:
        st = _loops(x, wire)
        return float("nan") if st is None else float(what(st))

    return f


def _entry(name, units, doc, func) -> tuple[str, StageObservable]:
    return name, StageObservable(name=name, units=units, doc=doc, func=func)


_log = logging.getLogger(__name__)

#: The registry, in the order ``load`` lists the variables. One line per observable.
OBSERVABLES: MappingProxyType[str, StageObservable] = MappingProxyType(dict((
    _entry("r_max", "length", "largest distance of a node from the centre of mass (the "
           "paper's R_g)", lambda x, w: r_max(x)),
    _entry("radius_of_gyration", "length", "RMS distance of the uniform wire from its centre "
           "of mass", lambda x, w: radius_of_gyration(x)),
    _entry("contacts", "1", "pairs of non-adjacent segments closer than 2 hard-core widths",
           _n_contacts),
    _entry("contacts_interior", "1", "contacts whose segments are both at least a tenth of "
           "the wire from either end", _n_contacts_interior),
    _entry("max_turning_angle", "rad", "largest |turning angle| of a joint (straight below "
           "STRAIGHT)", lambda x, w: float(np.abs(turning_angles(x)).max(initial=0.0))),
    _entry("contour_length", "length", "total length of the segments",
           lambda x, w: float(segment_lengths(x).sum())),
    _entry("n_loops", "1", "loops at contact distance 2 hard-core widths (NaN if the wire "
           "crosses itself: faces undefined)", _loop_number(lambda s: s.count)),
    _entry("n_loops_nested", "1", "loops enclosed by another loop (depth >= 1)",
           _loop_number(lambda s: int(np.count_nonzero(s.depth >= 1)))),
    _entry("loop_contacts", "1", "contact links at which two different loops touch "
           "(LoopStats.n_loop_contacts)", _loop_number(lambda s: s.n_loop_contacts)),
)))  # fmt: skip


def compute(positions, wire: Wire, names=None) -> dict[str, np.ndarray]:
    """Every observable (or those in ``names``) at every stage of one ramp.

    Parameters
    ----------
    positions : array_like, shape (S, n_nodes, 2)
        The stages ``[length]``; a stage with non-finite positions (not run) gives NaN.
    wire : Wire
        The run's wire (its hard-core width sets the contact distance).
    names : iterable of str, optional
        Default: all of :data:`OBSERVABLES`.

    Returns
    -------
    dict
        name → float array, shape (S,).

    An observable that raises at a stage gives NaN there, and one warning on the
    ``crumple.stage_observables`` logger names it and its first error: a measurement is
    never worth the simulation it measures (a sweep stores the run whatever happens here).
    """
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 3 or pos.shape[-1] != 2:
        raise ValueError(f"positions must have shape (stages, n_nodes, 2), got {pos.shape}")
    names = tuple(OBSERVABLES) if names is None else tuple(names)
    out = {k: np.full(pos.shape[0], np.nan) for k in names}
    failed: dict[str, list] = {}  # name -> [stages, first error]
    for s in range(pos.shape[0]):
        x = pos[s]
        if not np.isfinite(x).all():
            continue
        for k in names:
            try:
                out[k][s] = OBSERVABLES[k].func(x, wire)
            except Exception as exc:  # any bug of an observable: NaN, logged
                failed.setdefault(k, [0, f"{type(exc).__name__}: {exc}"])[0] += 1
    for k, (n, first) in failed.items():
        _log.warning("observable %r failed at %d stage(s), stored as NaN (first: %s)", k, n, first)
    return out


def is_straight(max_turning_angle):
    """True where every joint turns by less than :data:`STRAIGHT` (NaN angles: False)."""
    return np.asarray(max_turning_angle, dtype=float) < STRAIGHT


def gamma(E_s, E_b, max_turning_angle):
    """γ = E_s / E_b (Sec. III.B), NaN where it is undefined: on a straight wire
    (:func:`is_straight`: E_b is round-off there, and γ would read 1e15-1e21), where
    ``E_b <= 0`` and where an input is NaN. Element-wise on broadcastable arrays.

    >>> gamma([1.0, 1.0], [2.0, 1e-24], [0.3, 1e-9]).tolist()
    [0.5, nan]
    """
    es = np.asarray(E_s, dtype=float)
    eb = np.asarray(E_b, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.where(eb > 0, es / np.where(eb > 0, eb, 1.0), np.nan)
    return np.where(is_straight(max_turning_angle), np.nan, g)
