"""Continuous collision detection: how far every node may move along a direction.

Two broad phases with one narrow phase, so one answer: the spatial hash of swept boxes, and for
steps long against the segments a tree along the chain (below).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._input import _as_positions
from .cells import _build_hash, _cell, _cell_hash, _cell_size
from .distance import _node_segment_pairs, _point_segment

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
def _node_segment_contact(pos, step, k, j):
    """:func:`_first_contact` of node k and segment j (nodes j, j + 1) moving by ``step``."""
    return _first_contact(
        pos[k, 0], pos[k, 1], step[k, 0], step[k, 1],
        pos[j, 0], pos[j, 1], step[j, 0], step[j, 1],
        pos[j + 1, 0], pos[j + 1, 1], step[j + 1, 0], step[j + 1, 1],
    )  # fmt: skip


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
                    tmin = min(tmin, _node_segment_contact(pos, step, k, j))
    return min(tmin, 1.0)


# --------------------------------------------------------------------------------------------
# The tree for long steps of long wires
# --------------------------------------------------------------------------------------------
# The hash above takes as its cell the largest swept box. A step that moves the whole wire far
# against its segment length (the buckling mode of a long wire moves every node by hundreds of
# segments) then puts hundreds of segments in every cell, and the test costs N times that
# (measured: 0.45 s per call for a smooth step of 0.01 at N = 5 × 10⁴, 17 s for a rigid
# translation by 100 segments). Yet two pieces of the wire can meet only through their
# relative motion, and a smooth step moves neighbouring pieces almost together.
#
# The tree cuts the chain into leaves of ``TREE_LEAF`` consecutive segments, held in a binary
# tree over contiguous runs of leaves; each tree node has the box of its nodes' positions and
# the box of their displacements. A node of A and a segment of B can touch at some t in [0, 1]
# only if 0 is in (A - B) + t (D_A - D_B), the Minkowski differences of the boxes (a point of
# a segment and its displacement are one convex combination of its ends'): a test in t per
# axis. Pairs of tree nodes that fail it are dropped with all their descendants; pairs of
# leaves that pass get the hash's narrow phase, with its swept-box filter. The candidates are
# the hash's, less pairs that cannot meet, so the fraction is the same number (tested; within
# float64's working range: beyond |x| ~ 1e75 the narrow phase's squares overflow, and the two can
# differ on pairs whose narrow-phase answer is already garbage).


#: Segments per leaf of the tree (``benchmarks/bench_ccd.py``, N = 10² … 5 × 10⁴, a loaded
#: machine: no leaf is the best on every step; 4 is within 2.5× of the best of 1, 2, 4 and 8 on
#: each step tried; at 5 × 10⁴ a call at 4 costs ~50 ms, a smooth stage's iteration ~1 s).
TREE_LEAF = 4
#: The tree is used where the largest displacement component exceeds this many mean segment
#: extents (the max-norm, as ``_safe_fraction_kernel`` measures both). The hash's cost grows
#: with it, the tree's does not; measured: below ~4 the hash is up to 3× faster on a packed
#: spiral, above it the tree, by 10–10³× for steps of 10² segments.
TREE_ABOVE = 4.0


@njit(cache=True)
def _leaf_boxes(pos, step, leaf, size):
    """Position and displacement boxes of the ``size`` leaves (empty boxes past the chain's
    end) in a heap-ordered tree of 2 ``size`` slots (slot 1 the root, leaves from ``size``)."""
    n = pos.shape[0]
    ns = n - 1
    box = np.empty((2 * size, 8))  # plo x, y, phi x, y, dlo x, y, dhi x, y
    for s in range(2 * size):
        for c in range(4):
            box[s, c] = np.inf if c < 2 else -np.inf
            box[s, 4 + c] = np.inf if c < 2 else -np.inf
    for lf in range((ns + leaf - 1) // leaf):
        b = box[size + lf]
        for k in range(lf * leaf, min((lf + 1) * leaf, ns) + 1):  # nodes of its segments
            for c in range(2):
                b[c] = min(b[c], pos[k, c])
                b[2 + c] = max(b[2 + c], pos[k, c])
                b[4 + c] = min(b[4 + c], step[k, c])
                b[6 + c] = max(b[6 + c], step[k, c])
    for s in range(size - 1, 0, -1):
        for c in range(8):
            if c % 4 < 2:
                box[s, c] = min(box[2 * s, c], box[2 * s + 1, c])
            else:
                box[s, c] = max(box[2 * s, c], box[2 * s + 1, c])
    return box


@njit(cache=True)
def _half_line(a, b, t0, t1):
    """[t0, t1] ∩ {t : a + b t <= 0}, as (t0, t1) (empty when t0 > t1)."""
    if b > 0.0:
        t1 = min(t1, -a / b)
    elif b < 0.0:
        t0 = max(t0, -a / b)
    elif a > 0.0:
        t0 = 2.0
    return t0, t1


@njit(cache=True)
def _may_meet(box, a, b):
    """Whether some point of tree node ``a`` and some point of ``b`` can coincide at some
    t ∈ [0, 1]: 0 ∈ [S_lo + t R_lo, S_hi + t R_hi] on both axes, S the boxes' Minkowski
    difference and R their displacements', widened by 10⁻⁸ of their extent (the narrow phase
    accepts a point 10⁻⁹ of a segment beyond its ends)."""
    if box[a, 0] > box[a, 2] or box[b, 0] > box[b, 2]:
        return False  # an empty slot past the chain's end
    t0, t1 = 0.0, 1.0
    for c in range(2):
        slo = box[a, c] - box[b, 2 + c]
        shi = box[a, 2 + c] - box[b, c]
        rlo = box[a, 4 + c] - box[b, 6 + c]
        rhi = box[a, 6 + c] - box[b, 4 + c]
        tol = 1e-8 * (shi - slo + rhi - rlo) + 1e-300
        t0, t1 = _half_line(slo - tol, rlo, t0, t1)  # S_lo + t R_lo <= 0
        t0, t1 = _half_line(-(shi + tol), -rhi, t0, t1)  # S_hi + t R_hi >= 0
        if t0 > t1 + 1e-12:
            return False
    return True


@njit(cache=True)
def _swept_boxes(pos, step):
    """The swept boxes of the nodes (rows 0–3 of ``node``: lo x, lo y, hi x, hi y) and of the
    segments, as the hash version forms them."""
    n = pos.shape[0]
    node = np.empty((n, 4))
    seg = np.empty((n - 1, 4))
    for k in range(n):
        for c in range(2):
            node[k, c] = min(pos[k, c], pos[k, c] + step[k, c])
            node[k, 2 + c] = max(pos[k, c], pos[k, c] + step[k, c])
    for j in range(n - 1):
        for c in range(2):
            seg[j, c] = min(pos[j, c], pos[j + 1, c], pos[j, c] + step[j, c],
                            pos[j + 1, c] + step[j + 1, c])  # fmt: skip
            seg[j, 2 + c] = max(pos[j, c], pos[j + 1, c], pos[j, c] + step[j, c],
                                pos[j + 1, c] + step[j + 1, c])  # fmt: skip
    return node, seg


@njit(cache=True)
def _leaf_pair(pos, step, node, seg, leaf, la, lb, tmin):
    """The narrow phase of leaves ``la`` <= ``lb``: every node of one against every segment of
    the other (each ordered pair once), with the hash version's filters; the smaller of
    ``tmin`` and the first contact."""
    ns = pos.shape[0] - 1
    for side in range(2 if la != lb else 1):
        ln, lsg = (la, lb) if side == 0 else (lb, la)
        k_end = (ln + 1) * leaf if (ln + 1) * leaf < ns else ns + 1
        for k in range(ln * leaf, k_end):  # the nodes of leaf ln (the last leaf: the end node)
            for j in range(lsg * leaf, min((lsg + 1) * leaf, ns)):
                if j == k or j + 1 == k:
                    continue
                if (seg[j, 0] > node[k, 2] or node[k, 0] > seg[j, 2] or seg[j, 1] > node[k, 3]
                        or node[k, 1] > seg[j, 3]):  # fmt: skip
                    continue
                tmin = min(tmin, _node_segment_contact(pos, step, k, j))
    return tmin


@njit(cache=True)
def _max_safe_fraction_tree(pos, step, leaf):
    """:func:`_max_safe_fraction` by the tree, with leaves of ``leaf`` segments: the same
    number."""
    ns = pos.shape[0] - 1
    leaves = (ns + leaf - 1) // leaf
    size = 1
    while size < leaves:
        size *= 2
    box = _leaf_boxes(pos, step, leaf, size)
    node, seg = _swept_boxes(pos, step)
    stack = np.empty((64 * 3 + 16, 2), dtype=np.int64)
    stack[0, 0] = stack[0, 1] = 1
    top = 1
    tmin = 2.0
    while top > 0:
        top -= 1
        a, b = stack[top, 0], stack[top, 1]
        if not _may_meet(box, a, b):
            continue
        if a >= size:  # both leaves (pairs are always of one depth)
            tmin = _leaf_pair(pos, step, node, seg, leaf, a - size, b - size, tmin)
            continue
        if top + 4 > stack.shape[0]:
            bigger = np.empty((2 * stack.shape[0], 2), dtype=np.int64)
            bigger[:top] = stack[:top]
            stack = bigger
        if a == b:
            for u, v in ((2 * a, 2 * a), (2 * a, 2 * a + 1), (2 * a + 1, 2 * a + 1)):
                stack[top, 0], stack[top, 1] = u, v
                top += 1
        else:
            for u, v in ((2 * a, 2 * b), (2 * a, 2 * b + 1), (2 * a + 1, 2 * b),
                         (2 * a + 1, 2 * b + 1)):  # fmt: skip
                stack[top, 0], stack[top, 1] = u, v
                top += 1
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
    return _safe_fraction(pos, stp)


def _safe_fraction(pos: np.ndarray, step: np.ndarray) -> float:
    """:func:`max_safe_fraction` of checked float arrays of one shape (n_nodes, 2), without
    the checks: the minimiser's hot path, where both are its own finite arrays."""
    if pos.shape[0] < 3:
        return 1.0
    return float(_safe_fraction_kernel(pos, step, TREE_ABOVE, TREE_LEAF))


