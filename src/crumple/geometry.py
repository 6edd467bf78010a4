"""Geometry of a polygonal chain in the plane: no physics here.

A wire is an array ``positions`` of shape ``(n_nodes, 2)`` ``[length]``; segment ``i`` joins
nodes ``i`` and ``i + 1``. Two segments are *adjacent* when they share a node (``|i - j| == 1``).

The neighbour searches use a uniform grid whose occupied cells are stored in a hash table
(a "spatial hash"), so building and querying cost O(n) expected time whatever the extent of
the wire: a crumpled wire of 10^5 segments of length 10^-5 occupies a few 10^5 cells of a
virtual 10^5 x 10^5 grid, and only those are stored.

The crossing test is *exact*: orientations are evaluated in floating point with Shewchuk's
static error bound, and the rare pairs whose sign the bound cannot certify are decided again
in exact rational arithmetic (:class:`fractions.Fraction`), so near-degenerate contacts are
never misclassified by round-off.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from numba import njit

__all__ = [
    "as_positions",
    "close_segment_pairs",
    "disc_exit_fraction",
    "find_crossings",
    "has_crossings",
    "max_safe_fraction",
    "node_segment_pairs",
    "point_segment_distance",
    "segment_distance",
    "segment_lengths",
    "turning_angles",
]

# Shewchuk's bound for orient2d: a float determinant larger than this (times the sum of the
# magnitudes of its two products) has the right sign. eps = 2**-53 is the unit round-off.
_EPS = 2.0**-53
_CCW_ERRBOUND = (3.0 + 16.0 * _EPS) * _EPS


# --------------------------------------------------------------------------------------------
# Spatial hash of axis-aligned boxes
# --------------------------------------------------------------------------------------------


def as_positions(positions, *, min_nodes: int = 2) -> np.ndarray:
    """``positions`` as a finite float array of shape (n_nodes, 2), ``n_nodes >= min_nodes``.

    Raises ValueError with a message naming what is wrong (not numbers, wrong shape, too few
    nodes, NaN or infinite values): the one input check of every function of positions.
    """
    try:
        pos = np.asarray(positions, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"positions must be an array of numbers, got {positions!r}") from err
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions must have shape (n_nodes, 2), got {pos.shape}")
    if pos.shape[0] < min_nodes:
        raise ValueError(f"a wire needs at least {min_nodes} nodes, got {pos.shape[0]}")
    if not np.all(np.isfinite(pos)):
        raise ValueError("positions contain NaN or infinite values")
    return pos


@njit(cache=True)
def _cell(v, origin, h):
    """Cell index of coordinate v (>= origin). Builds and queries must use this one formula:
    (v - o) * (1/h) and (v - o) / h can round to different cells on a boundary."""
    return int((v - origin) / h)


@njit(cache=True)
def _cell_hash(ix, iy, mask):
    # Large odd multipliers (Teschner et al. 2003) spread neighbouring cells over the table.
    return ((ix * 73856093) ^ (iy * 19349663)) & mask


@njit(cache=True)
def _build_hash(lox, loy, hix, hiy, origin_x, origin_y, h):
    """Insert each box into every grid cell it overlaps.

    Returns ``(start, item, cx, cy, mask)``: the entries of bucket ``b`` are
    ``item[start[b]:start[b + 1]]``, with their cell coordinates ``cx``, ``cy`` (a bucket may
    hold several cells; callers compare coordinates). Boxes lie at or above the origin, so
    truncation is the floor.
    """
    n = lox.shape[0]
    x0 = np.empty(n, dtype=np.int64)
    x1 = np.empty(n, dtype=np.int64)
    y0 = np.empty(n, dtype=np.int64)
    y1 = np.empty(n, dtype=np.int64)
    total = 0
    for i in range(n):
        x0[i] = _cell(lox[i], origin_x, h)
        x1[i] = _cell(hix[i], origin_x, h)
        y0[i] = _cell(loy[i], origin_y, h)
        y1[i] = _cell(hiy[i], origin_y, h)
        total += (x1[i] - x0[i] + 1) * (y1[i] - y0[i] + 1)
    size = 1
    while size < total:  # load factor <= 1; int32 tables stay in cache (measured faster)
        size *= 2
    mask = size - 1
    start = np.zeros(size + 1, dtype=np.int32)
    for i in range(n):
        for ix in range(x0[i], x1[i] + 1):
            for iy in range(y0[i], y1[i] + 1):
                start[_cell_hash(ix, iy, mask) + 1] += 1
    for b in range(size):
        start[b + 1] += start[b]
    fill = start[:-1].copy()
    item = np.empty(total, dtype=np.int32)
    cx = np.empty(total, dtype=np.int32)
    cy = np.empty(total, dtype=np.int32)
    for i in range(n):
        for ix in range(x0[i], x1[i] + 1):
            for iy in range(y0[i], y1[i] + 1):
                b = _cell_hash(ix, iy, mask)
                k = fill[b]
                item[k] = i
                cx[k] = ix
                cy[k] = iy
                fill[b] = k + 1
    return start, item, cx, cy, mask


@njit(cache=True)
def _cell_size(lox, loy, hix, hiy):
    h = 0.0
    for i in range(lox.shape[0]):
        h = max(h, hix[i] - lox[i], hiy[i] - loy[i])
    if not h > 0.0:
        h = 1.0
    return h


@njit(cache=True)
def _segment_boxes(pos, pad):
    n = pos.shape[0] - 1
    lox = np.empty(n)
    loy = np.empty(n)
    hix = np.empty(n)
    hiy = np.empty(n)
    for i in range(n):
        lox[i] = min(pos[i, 0], pos[i + 1, 0]) - pad
        hix[i] = max(pos[i, 0], pos[i + 1, 0]) + pad
        loy[i] = min(pos[i, 1], pos[i + 1, 1]) - pad
        hiy[i] = max(pos[i, 1], pos[i + 1, 1]) + pad
    return lox, loy, hix, hiy


@njit(cache=True)
def _box_pairs(lox, loy, hix, hiy, min_gap):
    """All pairs ``i < j`` with ``j - i >= min_gap`` whose boxes overlap, each once.

    A pair is reported only from the cell holding the lower-left corner of the intersection of
    the two boxes, which both boxes overlap: no duplicates, no misses.
    """
    n = lox.shape[0]
    out = np.empty((max(16, 4 * n), 2), dtype=np.int64)
    m = 0
    if n == 0:
        return out[:0]
    ox = lox.min()
    oy = loy.min()
    h = _cell_size(lox, loy, hix, hiy)
    start, item, cx, cy, mask = _build_hash(lox, loy, hix, hiy, ox, oy, h)
    for i in range(n):
        x0 = _cell(lox[i], ox, h)
        x1 = _cell(hix[i], ox, h)
        y0 = _cell(loy[i], oy, h)
        y1 = _cell(hiy[i], oy, h)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                b = _cell_hash(ix, iy, mask)
                for k in range(start[b], start[b + 1]):
                    j = item[k]
                    if j - i < min_gap or cx[k] != ix or cy[k] != iy:
                        continue
                    if lox[j] > hix[i] or lox[i] > hix[j] or loy[j] > hiy[i] or loy[i] > hiy[j]:
                        continue
                    if _cell(max(lox[i], lox[j]), ox, h) != ix:
                        continue
                    if _cell(max(loy[i], loy[j]), oy, h) != iy:
                        continue
                    if m == out.shape[0]:
                        bigger = np.empty((2 * m, 2), dtype=np.int64)
                        bigger[:m] = out
                        out = bigger
                    out[m, 0] = i
                    out[m, 1] = j
                    m += 1
    return out[:m]


# --------------------------------------------------------------------------------------------
# Exact segment intersection
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _orient(ax, ay, bx, by, cx, cy):
    """Sign of the cross product (b - a) x (c - a), and whether that sign is certain."""
    l1, l2 = ax - cx, by - cy
    r1, r2 = ay - cy, bx - cx
    detleft = l1 * l2
    detright = r1 * r2
    # exactly zero only if a factor is: two distinct floats never differ by exactly 0 (gradual
    # underflow), but a product of tiny factors can underflow to 0
    if (l1 == 0.0 or l2 == 0.0) and (r1 == 0.0 or r2 == 0.0):
        return 0, True
    detsum = abs(detleft) + abs(detright)
    if detsum < 1e-280:  # near underflow Shewchuk's bound does not hold: decide exactly
        return 0, False
    det = detleft - detright
    bound = _CCW_ERRBOUND * detsum
    if det > bound:
        return 1, True
    if -det > bound:
        return -1, True
    return 0, False


@njit(cache=True)
def _within(a, b, c):
    # c lies in the closed interval spanned by a and b (exact: comparisons only)
    return min(a, b) <= c <= max(a, b)


@njit(cache=True)
def _decide(o1, o2, o3, o4, p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y):
    """Closed segments p1p2 and q1q2 intersect, given exact orientation signs.

    o1 = orient(p1, p2, q1), o2 = orient(p1, p2, q2), o3 = orient(q1, q2, p1),
    o4 = orient(q1, q2, p2).
    """
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    if o1 == 0 and _within(p1x, p2x, q1x) and _within(p1y, p2y, q1y):
        return True
    if o2 == 0 and _within(p1x, p2x, q2x) and _within(p1y, p2y, q2y):
        return True
    if o3 == 0 and _within(q1x, q2x, p1x) and _within(q1y, q2y, p1y):
        return True
    if o4 == 0 and _within(q1x, q2x, p2x) and _within(q1y, q2y, p2y):
        return True
    return False


@njit(cache=True)
def _intersect(pos, i, j):
    """(intersects, certain) for segments i and j (non-adjacent)."""
    p1x, p1y, p2x, p2y = pos[i, 0], pos[i, 1], pos[i + 1, 0], pos[i + 1, 1]
    q1x, q1y, q2x, q2y = pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1]
    o1, c1 = _orient(p1x, p1y, p2x, p2y, q1x, q1y)
    o2, c2 = _orient(p1x, p1y, p2x, p2y, q2x, q2y)
    o3, c3 = _orient(q1x, q1y, q2x, q2y, p1x, p1y)
    o4, c4 = _orient(q1x, q1y, q2x, q2y, p2x, p2y)
    if not (c1 and c2 and c3 and c4):
        return False, False
    return _decide(o1, o2, o3, o4, p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y), True


@njit(cache=True)
def _fold_back(pos, i):
    """(overlap, certain) for adjacent segments i, i + 1 folded exactly onto each other."""
    o, c = _orient(pos[i, 0], pos[i, 1], pos[i + 1, 0], pos[i + 1, 1], pos[i + 2, 0], pos[i + 2, 1])
    if not c:
        return False, False
    if o != 0:
        return False, True
    ux, uy = pos[i + 1, 0] - pos[i, 0], pos[i + 1, 1] - pos[i, 1]
    vx, vy = pos[i + 2, 0] - pos[i + 1, 0], pos[i + 2, 1] - pos[i + 1, 1]
    dot = ux * vx + uy * vy
    if dot < 0.0:
        return True, abs(dot) > 4.0 * _EPS * (abs(ux * vx) + abs(uy * vy))
    return False, dot > 4.0 * _EPS * (abs(ux * vx) + abs(uy * vy))


@njit(cache=True)
def _crossing_candidates(pos, stop_at_first):
    """Certain crossings and uncertain pairs (to be decided exactly), as index pairs."""
    lox, loy, hix, hiy = _segment_boxes(pos, 0.0)
    pairs = _box_pairs(lox, loy, hix, hiy, 1)
    hits = np.empty((pairs.shape[0], 2), dtype=np.int64)
    unsure = np.empty((pairs.shape[0], 2), dtype=np.int64)
    nh = 0
    nu = 0
    for k in range(pairs.shape[0]):
        i, j = pairs[k, 0], pairs[k, 1]
        if j == i + 1:
            hit, certain = _fold_back(pos, i)
        else:
            hit, certain = _intersect(pos, i, j)
        if not certain:
            unsure[nu, 0] = i
            unsure[nu, 1] = j
            nu += 1
        elif hit:
            hits[nh, 0] = i
            hits[nh, 1] = j
            nh += 1
            if stop_at_first:
                break
    return hits[:nh], unsure[:nu]


def _orient_exact(a, b, c):
    ax, ay, bx, by, cx, cy = (Fraction(float(v)) for v in (*a, *b, *c))
    det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return (det > 0) - (det < 0)


def _intersect_exact(pos: np.ndarray, i: int, j: int) -> bool:
    p1, p2, q1, q2 = pos[i], pos[i + 1], pos[j], pos[j + 1]
    if j == i + 1:  # adjacent: overlap only when folded back exactly along the same line
        if _orient_exact(p1, p2, q2) != 0:
            return False
        u, v = p2 - p1, q2 - q1
        return (
            Fraction(float(u[0])) * Fraction(float(v[0]))
            + Fraction(float(u[1])) * Fraction(float(v[1]))
            < 0
        )
    o = (
        _orient_exact(p1, p2, q1),
        _orient_exact(p1, p2, q2),
        _orient_exact(q1, q2, p1),
        _orient_exact(q1, q2, p2),
    )
    return bool(_decide.py_func(*o, *p1, *p2, *q1, *q2))


def _as_positions(positions) -> np.ndarray:
    """:func:`as_positions` (any number of nodes), C-contiguous for the Numba kernels."""
    return np.ascontiguousarray(as_positions(positions, min_nodes=0))


def find_crossings(positions) -> np.ndarray:
    """All pairs of segments of a wire that intersect, exactly.

    Segments are closed: touching counts as intersecting. Two non-adjacent segments
    (``j >= i + 2``) intersect when they share any point; two adjacent segments (``j == i + 1``)
    are reported only when folded back exactly onto each other (turning angle of π). Expected
    cost O(n) (spatial hash); orientation signs are certified by Shewchuk's error bound and the
    few uncertain ones recomputed in exact rational arithmetic.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``.

    Returns
    -------
    ndarray of int, shape (n_crossings, 2)
        Segment index pairs ``(i, j)`` with ``i < j``, sorted.

    Examples
    --------
    >>> import numpy as np
    >>> z = np.array([[0, 0], [1, 0], [1, 1], [0.5, -1]])   # the third segment cuts the first
    >>> find_crossings(z).tolist()
    [[0, 2]]
    >>> find_crossings([[0, 0], [1, 0], [2, 0]]).shape
    (0, 2)
    """
    pos = _as_positions(positions)
    if pos.shape[0] < 3:
        return np.empty((0, 2), dtype=np.int64)
    hits, unsure = _crossing_candidates(pos, False)
    extra = [(int(i), int(j)) for i, j in unsure if _intersect_exact(pos, int(i), int(j))]
    if extra:
        hits = np.concatenate([hits, np.array(extra, dtype=np.int64)])
    order = np.lexsort((hits[:, 1], hits[:, 0]))
    return hits[order]


def has_crossings(positions) -> bool:
    """Whether any two segments intersect (see :func:`find_crossings`); stops at the first.

    >>> has_crossings([[0, 0], [1, 0], [1, 1], [0.5, -1]])
    True
    """
    pos = _as_positions(positions)
    if pos.shape[0] < 3:
        return False
    hits, unsure = _crossing_candidates(pos, True)
    if hits.shape[0]:
        return True
    return any(_intersect_exact(pos, int(i), int(j)) for i, j in unsure)


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
    p1x, p1y, p2x, p2y = pos[i, 0], pos[i, 1], pos[i + 1, 0], pos[i + 1, 1]
    q1x, q1y, q2x, q2y = pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1]
    hit, certain = _intersect(pos, i, j)
    if hit or not certain:
        # "not certain" means within round-off of touching: the distance is zero to
        # working precision either way
        return 0.0
    d = _point_segment(p1x, p1y, q1x, q1y, q2x, q2y)[0]
    d = min(d, _point_segment(p2x, p2y, q1x, q1y, q2x, q2y)[0])
    d = min(d, _point_segment(q1x, q1y, p1x, p1y, p2x, p2y)[0])
    d = min(d, _point_segment(q2x, q2y, p1x, p1y, p2x, p2y)[0])
    return d


@njit(cache=True)
def _close_pairs(pos, cutoff):
    lox, loy, hix, hiy = _segment_boxes(pos, 0.5 * cutoff)
    pairs = _box_pairs(lox, loy, hix, hiy, 2)
    keep = np.empty(pairs.shape[0], dtype=np.bool_)
    dist = np.empty(pairs.shape[0])
    for k in range(pairs.shape[0]):
        dist[k] = _segment_segment(pos, pairs[k, 0], pairs[k, 1])
        keep[k] = dist[k] < cutoff
    return pairs[keep], dist[keep]


def close_segment_pairs(positions, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of non-adjacent segments closer than ``cutoff``, with their distances.

    Non-adjacent means ``j >= i + 2``. Crossing segments have distance 0.

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
    pairs, dist = _close_pairs(pos, float(cutoff))
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
    """
    pos = _as_positions(positions)
    n = pos.shape[0] - 1
    if not (0 <= i < n and 0 <= j < n) or abs(i - j) < 2:
        raise ValueError(f"need two non-adjacent segments of {n}, got {i} and {j}")
    return float(_segment_segment(pos, int(i), int(j)))


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
# Continuous collision detection: how far may every node move along a direction
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


