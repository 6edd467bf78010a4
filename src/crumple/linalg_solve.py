"""Solves with the sparse LDLᵀ factor of :mod:`crumple.linalg` (Numba kernels on its arrays).

Private: :class:`crumple.linalg.Factorization` calls them. The plain solve, the back
substitution that gives a direction of negative curvature, and the step of a model with
one-sided springs (an active set of Sherman–Morrison–Woodbury updates on the factor, one
solve per spring). The factor is P (A + diag(shift)) Pᵀ = L D Lᵀ, L unit lower triangular and
stored by columns without its diagonal (``lp``, ``li``, ``lx``), P b = b[perm].
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _solve(n, lp, li, lx, d, perm, b):
    """x = Pᵀ (L D Lᵀ)⁻¹ P b, with P b = b[perm]."""
    x = np.empty(n)
    for i in range(n):
        x[i] = b[perm[i]]
    for i in range(n):
        xi = x[i]
        if xi == 0.0:  # nothing to eliminate (a spring's sparse row: most of L is skipped)
            continue
        for p in range(lp[i], lp[i + 1]):
            x[li[p]] -= lx[p] * xi
    for i in range(n):
        x[i] /= d[i]
    return _back_unpermute(n, lp, li, lx, perm, x, n)


@njit(cache=True)
def _unit_back_solve(n, lp, li, lx, perm, k):
    """Pᵀ L⁻ᵀ e_k (back substitution from row k down)."""
    x = np.zeros(n)
    x[k] = 1.0
    return _back_unpermute(n, lp, li, lx, perm, x, k)


@njit(cache=True)
def _back_unpermute(n, lp, li, lx, perm, x, top):
    """Pᵀ L⁻ᵀ x in place over rows ``top - 1`` down to 0 (rows from ``top`` on are final)."""
    for i in range(top - 1, -1, -1):
        s = x[i]
        for p in range(lp[i], lp[i + 1]):
            s -= lx[p] * x[li[p]]
        x[i] = s
    out = np.empty(n)
    for i in range(n):
        out[perm[i]] = x[i]
    return out


@njit(cache=True)
def _spring_solve(n, lp, li, lx, d, perm, p0, index, value, offset, stiff, rounds, window,
                  max_new, start, known_slot, known_cols):  # fmt: skip
    """Minimise gᵀs + ½ sᵀAs + Σ_i k_i/2 max(0, r_i - a_iᵀs)² given p0 = -A⁻¹g (A factored).

    An active-set iteration on S, the springs the step enters. For a given S, by
    Sherman–Morrison–Woodbury, s = p0 + A⁻¹U μ with U = [a_i]_S and
    (K⁻¹ + UᵀA⁻¹U) μ = r_S - Uᵀp0. Each round drops the springs of S that the step no longer
    enters (a_iᵀs >= r_i, i.e. μ_i <= 0) and adds, of those it enters, the ones it enters first
    along s: fraction r_i / a_iᵀs within ``window`` of the first, at most ``max_new`` of them
    in list order. A long step through a soft mode enters many springs that the first contacts
    then keep it from, each costing a solve: measured, at most 2 per round halved the CPU of an
    N = 1000 ramp against no limit (1 and 4 were slower than 2). Each A⁻¹a_i is one solve
    with the factor, computed once, and only the products a_jᵀA⁻¹a_i are kept: a round costs
    O(m |S| + |S|³). Converged when a round changes nothing: s is then the exact minimiser.

    ``start`` (a boolean mask over the springs, or empty) is a first S: its step is solved
    before the first round (a warm start, e.g. the springs a step entered at the point before;
    where the model with it is not strictly convex, the rounds start from S empty instead).
    With positive springs the minimiser is unique, so the start changes only the rounds it
    takes. ``known_cols`` (k, n) are columns A⁻¹a already solved with this factor (an earlier
    call's), ``known_slot[i]`` the one of spring i (-1: none; empty: no spring known): they are
    not solved again, and the results are bit for bit those without them. Returns (s,
    converged, the mask of S at s, slot, cols): every column solved or known, and where.
    """
    m = index.shape[0]
    active = np.zeros(m, dtype=np.bool_)
    slot = np.full(m, -1, dtype=np.int64)  # where A⁻¹a_i is in cols, g; -1: not computed
    used = known_cols.shape[0]
    cols = np.empty((max(8, 2 * used), n))
    g = np.empty((m, cols.shape[0]))  # g[j, slot[i]] = a_jᵀ A⁻¹ a_i
    if known_slot.shape[0]:
        slot[:] = known_slot
    for u in range(used):
        cols[u] = known_cols[u]
        for j in range(m):
            g[j, u] = _row_dot(index, value, j, cols[u])
    base = np.empty(m)  # a_jᵀ p0
    for j in range(m):
        base[j] = _row_dot(index, value, j, p0)
    sel = np.empty(0, dtype=np.int64)
    mu = np.empty(0)
    now = np.empty(m)  # a_jᵀ s
    if start.shape[0] and start.any():
        trial = np.flatnonzero(start)
        cols, g, used = _spring_columns(n, lp, li, lx, d, perm, index, value, trial, slot, cols,
                                        g, used)  # fmt: skip
        step, convex = _spring_system(trial, slot, g, offset, base, stiff)
        if convex:
            sel, mu = trial, step
            active[trial] = True
    converged = False
    for _ in range(rounds):
        if not _spring_round(base, g, slot, sel, mu, offset, active, now, window, max_new):
            converged = True
            break
        trial = np.flatnonzero(active)
        cols, g, used = _spring_columns(n, lp, li, lx, d, perm, index, value, trial, slot, cols,
                                        g, used)  # fmt: skip
        step, convex = _spring_system(trial, slot, g, offset, base, stiff)
        if not convex:  # no minimiser on this active set: the last one's step, not converged
            break
        sel, mu = trial, step
    s = p0.copy()
    final = np.zeros(m, dtype=np.bool_)
    for r in range(sel.shape[0]):
        final[sel[r]] = True
        col = cols[slot[sel[r]]]
        for e in range(n):
            s[e] += mu[r] * col[e]
    return s, converged, final, slot, cols[:used]


@njit(cache=True)
def _row_dot(index, value, j, v):
    """a_jᵀ v, a_j the sparse row with entries ``value[j]`` at ``index[j]``."""
    t = 0.0
    for c in range(index.shape[1]):
        t += value[j, c] * v[index[j, c]]
    return t


@njit(cache=True)
def _spring_round(base, g, slot, sel, mu, offset, active, now, window, max_new):
    """One round's update of the active set S (``active``, in place) from the step of the
    current S (``sel``, ``mu``): ``now`` = a_jᵀs; the springs of S the step no longer enters
    leave, and of those it enters, those within ``window`` of the first join, ``max_new`` at
    most in list order. Returns whether S changed."""
    m = base.shape[0]
    first = 2.0
    for j in range(m):
        t = base[j]
        for r in range(sel.shape[0]):
            t += g[j, slot[sel[r]]] * mu[r]
        now[j] = t
        if not active[j] and t < offset[j]:
            first = min(first, offset[j] / t)
    changed = False
    added = 0
    for j in range(m):
        if active[j]:
            if now[j] >= offset[j]:
                active[j] = False
                changed = True
        elif now[j] < offset[j] and offset[j] / now[j] <= first + window and added < max_new:
            active[j] = True
            changed = True
            added += 1
    return changed


@njit(cache=True)
def _spring_columns(n, lp, li, lx, d, perm, index, value, sel, slot, cols, g, used):
    """A⁻¹a_i of every spring i of S (``sel``) not met before, one solve each (two at a time,
    :func:`_solve_pair`), into ``cols``, and its products a_jᵀA⁻¹a_i with every spring j into
    ``g`` (both doubled when full); ``slot[i]`` says where, in the order of ``sel``. Returns
    (cols, g, used)."""
    m, w = index.shape
    todo = np.empty(sel.shape[0], dtype=np.int64)
    k = 0
    for r in range(sel.shape[0]):
        if slot[sel[r]] < 0:
            todo[k] = sel[r]
            k += 1
    while used + k > cols.shape[0]:
        bigger = np.empty((2 * cols.shape[0], n))
        bigger[:used] = cols[:used]
        cols = bigger
        wider = np.empty((m, cols.shape[0]))
        wider[:, :used] = g[:, :used]
        g = wider
    a = np.zeros(n)
    b = np.zeros(n)
    for t in range(0, k, 2):
        i = todo[t]
        for c in range(w):
            a[index[i, c]] += value[i, c]
        if t + 1 < k:
            q = todo[t + 1]
            for c in range(w):
                b[index[q, c]] += value[q, c]
            _solve_pair(n, lp, li, lx, d, perm, a, b, cols[used], cols[used + 1])
            for c in range(w):
                b[index[q, c]] = 0.0
        else:
            cols[used] = _solve(n, lp, li, lx, d, perm, a)
        for c in range(w):
            a[index[i, c]] = 0.0
        for e in range(min(2, k - t)):
            for j in range(m):
                g[j, used] = _row_dot(index, value, j, cols[used])
            slot[todo[t + e]] = used
            used += 1
    return cols, g, used


@njit(cache=True)
def _solve_pair(n, lp, li, lx, d, perm, b0, b1, out0, out1):
    """:func:`_solve` of two right-hand sides at once, into ``out0`` and ``out1``: each one's
    operations those of its own solve, in the same order (so the same bits), interleaved over
    the one pass through L, where each solve alone waits on its chain of subtractions
    (measured: 1.5× two solves, N = 100)."""
    x = np.empty(n)
    y = np.empty(n)
    for i in range(n):
        x[i] = b0[perm[i]]
        y[i] = b1[perm[i]]
    for i in range(n):
        xi = x[i]
        yi = y[i]
        if xi != 0.0 and yi != 0.0:
            for p in range(lp[i], lp[i + 1]):
                r = li[p]
                x[r] -= lx[p] * xi
                y[r] -= lx[p] * yi
        elif xi != 0.0:  # each skips its own zeros, as alone
            for p in range(lp[i], lp[i + 1]):
                x[li[p]] -= lx[p] * xi
        elif yi != 0.0:
            for p in range(lp[i], lp[i + 1]):
                y[li[p]] -= lx[p] * yi
    for i in range(n):
        x[i] /= d[i]
        y[i] /= d[i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        t = y[i]
        for p in range(lp[i], lp[i + 1]):
            s -= lx[p] * x[li[p]]
            t -= lx[p] * y[li[p]]
        x[i] = s
        y[i] = t
    for i in range(n):
        out0[perm[i]] = x[i]
        out1[perm[i]] = y[i]


@njit(cache=True)
def _spring_system(sel, slot, g, offset, base, stiff):
    """μ of (K⁻¹ + UᵀA⁻¹U) μ = r_S - Uᵀp0 over the springs of S (``sel``), UᵀA⁻¹U symmetrised,
    and whether the model with S active is strictly convex (A + U K Uᵀ positive definite).

    With every k_i > 0 it is (A is). A spring of negative stiffness (one that releases a
    curvature of A, :meth:`crumple.energy.WireEnergy.barriers` with ``releasing``) can make it
    indefinite or singular, and then the system has no minimiser to give. By Haynsworth's
    inertia additivity on [[A, U], [Uᵀ, -K⁻¹]], the negative eigenvalues of A + U K Uᵀ number
    pos(K⁻¹ + UᵀA⁻¹U) - #{i in S: k_i > 0}; the test is that count, from the eigenvalues of the
    small symmetric matrix (none within ``SPRING_SINGULAR`` of zero, relative to the largest)."""
    k = sel.shape[0]
    mat = np.empty((k, k))
    rhs = np.empty(k)
    positive = 0
    for r in range(k):
        rhs[r] = offset[sel[r]] - base[sel[r]]
        for q in range(k):
            mat[r, q] = 0.5 * (g[sel[r], slot[sel[q]]] + g[sel[q], slot[sel[r]]])
        mat[r, r] += 1.0 / stiff[sel[r]]
        positive += stiff[sel[r]] > 0.0
    if k == 0:
        return rhs, True
    if positive == k:
        return np.linalg.solve(mat, rhs), True
    w, v = np.linalg.eigh(mat)
    top = np.abs(w).max()
    if not (np.isfinite(top) and top > 0.0):
        return rhs, False
    if (np.abs(w) <= SPRING_SINGULAR * top).any() or (w > 0.0).sum() != positive:
        return rhs, False
    return v @ ((v.T @ rhs) / w), True


#: Where :func:`_spring_system` calls the model with negative springs singular: an eigenvalue of
#: K⁻¹ + UᵀA⁻¹U within this fraction of the largest (their round-off is ~10⁻¹⁶ of it).
SPRING_SINGULAR = 1e-12


@njit(cache=True)
def _row_hashes(index):
    """An FNV-style hash of every row of an integer array (wrapping int64 arithmetic). Compiled
    into the cached ``minimize_barriers._merge`` through :func:`_row_positions`: after editing
    it clear ``__pycache__``."""
    m, w = index.shape
    out = np.empty(m, dtype=np.int64)
    for i in range(m):
        h = np.int64(-3750763034362895579)
        for c in range(w):
            h = (h ^ np.int64(index[i, c])) * np.int64(1099511628211)
        out[i] = h
    return out


@njit(cache=True)
def _row_positions(old, new, old_value, new_value):
    """For every row of ``new``, the row of ``old`` equal to it (both integer arrays of the
    same width), or -1: exact, rows with equal hashes compared entry by entry. With values
    (float arrays of the rows' shapes; empty: not compared) the rows of values must be equal
    too. Of several equal rows of ``old``, the first. Few rows (at most 1024 pairs of rows) are
    compared directly, more by hash. Called by the cached ``minimize_barriers._merge``: Numba's
    cache does not see a change to a callee, so after editing this function or its callees
    (:func:`_same_row`, :func:`_row_hashes`) clear ``__pycache__``."""
    values = old_value.shape[0] > 0
    if old.shape[0] * new.shape[0] <= 1024:
        out = np.full(new.shape[0], -1, dtype=np.int64)
        for i in range(new.shape[0]):
            for r in range(old.shape[0]):
                if _same_row(old, new, old_value, new_value, values, r, i):
                    out[i] = r
                    break
        return out
    hashes = _row_hashes(old)
    order = np.argsort(hashes, kind="mergesort")  # stable: equal rows met first to last
    sorted_hashes = hashes[order]
    mine = _row_hashes(new)
    out = np.full(new.shape[0], -1, dtype=np.int64)
    for i in range(new.shape[0]):
        k = np.searchsorted(sorted_hashes, mine[i])
        while k < sorted_hashes.shape[0] and sorted_hashes[k] == mine[i]:
            r = order[k]
            if _same_row(old, new, old_value, new_value, values, r, i):
                out[i] = r
                break
            k += 1
    return out


@njit(cache=True)
def _same_row(old, new, old_value, new_value, values, r, i):
    """Whether row r of ``old`` is row i of ``new`` (and their values, with ``values``).
    Compiled into the cached ``minimize_barriers._merge`` through :func:`_row_positions`: after
    editing it clear ``__pycache__``."""
    for c in range(old.shape[1]):
        if old[r, c] != new[i, c] or (values and old_value[r, c] != new_value[i, c]):
            return False
    return True


@njit(cache=True)
def _known_slots(old, new, old_value, new_value, old_slot):
    """For every row of ``new`` (with its values), the slot ``old_slot`` gives the equal row of
    ``old`` (:func:`_row_positions`), or -1; and whether any row has one."""
    where = _row_positions(old, new, old_value, new_value)
    slot = np.full(where.shape[0], -1, dtype=np.int64)
    known = False
    for i in range(where.shape[0]):
        if where[i] >= 0:
            slot[i] = old_slot[where[i]]
            known = known or slot[i] >= 0
    return slot, known