@njit(cache=True)
def _safe_fraction_kernel(pos, step, above, leaf):
    """The hash for steps below ``above`` mean segment lengths (in the max norm of both, no
    square roots on the hot path), else the tree (the same number)."""
    n = pos.shape[0]
    length = 0.0
    for i in range(n - 1):
        length += max(abs(pos[i + 1, 0] - pos[i, 0]), abs(pos[i + 1, 1] - pos[i, 1]))
    biggest = 0.0
    for i in range(n):
        biggest = max(biggest, abs(step[i, 0]), abs(step[i, 1]))
    if biggest > above * length / (n - 1):
        return _max_safe_fraction_tree(pos, step, leaf)
    return _max_safe_fraction(pos, step)


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
# Where to stop a step that collision detection cuts: the touching pairs brought to a gap
# --------------------------------------------------------------------------------------------


def approach_fraction(positions, step, t: float, gap: float) -> float:
    """Where to stop a straight step short of a contact: the touching pairs ``gap`` apart.

    The node-segment pairs that touch at the fraction ``t`` of the step (a contact fraction
    of :func:`max_safe_fraction`) are those closer than ``gap / 2`` at
    ``positions + t * step``; the fraction returned is a point of ``[0, t)`` at which the
    nearest of them is ``gap`` apart, found by bisection (the first such point where their
    distance falls monotonically; where it does not, one of them). A step cut at a fixed
    fraction of the contact (0.8 t, say) leaves a pair that was far at a fifth of its gap,
    and the next step, cut again, at a fifth of that: a contact far from the start costs
    several cut steps. Stopped at ``gap`` it costs one.

    Parameters
    ----------
    positions, step : array_like, shape (n_nodes, 2)
        Start configuration and displacement ``[length]``.
    t : float
        The contact fraction, in ``(0, 1]``.
    gap : float
        The distance to stop the touching pairs at ``[length]``, positive.

    Returns
    -------
    float
        The fraction, below ``t``; 0.0 where no pair is found closer than ``gap / 2`` at ``t``
        (the cut was not a pair's: a wall's, say) or one of them is within ``gap`` already at
        the start.

    Raises
    ------
    ValueError
        If the shapes differ, or ``t`` or ``gap`` is out of range.

    Examples
    --------
    >>> pos = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.5, 1.0], [0.5, 0.5]])
    >>> step = np.zeros_like(pos); step[4] = [0.0, -1.0]   # the last node meets y = 0 at 0.5
    >>> round(approach_fraction(pos, step, 0.5, 0.1), 6)     # and is 0.1 above it at 0.4
    0.4
    """
    pos = _as_positions(positions)
    stp = _as_positions(step)
    if stp.shape != pos.shape:
        raise ValueError(f"step has shape {stp.shape}, positions {pos.shape}")
    if not (0.0 < t <= 1.0 and gap > 0.0):
        raise ValueError(f"need 0 < t <= 1 and gap > 0, got t = {t!r}, gap = {gap!r}")
    if pos.shape[0] < 3:
        return 0.0
    return _approach(pos, stp, float(t), float(gap))


