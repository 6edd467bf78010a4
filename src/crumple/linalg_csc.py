"""Kernels on raw CSC arrays for :mod:`crumple.linalg` (Numba): a dense matrix into CSC, and
rows and columns pinned to the identity's. Private: :func:`crumple.linalg.dense_csc` and
:func:`crumple.linalg.pin_rows` call them."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _dense_to_csc(a):
    """The stored entries of a dense square array as CSC arrays (data, indices, indptr): its
    nonzeros (NaN included) column by column, rows ascending; what
    ``scipy.sparse.csc_matrix(a)`` holds."""
    n = a.shape[0]
    indptr = np.zeros(n + 1, dtype=np.int64)
    for j in range(n):
        c = 0
        for i in range(n):
            c += a[i, j] != 0.0
        indptr[j + 1] = indptr[j] + c
    indices = np.empty(indptr[n], dtype=np.int64)
    data = np.empty(indptr[n])
    p = 0
    for j in range(n):
        for i in range(n):
            if a[i, j] != 0.0:
                indices[p] = i
                data[p] = a[i, j]
                p += 1
    return data, indices, indptr


@njit(cache=True)
def _pin(indptr, indices, data, mask, drop_zeros):
    """(data, indices, indptr, ok) of the CSC matrix with the rows and columns of ``mask``
    made the identity's: 1 on their stored diagonal, 0 elsewhere in them. ``drop_zeros``: the
    entries that are then zero are dropped (new index arrays), else the input's pattern is
    kept and the index arrays returned are empty. ``ok`` is False where a masked row's
    diagonal is not stored (the identity then needs an entry the pattern does not have)."""
    n = indptr.shape[0] - 1
    out_x = np.empty(data.shape[0])
    out_i = np.empty(indices.shape[0] if drop_zeros else 0, dtype=np.int64)
    out_p = np.zeros(n + 1 if drop_zeros else 0, dtype=np.int64)
    q = 0
    for j in range(n):
        seen = not mask[j]
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            v = data[p]
            if i == j and mask[j]:
                v = 1.0
                seen = True
            elif mask[i] or mask[j]:
                v = 0.0
            if not drop_zeros:
                out_x[p] = v
            elif v != 0.0:
                out_i[q] = i
                out_x[q] = v
                q += 1
        if not seen:
            return out_x, out_i, out_p, False
        if drop_zeros:
            out_p[j + 1] = q
    if drop_zeros:
        return out_x[:q], out_i[:q], out_p, True
    return out_x, out_i, out_p, True
