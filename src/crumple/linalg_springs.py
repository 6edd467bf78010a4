"""The step of a Newton model with many one-sided springs: one factorisation per active set.

Private to the minimiser. :meth:`crumple.linalg.Factorization.solve_springs` finds the
minimiser of the convex piecewise quadratic

    q(s) = gᵀs + ½ sᵀAs + Σ_i k_i/2 max(0, r_i - a_iᵀs)²

with the factor of A alone, one solve per spring that joins the active set. That is cheap when
a step enters a few springs, and it is what the minimiser tries first. A step through a packed
region enters hundreds, most of which the first contacts then keep it from; the rounds run out
and the step ignores every contact (docs/performance.md, "Measured, not adopted").
:func:`spring_step` finishes the job in another way: a semismooth Newton iteration on q, in
which each round factorises A + Σ_S k_i a_i a_iᵀ for the springs S active at the current point
(the springs' rows lie in A's sparsity pattern, so the symbolic analysis is reused) and moves
to the minimiser of that quadratic, or to the minimiser of q on the way there (an exact line
search: q is convex along any line, its derivative piecewise linear and nondecreasing). q falls
at every round, and a round whose solution has the active set it was computed with has found
the exact minimiser. The cost of a round does not depend on how many springs are active. With
``updates``, a round after the first modifies the last round's factor instead, a rank-one
update or downdate per spring that joined or left (:mod:`crumple.linalg_update`), where that
is the cheaper.
All of this is for springs of positive stiffness. A spring of negative stiffness (a releasing
row, :meth:`crumple.energy.WireEnergy.barriers`) can make q non-convex: a round whose
A + Σ_S k_i a_i a_iᵀ has a negative pivot then stops, not converged, at its start.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .linalg import CSC
from .linalg_csc import _csc_matvec, _position
from .linalg_solve import _row_dot, _row_positions
from .linalg_update import factor_work, inverse_order, modified, path_work

#: A round of the refactorised springs' step modifies the last round's factor (a rank-one
#: update or downdate per spring that joined or left) where the entries of L those touch,
#: times this, are fewer than a factorisation's work (``linalg_update.factor_work``); else it
#: factorises.
UPDATE_COST = 4.0


@njit(cache=True)
def _with_springs(indptr, indices, data, index, value, stiff, active):
    """``data`` plus k_i a_i a_iᵀ of every active spring, in the same CSC pattern; ok False
    (and the data unusable) when an entry of some a_i a_iᵀ is not in the pattern."""
    out = data.copy()
    w = index.shape[1]
    for i in range(index.shape[0]):
        if not active[i]:
            continue
        for c2 in range(w):
            col = index[i, c2]
            for c1 in range(w):
                at = _position(indptr, indices, index[i, c1], col)
                if at < 0:
                    return out, False
                out[at] += stiff[i] * value[i, c1] * value[i, c2]
    return out, True


@njit(cache=True)
def _rows_dot(index, value, v):
    """a_iᵀ v for every spring i."""
    out = np.empty(index.shape[0])
    for i in range(index.shape[0]):
        out[i] = _row_dot(index, value, i, v)
    return out


@njit(cache=True)
def _spring_rhs(b, index, value, offset, stiff, active):
    """b + Σ_S k_i r_i a_i."""
    out = b.copy()
    for i in range(index.shape[0]):
        if active[i]:
            for c in range(index.shape[1]):
                out[index[i, c]] += stiff[i] * offset[i] * value[i, c]
    return out


@njit(cache=True)
def _slope(t, c0, c1, u, v, offset, stiff):
    """q'(t) along the line: c0 + c1 t - Σ k_i max(0, r_i - u_i - t v_i) v_i."""
    f = c0 + c1 * t
    for i in range(u.shape[0]):
        gap = offset[i] - u[i] - t * v[i]
        if gap > 0.0:
            f -= stiff[i] * gap * v[i]
    return f


@njit(cache=True)
def _line_minimum(c0, c1, u, v, offset, stiff):
    """The t in [0, 1] that minimises q(s + t d) (u = Uᵀs, v = Uᵀd; q' is nondecreasing in
    t): 1 if q' <= 0 there, else the root of q' by bisection."""
    if _slope(1.0, c0, c1, u, v, offset, stiff) <= 0.0:
        return 1.0
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _slope(mid, c0, c1, u, v, offset, stiff) <= 0.0:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def _q_change(c0, c1, u, v, offset, stiff):
    """q(s + d) - q(s), u = Uᵀs, v = Uᵀd, c0 = (g + As)ᵀd and c1 = dᵀAd (the smooth part's
    slope and curvature along d)."""
    out = c0 + 0.5 * c1
    for i in range(u.shape[0]):
        before = max(0.0, offset[i] - u[i])
        after = max(0.0, offset[i] - u[i] - v[i])
        out += 0.5 * stiff[i] * (after * after - before * before)
    return out


