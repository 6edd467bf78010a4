"""The symbolic analysis of :mod:`crumple.linalg`'s LDLᵀ, done once per sparsity pattern.

Private. A pattern's fill-reducing order (the natural one, SciPy's reverse Cuthill–McKee or a
caller's nested dissection, whichever gives L the fewest nonzeros), the upper triangle of the
permuted pattern with where each entry comes from, the elimination tree and the column counts
of L (QDLDL's), and the row patterns the numeric factorisation
(:func:`crumple.linalg._factor`) walks. Without a caller's order the whole analysis is one
kernel (:func:`_analysis`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

from .linalg_csc import unsigned_view
from .linalg_order import _by_degree, _degrees, _rcm_kernel


@njit(cache=True)
def _etree(n, ap, ai, budget=-1):
    """Elimination tree and the number of nonzeros of every column of L (QDLDL_etree), and
    their total; with ``budget`` >= 0, the walk stops as soon as the total exceeds it (the
    work is O(nnz(L)): an order with much fill costs much to count) and the total is -1.
    Entries below the diagonal are skipped, so a whole symmetric CSC pattern gives its
    natural order's tree."""
    work = np.zeros(n, dtype=np.int64)
    lnz = np.zeros(n, dtype=np.int64)
    parent = np.full(n, -1, dtype=np.int64)
    total = 0
    for j in range(n):
        work[j] = j
        for p in range(ap[j], ap[j + 1]):
            i = np.int64(ai[p])  # an unsigned index (A's own pattern) walks as a signed one
            if i > j:
                continue
            while work[i] != j:
                if parent[i] == -1:
                    parent[i] = j
                lnz[i] += 1
                total += 1
                work[i] = j
                i = parent[i]
        if budget >= 0 and total > budget:
            return parent, lnz, -1
    return parent, lnz, total


@njit(cache=True)
def _row_patterns(n, ap, ai, parent, lp):
    """The symbolic part of :func:`crumple.linalg._factor`, done once per pattern: for every
    row k of L, the columns c of its nonzeros in the order the numeric factorisation visits
    them (the topological order of QDLDL's elimination-tree walk, ``rc[rp[k]:rp[k + 1]]``),
    where each l_kc goes in L (``rpos``), and L's row indices ``li``. Returns (rp, rc, rpos,
    li)."""
    marker = np.zeros(n, dtype=np.bool_)
    yidx = np.empty(n, dtype=np.int64)
    buf = np.empty(n, dtype=np.int64)
    nxt = lp[:-1].copy()
    rp = np.zeros(n + 1, dtype=np.int64)
    rc = np.empty(lp[n], dtype=np.int64)
    rpos = np.empty(lp[n], dtype=np.int64)
    li = np.empty(lp[n], dtype=np.int64)
    t = 0
    for k in range(n):
        nnzy = 0
        for p in range(ap[k], ap[k + 1]):
            b = ai[p]
            if b == k or marker[b]:
                continue
            marker[b] = True
            buf[0] = b
            ne = 1
            c = parent[b]
            while c != -1 and c < k:
                if marker[c]:
                    break
                marker[c] = True
                buf[ne] = c
                ne += 1
                c = parent[c]
            while ne > 0:
                ne -= 1
                yidx[nnzy] = buf[ne]
                nnzy += 1
        for q in range(nnzy - 1, -1, -1):
            c = yidx[q]
            end = nxt[c]
            li[end] = k
            rc[t] = c
            rpos[t] = end
            t += 1
            nxt[c] = end + 1
            marker[c] = False
        rp[k + 1] = t
    return rp, rc, rpos, li


class _Symbolic:
    """A pattern's fill-reducing order, permuted upper pattern, elimination tree, L's shape and
    row patterns."""

    def __init__(self, a: sp.csc_matrix, candidate=None):
        # candidate: None or a permutation of range(n) (order[i], the unknown that goes i-th)
        n = a.shape[0]
        self.n = n
        self.indptr, self.indices = a.indptr, a.indices
        self._unsigned = None
        # the order with the fewest nonzeros in L, the later on a tie, of a caller's candidate
        # (a nested dissection), RCM and the natural order, counted in that order so that a
        # later count (all fill, for the natural order of a packed wire) stops once beaten
        budget, mine = -1, None
        if candidate is not None:
            ap, ai, src = _permuted_upper(a, candidate)
            parent, lnz, budget = _etree(n, ap, ai)
            mine = (np.asarray(candidate, dtype=np.int64), ap, ai, src, parent, lnz)
        indptr, indices = unsigned_view(a.indptr), unsigned_view(a.indices)
        degree = _degrees(n, indptr, indices)
        won, *found = _analysis(n, indptr, indices, degree, _by_degree(degree), budget)
        if not won:  # the candidate's
            found = [*mine[:5], *_completed(n, mine[1], mine[2], mine[4], mine[5])]
        self.perm, self.ap, self.ai, self.src, self.parent, self.lp = found[:6]
        self.rp, self.rc, self.rpos, self.ai_l = found[6:]
        self.l_nnz = int(self.lp[n])

    @property
    def unsigned(self) -> dict:
        """The index arrays the numeric kernels read, as unsigned views of the same memory
        (``src``, ``perm``, ``ap``, ``ai``, ``rp``, ``rc``, ``rpos``, ``lp``, ``li``: every value
        is non-negative, so the same numbers). Numba checks a signed index for wrap-around at
        every access, an unsigned one not: the factorisation's kernel measured 1.7× faster at
        N = 100 and 1.9× at N = 1000, the same operations in the same order, so the same bits
        (docs/performance.md, "Unsigned indices"). ``factor`` is the tuple of those the
        factorisation's kernel takes after its data (n, ap, ai, rp, rc, rpos, lp, li). Made
        once, at the first use (``__init__`` sets every array it views)."""
        if self._unsigned is None:
            names = ("src", "perm", "ap", "ai", "rp", "rc", "rpos", "lp", "ai_l")
            self._unsigned = {
                ("li" if k == "ai_l" else k): unsigned_view(np.asarray(getattr(self, k), np.int64))
                for k in names
            }
            u = self._unsigned
            u["factor"] = (self.n, u["ap"], u["ai"], u["rp"], u["rc"], u["rpos"], u["lp"], u["li"])
        return self._unsigned

    def matches(self, a) -> bool:
        if a.indptr is self.indptr and a.indices is self.indices:
            return True
        return (
            a.shape[0] == self.n
            and a.indices.shape == self.indices.shape
            and np.array_equal(a.indptr, self.indptr)
            and np.array_equal(a.indices, self.indices)
        )


