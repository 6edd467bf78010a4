"""Distances between points and segments, close pairs, lengths and turning angles."""

from __future__ import annotations

import numpy as np
from numba import njit

from ._input import _as_positions
from .cells import (
    CROWD,
    _cell,
    _cell_hash,
    _chunked_hash,
    _chunks_pay,
    _fine_cell,
    _grow,
    _one_cell_hash,
    _segment_boxes,
    _segment_pairs,
)
from .crossings import _intersect_exact, _meet

# --------------------------------------------------------------------------------------------
# Distances
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _point_segment(px, py, ax, ay, bx, by):
    """Distance from p to segment ab, the closest point's parameter t in [0, 1], and p - c."""
    ex, ey = bx - ax, by - ay
    ee = ex * ex + ey * ey
    t = 0.0
    if ee > 0.0:
        t = ((px - ax) * ex + (py - ay) * ey) / ee
        t = min(1.0, max(0.0, t))
    vx = px - (ax + t * ex)
    vy = py - (ay + t * ey)
    return np.sqrt(vx * vx + vy * vy), t, vx, vy


@njit(cache=True)
def _segment_segment(pos, i, j):
    """(distance, certain) between segments i and j, 0 where they share a point.

    Else the least of the four end-to-segment distances, which is the distance of two
    disjoint segments in the plane. Not certain only beyond the exact signs' bounds
    (:func:`crumple.geometry.crossings._orient_sure`): the distance is then the ends' and the
    caller decides the meeting in rational arithmetic.
    """
    p1x, p1y, p2x, p2y = pos[i, 0], pos[i, 1], pos[i + 1, 0], pos[i + 1, 1]
    q1x, q1y, q2x, q2y = pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1]
    hit, certain = _meet(p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y)
    if hit:
        return 0.0, True
    d = _point_segment(p1x, p1y, q1x, q1y, q2x, q2y)[0]
    d = min(d, _point_segment(p2x, p2y, q1x, q1y, q2x, q2y)[0])
    d = min(d, _point_segment(q1x, q1y, p1x, p1y, p2x, p2y)[0])
    d = min(d, _point_segment(q2x, q2y, p1x, p1y, p2x, p2y)[0])
    return d, certain


@njit(cache=True)
def _close_pairs(pos, cutoff):
    """Candidate pairs within ``cutoff``, their distances, and which are certain.

    A pair not certain is kept whatever its ends' distance, for :func:`_decided`.
    """
    a0, a1, b0, b1 = pos[:-1, 0], pos[:-1, 1], pos[1:, 0], pos[1:, 1]
    pairs = _segment_pairs(a0, a1, b0, b1, 0.5 * cutoff, 2, 0, CROWD)
    keep = np.empty(pairs.shape[0], dtype=np.bool_)
    dist = np.empty(pairs.shape[0])
    sure = np.empty(pairs.shape[0], dtype=np.bool_)
    for k in range(pairs.shape[0]):
        dist[k], sure[k] = _segment_segment(pos, pairs[k, 0], pairs[k, 1])
        keep[k] = dist[k] < cutoff or not sure[k]
    return pairs[keep], dist[keep], sure[keep]


def _decided(pos, pairs, dist, sure):
    """The distances, every uncertain pair decided in rational arithmetic (0: they meet)."""
    for k in np.flatnonzero(~sure):
        if _intersect_exact(pos, int(pairs[k, 0]), int(pairs[k, 1])):
            dist[k] = 0.0
    return dist


