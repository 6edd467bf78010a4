"""The fixed-pattern assembly of Hessian triplets into a CSC matrix (Numba kernels).

Private: :class:`crumple.energy.WireEnergy` finds the CSC pattern of its triplets once per
neighbour list (rows sorted in each column, duplicates merged) and the entry each triplet adds
to (or, for a rebuilt list that the pattern still holds, only its pairs' entries), then
assembles every Hessian into that pattern (``energy_kernels._hessian_values``: the same sums
as the scatter-add of its triplets, :func:`_scatter_add`, the reference the tests hold it
to). Nothing here knows what a wire is. Split from ``energy_kernels.py`` (the terms'
kernels), which stays one readable module.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _column_order(cols, ndof):
    """The triplets grouped by column, each group in triplet order (a counting sort):
    column c's triplets are ``order[start[c]:start[c + 1]]`` (unsigned: see
    :func:`_csc_pattern`)."""
    start = np.zeros(ndof + 1, dtype=np.uint64)
    for e in range(cols.shape[0]):
        start[cols[e] + 1] += 1
    for c in range(ndof):
        start[c + 1] += start[c]
    order = np.empty(cols.shape[0], dtype=np.uint64)
    fill = start[:-1].copy()
    for e in range(cols.shape[0]):
        order[fill[cols[e]]] = e
        fill[cols[e]] += 1
    return start, order


@njit(cache=True)
def _csc_pattern_kernel(rows, cols, ndof):
    """CSC pattern of the triplets (rows sorted in each column, duplicates merged) and the entry
    each triplet adds to. Per column: its distinct rows are marked in a row map, sorted (the
    few of a chain's column by insertion, a crowded one by ``np.sort``), numbered, and each
    triplet looks its entry up in the map. O(triplets + Σ distinct²) for a chain, far cheaper
    than sorting the triplets themselves (each row appears ~3 times in a column)."""
    t = rows.shape[0]
    start, order = _column_order(cols, ndof)
    slot = np.full(ndof, -1, dtype=np.int64)
    buf = np.empty(ndof, dtype=np.uint64)
    indptr = np.zeros(ndof + 1, dtype=np.int64)
    indices = np.empty(t, dtype=np.int64)
    where = np.empty(t, dtype=np.int64)
    nnz = 0
    for c in range(ndof):
        k = 0
        for q in range(start[c], start[c + 1]):
            r = rows[order[q]]
            if slot[r] < 0:
                slot[r] = 0
                buf[k] = r
                k += 1
        if k > 48:
            buf[:k] = np.sort(buf[:k])
        else:
            for e in range(1, k):
                v = buf[e]
                f = e - 1
                while f >= 0 and buf[f] > v:
                    buf[f + 1] = buf[f]
                    f -= 1
                buf[f + 1] = v
        for e in range(k):
            indices[nnz + e] = buf[e]
            slot[buf[e]] = nnz + e
        for q in range(start[c], start[c + 1]):
            where[order[q]] = slot[rows[order[q]]]
        for e in range(k):
            slot[buf[e]] = -1
        nnz += k
        indptr[c + 1] = nnz
    return indptr, indices[:nnz], where


@njit(cache=True)
def _scatter_add(where, vals, nnz):
    """data[where[e]] += vals[e] over the triplets in order, from zeros: ``np.bincount(where,
    weights=vals, minlength=nnz)`` bit for bit, without its checks."""
    data = np.zeros(nnz)
    for e in range(where.shape[0]):
        data[where[e]] += vals[e]
    return data


@njit(cache=True)
def _pair_blocks_where(indptr, indices, head, ks, js):
    """The entries of an existing CSC pattern (rows sorted in each column) that the triplets
    ``head`` then one 6 × 6 block per pair p over the nodes (ks[p], js[p], js[p] + 1), in
    ``_put_block``'s order, add to: ``head`` as it is, each block entry by a binary search
    in its column. Returns (where, whether every entry is in the pattern)."""
    h = head.shape[0]
    where = np.empty(h + 36 * ks.shape[0], dtype=np.uint64)  # as the pattern's (unsigned)
    where[:h] = head
    m = h
    nodes = np.empty(3, dtype=np.int64)
    for p in range(ks.shape[0]):
        nodes[0], nodes[1], nodes[2] = ks[p], js[p], js[p] + 1
        for a in range(3):
            for b in range(3):
                for u in range(2):
                    for v in range(2):
                        r = 2 * nodes[a] + u
                        c = 2 * nodes[b] + v
                        lo, end = np.int64(indptr[c]), np.int64(indptr[c + 1])
                        hi = end
                        while lo < hi:  # the first row >= r
                            mid = (lo + hi) // 2
                            if np.int64(indices[mid]) < r:
                                lo = mid + 1
                            else:
                                hi = mid
                        if lo == end or np.int64(indices[lo]) != r:
                            return where, False
                        where[m] = lo
                        m += 1
    return where, True
