"""The record :func:`crumple.loops.loops` returns (:class:`LoopStats`) and its defaults.

Lengths in units of L0. Depends on nothing of crumple.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["RESOLUTION", "LoopStats", "positive_length"]

#: Default ``min_width`` as a fraction of the mean segment length (when above the contact
#: distance). The narrowest loop a chain of segments of length s can close is a triangle, of
#: mean width 2A/P = s/(2√3) ≈ 0.29 s; two strands pressed together touch at their nodes and
#: leave, between two contacts, a gap of at most the chords' sagittas, ~ s θ/8 each for turning
#: angles θ, i.e. below s/4 for any θ < 1 rad. A quarter segment separates the two.
RESOLUTION = 0.25


def _frozen(a, dtype) -> np.ndarray:
    a = np.array(a, dtype=dtype)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, slots=True, kw_only=True)
class LoopStats:
    """Loops of one wire (:func:`loops`). Per-loop arrays are sorted by decreasing area.

    Attributes
    ----------
    contact_distance : float
        ``[length]`` used to find contacts.
    min_width : float
        ``[length]``: faces with mean width ``2 A / P`` below it are inside a contact.
    area : ndarray, shape (n_loops,)
        Area of each loop ``[length²]``: the face itself, without the loops and wire inside it.
    perimeter : ndarray, shape (n_loops,)
        Length of wire along the loop's boundary ``[length]`` (contact links excluded; a piece of
        wire that sticks into the loop is bordered on both sides and counts twice).
    n_contacts : ndarray of int, shape (n_loops,)
        Distinct contacts on the loop's boundary: a run of touching segments (links joined by
        slivers) is one contact, met once however many of its links the boundary crosses.
    depth : ndarray of int, shape (n_loops,)
        Number of loops that enclose this one (0: outermost).
    centroid : ndarray, shape (n_loops, 2)
        Centroid of each loop's face ``[length]``.
    n_links : int
        Contact links in the graph (after the planarity rules).
    n_loop_contacts : int
        Contact links at which two loops touch: each end of the link lies on the boundary of a
        loop that does not reach the other end (the strands in contact border two different
        loops on their far sides; the neck of a lone water drop, whose drop reaches both ends,
        does not count). ``docs/observables.md``, "Loops touching loops".
    n_slivers : int
        Bounded faces narrower than ``min_width`` (inside contacts; not loops).
    boundaries : tuple of ndarray or None
        With ``boundaries=True``: each loop's boundary walk, shape (n_k, 2), counter-clockwise.
    links : ndarray or None
        With ``boundaries=True``: the contact links, shape (n_links, 2, 2) ``[length]``.
    """

    contact_distance: float
    min_width: float
    area: np.ndarray
    perimeter: np.ndarray
    n_contacts: np.ndarray
    depth: np.ndarray
    centroid: np.ndarray
    n_links: int
    n_slivers: int
    n_loop_contacts: int = 0
    boundaries: tuple | None = None
    links: np.ndarray | None = None

    @property
    def count(self) -> int:
        """Number of loops."""
        return int(self.area.shape[0])

    @property
    def counts_by_depth(self) -> tuple[int, ...]:
        """Number of loops at depth 0, 1, 2, ... (empty for a wire without loops)."""
        if self.depth.shape[0] == 0:
            return ()
        return tuple(int(v) for v in np.bincount(self.depth))

    def area_summary(self) -> dict:
        """The loop-area distribution in a few numbers ``[length²]``.

        Keys ``count``, ``total``, ``mean``, ``min``, ``q25``, ``median``, ``q75``, ``max``
        (quantiles by linear interpolation); NaN for the statistics of an empty set.
        """
        a = self.area
        if a.shape[0] == 0:
            nan = float("nan")
            return {"count": 0, "total": 0.0, "mean": nan, "min": nan, "q25": nan,
                    "median": nan, "q75": nan, "max": nan}  # fmt: skip
        q = np.quantile(a, [0.25, 0.5, 0.75])
        return {
            "count": int(a.shape[0]),
            "total": float(a.sum()),
            "mean": float(a.mean()),
            "min": float(a.min()),
            "q25": float(q[0]),
            "median": float(q[1]),
            "q75": float(q[2]),
            "max": float(a.max()),
        }

    def to_dict(self) -> dict:
        """JSON-able summary (what ``crumple measure`` prints under ``"loops"``).

        NaN statistics of an empty set become ``None``.
        """
        summary = {
            k: (None if isinstance(v, float) and math.isnan(v) else v)
            for k, v in self.area_summary().items()
        }
        return {
            "contact_distance": self.contact_distance,
            "min_width": self.min_width,
            "count": self.count,
            "counts_by_depth": list(self.counts_by_depth),
            "loop_contacts": self.n_loop_contacts,
            "area": summary,
        }


def positive_length(name: str, value) -> float:
    """``value`` as a float, or ``ValueError("<name> must be a positive length, got ...")``
    (also used by :mod:`crumple.observables` for its distances)."""
    try:
        v = float(value)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must be a positive length, got {value!r}") from err
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a positive length, got {value!r}")
    return v


def _empty(c: float, w: float, n_links: int = 0, boundaries: bool = False) -> LoopStats:
    return LoopStats(
        contact_distance=c,
        min_width=w,
        area=_frozen([], float),
        perimeter=_frozen([], float),
        n_contacts=_frozen([], np.int64),
        depth=_frozen([], np.int64),
        centroid=_frozen(np.empty((0, 2)), float),
        n_links=n_links,
        n_slivers=0,
        boundaries=() if boundaries else None,
        links=_frozen(np.empty((0, 2, 2)), float) if boundaries else None,
    )
