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

Cost: O(N log N) (spatial hashes, one sort of the half-edges); N = 10^5 in 0.2-0.4 s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from crumple.geometry import (
    _build_hash,
    _cell,
    _cell_hash,
    _cell_size,
    _orient,
    find_crossings,
    node_segment_pairs,
)

__all__ = ["RESOLUTION", "LoopStats", "loops"]

#: Default ``min_width`` as a fraction of the mean segment length (when above the contact
#: distance). The narrowest loop a chain of segments of length s can close is a triangle, of
#: mean width 2A/P = s/(2√3) ≈ 0.29 s; two strands pressed together touch at their nodes and
#: leave, between two contacts, a gap of at most the chords' sagittas, ~ s θ/8 each for turning
#: angles θ, i.e. below s/4 for any θ < 1 rad. A quarter segment separates the two.
RESOLUTION = 0.25


# --------------------------------------------------------------------------------------------
# The result
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Contact links
# --------------------------------------------------------------------------------------------


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
    """Closed segments ab and cd share a point, or round-off cannot tell (conservative)."""
    o1, c1 = _orient(ax, ay, bx, by, cx, cy)
    o2, c2 = _orient(ax, ay, bx, by, dx, dy)
    o3, c3 = _orient(cx, cy, dx, dy, ax, ay)
    o4, c4 = _orient(cx, cy, dx, dy, bx, by)
    if not (c1 and c2 and c3 and c4):
        return True
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    if o1 == 0 and min(ax, bx) <= cx <= max(ax, bx) and min(ay, by) <= cy <= max(ay, by):
        return True
    if o2 == 0 and min(ax, bx) <= dx <= max(ax, bx) and min(ay, by) <= dy <= max(ay, by):
        return True
    if o3 == 0 and min(cx, dx) <= ax <= max(cx, dx) and min(cy, dy) <= ay <= max(cy, dy):
        return True
    if o4 == 0 and min(cx, dx) <= bx <= max(cx, dx) and min(cy, dy) <= by <= max(cy, dy):
        return True
    return False


@njit(cache=True)
def _overlap_from(sx, sy, ax, ay, bx, by):
    """Segments sa and sb, which share the end s, overlap beyond it (same ray)."""
    o, certain = _orient(sx, sy, ax, ay, bx, by)
    if certain and o != 0:
        return False
    return (ax - sx) * (bx - sx) + (ay - sy) * (by - sy) > 0.0


@njit(cache=True)
def _link_box_pairs(lox, loy, hix, hiy, ns):
    """Pairs (a, b), a < b, b >= ns (a link), of overlapping boxes, each once.

    Like :func:`crumple.geometry._box_pairs` but queried from the links only: the segments
    (indices < ns) are not paired with each other, which is most of the work there.
    """
    ne = lox.shape[0]
    out = np.empty((max(16, 4 * (ne - ns)), 2), dtype=np.int64)
    m = 0
    ox = lox.min()
    oy = loy.min()
    h = _cell_size(lox, loy, hix, hiy)
    start, item, cx, cy, mask = _build_hash(lox, loy, hix, hiy, ox, oy, h)
    for b in range(ns, ne):
        x0 = _cell(lox[b], ox, h)
        x1 = _cell(hix[b], ox, h)
        y0 = _cell(loy[b], oy, h)
        y1 = _cell(hiy[b], oy, h)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                bk = _cell_hash(ix, iy, mask)
                for k in range(start[bk], start[bk + 1]):
                    a = item[k]
                    if a == b or (a >= ns and a > b) or cx[k] != ix or cy[k] != iy:
                        continue
                    if lox[a] > hix[b] or lox[b] > hix[a] or loy[a] > hiy[b] or loy[b] > hiy[a]:
                        continue
                    if _cell(max(lox[a], lox[b]), ox, h) != ix:
                        continue
                    if _cell(max(loy[a], loy[b]), oy, h) != iy:
                        continue
                    if m == out.shape[0]:
                        bigger = np.empty((2 * m, 2), dtype=np.int64)
                        bigger[:m] = out
                        out = bigger
                    out[m, 0] = a
                    out[m, 1] = b
                    m += 1
    return out[:m]