@njit(cache=True)
def _first_contact_collinear(e0x, e0y, dex, dey, q0x, q0y, dqx, dqy):
    """First contact of a point and a segment that stay on one common line.

    Along a unit vector u of that line, the point is at P(t) = q(t)·u and the segment spans
    [0, E(t)] with E(t) = e(t)·u (both linear in t, relative to the segment's start): contact
    when P lies between 0 and E, first at t = 0 or where P = 0 or P = E.
    """
    ux, uy = e0x, e0y
    for vx, vy in ((q0x, q0y), (dqx, dqy), (dex, dey)):
        if vx * vx + vy * vy > ux * ux + uy * uy:
            ux, uy = vx, vy
    norm = np.sqrt(ux * ux + uy * uy)
    if norm == 0.0:
        return 0.0  # everything at one point
    ux, uy = ux / norm, uy / norm
    p0, dp = q0x * ux + q0y * uy, dqx * ux + dqy * uy
    s0, ds = e0x * ux + e0y * uy, dex * ux + dey * uy
    best = 2.0
    cands = np.array([0.0, -p0 / dp if dp != 0.0 else 2.0,
                      (s0 - p0) / (dp - ds) if dp != ds else 2.0])  # fmt: skip
    for t in cands:
        if 0.0 <= t <= 1.0:
            pt, st = p0 + t * dp, s0 + t * ds
            tol = 1e-12 * (abs(pt) + abs(st))
            if min(0.0, st) - tol <= pt <= max(0.0, st) + tol:
                best = min(best, t)
    return best