def close_segment_pairs(positions, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of non-adjacent segments closer than ``cutoff``, with their distances.

    Non-adjacent means ``j >= i + 2``. Segments that share a point (crossing or touching,
    decided exactly) have distance 0.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``.
    cutoff : float
        Distance ``[length]``, > 0.

    Returns
    -------
    pairs : ndarray of int, shape (n_pairs, 2)
        ``(i, j)`` with ``j >= i + 2``, sorted.
    distances : ndarray, shape (n_pairs,)
        Segment-segment distances ``[length]``.

    Examples
    --------
    >>> hairpin = [[0, 0], [1, 0], [1, 0.1], [0, 0.1]]
    >>> pairs, d = close_segment_pairs(hairpin, 0.2)
    >>> pairs.tolist(), d.round(6).tolist()
    ([[0, 2]], [0.1])
    """
    pos = _as_positions(positions)
    if not (np.isfinite(cutoff) and cutoff > 0):
        raise ValueError(f"cutoff must be a positive distance, got {cutoff}")
    if pos.shape[0] < 4:
        return np.empty((0, 2), dtype=np.int64), np.empty(0)
    pairs, dist, sure = _close_pairs(pos, float(cutoff))
    dist = _decided(pos, pairs, dist, sure)
    keep = dist < cutoff
    pairs, dist = pairs[keep], dist[keep]
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return pairs[order], dist[order]


def point_segment_distance(point, a, b) -> float:
    """Euclidean distance ``[length]`` from ``point`` to the closed segment ``ab``.

    >>> point_segment_distance([0.5, 2.0], [0, 0], [1, 0])
    2.0
    >>> point_segment_distance([3.0, 4.0], [0, 0], [0, 0])
    5.0
    """
    (px, py), (ax, ay), (bx, by) = (np.asarray(v, dtype=float) for v in (point, a, b))
    return float(_point_segment(px, py, ax, ay, bx, by)[0])


def segment_distance(positions, i: int, j: int) -> float:
    """Distance ``[length]`` between segments ``i`` and ``j`` (0 if they intersect).

    >>> segment_distance([[0, 0], [1, 0], [1, 0.1], [0, 0.1]], 0, 2)
    0.1
    >>> segment_distance([[0, 0], [1, 1], [2, 2], [3, 3]], 0, 2)  # collinear, decided exactly
    1.4142135623730951
    """
    pos = _as_positions(positions)
    n = pos.shape[0] - 1
    if not (0 <= i < n and 0 <= j < n) or abs(i - j) < 2:
        raise ValueError(f"need two non-adjacent segments of {n}, got {i} and {j}")
    d, sure = _segment_segment(pos, int(i), int(j))
    return 0.0 if not sure and _intersect_exact(pos, int(i), int(j)) else float(d)


def segment_lengths(positions) -> np.ndarray:
    """Lengths ``[length]`` of the segments, shape ``(n_nodes - 1,)``.

    >>> segment_lengths([[0, 0], [3, 4], [3, 5]]).tolist()
    [5.0, 1.0]
    """
    pos = _as_positions(positions)
    return np.hypot(*np.diff(pos, axis=0).T)


def turning_angles(positions) -> np.ndarray:
    """Signed turning angles θ_i ∈ (-π, π] at the interior nodes, shape ``(n_nodes - 2,)``.

    θ_i is the angle from segment ``i - 1`` to segment ``i`` (counter-clockwise positive), the
    bending angle of the paper's Eq. (1).

    >>> np.degrees(turning_angles([[0, 0], [1, 0], [1, 1], [0, 1]])).tolist()
    [90.0, 90.0]
    """
    pos = _as_positions(positions)
    e = np.diff(pos, axis=0)
    cross = e[:-1, 0] * e[1:, 1] - e[:-1, 1] * e[1:, 0]
    dot = np.einsum("ij,ij->i", e[:-1], e[1:])
    return np.arctan2(cross, dot)


# --------------------------------------------------------------------------------------------
# Node-segment pairs within a distance (the hard core's neighbour list)
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _node_segment_pairs(pos, cutoff):
    """:func:`_node_segment_pairs_crowd` at the default crowding (``cells.CROWD``). Its own
    function, not a default argument: see ``cells._segment_pairs``."""
    return _node_segment_pairs_crowd(pos, cutoff, CROWD)


@njit(cache=True)
def _node_segment_pairs_crowd(pos, cutoff, crowd):
    """Pairs (node k, segment j) closer than ``cutoff`` whose segments are non-adjacent.

    Node k belongs to segments k - 1 and k; the pair is kept when segment j is non-adjacent
    (``|a - j| >= 2``) to at least one segment a that holds k. Each segment is inserted in every
    cell its box (padded by the cutoff) overlaps, so a node queries its own cell only and finds
    each pair once. The boxes are copied in table order so that a query reads memory
    sequentially. Where that hash is more crowded than ``crowd`` (``cells.CROWD``), the
    segments are hashed in chunks (:func:`_node_segment_pairs_chunked`): the same pairs, in the
    same order.
    """
    n = pos.shape[0]
    ns = n - 1
    lox, loy, hix, hiy = _segment_boxes(pos, cutoff)
    h, ox, oy, start, item, cx, cy, mask = _one_cell_hash(lox, loy, hix, hiy)
    if _chunks_pay(h, start, item, lox, loy, hix, hiy, crowd):
        h = _fine_cell(lox, loy, hix, hiy)
        return _node_segment_pairs_chunked(pos, cutoff, lox, loy, hix, hiy, h)
    m_tot = item.shape[0]
    ebox = np.empty((m_tot, 4))
    for e in range(m_tot):
        j = item[e]
        ebox[e, 0] = lox[j]
        ebox[e, 1] = hix[j]
        ebox[e, 2] = loy[j]
        ebox[e, 3] = hiy[j]
    out_k = np.empty(max(16, n), dtype=np.int64)
    out_j = np.empty(max(16, n), dtype=np.int64)
    m = 0
    for k in range(n):
        px, py = pos[k, 0], pos[k, 1]
        if px < ox or py < oy:
            continue
        ix, iy, bkt = _bucket_of(px, py, ox, oy, h, mask)
        for e in range(start[bkt], start[bkt + 1]):
            if px < ebox[e, 0] or px > ebox[e, 1] or py < ebox[e, 2] or py > ebox[e, 3]:
                continue
            if cx[e] != ix or cy[e] != iy:
                continue
            j = item[e]
            if not ((k >= 1 and abs(k - 1 - j) >= 2) or (k <= ns - 1 and abs(k - j) >= 2)):
                continue
            d = _point_segment(px, py, pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1])[0]
            if d >= cutoff:
                continue
            if m == out_k.shape[0]:
                bk = np.empty(2 * m, dtype=np.int64)
                bj = np.empty(2 * m, dtype=np.int64)
                bk[:m] = out_k
                bj[:m] = out_j
                out_k, out_j = bk, bj
            out_k[m] = k
            out_j[m] = j
            m += 1
    return out_k[:m], out_j[:m]


@njit(cache=True)
def _bucket_of(px, py, ox, oy, h, mask):
    """The cell of the point (px, py) >= the origin, and its bucket: (ix, iy, bucket)."""
    ix = _cell(px, ox, h)
    iy = _cell(py, oy, h)
    return ix, iy, _cell_hash(ix, iy, mask)


@njit(cache=True)
def _node_segment_pairs_chunked(pos, cutoff, lox, loy, hix, hiy, h):
    """:func:`_node_segment_pairs` where its one-cell hash is crowded: the segments hashed in
    chunks of extent at most h. A node queries its own cell, whose bucket lists each segment's
    chunks together and the segments in increasing order, so that the pairs come out as from
    the one-cell hash: the same pairs in the same order."""
    n = pos.shape[0]
    ns = n - 1
    start, item, cx, cy, mask, ox, oy, owner, _, _, _, _, _ = _chunked_hash(
        pos[:-1, 0], pos[:-1, 1], pos[1:, 0], pos[1:, 1], cutoff, h
    )
    out = np.empty((max(16, n), 2), dtype=np.int64)
    m = 0
    for k in range(n):
        px, py = pos[k, 0], pos[k, 1]
        if px < ox or py < oy:
            continue
        ix, iy, bkt = _bucket_of(px, py, ox, oy, h, mask)
        last = -1
        for e in range(start[bkt], start[bkt + 1]):
            if cx[e] != ix or cy[e] != iy:
                continue
            j = owner[item[e]]
            if j == last:  # another chunk of the segment just met
                continue
            last = j
            if px < lox[j] or px > hix[j] or py < loy[j] or py > hiy[j]:
                continue
            if not ((k >= 1 and abs(k - 1 - j) >= 2) or (k <= ns - 1 and abs(k - j) >= 2)):
                continue
            d = _point_segment(px, py, pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1])[0]
            if d >= cutoff:
                continue
            out = _grow(out, m)
            out[m, 0] = k
            out[m, 1] = j
            m += 1
    return out[:m, 0].copy(), out[:m, 1].copy()


def node_segment_pairs(positions, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes closer than ``cutoff`` to a segment non-adjacent to one of the node's segments.

    These (node, segment) pairs carry the hard core of :mod:`crumple.energy`: every pair of
    non-adjacent segments closer than the cutoff has at least one endpoint within the cutoff of
    the other segment. O(n) expected time.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    cutoff : float
        ``[length]``, > 0.

    Returns
    -------
    nodes, segments : ndarray of int, shape (n_pairs,)

    Examples
    --------
    >>> k, j = node_segment_pairs([[0, 0], [1, 0], [1, 0.1], [0, 0.1]], 0.2)
    >>> sorted(zip(k.tolist(), j.tolist()))
    [(0, 2), (1, 2), (2, 0), (3, 0)]
    """
    pos = _as_positions(positions)
    if not (np.isfinite(cutoff) and cutoff > 0):
        raise ValueError(f"cutoff must be a positive distance, got {cutoff}")
    if pos.shape[0] < 4:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    return _node_segment_pairs(pos, float(cutoff))