def _permuted_upper(a, perm):
    """Upper triangle of P A Pᵀ as CSC (int64), and where each of its entries is in ``a.data``
    (the kernel reads unsigned views of the index arrays: :attr:`_Symbolic.unsigned`)."""
    return _permuted_upper_kernel(
        a.shape[0], unsigned_view(a.indptr), unsigned_view(a.indices),
        unsigned_view(np.asarray(perm, dtype=np.int64)),
    )  # fmt: skip


@njit(cache=True)
def _permuted_upper_kernel(n, indptr, indices, perm):
    """Row i, column j of A goes to (pinv[i], pinv[j]) of P A Pᵀ, P b = b[perm]; keep the upper
    triangle, rows sorted within each column (a missing diagonal entry is fine: the
    factorisation starts every pivot from the shift)."""
    pinv = np.empty(n, dtype=np.uint64)
    for k in range(n):
        pinv[perm[k]] = k
    count = np.zeros(n + 1, dtype=np.int64)
    for j in range(n):
        cj = pinv[j]
        for q in range(indptr[j], indptr[j + 1]):
            ri = pinv[indices[q]]
            if ri <= cj:
                count[cj + 1] += 1
    ap = np.cumsum(count)
    ai = np.empty(ap[n], dtype=np.int64)
    src = np.empty(ap[n], dtype=np.int64)
    fill = ap[:-1].copy()
    for j in range(n):
        cj = pinv[j]
        for q in range(indptr[j], indptr[j + 1]):
            ri = pinv[indices[q]]
            if ri <= cj:
                e = fill[cj]
                ai[e] = ri
                src[e] = q
                fill[cj] += 1
    for c in range(n):  # insertion sort of the (few) rows of each column
        for e in range(ap[c] + 1, ap[c + 1]):
            r, q = ai[e], src[e]
            f = e - 1
            while f >= ap[c] and ai[f] > r:
                ai[f + 1] = ai[f]
                src[f + 1] = src[f]
                f -= 1
            ai[f + 1] = r
            src[f + 1] = q
    return ap, ai, src


@njit(cache=True)
def _analysis(n, indptr, indices, degree, by_degree, budget):
    """The analysis of a pattern by SciPy's reverse Cuthill–McKee (from the ``degree`` of
    :func:`_degrees` and its order ``by_degree``, :func:`_by_degree`) or the natural order,
    whichever gives L fewer nonzeros (the natural on a tie), in one call: its order, permuted
    upper pattern, elimination tree, ``lp`` and row patterns. With ``budget`` >= 0 (a caller's
    candidate's count), only an order with at most that many (the later on a tie, as counted):
    the result's first entry says whether one had, the arrays are empty where none had. Each
    count stops once beaten. The same arrays as :func:`_rcm`, :func:`_permuted_upper`,
    :func:`_etree` and :func:`_row_patterns` called in turn. Returns (won, perm, ap, ai, src,
    parent, lp, rp, rc, rpos, li)."""
    perm = _rcm_kernel(n, indptr, indices, degree, by_degree)
    ap, ai, src = _permuted_upper_kernel(n, indptr, indices, perm)
    parent, lnz, total = _etree(n, ap, ai, budget)
    won = total >= 0
    if won:
        budget = total
    # the natural order's upper pattern is A's own: counted on A, built only where it wins
    parent2, lnz2, total2 = _etree(n, indptr, indices, budget)
    if total2 >= 0:
        won, perm, parent, lnz = True, np.arange(n), parent2, lnz2
        ap, ai, src = _permuted_upper_kernel(n, indptr, indices, perm)
    if not won:
        none = np.empty(0, dtype=np.int64)
        return False, none, none, none, none, none, none, none, none, none, none
    lp, rp, rc, rpos, li = _completed(n, ap, ai, parent, lnz)
    return True, perm, ap, ai, src, parent, lp, rp, rc, rpos, li


@njit(cache=True)
def _completed(n, ap, ai, parent, lnz):
    """L's column pointers ``lp`` from its column counts, and the row patterns: (lp, rp, rc,
    rpos, li)."""
    lp = np.zeros(n + 1, dtype=np.int64)
    for k in range(n):
        lp[k + 1] = lp[k] + lnz[k]
    rp, rc, rpos, li = _row_patterns(n, ap, ai, parent, lp)
    return lp, rp, rc, rpos, li