@njit(cache=True)
def _first_contact(p0x, p0y, dpx, dpy, a0x, a0y, dax, day, b0x, b0y, dbx, dby):
    """Earliest t in [0, 1] at which point p(t) lies on segment a(t)b(t), or 2.0 if none.

    Collinearity of p - a with b - a is a quadratic in t; each root in [0, 1] is a contact when
    the projection parameter lies in [0, 1] (widened by 1e-9 to stay on the safe side).
    """
    e0x, e0y = b0x - a0x, b0y - a0y
    dex, dey = dbx - dax, dby - day
    q0x, q0y = p0x - a0x, p0y - a0y
    dqx, dqy = dpx - dax, dpy - day
    c = _cross(e0x, e0y, q0x, q0y)
    b = _cross(e0x, e0y, dqx, dqy) + _cross(dex, dey, q0x, q0y)
    a = _cross(dex, dey, dqx, dqy)
    roots = np.empty(2)
    nr = 0
    scale = abs(a) + abs(b) + abs(c)
    if scale == 0.0:
        return _first_contact_collinear(e0x, e0y, dex, dey, q0x, q0y, dqx, dqy)
    if abs(a) <= 1e-14 * scale:
        if b != 0.0:
            roots[0] = -c / b
            nr = 1
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            sq = np.sqrt(disc)
            q = -0.5 * (b + sq) if b >= 0.0 else -0.5 * (b - sq)
            r1 = q / a
            r2 = c / q if q != 0.0 else r1
            roots[0] = min(r1, r2)
            roots[1] = max(r1, r2)
            nr = 2
    for k in range(nr):
        t = roots[k]
        if t < 0.0 or t > 1.0:
            continue
        ex, ey = e0x + t * dex, e0y + t * dey
        qx, qy = q0x + t * dqx, q0y + t * dqy
        ee = ex * ex + ey * ey
        s = (qx * ex + qy * ey) / ee if ee > 0.0 else 0.0
        if -1e-9 <= s <= 1.0 + 1e-9:
            return t
    return 2.0


