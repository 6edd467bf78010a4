"""A spatial hash of axis-aligned boxes: the neighbour searches in O(n) expected time.

The cell is the largest box, so that a box lies in at most four cells. Where the segments are
alike in size (the engine's wires: their stretching keeps the segments equal) a cell then holds a
few. Where they are not (a wire sampled unevenly, say at a fixed angle along a spiral, or a
digitised one), a cell that size holds the many short segments of a dense region, and a search
costs O(n²). Where the buckets are crowded (:data:`CROWD`) the segments are cut into chunks no
longer than a finer cell instead, each chunk's box hashed for its segment (:func:`_chunked_hash`):
a long segment then lies in O(length / cell) cells, not in its box's O((length / cell)²), and a
query meets each candidate once.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: The one-cell hash is crowded, and the segments are hashed in chunks instead, where its
#: buckets hold more than this many boxes on average over its boxes (Σ count² / Σ count, a
#: search's cost per box) and the boxes that crowd it are smaller than its cell over
#: ``SPREAD`` (:func:`_chunks_pay`). Measured (``cells._crowding``, count and weighted extent
#: over the cell): 3–7 and 0.88–0.90 on the engine's packed wires (N = 100 … 10⁵) and on
#: bench_loops' spirals of equal segments; 34 and 320, 0.99 and 1.00, on the packed N = 10⁴ and
#: 10⁵ wires padded by 5 × 10⁻⁴ (10 and 100 segments: crowded by boxes the cell's size, which
#: a finer cell does not help); 142 and 1141, 0.34, on the fixed-angle spiral at N = 8000 and
#: 64 000.
CROWD = 32.0
SPREAD = 2.0
#: The chunked hash's cell: the mean extent over this (``benchmarks/bench_loops.py --fan``:
#: 1 to 16 within 10 % of each other at N = 32 000 and 128 000).
FINE = 4.0

_EPS = float(np.finfo(np.float64).eps)


@njit(cache=True)
def _cell(v, origin, h):
    """Cell index of coordinate v (>= origin). Builds and queries must use this one formula:
    (v - o) * (1/h) and (v - o) / h can round to different cells on a boundary."""
    return int((v - origin) / h)


@njit(cache=True)
def _cells_of(lo_x, lo_y, hi_x, hi_y, ox, oy, h):
    """The cells a box overlaps: (x0, x1, y0, y1), inclusive."""
    return _cell(lo_x, ox, h), _cell(hi_x, ox, h), _cell(lo_y, oy, h), _cell(hi_y, oy, h)


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
def _one_cell_hash(lox, loy, hix, hiy):
    """The hash with the largest box as its cell: ``(h, ox, oy, start, item, cx, cy, mask)``."""
    ox = lox.min()
    oy = loy.min()
    h = _cell_size(lox, loy, hix, hiy)
    start, item, cx, cy, mask = _build_hash(lox, loy, hix, hiy, ox, oy, h)
    return h, ox, oy, start, item, cx, cy, mask


@njit(cache=True)
def _crowding(start, n_entries):
    """Σ count² / Σ count over a hash's buckets: about the boxes a search meets per box."""
    total = 0.0
    for b in range(start.shape[0] - 1):
        c = float(start[b + 1] - start[b])
        total += c * c
    return total / max(n_entries, 1)


@njit(cache=True)
def _crowding_size(start, item, lox, loy, hix, hiy):
    """The mean extent (the larger side) of a hash's boxes weighted alike, by their bucket's
    count: the size of the boxes that crowd it."""
    total = 0.0
    weighted = 0.0
    for b in range(start.shape[0] - 1):
        c = float(start[b + 1] - start[b])
        total += c * c
        for k in range(start[b], start[b + 1]):
            i = item[k]
            weighted += c * max(hix[i] - lox[i], hiy[i] - loy[i])
    return weighted / total if total > 0.0 else 0.0


@njit(cache=True)
def _chunks_pay(h, start, item, lox, loy, hix, hiy, crowd):
    """Whether to hash in chunks: the one-cell hash (cell h) is more crowded than ``crowd``, by
    boxes smaller than its cell over ``SPREAD`` (a finer cell then holds fewer of them; where
    the crowding boxes are about the cell's size, a finer one only puts each in more cells).
    ``crowd`` <= 0: always; infinite: never."""
    if crowd <= 0.0:  # always (the tests' switch)
        return True
    if not _crowding(start, item.shape[0]) > crowd:
        return False
    return _crowding_size(start, item, lox, loy, hix, hiy) * SPREAD < h


