"""The step of :func:`crumple.minimize.newton`'s model with a caller's barriers. Private,
model-blind.

A contact barrier that acts only within a distance d of its pair is invisible to a quadratic
model taken outside it: the Newton step runs into it and is cut by the caller's
``step_limit``. With ``barriers(x, p)`` the caller lists the barriers the step may enter, as
one-sided springs the model adds (k_i/2 max(0, r_i - a_iᵀs)², the barrier's curvature at its
edge); the step is then the minimiser of that convex piecewise quadratic, found with the factor
the Newton direction was solved with (:meth:`crumple.linalg.Factorization.solve_springs`) or,
where that runs out of rounds or the caller's limit says it would (``st.springs_solve_limit``),
a factorisation per active set (:func:`crumple.linalg_springs.spring_step`). The energy is
unchanged: only the step is.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .linalg_solve import _row_positions
from .linalg_springs import _rows_dot, new_rows, spring_step
from .minimize_result import _equal, all_finite

#: How many times :func:`_barrier_step` lists the barriers: for the Newton step, then for each
#: step found, while that adds springs.
RELISTINGS = 3
#: Opt-in (False: every springs' solve starts from no spring): start the springs' solve from
#: the springs the step before entered (those of them listed again), and a relisting's from
#: the listing before's. The minimiser is the same (unique with positive springs); only the
#: rounds that find its active set, and so the steps where they run out, change. Measured
#: (docs/performance.md, "The springs' columns kept with the factor"): the default N = 100
#: ramp's springs' solves 25 % cheaper (about 5 % of the ramp), seeds 0, 2, 3 unchanged and
#: seed 1 not (its iterates); the N = 10⁴ ramp 1.1–2.3× slower (every spring of a large
#: first set costs a solve with the factor at once), though with fewer factorisations.
WARM_START = False


def _barrier_step(st, p, barriers, ldl) -> np.ndarray:
    """The step of the model with the one-sided springs of ``barriers`` added.

    The minimiser of the convex piecewise quadratic gᵀs + ½ sᵀHs + Σ k_i/2 max(0, r_i - a_iᵀs)²,
    H the factored model (``st.factor``) (:func:`_spring_model_step`). The springs are those
    ``barriers`` lists for p; the step found, held by its first contacts, can turn towards
    pairs p never approached, so the springs are listed again for it and the model solved
    again with them, up to ``RELISTINGS`` listings in all. Every step kept is checked to be a
    descent direction (gᵀs < 0: the model's minimiser is one, because every r_i <= 0 makes the
    model zero at s = 0; a point the solve reached without the active set need not be). If
    none is, p is kept. ``st.springs``: the rows of the step kept (None: p kept).
    """
    st.springs = None
    rows = barriers(st.x, p)
    if len(rows[2]) == 0:
        st.entered = None
        return p
    g = st.g.ravel()
    best = p
    start = _warm_start(st.entered, rows)
    entered = None
    for listing in range(RELISTINGS):
        s, active = _spring_model_step(st, p, rows, ldl, start, best)
        if s is None or not float(np.dot(g, s)) < 0.0:
            break
        best = s.reshape(p.shape)
        st.springs = _masked(st, rows)
        entered = rows[0][active] if WARM_START and active is not None else None
        if listing + 1 == RELISTINGS or _equal(best, p):  # p unchanged: same listing
            break
        before = len(rows[2])
        rows, grown = _merged_rows(rows, barriers(st.x, best))
        if not grown:
            break
        if WARM_START and active is not None:
            start = np.r_[active, np.zeros(len(rows[2]) - before, dtype=np.bool_)]
    st.entered = entered
    return best


def _warm_start(entered, rows):
    """The springs of ``rows`` that the last step kept entered (``entered``: their rows of
    ``index``, or None), as the mask that starts the springs' solve (:data:`WARM_START`)."""
    if not WARM_START or entered is None or len(entered) == 0:
        return None
    return ~new_rows(np.ascontiguousarray(entered, dtype=np.int64),
                     np.ascontiguousarray(rows[0], dtype=np.int64))  # fmt: skip


def _spring_model_step(st, p, rows, ldl, start=None, last=None):
    """The springs' model step: one solve per spring that becomes active, no new factorisation
    (:meth:`crumple.linalg.Factorization.solve_springs`, its rounds started from the mask
    ``start`` where given); where that runs out of rounds (a step through a packed region),
    one factorisation of H plus the active springs per round
    (:func:`crumple.linalg_springs.spring_step`), its best point kept if the active set is
    still not found. Where more springs are listed than ``st.springs_solve_limit`` and the
    factored model is known (``st.model``), the factorisations at once, from ``last`` (the step
    of the listing before; p at the first).
    Returns (s, the mask of the springs s enters); (None, None): no step."""
    index, value, offset, stiff = _masked(st, rows)
    limit = st.springs_solve_limit
    if st.model is not None and limit is not None and len(offset) > limit:
        s, ok = (p if last is None else last).ravel(), False
    else:
        s, ok, active = st.factor.solve_springs(p, index, value, offset, stiff, start=start,
                                                return_active=True)  # fmt: skip
    if not ok:
        if st.model is None:
            return None, None
        first = s if all_finite(s) else p.ravel()
        s, _, _ = spring_step(ldl, *st.model, st.g.ravel(), index, value, offset, stiff, first,
                              from_segment=st.springs_from_segment,
                              updates=st.springs_updates)  # fmt: skip
        active = None if s is None or not WARM_START else _rows_dot(index, value, s) < offset
    return s, active


def _masked(st, rows):
    """The springs' rows with their entries on the fixed coordinates (``st.mask``) zeroed."""
    index, value, offset, stiff = rows
    if st.mask is not None:
        value = np.array(value, dtype=np.float64)
        value[st.mask[index]] = 0.0
    return index, value, offset, stiff


#: The dtypes of a listing's arrays: index, value, offset, stiffness.
_TYPES = (np.int64, np.float64, np.float64, np.float64)


def _merged_rows(rows, more):
    """The springs of ``rows`` and those of ``more`` not among them, and whether any was added.
    Both listings are made at the same point, so a spring is known by its row of ``index``."""
    if len(more[2]) == 0:
        return rows, False
    index, value, offset, stiff, grown = _merge(
        *(np.ascontiguousarray(a, dtype=t) for a, t in zip(rows, _TYPES, strict=True)),
        *(np.ascontiguousarray(a, dtype=t) for a, t in zip(more, _TYPES, strict=True)),
    )  # fmt: skip
    return ((index, value, offset, stiff) if grown else rows), grown


@njit(cache=True)
def _merge(index, value, offset, stiff, index2, value2, offset2, stiff2):
    """:func:`_merged_rows` in one call: the rows of the second listing whose ``index`` row is
    not one of the first's (``linalg_springs.new_rows``), appended in their order."""
    new = _row_positions(index, index2, np.empty((0, 0)), np.empty((0, 0))) < 0
    k = new.sum()
    m = offset.shape[0]
    out_i = np.empty((m + k, index.shape[1]), dtype=np.int64)
    out_v = np.empty((m + k, value.shape[1]))
    out_o = np.empty(m + k)
    out_s = np.empty(m + k)
    out_i[:m], out_v[:m], out_o[:m], out_s[:m] = index, value, offset, stiff
    c = m
    for r in range(new.shape[0]):
        if new[r]:
            out_i[c], out_v[c], out_o[c], out_s[c] = index2[r], value2[r], offset2[r], stiff2[r]
            c += 1
    return out_i, out_v, out_o, out_s, k > 0
