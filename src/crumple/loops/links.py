"""Contact links of a wire and their planarity (the graph of :func:`crumple.loops.loops`).

Every node within ``c`` of a non-adjacent segment is linked to its nearest point there
(:func:`_links`); node-node links found from both ends are merged (:func:`_unique_links`);
links that touch the wire away from their ends, or cross a shorter link, are dropped
(:func:`_link_conflicts`, over a spatial hash of the links' bounding boxes). Lengths in
units of L0.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from crumple.geometry import node_segment_pairs
from crumple.geometry.cells import CROWD, _segment_pairs
from crumple.geometry.crossings import _meet, _orient_sure

__all__ = ["contact_links"]


def contact_links(pos: np.ndarray, c: float) -> tuple[np.ndarray, ...]:
    """The plane contact links of a wire that does not cross itself.

    ``pos`` (n, 2), consecutive nodes distinct; ``c`` the contact distance ``[length]``.
    Returns ``(lk, lj, lt, lo, ll, fx, fy)``, one entry per link: node ``lk`` joined to the
    point at parameter ``lt`` of segment ``lj`` (``lo >= 0``: that point is node ``lo``), of
    length ``ll``, its far end at ``(fx, fy)``.
    """
    seg_len = np.hypot(*np.diff(pos, axis=0).T)
    cum = np.r_[0.0, np.cumsum(seg_len)]
    nk, sj = node_segment_pairs(pos, c)
    lk, lj, lt, lo, ll = _unique_links(
        *_links(pos, cum, nk.astype(np.int64), sj.astype(np.int64), c)
    )
    fx = np.where(
        lo >= 0, pos[np.maximum(lo, 0), 0], pos[lj, 0] + lt * (pos[lj + 1, 0] - pos[lj, 0])
    )
    fy = np.where(
        lo >= 0, pos[np.maximum(lo, 0), 1], pos[lj, 1] + lt * (pos[lj + 1, 1] - pos[lj, 1])
    )
    if lk.shape[0]:
        drop = _link_conflicts(pos, lk, lo, fx, fy, ll, lj)
        good = ~drop
        lk, lj, lt, lo, ll, fx, fy = (a[good] for a in (lk, lj, lt, lo, ll, fx, fy))
    return lk, lj, lt, lo, ll, fx, fy


def _unique_links(lk, lj, lt, lo, ll):
    """Node-node links found from both ends are one link, stored from its lower node."""
    if lk.shape[0]:
        key_a = np.where(lo >= 0, np.minimum(lk, lo), lk)
        key_b = np.where(lo >= 0, np.maximum(lk, lo), -1 - lj)
        key_t = np.where(lo >= 0, 0.0, lt)
        order = np.lexsort((key_t, key_b, key_a))
        dup = np.zeros(order.shape[0], dtype=bool)
        dup[1:] = (
            (key_a[order][1:] == key_a[order][:-1])
            & (key_b[order][1:] == key_b[order][:-1])
            & (key_t[order][1:] == key_t[order][:-1])
        )
        sel = np.sort(order[~dup])
        lk, lj, lt, lo, ll = lk[sel], lj[sel], lt[sel], lo[sel], ll[sel]
        if np.any(lo >= 0):  # store node-node links from their lower node
            flip = (lo >= 0) & (lo < lk)
            lk, lo = np.where(flip, lo, lk), np.where(flip, lk, lo)
    return lk, lj, lt, lo, ll


@njit(cache=True)
def _links(pos, cum, nodes, segs, cutoff):
    """Candidate links from node k to the nearest point of segment j.

    Returns, per kept candidate: node k, segment j, foot parameter t (exactly 0 or 1 when the
    foot is an end of j; then ``other`` is that node, else -1), and the link length.
    """
    m = nodes.shape[0]
    out_k = np.empty(m, dtype=np.int64)
    out_j = np.empty(m, dtype=np.int64)
    out_t = np.empty(m)
    out_o = np.empty(m, dtype=np.int64)
    out_l = np.empty(m)
    min_loop = math.pi * cutoff
    n = 0
    for q in range(m):
        k = nodes[q]
        j = segs[q]
        ax, ay = pos[j, 0], pos[j, 1]
        ex, ey = pos[j + 1, 0] - ax, pos[j + 1, 1] - ay
        rx, ry = pos[k, 0] - ax, pos[k, 1] - ay
        ee = ex * ex + ey * ey
        t = (rx * ex + ry * ey) / ee if ee > 0.0 else 0.0
        other = -1
        if t <= 0.0:
            t = 0.0
            other = j
        elif t >= 1.0:
            t = 1.0
            other = j + 1
        dx, dy = ax + t * ex - pos[k, 0], ay + t * ey - pos[k, 1]
        if other >= 0:
            dx, dy = pos[other, 0] - pos[k, 0], pos[other, 1] - pos[k, 1]
        length = math.sqrt(dx * dx + dy * dy)
        s_foot = cum[j] + t * (cum[j + 1] - cum[j])
        if abs(s_foot - cum[k]) + length < min_loop:
            continue  # the wire between the ends and the link are too short to hold a loop
        out_k[n] = k
        out_j[n] = j
        out_t[n] = t
        out_o[n] = other
        out_l[n] = length
        n += 1
    return out_k[:n], out_j[:n], out_t[:n], out_o[:n], out_l[:n]


@njit(cache=True)
def _segments_meet(ax, ay, bx, by, cx, cy, dx, dy):
    """Closed segments ab and cd share a point (exact signs; where those cannot be had,
    beyond :func:`crumple.geometry.crossings._orient_sure`'s bounds, counted as meeting)."""
    hit, certain = _meet(ax, ay, bx, by, cx, cy, dx, dy)
    return hit or not certain


@njit(cache=True)
def _overlap_from(sx, sy, ax, ay, bx, by):
    """Segments sa and sb, which share the end s, overlap beyond it (same ray)."""
    o, certain = _orient_sure(sx, sy, ax, ay, bx, by)
    if certain and o != 0:
        return False
    return (ax - sx) * (bx - sx) + (ay - sy) * (by - sy) > 0.0


@njit(cache=True)
def _link_conflicts(pos, lk, lo, fx, fy, ll, lj):
    """Which links to drop: those touching the wire away from their ends, and those crossing a
    link that is not longer (of mutually crossing links the shortest stays)."""
    ns = pos.shape[0] - 1
    nl = lk.shape[0]
    drop = np.zeros(nl, dtype=np.bool_)
    if nl == 0:
        return drop
    # the segments, then the links (node k to its foot): queried from the links only, the
    # segments are not paired with each other
    ax = np.concatenate((pos[:-1, 0], pos[lk, 0]))
    ay = np.concatenate((pos[:-1, 1], pos[lk, 1]))
    bx = np.concatenate((pos[1:, 0], fx))
    by = np.concatenate((pos[1:, 1], fy))
    pairs = _segment_pairs(ax, ay, bx, by, 0.0, 1, ns, CROWD)
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]  # a < b, b a link
        q = b - ns
        k = lk[q]
        ox = lo[q]
        sx, sy, ex, ey = pos[k, 0], pos[k, 1], fx[q], fy[q]
        if a < ns:
            # link q against segment a
            if a == lj[q] and ox < 0:
                continue  # its foot lies on it
            ends_a = (a, a + 1)
            shared = -1
            for v in ends_a:
                if v == k or v == ox:
                    shared = v
            if shared >= 0:
                other = a + 1 if shared == a else a
                if shared == k:
                    if _overlap_from(sx, sy, ex, ey, pos[other, 0], pos[other, 1]):
                        drop[q] = True
                else:
                    if _overlap_from(ex, ey, sx, sy, pos[other, 0], pos[other, 1]):
                        drop[q] = True
                continue
            if _segments_meet(sx, sy, ex, ey, pos[a, 0], pos[a, 1], pos[a + 1, 0], pos[a + 1, 1]):
                drop[q] = True
            continue
        # two links r (= a - ns) and q
        r = a - ns
        kr, orr = lk[r], lo[r]
        tx, ty, ux, uy = pos[kr, 0], pos[kr, 1], fx[r], fy[r]
        same_foot = ox < 0 and orr < 0 and lj[q] == lj[r] and ex == ux and ey == uy
        conflict = False
        if kr == k:
            conflict = _overlap_from(sx, sy, ex, ey, ux, uy)
        elif (ox >= 0 and ox == orr) or same_foot:
            conflict = _overlap_from(ex, ey, sx, sy, tx, ty)
        elif ox >= 0 and ox == kr:
            conflict = _overlap_from(ex, ey, sx, sy, ux, uy)
        elif orr >= 0 and orr == k:
            conflict = _overlap_from(sx, sy, ex, ey, tx, ty)
        else:
            conflict = _segments_meet(sx, sy, ex, ey, tx, ty, ux, uy)
        if conflict:
            if ll[q] >= ll[r]:
                drop[q] = True
            if ll[r] >= ll[q]:
                drop[r] = True
    return drop
