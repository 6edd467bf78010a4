"""Rank-one modifications of a sparse LDLᵀ whose pattern holds them: L D Lᵀ + σ w wᵀ. Private.

The refactorised springs' step (:func:`crumple.linalg_springs.spring_step`) factorises
A + Σ_S k_i a_i a_iᵀ once per round, for an active set S that changes by a few springs from
one round to the next. Every a_i a_iᵀ lies in A's sparsity pattern, so the factor of any S has
the same elimination tree and the same pattern of L, and a change of S by one spring is a
rank-one update (σ = k_i > 0) or downdate (σ = -k_i) of the factor in place. Method C1 of Gill,
Golub, Murray and Saunders (Math. Comp. 28, 1974), on the sparse factor as in Davis and Hager
(SIAM J. Matrix Anal. Appl. 20, 1999): only the columns on the path of the elimination tree
from the first nonzero of P w to the root change, at a cost of their entries, against the
whole factorisation's work, about Σ_j nnz(L_{:j})². A pivot that a modification takes to zero
or below (a downdate that leaves the matrix indefinite, or round-off), or below
:data:`CANCELLATION` of its value (a downdate that cancels most of a pivot keeps the
round-off of the larger one), is refused, as is a row whose entries do not lie on one path of
the tree: the caller then factorises afresh.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .linalg import Factorization

#: A modification that leaves a pivot below this fraction of its value is refused: the pivot's
#: round-off is that of the value before, so the digits it cancels are lost (a stiff spring
#: downdated from the pivot it dominated).
CANCELLATION = 1e-6


@njit(cache=True)
def _modify(lp, li, lx, d, parent, pinv, index, value, sigma, w, cancellation):
    """L D Lᵀ + σ w wᵀ in place, w the row with entries ``value`` at ``index`` (unknowns in
    the original order; ``pinv`` maps them to the factor's). ``w`` a work vector of zeros,
    left so. False (the factor then unusable) where a pivot falls to zero or below, or below
    ``cancellation`` of its value, or where an entry of the row is off the tree's path from
    its first one (outside the pattern)."""
    start = -1
    for c in range(index.shape[0]):
        if value[c] != 0.0:
            j = pinv[index[c]]
            w[j] += value[c]
            if start < 0 or j < start:
                start = j
    alpha = sigma
    j = start
    ok = True
    while j >= 0:
        p = w[j]
        w[j] = 0.0
        if p != 0.0 and ok:
            dj = d[j]
            bar = dj + alpha * p * p
            if not bar > cancellation * dj:
                ok = False
            else:
                beta = p * alpha / bar
                alpha = alpha * dj / bar
                d[j] = bar
                for q in range(lp[j], lp[j + 1]):
                    i = li[q]
                    w[i] -= p * lx[q]
                    lx[q] += beta * w[i]
        j = parent[j]
    for c in range(index.shape[0]):  # an entry off the path was never reached: left in w
        j = pinv[index[c]]
        if w[j] != 0.0:
            w[j] = 0.0
            ok = False
    return ok


def modified(f: Factorization, index, value, sigma, chosen) -> Factorization | None:
    """The factor of (f's matrix) + Σ_i σ_i a_i a_iᵀ over the chosen rows, f left as it was.

    Parameters
    ----------
    f : Factorization
        A complete factor of a positive definite matrix (not modified, not a trial, no
        negative pivot); else None is returned.
    index, value : ndarray, shape (m, w)
        Row i, a_i, has entries ``value[i]`` at ``index[i]`` (unknowns in the original order);
        every a_i a_iᵀ of a chosen row must lie in the factored pattern
        (:func:`crumple.linalg_springs._with_springs` checks it; a row off it is refused).
    sigma : ndarray, shape (m,)
        σ_i: a spring's stiffness to add it, minus it to take it out.
    chosen : ndarray of bool, shape (m,)
        The rows applied, in order.

    Returns
    -------
    Factorization or None
        The modified factor; None where a modification is refused (a pivot at or below
        :data:`CANCELLATION` of its value: indefinite, or cancelled to round-off).
    """
    if f.modified or not f.complete or f.negative:
        return None
    sym = f._sym
    pinv = inverse_order(sym)
    lx, d = f._lx.copy(), f._d.copy()
    w = np.zeros(sym.n)
    u = sym.unsigned  # the kernel's index arrays unsigned (linalg_symbolic._Symbolic.unsigned)
    for i in np.flatnonzero(chosen):
        if not _modify(u["lp"], u["li"], lx, d, sym.parent, pinv, index[i], value[i],
                       float(sigma[i]), w, CANCELLATION):  # fmt: skip
            return None
    out = Factorization(sym, lx, d, 0, 0)
    out.first_modified = -1  # no pivot raised, as LDLT.factorize sets it
    return out


def inverse_order(sym) -> np.ndarray:
    """The factor's position of every unknown (the inverse of ``sym.perm``), kept with it."""
    pinv = getattr(sym, "pinv", None)
    if pinv is None:
        pinv = np.empty(sym.n, dtype=np.int64)
        pinv[sym.perm] = np.arange(sym.n)
        sym.pinv = pinv
    return pinv


def factor_work(sym) -> float:
    """A numeric factorisation's work on the pattern, Σ_j (nnz(L_{:j}) + 1)²: a measure
    (about twice its multiply-adds), each column's pivot counted as an entry."""
    work = getattr(sym, "factor_work", None)
    if work is None:
        lnz = np.diff(sym.lp).astype(np.float64) + 1.0
        work = sym.factor_work = float(lnz @ lnz)
    return work


def path_work(sym) -> np.ndarray:
    """For every column j of L (the factor's order), the entries of L on the elimination
    tree's path from j to the root: what a modification starting at j touches."""
    work = getattr(sym, "path_work", None)
    if work is None:
        work = _path_work(sym.n, sym.lp, sym.parent)
        sym.path_work = work
    return work


@njit(cache=True)
def _path_work(n, lp, parent):
    """Σ over the path from j to the root of (nnz(L_{:k}) + 1), for every j (parents follow
    their children in the order)."""
    out = np.zeros(n)
    for j in range(n - 1, -1, -1):
        out[j] = lp[j + 1] - lp[j] + 1.0
        if parent[j] >= 0:
            out[j] += out[parent[j]]
    return out
