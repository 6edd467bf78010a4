"""Loops of a wire: the bounded faces of the planar graph formed by the wire and its contacts.

A pure function of node positions (``docs/observables.md``, "Loops", has the definition and a
figure). Lengths are in units of ``L0`` like everywhere in crumple; nothing depends on that.

The graph
---------
* **Edges of the wire**: its segments.
* **Contact links**: every node within ``contact_distance`` of a segment that is not adjacent to
  one of the node's segments is joined by a straight link to the nearest point of that segment
  (this contains the closest-point link of every pair of non-adjacent segments closer than
  ``contact_distance``, since for two segments that do not intersect the closest points are an
  end of one and its foot on the other). A link whose two ends are so close *along the wire*
  that the wire between them and the link form a closed curve shorter than ``π c`` (the
  circumference of a disc of diameter ``c = contact_distance``) cannot hold a loop and is not
  made: this removes the "contacts" between neighbours along the wire when ``c`` is not small
  against the segments.
* **Planarity**: a link that touches the wire anywhere but at its ends (a third strand lies
  between the two strands it joins: the contact goes through that strand), or that crosses a
  shorter link, is dropped; of a group of mutually crossing links the shortest stays.

Faces
-----
The faces are traced on a half-edge structure (edges sorted by angle around each vertex);
exactly one face is unbounded. A bounded face whose *mean width* ``2 A / P`` (area over half its
boundary length, links included) is below ``min_width`` lies inside a contact: the sliver
between consecutive links of two strands touching along a run, the tip of a fold whose arms
touch, the hairline gap between the nodes of two pressed strands (hence the default
``max(c, RESOLUTION × mean segment length)``). It is not a loop. The other bounded faces are
the loops. A run of contacts therefore acts as one contact, the loops on either side of it
being closed at its ends.

Cost: O(N) expected for segments of similar length (spatial hashes), plus one sort of the
half-edges; N = 10^5 in 0.2-0.4 s. Where segment lengths differ by orders of magnitude the
long segments are cut into short pieces before they are entered in the hash (a spiral sampled
at a fixed angle: N = 1.28 × 10^5 in 2.7 s, growing as N^1.6; its crossing check still as
N^1.9, ``docs/performance.md``).

Modules, by concept: :mod:`~crumple.loops.record` (the :class:`LoopStats` record and its
defaults), :mod:`~crumple.loops.links` (the contact links and their planarity),
:mod:`~crumple.loops.faces` (the half-edge structure, its faces, which are loops),
:mod:`~crumple.loops.depths` (enclosure depths and loop-loop contacts); :func:`loops` here.
"""

from __future__ import annotations

import numpy as np

from crumple.geometry import as_positions, find_crossings

from .faces import faces
from .links import contact_links
from .record import RESOLUTION, LoopStats, _empty, positive_length

__all__ = ["RESOLUTION", "LoopStats", "loops", "positive_length"]


def loops(
    positions,
    *,
    contact_distance: float,
    min_width: float | None = None,
    boundaries: bool = False,
) -> LoopStats:
    """Loops of a wire: bounded faces of the planar graph of the wire and its contacts.

    The wire's segments and a straight link for every contact (a node closer than
    ``contact_distance`` to a segment not adjacent to one of its own segments, joined to the
    nearest point of that segment) form a planar graph. Its bounded faces with mean width
    ``2 A / P >= min_width`` are the loops; narrower faces lie inside a contact (between
    consecutive links of two strands touching along a run). The ends of the wire touching
    another part of it close loops like any other contact. See ``docs/observables.md``.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``. The wire must not cross or touch itself exactly
        (:func:`crumple.geometry.find_crossings` empty); consecutive duplicate nodes are merged.
    contact_distance : float
        ``[length]``, > 0. For a simulated wire, twice the hard-core width:
        ``2 * wire.hard_core`` (``2e-5`` with Table I's ``d = 1e-5``); a contact is closer
        than the hard core lets strands get at zero pressure plus the same again.
    min_width : float, optional
        ``[length]``, > 0: faces with ``2 A / P`` below it are not loops. Default
        ``max(contact_distance, RESOLUTION * mean segment length)``: a quarter segment is
        below the narrowest loop a chain of segments can close (a triangle, 0.29 segment) and
        above the gaps left between the nodes of two strands pressed together.
    boundaries : bool
        Also return each loop's boundary polygon (for drawing).

    Returns
    -------
    LoopStats
        Per loop (sorted by decreasing area): area, perimeter (wire only), number of
        contacts, depth (number of enclosing loops); ``count``, ``counts_by_depth``,
        ``area_summary()``.

    Raises
    ------
    ValueError
        Bad input, or a wire that crosses or touches itself exactly (its faces are not
        defined: contacts are distances below ``contact_distance``, never intersections).

    Examples
    --------
    A square whose ends nearly meet holds one loop; open them and it holds none:

    >>> sq = [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0.001]]
    >>> st = loops(sq, contact_distance=0.01)
    >>> st.count, round(float(st.area[0]), 4), st.counts_by_depth
    (1, 1.0, (1,))
    >>> loops(sq[:-1], contact_distance=0.01).count
    0
    """
    pos = _clean_positions(positions)
    c = positive_length("contact_distance", contact_distance)
    n = pos.shape[0]
    if min_width is None:
        seg_len = np.hypot(*np.diff(pos, axis=0).T)
        w = max(c, RESOLUTION * float(seg_len.mean())) if n >= 2 else c
    else:
        w = positive_length("min_width", min_width)
    if n < 4:
        return _empty(c, w, boundaries=boundaries)
    _refuse_crossings(pos)
    lk, lj, lt, lo, _, fx, fy = contact_links(pos, c)
    n_links = int(lk.shape[0])
    if n_links == 0:
        return _empty(c, w, boundaries=boundaries)
    return faces(pos, lk, lj, lt, lo, fx, fy, c, w, n_links, boundaries)


def _clean_positions(positions) -> np.ndarray:
    """Positions as a finite (n, 2) float array, consecutive duplicate nodes merged."""
    pos = as_positions(positions, min_nodes=0)
    if pos.shape[0] >= 2:
        keep = np.r_[True, np.any(np.diff(pos, axis=0) != 0.0, axis=1)]
        pos = np.ascontiguousarray(pos[keep])
    return pos


def _refuse_crossings(pos: np.ndarray) -> None:
    """Faces are defined for a wire that does not intersect itself: ValueError otherwise."""
    cross = find_crossings(pos)
    if cross.shape[0]:
        i, j = (int(v) for v in cross[0])
        more = f" (and {cross.shape[0] - 1} more pairs)" if cross.shape[0] > 1 else ""
        raise ValueError(
            f"the wire crosses or touches itself: segments {i} and {j} intersect{more}; loops "
            "are defined for a wire that does not intersect itself (a contact is a distance "
            "below contact_distance, never an intersection)"
        )
