"""The fill-reducing orders of :mod:`crumple.linalg`'s symbolic analysis, on a structurally
symmetric CSC pattern (Numba kernels): reverse Cuthill–McKee, and a nested dissection by the
points the unknowns sit at (geometric, for a caller that has them). Private."""

from __future__ import annotations

import numpy as np
from numba import njit


def _rcm(a) -> np.ndarray:
    """The reverse Cuthill–McKee order of a structurally symmetric pattern (its CSC arrays are
    those of its CSR): SciPy's ``reverse_cuthill_mckee(…, symmetric_mode=True)``, the same
    order (each component from a node of least degree, as ordered by ``np.argsort`` of the
    degrees, neighbours by increasing degree, ties in the order met: checked against SciPy on
    random patterns in ``tests/test_linalg.py``), without building a SciPy matrix (~5× faster
    at N = 100)."""
    n = a.shape[0]
    indptr = np.asarray(a.indptr, dtype=np.int64)
    indices = np.asarray(a.indices, dtype=np.int64)
    degree = _degrees(n, indptr, indices)
    return _rcm_kernel(n, indptr, indices, degree, _by_degree(degree))


def _by_degree(degree) -> np.ndarray:
    """The unknowns by increasing degree, as SciPy's RCM orders them: ``np.argsort`` in SciPy's
    index dtype (NumPy's SIMD sorts need not break ties alike for int32 and int64)."""
    return np.argsort(degree.astype(np.int32) if degree.shape[0] < 2**31 else degree)


@njit(cache=True)
def _degrees(n, indptr, indices):
    """Entries per row, the diagonal counted twice (as SciPy's RCM counts it)."""
    degree = np.empty(n, dtype=np.int64)
    for i in range(n):
        degree[i] = indptr[i + 1] - indptr[i]
        for q in range(indptr[i], indptr[i + 1]):
            if indices[q] == i:
                degree[i] += 1
                break
    return degree


@njit(cache=True)
def _rcm_kernel(n, indptr, indices, degree, by_degree):
    """Cuthill–McKee by breadth-first search from ``by_degree``'s first unvisited node of every
    component, each node's new neighbours sorted by degree (stable insertion sort), reversed.
    Called by the cached ``linalg_symbolic._analysis``: Numba's cache does not see a change to
    a callee, so after editing this function clear ``__pycache__``."""
    order = np.empty(n, dtype=np.int64)
    seen = np.zeros(n, dtype=np.bool_)
    key = np.empty(n, dtype=np.int64)
    count = 0
    for z in range(n):
        seed = by_degree[z]
        if seen[seed]:
            continue
        seen[seed] = True
        order[count] = seed
        count += 1
        start, end = count - 1, count
        while start < end:
            for ii in range(start, end):
                i = order[ii]
                old = count
                for q in range(indptr[i], indptr[i + 1]):
                    j = indices[q]
                    if not seen[j]:
                        seen[j] = True
                        order[count] = j
                        count += 1
                for k in range(count - old):
                    key[k] = degree[order[old + k]]
                for k in range(1, count - old):
                    t, node, f = key[k], order[old + k], k
                    while f > 0 and t < key[f - 1]:
                        key[f] = key[f - 1]
                        order[old + f] = order[old + f - 1]
                        f -= 1
                    key[f] = t
                    order[old + f] = node
            start, end = end, count
        if count == n:
            break
    return order[::-1].copy()


#: The nested dissection stops splitting at this many points; a leaf keeps their natural order
#: (for a wire, runs of the chain: a band). Measured on the Hessian of a packed N = 10⁵ wire
#: (``benchmarks/bench_order.py``, stage 43; docs/performance.md, "Nested dissection"): the
#: factorisation's multiply-adds 1.87 / 1.84 / 1.98 / 2.66 × 10⁷ at leaves of 8 / 16 / 32 / 64
#: points, against 4.80 × 10⁷ for reverse Cuthill–McKee.
ND_LEAF = 16