def _least_on_segment(s, a_mul, g, index, value, offset, stiff):
    """The point t s, t in [0, 1], where q is least on the segment from 0 (the Newton iterate)
    to ``s`` (:func:`_line_minimum`), or ``s`` itself where q is not strictly lower there. With
    positive springs q is convex along the segment and the point is its exact minimiser; a
    releasing spring (negative stiffness) can make it non-convex, and the point found is then
    a root of q' that need not be the least, which is why it is taken only where it is lower
    than at ``s``."""
    v = _rows_dot(index, value, s)
    c0, c1 = float(g @ s), float(s @ a_mul(s))
    zero = np.zeros_like(v)
    t = _line_minimum(c0, c1, zero, v, offset, stiff)
    if t >= 1.0:
        return s
    there = _q_change(t * c0, t * t * c1, zero, t * v, offset, stiff)
    return t * s if there < _q_change(c0, c1, zero, v, offset, stiff) else s


def spring_step(ldl, a, shift, g, index, value, offset, stiff, start, *, rounds=30,
                from_segment=True, updates=False):  # fmt: skip
    """The minimiser of q (module docstring) by semismooth Newton from ``start``.

    ``ldl`` is the :class:`crumple.linalg.LDLT` that factorised A = ``a`` + diag(``shift``)
    (``a`` a CSC matrix holding both triangles, as :class:`crumple.linalg.CSC`; ``shift``
    a vector or None); the springs are as in :meth:`crumple.linalg.Factorization.solve_springs`.
    Returns ``(s, converged, rounds_used)``: converged when the active set was found, s then the
    exact minimiser up to round-off. Not converged, s is the best point met, with
    q(s) <= q(start); None when a spring's rows fall outside the pattern of ``a``.

    With ``from_segment`` (the default) the rounds start from the point of the segment from 0
    to ``start`` where q is least, where q is lower there than at ``start``
    (:func:`_least_on_segment`). The start a caller has is where the solve with the factor ran
    out of rounds: the Newton step held by the few springs found by then, which goes deep into
    most of the others. From there the rounds shed those springs a few at a time (their line
    searches stop at the stiff springs' kinks); the segment's least point enters few of them.
    The price is where the start's springs were the right ones: from the segment the rounds
    then add them again, a few a round. Measured on the calls of contact stages replayed both
    ways (``benchmarks/bench_springs.py``; docs/performance.md, "The refactorised springs'
    step from the segment's least point").

    With ``updates`` a round after the first modifies the last round's factor, one rank-one
    update or downdate per spring that joined or left (:func:`_modified`), where the entries
    of L that touches, times :data:`UPDATE_COST`, are fewer than a factorisation's work, and
    solves with it refined once against the round's matrix; else, or where a modification is
    refused, it factorises. Measured in docs/performance.md, "Rank-one modifications".
    """
    indptr, indices = a.indptr, a.indices
    data = np.ascontiguousarray(a.data, dtype=np.float64)
    sh = np.zeros(g.shape[0]) if shift is None else np.asarray(shift, dtype=np.float64)

    def a_mul(v):
        return _csc_matvec(indptr, indices, data, v) + sh * v

    s = np.array(start, dtype=np.float64)
    if from_segment:
        s = _least_on_segment(s, a_mul, g, index, value, offset, stiff)
    used, f, last = 0, None, None
    for used in range(1, rounds + 1):
        u = _rows_dot(index, value, s)
        active = u < offset
        merged, ok = _with_springs(indptr, indices, data, index, value, stiff, active)
        if not ok:
            return None, False, used
        f = _modified(ldl, f, last, index, value, stiff, active) if updates else None
        fresh = f is None
        if fresh:
            f = ldl.factorize(CSC(merged, indices, indptr), shift=shift)
            if f.negative:  # not with positive springs (A is); releasing ones can: no minimiser
                return s, False, used
        rhs = _spring_rhs(-g, index, value, offset, stiff, active)
        trial = f.solve(rhs)
        if not fresh:  # one refinement against the matrix itself: the modifications' round-off
            trial += f.solve(rhs - _csc_matvec(indptr, indices, merged, trial) - sh * trial)
        last = active
        if np.array_equal(_rows_dot(index, value, trial) < offset, active):
            return trial, True, used
        d = trial - s
        ad = a_mul(d)
        t = _line_minimum(float(g @ d + s @ ad), float(d @ ad), u, _rows_dot(index, value, d),
                          offset, stiff)  # fmt: skip
        if t <= 0.0:
            break
        s = s + t * d
    return s, False, used


def _modified(ldl, f, last, index, value, stiff, active):
    """The factor of the round's matrix from the last round's ``f`` (active set ``last``) by a
    rank-one modification per spring that joined or left (:mod:`crumple.linalg_update`), where
    that is cheaper than a factorisation; None: factorise."""
    if f is None:
        return None
    change = active != last
    if not change.any():
        return f
    sym = f._sym
    first = inverse_order(sym)[index[change]].min(axis=1)  # where each one's path starts
    if path_work(sym)[first].sum() * UPDATE_COST > factor_work(sym):
        return None
    out = modified(f, index, value, np.where(active, stiff, -stiff), change)
    if out is not None:
        ldl.modifications += int(change.sum())
    return out


def new_rows(old, new):
    """True for every row of ``new`` that is not a row of ``old`` (both integer arrays of the
    same width): exact, rows with equal hashes compared entry by entry.

    >>> new_rows(np.array([[0, 1], [2, 3]]), np.array([[2, 3], [1, 0]])).tolist()
    [False, True]
    """
    return _row_positions(old, new, _NO_VALUES, _NO_VALUES) < 0


_NO_VALUES = np.empty((0, 0))