def _approach(pos: np.ndarray, step: np.ndarray, t: float, gap: float) -> float:
    """:func:`approach_fraction` of the minimiser's own checked arrays."""
    ks, js = _node_segment_pairs(pos + t * step, 0.5 * gap)
    if ks.shape[0] == 0:
        return 0.0
    return float(_approach_kernel(pos, step, t, gap, ks, js))


@njit(cache=True)
def _nearest(pos, step, s, ks, js):
    """The smallest distance over the pairs (ks, js) at ``pos + s * step``."""
    best = np.inf
    for i in range(ks.shape[0]):
        k, j = ks[i], js[i]
        d = _point_segment(pos[k, 0] + s * step[k, 0], pos[k, 1] + s * step[k, 1],
                           pos[j, 0] + s * step[j, 0], pos[j, 1] + s * step[j, 1],
                           pos[j + 1, 0] + s * step[j + 1, 0],
                           pos[j + 1, 1] + s * step[j + 1, 1])[0]  # fmt: skip
        best = min(best, d)
    return best


@njit(cache=True)
def _approach_kernel(pos, step, t, gap, ks, js):
    if _nearest(pos, step, 0.0, ks, js) <= gap:
        return 0.0
    lo, hi = 0.0, t
    for _ in range(60):  # to the last bits of t
        mid = 0.5 * (lo + hi)
        if _nearest(pos, step, mid, ks, js) > gap:
            lo = mid
        else:
            hi = mid
    return lo