@njit(cache=True)
def _fine_cell(lox, loy, hix, hiy):
    """The chunked hash's cell: the mean extent (the larger side) of the boxes over ``FINE``,
    and at least 4 times the widest margin :func:`_chunked_hash` may add to a chunk's box
    (8 eps (|a| + |b|), at most 32 eps times the largest coordinate): segments a few ulps long
    would otherwise have margins of hundreds of cells, each chunk in their square (found by
    the review: a wire within 2 ulps of (1, 1) hung)."""
    total = 0.0
    big = 0.0
    for i in range(lox.shape[0]):
        total += max(hix[i] - lox[i], hiy[i] - loy[i])
        big = max(big, abs(lox[i]), abs(loy[i]), abs(hix[i]), abs(hiy[i]))
    h = max(total / lox.shape[0] / FINE, 4.0 * 32.0 * _EPS * big)
    return h if h > 0.0 else 1.0


@njit(cache=True)
def _chunked_hash(ax, ay, bx, by, pad, h):
    """Segments a_i b_i cut into chunks of extent at most ``h``, each chunk's box padded by
    ``pad`` (and by a margin that covers the rounding of the chunks' ends), hashed with cell h.

    Returns ``(start, item, cx, cy, mask, ox, oy, owner, first_chunk, lox, loy, hix, hiy)``:
    as :func:`_build_hash` over the chunks, with ``owner[c]`` the segment of chunk c, the
    chunks of segment i ``first_chunk[i]:first_chunk[i + 1]`` (consecutive, so a bucket lists a
    cell's segments in increasing order), and the chunks' boxes. A point within ``pad`` of
    segment i lies in the box of one of its chunks.
    """
    n = ax.shape[0]
    first_chunk = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        e = max(abs(bx[i] - ax[i]), abs(by[i] - ay[i]))
        first_chunk[i + 1] = first_chunk[i] + max(1, int(np.ceil(e / h)))
    total = first_chunk[n]
    lox = np.empty(total)
    loy = np.empty(total)
    hix = np.empty(total)
    hiy = np.empty(total)
    owner = np.empty(total, dtype=np.int64)
    for i in range(n):
        c0, c1 = first_chunk[i], first_chunk[i + 1]
        m = c1 - c0
        dx, dy = bx[i] - ax[i], by[i] - ay[i]
        grow = pad + 8.0 * _EPS * (abs(ax[i]) + abs(ay[i]) + abs(bx[i]) + abs(by[i]))
        for k in range(m):
            t0, t1 = k / m, (k + 1) / m
            x0, y0 = ax[i] + t0 * dx, ay[i] + t0 * dy
            x1, y1 = (bx[i], by[i]) if k == m - 1 else (ax[i] + t1 * dx, ay[i] + t1 * dy)
            c = c0 + k
            lox[c] = min(x0, x1) - grow
            hix[c] = max(x0, x1) + grow
            loy[c] = min(y0, y1) - grow
            hiy[c] = max(y0, y1) + grow
            owner[c] = i
    ox = lox.min()
    oy = loy.min()
    start, item, cx, cy, mask = _build_hash(lox, loy, hix, hiy, ox, oy, h)
    return start, item, cx, cy, mask, ox, oy, owner, first_chunk, lox, loy, hix, hiy


@njit(cache=True)
def _grow(out, m):
    """``out`` (rows, 2) with room for row m: doubled when full."""
    if m < out.shape[0]:
        return out
    bigger = np.empty((2 * m, 2), dtype=np.int64)
    bigger[:m] = out[:m]
    return bigger


