"""The line search of :func:`crumple.minimize.newton`. Private, model-blind.

A Newton direction ``p`` is capped to the trust radius, cut to a safe fraction by the caller's
``step_limit`` and backtracked until the Armijo condition (or, below the energy's resolution,
a strictly lower largest force) holds and ``feasible`` accepts the point. With a caller's
``retract``, each trial fraction α is tried at two points, the straight ``x + αp`` and the
curved ``retract(x, p, α)`` (a point on a curve through x with tangent p, e.g. a chain whose
segments are turned rather than their ends moved): the lower energy of those that pass is
taken.
"""

from __future__ import annotations

import math

import numpy as np

from . import minimize_expand
from .minimize_result import all_finite, max_force

_EPS = float(np.finfo(float).eps)
#: The trust radius shrinks to the accepted displacement after a backtrack, by this factor at
#: most; it grows to this factor times an accepted step (up to ``max_step``).
RADIUS_SHRINK = 4.0
RADIUS_GROW = 4.0


def _line_search(st, fun, p, step_limit, feasible, armijo, max_backtracks, max_step,
                 retract=None):  # fmt: skip
    """Cap, cut and backtrack the step ``p``; update ``st`` and its radius; None or why not."""
    slope = float(np.vdot(st.g, p))
    if not (slope < 0 and all_finite(p)):
        return "the Newton step is not a descent direction (numerical breakdown)"
    biggest = max_force(p)  # the largest row displacement
    alpha = 1.0
    capped = biggest > st.radius
    if capped:
        alpha = st.radius / biggest
    cut = False
    if step_limit is not None:
        safe = step_limit(st.x, alpha * p)
        if safe < 1.0:
            alpha *= _cut_at(st, alpha * p, safe)
            cut = True
    halvings = 0
    for _ in range(max_backtracks):
        trial = _trial(st, fun, p, alpha, slope, armijo, feasible, step_limit, retract)
        if trial is not None:
            xt, et, gt, ft, curved = trial
            break
        alpha *= 0.5
        halvings += 1
    else:
        return f"line search failed at max force {st.fmax:.3g}"
    full = not (halvings or capped or cut or st.exact or curved)
    if minimize_expand.EXPANSIONS and full:  # opt-in: a straight fallback step taken in full
        alpha, xt, et, gt, ft = minimize_expand._expand(
            st, fun, p, step_limit, feasible, armijo, slope, biggest, max_step, alpha, xt, et, gt,
            ft,
        )  # fmt: skip
    moved = alpha * biggest
    if halvings:  # shrink towards what worked, by 4 at most: a poor direction is not a radius
        st.radius = max(moved, st.radius / RADIUS_SHRINK)
    elif max_step is not None:  # accepted at once: let it grow to 4 times the step
        st.radius = min(max(st.radius, RADIUS_GROW * moved), max_step)
    st.x, st.e, st.g, st.fmax = xt, float(et), gt, ft
    st.curved += curved
    return None


def _cut_at(st, step, safe) -> float:
    """The fraction of ``step`` at which a step cut at the safe fraction ``safe`` stops: 0.8
    ``safe``, or the caller's ``cut(x, step, safe)`` where that is further and short of
    ``safe`` (``newton(cut=...)``: e.g. where the pairs that would touch are brought to the
    edge of the barriers' listing, instead of a fifth of their gap)."""
    at = 0.8 * safe
    if st.cut is not None:
        further = float(st.cut(st.x, step, safe))
        if at < further < safe:
            at = further
    return at


def _trial(st, fun, p, alpha, slope, armijo, feasible, step_limit, retract):
    """The point taken at the fraction ``alpha`` of ``p``, as (x, E, g, max force, curved), or
    None: of the straight point (already cut to a safe fraction) and, with ``retract``, the
    curved one (its chord from x safe as a whole), the lower energy of those acceptable."""
    best = None
    for curved in (False, True) if retract is not None else (False,):
        if curved:
            xt = retract(st.x, p, alpha)
            if xt is None or (step_limit is not None and step_limit(st.x, xt - st.x) < 1.0):
                continue
        else:
            xt = st.x + alpha * p
        et, gt = fun(xt)
        st.nfev += 1
        if not math.isfinite(et) or (best is not None and not et < best[1]):
            continue
        sufficient = et <= st.e + armijo * alpha * slope
        # below the energy's floating-point resolution only the force can tell a better point
        # (Hager & Zhang's approximate Wolfe condition)
        ft = max_force(gt)
        roundoff = et <= st.e + resolution(st.e) and ft < st.fmax
        if (sufficient or roundoff) and (feasible is None or feasible(xt)):
            best = (xt, et, gt, ft, curved)
    return best


def resolution(energy: float) -> float:
    """Floating-point resolution of an energy value: 16 ε_mach |E| (and at least 1e-300).

    >>> bool(resolution(1.0) == 16 * np.finfo(float).eps)
    True
    """
    return max(16.0 * _EPS * abs(energy), 1e-300)