@njit(cache=True)
def _link_conflicts(pos, lk, lo, fx, fy, ll, lj):
    """Which links to drop: those touching the wire away from their ends, and those crossing a
    link that is not longer (of mutually crossing links the shortest stays)."""
    ns = pos.shape[0] - 1
    nl = lk.shape[0]
    ne = ns + nl
    lox = np.empty(ne)
    loy = np.empty(ne)
    hix = np.empty(ne)
    hiy = np.empty(ne)
    for i in range(ns):
        lox[i] = min(pos[i, 0], pos[i + 1, 0])
        hix[i] = max(pos[i, 0], pos[i + 1, 0])
        loy[i] = min(pos[i, 1], pos[i + 1, 1])
        hiy[i] = max(pos[i, 1], pos[i + 1, 1])
    for q in range(nl):
        k = lk[q]
        lox[ns + q] = min(pos[k, 0], fx[q])
        hix[ns + q] = max(pos[k, 0], fx[q])
        loy[ns + q] = min(pos[k, 1], fy[q])
        hiy[ns + q] = max(pos[k, 1], fy[q])
    drop = np.zeros(nl, dtype=np.bool_)
    if nl == 0:
        return drop
    pairs = _link_box_pairs(lox, loy, hix, hiy, ns)
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


# --------------------------------------------------------------------------------------------
# Faces
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _next_half_edges(org, ang, n_v):
    """Successor of each half-edge around its face (face on the left, bounded faces CCW).

    Half-edges ``2e`` and ``2e + 1`` are twins. Out of each vertex the half-edges are sorted
    by angle (counting sort by vertex, then insertion sort: degrees are small); the successor
    of u -> v is the half-edge out of v just clockwise of v -> u.
    """
    nh = org.shape[0]
    start = np.zeros(n_v + 1, dtype=np.int64)
    for h in range(nh):
        start[org[h] + 1] += 1
    for v in range(n_v):
        start[v + 1] += start[v]
    order = np.empty(nh, dtype=np.int64)
    fill = start[:n_v].copy()
    for h in range(nh):
        order[fill[org[h]]] = h
        fill[org[h]] += 1
    for v in range(n_v):
        for i in range(start[v] + 1, start[v + 1]):
            h = order[i]
            a = ang[h]
            j = i - 1
            while j >= start[v] and ang[order[j]] > a:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = h
    rank = np.empty(nh, dtype=np.int64)
    for i in range(nh):
        rank[order[i]] = i
    nxt = np.empty(nh, dtype=np.int64)
    for h in range(nh):
        t = h ^ 1
        v = org[t]
        s0 = start[v]
        d = start[v + 1] - s0
        nxt[h] = order[s0 + (rank[t] - s0 - 1) % d]
    return nxt


@njit(cache=True)
def _trace_faces(nxt):
    """Label the cycles of the permutation ``nxt`` (one per face); returns labels, count."""
    nh = nxt.shape[0]
    face = np.full(nh, -1, dtype=np.int64)
    nf = 0
    for h in range(nh):
        if face[h] >= 0:
            continue
        g = h
        while face[g] < 0:
            face[g] = nf
            g = nxt[g]
        nf += 1
    return face, nf


@njit(cache=True)
def _face_sums(face, nf, org, dst, vx, vy, is_link, elen):
    """Per face: signed area (about the face's first vertex), wire length, link length, number
    of links, area moments for the centroid."""
    nh = face.shape[0]
    ref = np.full(nf, -1, dtype=np.int64)
    area = np.zeros(nf)
    mx = np.zeros(nf)
    my = np.zeros(nf)
    wire = np.zeros(nf)
    link = np.zeros(nf)
    nlink = np.zeros(nf, dtype=np.int64)
    for h in range(nh):
        f = face[h]
        if ref[f] < 0:
            ref[f] = org[h]
        x0, y0 = vx[ref[f]], vy[ref[f]]
        ax, ay = vx[org[h]] - x0, vy[org[h]] - y0
        bx, by = vx[dst[h]] - x0, vy[dst[h]] - y0
        cr = ax * by - bx * ay
        area[f] += 0.5 * cr
        mx[f] += (ax + bx) * cr / 6.0
        my[f] += (ay + by) * cr / 6.0
        if is_link[h]:
            link[f] += elen[h]
            nlink[f] += 1
        else:
            wire[f] += elen[h]
    cx = np.empty(nf)
    cy = np.empty(nf)
    for f in range(nf):
        x0, y0 = vx[ref[f]], vy[ref[f]]
        if area[f] != 0.0:
            cx[f] = x0 + mx[f] / area[f]
            cy[f] = y0 + my[f] / area[f]
        else:
            cx[f] = x0
            cy[f] = y0
    return area, wire, link, nlink, cx, cy


