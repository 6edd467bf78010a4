"""Exact segment intersection: Shewchuk's static bound, then exact expansions or rationals.

The minimiser's test (:func:`_intersect`) sends what the static bound cannot certify to
rational arithmetic in Python; the observables' (:func:`_meet`) decide it in compiled exact
expansions first.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._input import _as_positions
from .cells import CROWD, _segment_boxes, _segment_pairs

# Shewchuk's bound for orient2d: a float determinant larger than this (times the sum of the
# magnitudes of its two products) has the right sign. eps = 2**-53 is the unit round-off.
_EPS = 2.0**-53
_CCW_ERRBOUND = (3.0 + 16.0 * _EPS) * _EPS


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


# Beyond the static bound: the determinant as an exact sum of floats (Shewchuk, "Adaptive
# precision floating-point arithmetic and fast robust geometric predicates", 1997). Exact
# while no product's error term underflows and nothing overflows, which these bounds ensure:
# a product of at least 1e-288 has its error term a multiple of at least 2**-1074 (TwoProduct
# first fails below ~2e-292), and parts below 1e150 keep every product and split finite. The
# kernels below rely on IEEE arithmetic as written: they must never be compiled with fastmath
# (a fused multiply-add in the split breaks it).
_SPLITTER = 134217729.0  # 2**27 + 1: splits a double into two halves of 26 bits
_EXACT_MAX = 1e150  # |a coordinate difference| above this: products may overflow
_EXACT_TINY = 1e-288  # a nonzero product below this: its error term may underflow


@njit(cache=True)
def _two_sum(a, b):
    """x + y = a + b exactly, x = fl(a + b) (Knuth's TwoSum), barring overflow."""
    x = a + b
    bv = x - a
    av = x - bv
    return x, (a - av) + (b - bv)


@njit(cache=True)
def _two_product(a, b):
    """x + y = a b exactly, x = fl(a b) (Dekker's product by Veltkamp's split), within the
    bounds above (no overflow; |x| >= 1e-288 or a factor zero)."""
    x = a * b
    c = _SPLITTER * a
    ahi = c - (c - a)
    alo = a - ahi
    c = _SPLITTER * b
    bhi = c - (c - b)
    blo = b - bhi
    return x, alo * blo - (((x - ahi * bhi) - alo * bhi) - ahi * blo)


@njit(cache=True)
def _orient_expansion(ax, ay, bx, by, cx, cy):
    """(sign, certain) of (ax - cx)(by - cy) - (ay - cy)(bx - cx), in exact arithmetic.

    Each difference is two floats (TwoSum). Where the four are exact and so are the two
    products (integer coordinates, a pixel grid's), the sign is that of comparing the
    products. Else each of the eight products of the parts is two more floats (TwoProduct):
    the determinant is exactly the sum of these 16, which Shewchuk's Grow-Expansion turns into
    a nonoverlapping expansion whose largest nonzero component has the sum's sign. Not
    certain, (0, False), only outside the bounds above: a difference above 1e150, or a nonzero
    product of parts below 1e-288.
    """
    l1, l1t = _two_sum(ax, -cx)
    l2, l2t = _two_sum(by, -cy)
    r1, r1t = _two_sum(ay, -cy)
    r2, r2t = _two_sum(bx, -cx)
    if max(abs(l1), abs(l2), abs(r1), abs(r2)) > _EXACT_MAX:
        return 0, False
    if l1t == 0.0 and l2t == 0.0 and r1t == 0.0 and r2t == 0.0:
        x1, y1 = _two_product(l1, l2)
        x2, y2 = _two_product(r1, r2)
        small = (l1 != 0.0 and l2 != 0.0 and abs(x1) < _EXACT_TINY) or (
            r1 != 0.0 and r2 != 0.0 and abs(x2) < _EXACT_TINY
        )
        if y1 == 0.0 and y2 == 0.0 and not small:
            return (1 if x1 > x2 else (-1 if x1 < x2 else 0)), True
    left = ((l1, l2), (l1, l2t), (l1t, l2), (l1t, l2t))
    right = ((r1, r2), (r1, r2t), (r1t, r2), (r1t, r2t))
    terms = np.empty(16)
    for k in range(4):
        for side in range(2):
            u, v = left[k] if side == 0 else right[k]
            x, y = _two_product(u, v)
            if u != 0.0 and v != 0.0 and abs(x) < _EXACT_TINY:
                return 0, False
            sign = 1.0 if side == 0 else -1.0
            terms[4 * k + 2 * side] = sign * x
            terms[4 * k + 2 * side + 1] = sign * y
    e = np.empty(16)
    for m in range(16):  # Grow-Expansion: e[:m] stays nonoverlapping, smallest first
        q = terms[m]
        for i in range(m):
            q, e[i] = _two_sum(q, e[i])
        e[m] = q
    for i in range(15, -1, -1):
        if e[i] != 0.0:
            return (1 if e[i] > 0.0 else -1), True
    return 0, True


@njit(cache=True)
def _orient_sure(ax, ay, bx, by, cx, cy):
    """:func:`_orient`, its uncertain signs decided exactly (:func:`_orient_expansion`).

    Uncertain only beyond the expansion's bounds: differences above 1e150, or products of
    their parts below 1e-288, which needs a nonzero coordinate below ~1e-128 in magnitude
    (subnormals among them).
    """
    o, certain = _orient(ax, ay, bx, by, cx, cy)
    if certain:
        return o, True
    return _orient_expansion(ax, ay, bx, by, cx, cy)


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
def _meet(p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y):
    """(share a point, certain) for closed segments p1p2 and q1q2, by exact signs.

    The signs are :func:`_orient_sure`'s: uncertain only beyond its bounds. Off the
    minimiser's path, which keeps the static bound alone (:func:`_intersect`).
    """
    o1, c1 = _orient_sure(p1x, p1y, p2x, p2y, q1x, q1y)
    o2, c2 = _orient_sure(p1x, p1y, p2x, p2y, q2x, q2y)
    o3, c3 = _orient_sure(q1x, q1y, q2x, q2y, p1x, p1y)
    o4, c4 = _orient_sure(q1x, q1y, q2x, q2y, p2x, p2y)
    if not (c1 and c2 and c3 and c4):
        return False, False
    return _decide(o1, o2, o3, o4, p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y), True


@njit(cache=True)
def _fold_back(pos, i):
    """(overlap, certain) for adjacent segments i, i + 1 folded exactly onto each other."""
    o, c = _orient(pos[i, 0], pos[i, 1], pos[i + 1, 0], pos[i + 1, 1], pos[i + 2, 0], pos[i + 2, 1])
    if c and o != 0:
        return False, True
    ux, uy = pos[i + 1, 0] - pos[i, 0], pos[i + 1, 1] - pos[i, 1]
    vx, vy = pos[i + 2, 0] - pos[i + 1, 0], pos[i + 2, 1] - pos[i + 1, 1]
    dot = ux * vx + uy * vy
    if not c:
        # collinear or not, the segments cannot fold back where they certainly point the same
        # way: the exact dot product of the exact differences is then positive (rounded
        # differences, products and sum: an error below 4 eps (|ux vx| + |uy vy|); 8 here, and
        # away from underflow). A nearly straight wire is decided here, not exactly in Python.
        mag = abs(ux * vx) + abs(uy * vy)
        return False, mag > 1e-280 and dot > 8.0 * _EPS * mag
    if dot < 0.0:
        return True, abs(dot) > 4.0 * _EPS * (abs(ux * vx) + abs(uy * vy))
    return False, dot > 4.0 * _EPS * (abs(ux * vx) + abs(uy * vy))


#: Up to this many segments the crossing check finds the pairs of overlapping boxes by a sweep
#: along x (:func:`_sweep_pairs`), above it by the spatial hash (``cells._segment_pairs``). The
#: sweep lists every pair whose boxes overlap, as the one-cell hash does (the chunked hash, on a
#: crowded wire of unlike segments, lists a subset that still holds every intersecting pair).
#: Measured on packed wires (λ = 300): the sweep 2.7–2.9× faster at N = 100 … 1000 (2.9
#: against 7.9 µs at N = 100, 27.7 against 79.7 µs at 1000); its cost grows as the pairs
#: overlapping in x alone, faster than N in a dense packing, so the hash keeps large wires.
#: Read when the kernel compiles.
SWEEP_MAX = 1024


@njit(cache=True)
def _sweep_pairs(pos):
    """All pairs (p, q), p < q, of segments whose closed bounding boxes overlap: the boxes
    sorted by their left edge, each compared with those that start before its right edge ends.
    In no particular order; a first row (-1, -1) where a coordinate is not finite (the
    caller then takes the hash, whatever such a wire gives there)."""
    for k in range(pos.shape[0]):
        if not (np.isfinite(pos[k, 0]) and np.isfinite(pos[k, 1])):
            return np.full((1, 2), -1, dtype=np.int64)
    n = pos.shape[0] - 1
    lox, loy, hix, hiy = _segment_boxes(pos, 0.0)
    order = np.argsort(lox)
    out = np.empty((4 * n + 16, 2), dtype=np.int64)
    m = 0
    for a in range(n):
        p = order[a]
        for b in range(a + 1, n):
            q = order[b]
            if lox[q] > hix[p]:  # this box, and every later one, starts right of p's
                break
            if loy[p] > hiy[q] or loy[q] > hiy[p]:
                continue
            if m == out.shape[0]:
                bigger = np.empty((2 * m, 2), dtype=np.int64)
                bigger[:m] = out
                out = bigger
            out[m, 0] = min(p, q)
            out[m, 1] = max(p, q)
            m += 1
    return out[:m]


@njit(cache=True)
def _crossing_candidates(pos, stop_at_first):
    """Certain crossings and uncertain pairs (to be decided exactly), as index pairs."""
    swept = pos.shape[0] <= SWEEP_MAX + 1
    pairs = _sweep_pairs(pos) if swept else np.empty((0, 2), dtype=np.int64)
    if not swept or (pairs.shape[0] and pairs[0, 0] < 0):  # long, or a coordinate not finite
        pairs = _segment_pairs(pos[:-1, 0], pos[:-1, 1], pos[1:, 0], pos[1:, 1], 0.0, 1, 0, CROWD)
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


def _as_integers(*values) -> list[int]:
    """Floats as integers over one common power of two (v_k = n_k / 2^s, exactly): signs of
    sums and products of them are those of the rationals, in fast integer arithmetic."""
    ratios = [float(v).as_integer_ratio() for v in values]  # denominators: powers of two
    den = max(d for _, d in ratios)
    return [num * (den // d) for num, d in ratios]


def _orient_int(ax, ay, bx, by, cx, cy) -> int:
    det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return (det > 0) - (det < 0)


def _orient_exact(a, b, c):
    return _orient_int(*_as_integers(*a, *b, *c))


def _intersect_exact(pos: np.ndarray, i: int, j: int) -> bool:
    p1, p2, q1, q2 = pos[i], pos[i + 1], pos[j], pos[j + 1]
    if j == i + 1:  # adjacent: overlap only when folded back exactly along the same line
        if _orient_exact(p1, p2, q2) != 0:
            return False
        u, v = p2 - p1, q2 - q1
        ux, uy, vx, vy = _as_integers(*u, *v)
        return ux * vx + uy * vy < 0
    ax, ay, bx, by, cx, cy, dx, dy = _as_integers(*p1, *p2, *q1, *q2)
    o = (
        _orient_int(ax, ay, bx, by, cx, cy),
        _orient_int(ax, ay, bx, by, dx, dy),
        _orient_int(cx, cy, dx, dy, ax, ay),
        _orient_int(cx, cy, dx, dy, bx, by),
    )
    return bool(_decide.py_func(*o, *p1, *p2, *q1, *q2))


def find_crossings(positions) -> np.ndarray:
    """All pairs of segments of a wire that intersect, exactly.

    Segments are closed: touching counts as intersecting. Two non-adjacent segments
    (``j >= i + 2``) intersect when they share any point; two adjacent segments (``j == i + 1``)
    are reported only when folded back exactly onto each other (turning angle of π). Expected
    cost O(n) (a spatial hash; up to ``SWEEP_MAX`` segments a sweep, faster there); orientation
    signs are certified by Shewchuk's error bound and the few uncertain ones recomputed in
    exact rational arithmetic.

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
    return _has_crossings(_as_positions(positions))


def _has_crossings(pos: np.ndarray) -> bool:
    """:func:`has_crossings` of a checked, C-contiguous float array (the minimiser's hot path)."""
    if pos.shape[0] < 3:
        return False
    hits, unsure = _crossing_candidates(pos, True)
    if hits.shape[0]:
        return True
    return unsure.shape[0] > 0 and any(_intersect_exact(pos, int(i), int(j)) for i, j in unsure)