@njit(cache=True)
def _max_safe_fraction(pos, step):
    """Largest t in (0, 1] such that moving pos by t * step causes no node-segment contact."""
    n = pos.shape[0]
    ns = n - 1
    lox = np.empty(ns)
    loy = np.empty(ns)
    hix = np.empty(ns)
    hiy = np.empty(ns)
    for i in range(ns):
        lox[i] = min(
            pos[i, 0], pos[i + 1, 0], pos[i, 0] + step[i, 0], pos[i + 1, 0] + step[i + 1, 0]
        )
        hix[i] = max(
            pos[i, 0], pos[i + 1, 0], pos[i, 0] + step[i, 0], pos[i + 1, 0] + step[i + 1, 0]
        )
        loy[i] = min(
            pos[i, 1], pos[i + 1, 1], pos[i, 1] + step[i, 1], pos[i + 1, 1] + step[i + 1, 1]
        )
        hiy[i] = max(
            pos[i, 1], pos[i + 1, 1], pos[i, 1] + step[i, 1], pos[i + 1, 1] + step[i + 1, 1]
        )
    ox = lox.min()
    oy = loy.min()
    h = _cell_size(lox, loy, hix, hiy)
    start, item, cx, cy, mask = _build_hash(lox, loy, hix, hiy, ox, oy, h)
    tmin = 2.0
    for k in range(n):
        plx = min(pos[k, 0], pos[k, 0] + step[k, 0])
        phx = max(pos[k, 0], pos[k, 0] + step[k, 0])
        ply = min(pos[k, 1], pos[k, 1] + step[k, 1])
        phy = max(pos[k, 1], pos[k, 1] + step[k, 1])
        x0 = _cell(plx, ox, h)
        x1 = _cell(phx, ox, h)
        y0 = _cell(ply, oy, h)
        y1 = _cell(phy, oy, h)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                bkt = _cell_hash(ix, iy, mask)
                for e in range(start[bkt], start[bkt + 1]):
                    j = item[e]
                    if j == k or j + 1 == k or cx[e] != ix or cy[e] != iy:
                        continue
                    if lox[j] > phx or plx > hix[j] or loy[j] > phy or ply > hiy[j]:
                        continue
                    t = _first_contact(
                        pos[k, 0], pos[k, 1], step[k, 0], step[k, 1],
                        pos[j, 0], pos[j, 1], step[j, 0], step[j, 1],
                        pos[j + 1, 0], pos[j + 1, 1], step[j + 1, 0], step[j + 1, 1],
                    )  # fmt: skip
                    tmin = min(tmin, t)
    return min(tmin, 1.0)


