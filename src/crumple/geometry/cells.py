"""A spatial hash of axis-aligned boxes: the neighbour searches in O(n) expected time."""

from __future__ import annotations

import numpy as np
from numba import njit


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