@njit(cache=True)
def _find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(cache=True)
def _depths(face, nf, nxt, is_link, is_loop, is_sliver, vx, vy, org):
    """Number of loops enclosing each face.

    A loop M encloses a face F when F lies in a bounded component of the plane minus the
    closure of S(M) = M together with the contact runs on its boundary (slivers joined to M
    across one of its contact links, and the slivers joined to those across links: a run of
    touching segments is one contact, a point of M's boundary). The boundary of S(M) is traced
    as cycles keeping S(M) on the left; the cycle of largest signed area is the outer one, every
    other is a hole, and the faces reached from a hole without entering S(M) are enclosed.
    Cost: O(E) for the tracing plus the total size of the holes (the sum of the depths).
    """
    nh = face.shape[0]
    # half-edges of each face (CSR)
    cnt = np.zeros(nf + 1, dtype=np.int64)
    for h in range(nh):
        cnt[face[h] + 1] += 1
    for f in range(nf):
        cnt[f + 1] += cnt[f]
    fh = np.empty(nh, dtype=np.int64)
    fill = cnt[:nf].copy()
    for h in range(nh):
        fh[fill[face[h]]] = h
        fill[face[h]] += 1
    # contact runs: slivers joined across links
    par = np.arange(nf)
    for h in range(0, nh, 2):
        if is_link[h]:
            a, b = face[h], face[h + 1]
            if is_sliver[a] and is_sliver[b]:
                ra, rb = _find(par, a), _find(par, b)
                if ra != rb:
                    par[ra] = rb
    root = np.empty(nf, dtype=np.int64)
    for f in range(nf):
        root[f] = _find(par, f)
    rcnt = np.zeros(nf + 1, dtype=np.int64)
    for f in range(nf):
        if is_sliver[f]:
            rcnt[root[f] + 1] += 1
    for f in range(nf):
        rcnt[f + 1] += rcnt[f]
    rmem = np.empty(rcnt[nf], dtype=np.int64)
    rfill = rcnt[:nf].copy()
    for f in range(nf):
        if is_sliver[f]:
            rmem[rfill[root[f]]] = f
            rfill[root[f]] += 1
    # contacts on each loop's boundary: a link next to a sliver belongs to that sliver's run,
    # any other link is a contact of its own
    n_contacts = np.zeros(nf, dtype=np.int64)
    ids = np.empty(nh, dtype=np.int64)
    for m in range(nf):
        if not is_loop[m]:
            continue
        ni = 0
        for q in range(cnt[m], cnt[m + 1]):
            h = fh[q]
            if is_link[h]:
                g = face[h ^ 1]
                ids[ni] = root[g] if is_sliver[g] else nf + (h >> 1)
                ni += 1
        if ni:
            srt = np.sort(ids[:ni])
            n_contacts[m] = 1
            for z in range(1, ni):
                if srt[z] != srt[z - 1]:
                    n_contacts[m] += 1
    in_s = np.full(nf, -1, dtype=np.int64)
    seen_h = np.full(nh, -1, dtype=np.int64)
    flood = np.full(nf, -1, dtype=np.int64)
    depth = np.zeros(nf, dtype=np.int64)
    members = np.empty(nf, dtype=np.int64)
    cyc_start = np.empty(nh + 1, dtype=np.int64)
    cyc_area = np.empty(nh + 1)
    cyc_h = np.empty(nh, dtype=np.int64)
    queue = np.empty(nf, dtype=np.int64)
    for m in range(nf):
        if not is_loop[m]:
            continue
        # S(M): M and the runs across its links
        nm = 0
        in_s[m] = m
        members[nm] = m
        nm += 1
        for q in range(cnt[m], cnt[m + 1]):
            h = fh[q]
            if is_link[h]:
                g = face[h ^ 1]
                if is_sliver[g] and in_s[g] != m:
                    r = root[g]
                    for z in range(rcnt[r], rcnt[r + 1]):
                        in_s[rmem[z]] = m
                        members[nm] = rmem[z]
                        nm += 1
        # boundary cycles of S(M)
        nc = 0
        k = 0
        for i in range(nm):
            f = members[i]
            for q in range(cnt[f], cnt[f + 1]):
                h0 = fh[q]
                if in_s[face[h0 ^ 1]] == m or seen_h[h0] == m:
                    continue
                cyc_start[nc] = k
                x0, y0 = vx[org[h0]], vy[org[h0]]
                area = 0.0
                h = h0
                while True:
                    seen_h[h] = m
                    cyc_h[k] = h
                    k += 1
                    ax, ay = vx[org[h]] - x0, vy[org[h]] - y0
                    bx, by = vx[org[h ^ 1]] - x0, vy[org[h ^ 1]] - y0
                    area += 0.5 * (ax * by - bx * ay)
                    g = nxt[h]
                    while in_s[face[g ^ 1]] == m:
                        g = nxt[g ^ 1]
                    h = g
                    if h == h0:
                        break
                cyc_area[nc] = area
                nc += 1
        cyc_start[nc] = k
        if nc < 2:
            continue
        outer = 0
        for c in range(1, nc):
            if cyc_area[c] > cyc_area[outer]:
                outer = c
        # flood the holes
        qn = 0
        for c in range(nc):
            if c == outer:
                continue
            for z in range(cyc_start[c], cyc_start[c + 1]):
                g = face[cyc_h[z] ^ 1]
                if flood[g] != m and in_s[g] != m:
                    flood[g] = m
                    queue[qn] = g
                    qn += 1
        qi = 0
        while qi < qn:
            f = queue[qi]
            qi += 1
            if is_loop[f]:
                depth[f] += 1
            for q in range(cnt[f], cnt[f + 1]):
                g = face[fh[q] ^ 1]
                if flood[g] != m and in_s[g] != m:
                    flood[g] = m
                    queue[qn] = g
                    qn += 1
    return depth, n_contacts