def nested_dissection(points, a, leaf: int | None = None) -> np.ndarray:
    """A nested-dissection order of the unknowns of a structurally symmetric pattern.

    The points are split at the lower median of their widest coordinate (or, where every
    point is on it, by position); the points of the lower half that share an entry with the
    upper half are the separator and go last, and each half is ordered so in turn, down to
    ``leaf`` points: George's nested dissection with separators found by recursive coordinate
    bisection. Within a leaf and a separator the unknowns keep their order.

    Parameters
    ----------
    points : array_like, shape (n_points, dim)
        The points the unknowns sit at, finite: unknown k belongs to point k // per, per =
        n_unknowns / n_points (a wire's nodes: their two coordinates).
    a : CSC matrix (SciPy or :class:`crumple.linalg.CSC`), shape (n_unknowns, n_unknowns)
        The pattern, both triangles.
    leaf : int, optional
        The points below which a range is not split (None: :data:`ND_LEAF`).

    Returns
    -------
    ndarray of int64
        ``order[i]``, the unknown that goes i-th (as for :func:`_rcm`).

    Raises
    ------
    ValueError
        Where the points do not hold the unknowns, or are not finite.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> chain = sp.diags([1.0, 2.0, 1.0], [-1, 0, 1], shape=(8, 8), format="csc")
    >>> nested_dissection(np.arange(8.0)[:, None], chain, leaf=2).tolist()
    [0, 2, 1, 4, 6, 7, 5, 3]
    """
    pts = np.ascontiguousarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[0] == 0 or a.shape[0] % pts.shape[0]:
        raise ValueError(f"points of shape {pts.shape} do not hold the {a.shape[0]} unknowns")
    if not np.isfinite(pts).all():
        raise ValueError("the points must be finite")
    per = a.shape[0] // pts.shape[0]
    gp, gv = _point_graph(pts.shape[0], per, np.asarray(a.indptr, dtype=np.int64),
                          np.asarray(a.indices, dtype=np.int64))  # fmt: skip
    nodes = _dissect(pts, gp, gv, max(1, int(ND_LEAF if leaf is None else leaf)))
    return (per * np.repeat(nodes, per) + np.tile(np.arange(per), nodes.shape[0])).astype(np.int64)


@njit(cache=True)
def _point_graph(n_points, per, indptr, indices):
    """The points' adjacency (CSR, repeats kept) of the unknowns' pattern: an entry (i, j)
    joins point i // per and j // per."""
    deg = np.zeros(n_points + 1, dtype=np.int64)
    for j in range(indptr.shape[0] - 1):
        for q in range(indptr[j], indptr[j + 1]):
            if indices[q] // per != j // per:
                deg[j // per + 1] += 1
    gp = np.cumsum(deg)
    fill = gp[:-1].copy()
    gv = np.empty(gp[-1], dtype=np.int64)
    for j in range(indptr.shape[0] - 1):
        for q in range(indptr[j], indptr[j + 1]):
            u, v = j // per, indices[q] // per
            if u != v:
                gv[fill[u]] = v
                fill[u] += 1
    return gp, gv


@njit(cache=True)
def _dissect(pts, gp, gv, leaf):
    """The points' nested-dissection order (:func:`nested_dissection`): each range of ``order``
    a subproblem, split into [lower half less its separator, upper half, separator]."""
    n = pts.shape[0]
    order = np.arange(n)
    tag = np.full(n, -1, dtype=np.int64)  # 2c / 2c + 1: lower / upper half of split c
    sep = np.zeros(n, dtype=np.bool_)
    tmp = np.empty(n, dtype=np.int64)
    lo_stack = np.empty(n + 1, dtype=np.int64)
    hi_stack = np.empty(n + 1, dtype=np.int64)
    lo_stack[0], hi_stack[0], top, c = 0, n, 1, 0
    while top > 0:
        top -= 1
        lo, hi = lo_stack[top], hi_stack[top]
        if hi - lo <= leaf:  # ranges stay ascending: each split keeps the relative order
            continue
        axis, widest = 0, -1.0
        for d in range(pts.shape[1]):
            lo_v, hi_v = np.inf, -np.inf
            for i in range(lo, hi):
                lo_v = min(lo_v, pts[order[i], d])
                hi_v = max(hi_v, pts[order[i], d])
            if hi_v - lo_v > widest:
                axis, widest = d, hi_v - lo_v
        vals = np.empty(hi - lo)
        for i in range(lo, hi):
            vals[i - lo] = pts[order[i], axis]
        med = np.sort(vals)[(hi - lo - 1) // 2]  # the lower median: a point's own coordinate
        c += 1
        lower = 0
        for i in range(lo, hi):
            if pts[order[i], axis] <= med:
                tag[order[i]] = 2 * c
                lower += 1
            else:
                tag[order[i]] = 2 * c + 1
        if lower == hi - lo:  # every point on the median (a degenerate cloud): split the range
            for i in range(lo, hi):
                tag[order[i]] = 2 * c + (i >= lo + (hi - lo) // 2)
        n_sep = 0
        for i in range(lo, hi):
            u = order[i]
            if tag[u] == 2 * c:
                for q in range(gp[u], gp[u + 1]):
                    if tag[gv[q]] == 2 * c + 1:
                        sep[u] = True
                        n_sep += 1
                        break
        n_low = 0
        for i in range(lo, hi):
            if tag[order[i]] == 2 * c and not sep[order[i]]:
                n_low += 1
        n_up = hi - lo - n_low - n_sep
        ia, ib, isp = lo, lo + n_low, lo + n_low + n_up
        for i in range(lo, hi):
            u = order[i]
            if sep[u]:
                tmp[isp] = u
                isp += 1
                sep[u] = False
            elif tag[u] == 2 * c:
                tmp[ia] = u
                ia += 1
            else:
                tmp[ib] = u
                ib += 1
        order[lo:hi] = tmp[lo:hi]
        lo_stack[top], hi_stack[top] = lo, lo + n_low
        lo_stack[top + 1], hi_stack[top + 1] = lo + n_low, lo + n_low + n_up
        top += 2
    return order