def max_safe_fraction(positions, step) -> float:
    """Continuous collision detection along a straight path.

    The largest ``t`` in ``[0, 1]`` such that no node touches a segment it does not belong to
    while the wire moves from ``positions`` to ``positions + t' * step`` for every ``t' < t``.
    In the plane, two segments can begin to cross only through such a node-segment contact,
    so a crossing-free wire stays crossing-free along the whole path up to ``t``. Returns 1.0
    when the whole step is safe.

    Parameters
    ----------
    positions, step : array_like, shape (n_nodes, 2)
        Start configuration and displacement ``[length]``.

    Examples
    --------
    >>> pos = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.5, 1.0], [0.5, 0.5]])
    >>> step = np.zeros_like(pos); step[4] = [0.0, -1.0]          # last node dives through
    >>> round(max_safe_fraction(pos, step), 6)                     # segment 0 at y = 0
    0.5
    """
    pos = _as_positions(positions)
    stp = _as_positions(step)
    if stp.shape != pos.shape:
        raise ValueError(f"step has shape {stp.shape}, positions {pos.shape}")
    if pos.shape[0] < 3:
        return 1.0
    return float(_max_safe_fraction(pos, stp))


def disc_exit_fraction(positions, step, radius: float) -> float:
    """Continuous collision detection against a circle: the largest ``t`` in ``[0, 1]`` such
    that every node stays strictly inside the disc ``|x| < radius`` (centred at the origin)
    while the wire moves from ``positions`` to ``positions + t' * step``, ``t' < t``.

    Node i leaves at the positive root of ``|x_i + t p_i|² = radius²`` (one positive root,
    since the start is inside). The disc is convex, so a segment whose two ends are inside
    lies inside: testing the nodes is enough. Returns 1.0 when the whole step stays inside.

    Parameters
    ----------
    positions, step : array_like, shape (n_nodes, 2)
        Start configuration (every node inside) and displacement ``[length]``.
    radius : float
        Radius of the disc ``[length]``.

    Examples
    --------
    >>> round(disc_exit_fraction([[0.5, 0.0]], [[1.0, 0.0]], 1.0), 12)   # reaches x = 1 at t = ½
    0.5
    >>> disc_exit_fraction([[0.5, 0.0]], [[-1.0, 0.0]], 1.0)              # inward: whole step
    1.0
    """
    pos = _as_positions(positions)
    stp = _as_positions(step)
    if stp.shape != pos.shape:
        raise ValueError(f"step has shape {stp.shape}, positions {pos.shape}")
    a = np.einsum("ij,ij->i", stp, stp)
    b = np.einsum("ij,ij->i", pos, stp)
    c = np.einsum("ij,ij->i", pos, pos) - float(radius) ** 2  # < 0 inside
    moving = a > 0
    if not np.any(moving):
        return 1.0
    a, b, c = a[moving], b[moving], c[moving]
    root = np.sqrt(np.maximum(b * b - a * c, 0.0))
    # the positive root of a t² + 2 b t + c, written without cancellation
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(b > 0, -c / (b + root), (root - b) / a)
    t = np.where(c < 0, t, 0.0)  # a node already on or outside the circle: no safe step
    return float(min(1.0, np.min(t)))


# --------------------------------------------------------------------------------------------
# Node-segment pairs within a distance (the hard core's neighbour list)
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _node_segment_pairs(pos, cutoff):
    """Pairs (node k, segment j) closer than ``cutoff`` whose segments are non-adjacent.

    Node k belongs to segments k - 1 and k; the pair is kept when segment j is non-adjacent
    (``|a - j| >= 2``) to at least one segment a that holds k. Each segment is inserted in every
    cell its box (padded by the cutoff) overlaps, so a node queries its own cell only and finds
    each pair once. The boxes are copied in table order so that a query reads memory
    sequentially.
    """
    n = pos.shape[0]
    ns = n - 1
    lox, loy, hix, hiy = _segment_boxes(pos, cutoff)
    ox = lox.min()
    oy = loy.min()
    h = _cell_size(lox, loy, hix, hiy)
    start, item, cx, cy, mask = _build_hash(lox, loy, hix, hiy, ox, oy, h)
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
        ix = _cell(px, ox, h)
        iy = _cell(py, oy, h)
        bkt = _cell_hash(ix, iy, mask)
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