# --------------------------------------------------------------------------------------------
# The public function
# --------------------------------------------------------------------------------------------


def _check_length(name: str, value) -> float:
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
    try:
        pos = np.asarray(positions, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"positions must be an array of numbers, got {positions!r}") from err
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions must have shape (n_nodes, 2), got {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise ValueError("positions contain NaN or infinite values")
    c = _check_length("contact_distance", contact_distance)
    if pos.shape[0] >= 2:
        keep = np.r_[True, np.any(np.diff(pos, axis=0) != 0.0, axis=1)]
        pos = np.ascontiguousarray(pos[keep])
    n = pos.shape[0]
    seg_len = np.hypot(*np.diff(pos, axis=0).T)
    if min_width is None:
        w = max(c, RESOLUTION * float(seg_len.mean())) if n >= 2 else c
    else:
        w = _check_length("min_width", min_width)
    if n < 4:
        return _empty(c, w, boundaries=boundaries)
    cross = find_crossings(pos)
    if cross.shape[0]:
        i, j = (int(v) for v in cross[0])
        more = f" (and {cross.shape[0] - 1} more pairs)" if cross.shape[0] > 1 else ""
        raise ValueError(
            f"the wire crosses or touches itself: segments {i} and {j} intersect{more}; loops "
            "are defined for a wire that does not intersect itself (a contact is a distance "
            "below contact_distance, never an intersection)"
        )
    cum = np.r_[0.0, np.cumsum(seg_len)]
    nk, sj = node_segment_pairs(pos, c)
    lk, lj, lt, lo, ll = _links(pos, cum, nk.astype(np.int64), sj.astype(np.int64), c)
    # node-node links found from both ends are one link
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
    n_links = int(lk.shape[0])
    if n_links == 0:
        return _empty(c, w, boundaries=boundaries)
    return _faces(pos, lk, lj, lt, lo, fx, fy, c, w, n_links, boundaries)


def _loop_contacts(face, nf, org, is_loop, a, b) -> int:
    """Number of links ``a[i] - b[i]`` at which two loops touch (:class:`LoopStats`).

    The loops around a vertex are the faces of its outgoing half-edges. A link counts when some
    loop around ``a`` is not around ``b`` and some loop around ``b`` is not around ``a``. O(E).
    """
    n_l = a.shape[0]
    on_loop = is_loop[face]
    if n_l == 0 or not on_loop.any():
        return 0
    pairs = np.unique(org[on_loop] * nf + face[on_loop])  # (vertex, loop), sorted by vertex
    v_of, f_of = pairs // nf, pairs % nf
    ends = np.r_[a, b]
    lo = np.searchsorted(v_of, ends, side="left")
    cnt = np.searchsorted(v_of, ends, side="right") - lo
    which = np.repeat(np.arange(2 * n_l), cnt)  # one row per (link end, loop around it)
    offset = np.arange(which.shape[0]) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    loop = f_of[lo[which] + offset]
    link = which % n_l
    side = np.where(which < n_l, 1, 2)  # bit 1: around a; bit 2: around b
    key = link * nf + loop
    order = np.argsort(key, kind="stable")
    key, side = key[order], side[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    mask = np.bitwise_or.reduceat(side, start) if start.shape[0] else side
    grp_link = key[start] // nf
    a_only = np.zeros(n_l, dtype=bool)
    b_only = np.zeros(n_l, dtype=bool)
    a_only[grp_link[mask == 1]] = True
    b_only[grp_link[mask == 2]] = True
    return int(np.count_nonzero(a_only & b_only))


def _faces(pos, lk, lj, lt, lo, fx, fy, c, w, n_links, want_boundaries) -> LoopStats:
    n = pos.shape[0]
    ns = n - 1
    # vertices: the nodes, then the feet inside segments (one per distinct (segment, t))
    is_foot = lo < 0
    fj, ft = lj[is_foot], lt[is_foot]
    forder = np.lexsort((ft, fj))
    fj_s, ft_s = fj[forder], ft[forder]
    first = np.ones(fj_s.shape[0], dtype=bool)
    first[1:] = (fj_s[1:] != fj_s[:-1]) | (ft_s[1:] != ft_s[:-1])
    uid = np.cumsum(first) - 1
    n_feet = int(uid[-1] + 1) if uid.shape[0] else 0
    foot_vertex = np.empty(fj.shape[0], dtype=np.int64)
    foot_vertex[forder] = n + uid
    foot_seg = fj_s[first]
    foot_x = fx[is_foot][forder][first]
    foot_y = fy[is_foot][forder][first]
    vx = np.r_[pos[:, 0], foot_x]
    vy = np.r_[pos[:, 1], foot_y]
    # wire edges: each segment split at its feet, in order of t
    counts = np.bincount(foot_seg, minlength=ns)
    chain_start = np.r_[0, np.cumsum(counts + 1)]  # edges of segment j start here
    n_wire = int(chain_start[-1])
    pts_per_seg = counts + 2
    # vertex sequence along the wire: node j, feet of j, node j+1 (shared between segments)
    seq = np.empty(n_wire + 1, dtype=np.int64)
    node_at = chain_start[:-1]  # index in seq of node j
    seq[node_at] = np.arange(ns)
    seq[-1] = ns
    if n_feet:
        within = np.arange(n_feet) - np.r_[0, np.cumsum(counts)][foot_seg]
        seq[node_at[foot_seg] + 1 + within] = n + np.arange(n_feet)
    del pts_per_seg
    w_org = seq[:-1]
    w_dst = seq[1:]
    w_seg = np.repeat(np.arange(ns), counts + 1)
    # link edges
    l_org = lk
    l_dst = np.where(lo >= 0, lo, 0)
    l_dst[is_foot] = foot_vertex
    e_org = np.r_[w_org, l_org]
    e_dst = np.r_[w_dst, l_dst]
    n_e = e_org.shape[0]
    # directions: wire edges along their segment (exact data), links from the relative vector
    seg_dx = np.diff(pos[:, 0])
    seg_dy = np.diff(pos[:, 1])
    dxe = np.r_[seg_dx[w_seg], np.where(lo >= 0, pos[np.maximum(lo, 0), 0] - pos[lk, 0], 0.0)]
    dye = np.r_[seg_dy[w_seg], np.where(lo >= 0, pos[np.maximum(lo, 0), 1] - pos[lk, 1], 0.0)]
    if n_feet or np.any(is_foot):
        jj, tt, kk = lj[is_foot], lt[is_foot], lk[is_foot]
        rx = (pos[jj, 0] - pos[kk, 0]) + tt * seg_dx[jj]
        ry = (pos[jj, 1] - pos[kk, 1]) + tt * seg_dy[jj]
        # the foot end of the link must leave the segment on the side of the node
        side = np.sign(
            seg_dx[jj] * (pos[kk, 1] - pos[jj, 1]) - seg_dy[jj] * (pos[kk, 0] - pos[jj, 0])
        )
        wrong = np.sign(seg_dx[jj] * (-ry) - seg_dy[jj] * (-rx)) != side
        if np.any(wrong):  # round-off on a link far shorter than the segment: use the normal
            rx = np.where(wrong, side * seg_dy[jj], rx)
            ry = np.where(wrong, -side * seg_dx[jj], ry)
        idx = n_wire + np.flatnonzero(is_foot)
        dxe[idx] = rx
        dye[idx] = ry
    e_len = np.r_[
        np.hypot(vx[w_dst] - vx[w_org], vy[w_dst] - vy[w_org]),
        np.hypot(vx[l_dst] - vx[l_org], vy[l_dst] - vy[l_org]),
    ]
    # half-edges 2e (org -> dst) and 2e + 1 (dst -> org)
    org = np.empty(2 * n_e, dtype=np.int64)
    dst = np.empty(2 * n_e, dtype=np.int64)
    org[0::2], org[1::2] = e_org, e_dst
    dst[0::2], dst[1::2] = e_dst, e_org
    ang = np.empty(2 * n_e)
    ang[0::2] = np.arctan2(dye, dxe)
    ang[1::2] = np.arctan2(-dye, -dxe)
    is_link = np.zeros(2 * n_e, dtype=bool)
    is_link[2 * n_wire :] = True
    hlen = np.repeat(e_len, 2)
    nxt = _next_half_edges(org, ang, vx.shape[0])
    face, nf = _trace_faces(nxt)
    # Euler: the wire is a tree (one face) and every link closes one more face. Anything else
    # means the drawing is not plane (edges crossing by round-off): refuse rather than guess.
    if nf != n_links + 1:
        raise RuntimeError(
            f"loops: the wire and its {n_links} contact links trace {nf} faces instead of "
            f"{n_links + 1}; the contact graph is not plane (strands closer than round-off?)"
        )
    area, wire_len, link_len, _, cx, cy = _face_sums(face, nf, org, dst, vx, vy, is_link, hlen)
    outer = int(np.argmin(area))
    bounded = np.ones(nf, dtype=bool)
    bounded[outer] = False
    perim_all = wire_len + link_len
    with np.errstate(divide="ignore", invalid="ignore"):
        width = np.where(perim_all > 0, 2.0 * area / perim_all, 0.0)
    is_loop = bounded & (width >= w)
    depth, n_contacts = _depths(face, nf, nxt, is_link, is_loop, bounded & ~is_loop, vx, vy, org)
    n_loop_contacts = _loop_contacts(face, nf, org, is_loop, l_org, l_dst)
    ids = np.flatnonzero(is_loop)
    ids = ids[np.lexsort((cy[ids], cx[ids], -area[ids]))]
    bnd = None
    if want_boundaries:
        first_h = np.full(nf, -1, dtype=np.int64)
        first_h[face[::-1]] = np.arange(face.shape[0])[::-1]  # lowest half-edge of each face
        bnd_list = []
        for f in ids:
            h0 = first_h[f]
            walk = [h0]
            h = nxt[h0]
            while h != h0:
                walk.append(h)
                h = nxt[h]
            walk = np.array(walk)
            bnd_list.append(np.c_[vx[org[walk]], vy[org[walk]]])
        bnd = tuple(bnd_list)
    return LoopStats(
        contact_distance=c,
        min_width=w,
        area=_frozen(area[ids], float),
        perimeter=_frozen(wire_len[ids], float),
        n_contacts=_frozen(n_contacts[ids], np.int64),
        depth=_frozen(depth[ids], np.int64),
        centroid=_frozen(np.c_[cx[ids], cy[ids]], float),
        n_links=n_links,
        n_slivers=int(np.count_nonzero(bounded & ~is_loop)),
        n_loop_contacts=n_loop_contacts,
        boundaries=bnd,
        links=(
            _frozen(np.stack([np.c_[vx[l_org], vy[l_org]], np.c_[vx[l_dst], vy[l_dst]]], 1), float)
            if want_boundaries
            else None
        ),
    )