@njit(cache=True)
def _segment_pairs(ax, ay, bx, by, pad, min_gap, first, crowd):
    """All pairs ``p < q`` of segments a_i b_i with ``q - p >= min_gap`` and ``q >= first`` whose
    boxes, padded by ``pad``, overlap, each once: those of the one-cell hash, or, where it is
    more crowded than ``crowd``, those whose chunks share a cell (a subset that still holds
    every pair within 2 ``pad`` of each other, intersecting ones included). In no particular
    order. No default arguments: a call that omits some went through Numba's slow dispatch,
    and (measured) slowed other kernels' calls that omit theirs, ~100 µs each."""
    n = ax.shape[0]
    if n == 0:
        return np.empty((0, 2), dtype=np.int64)
    lox = np.empty(n)
    loy = np.empty(n)
    hix = np.empty(n)
    hiy = np.empty(n)
    for i in range(n):
        lox[i] = min(ax[i], bx[i]) - pad
        hix[i] = max(ax[i], bx[i]) + pad
        loy[i] = min(ay[i], by[i]) - pad
        hiy[i] = max(ay[i], by[i]) + pad
    h, ox, oy, start, item, cx, cy, mask = _one_cell_hash(lox, loy, hix, hiy)
    if _chunks_pay(h, start, item, lox, loy, hix, hiy, crowd):
        h = _fine_cell(lox, loy, hix, hiy)
        # C-contiguous, as the other branch's: a caller's loop over an array of either layout
        # ('A') was measured 3× slower (the links' conflicts at N = 10⁴)
        return np.ascontiguousarray(
            _chunked_pairs(ax, ay, bx, by, pad, lox, loy, hix, hiy, min_gap, first, h)
        )
    out = np.empty((max(16, 4 * n), 2), dtype=np.int64)
    m = 0
    # a pair is reported only from the cell holding the lower-left corner of the intersection
    # of the two boxes, which both boxes overlap: no duplicates, no misses
    for q in range(first, n):
        x0, x1, y0, y1 = _cells_of(lox[q], loy[q], hix[q], hiy[q], ox, oy, h)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                b = _cell_hash(ix, iy, mask)
                for k in range(start[b], start[b + 1]):
                    p = item[k]
                    if q - p < min_gap or cx[k] != ix or cy[k] != iy:
                        continue
                    if lox[p] > hix[q] or lox[q] > hix[p] or loy[p] > hiy[q] or loy[q] > hiy[p]:
                        continue
                    if _cell(max(lox[p], lox[q]), ox, h) != ix:
                        continue
                    if _cell(max(loy[p], loy[q]), oy, h) != iy:
                        continue
                    if m == out.shape[0]:  # inline: a call per pair costs (measured)
                        bigger = np.empty((2 * m, 2), dtype=np.int64)
                        bigger[:m] = out
                        out = bigger
                    out[m, 0] = p
                    out[m, 1] = q
                    m += 1
    return np.ascontiguousarray(out[:m])


@njit(cache=True)
def _chunked_pairs(ax, ay, bx, by, pad, lox, loy, hix, hiy, min_gap, first, h):
    """:func:`_segment_pairs` over the chunks of :func:`_chunked_hash`: each segment q's chunks
    query their cells, and a candidate p is met once per q (``seen``)."""
    n = ax.shape[0]
    start, item, cx, cy, mask, ox, oy, owner, first_chunk, clo_x, clo_y, chi_x, chi_y = (
        _chunked_hash(ax, ay, bx, by, pad, h)
    )
    seen = np.full(n, -1, dtype=np.int64)
    out = np.empty((max(16, 4 * n), 2), dtype=np.int64)
    m = 0
    for q in range(first, n):
        for c in range(first_chunk[q], first_chunk[q + 1]):
            x0, x1, y0, y1 = _cells_of(clo_x[c], clo_y[c], chi_x[c], chi_y[c], ox, oy, h)
            for ix in range(x0, x1 + 1):
                for iy in range(y0, y1 + 1):
                    b = _cell_hash(ix, iy, mask)
                    for k in range(start[b], start[b + 1]):
                        p = owner[item[k]]
                        if q - p < min_gap or seen[p] == q or cx[k] != ix or cy[k] != iy:
                            continue
                        seen[p] = q
                        if lox[p] > hix[q] or lox[q] > hix[p] or loy[p] > hiy[q] or loy[q] > hiy[p]:
                            continue
                        out = _grow(out, m)
                        out[m, 0] = p
                        out[m, 1] = q
                        m += 1
    return out[:m]
