"""Lengthening an accepted step of Newton's positive definite fallback. Private, model-blind.

:func:`crumple.minimize.newton` calls :func:`_expand` after its line search accepted a step of
the fallback in full at once, and only when :data:`EXPANSIONS` > 0 (off by default: measured
in docs/performance.md, "Long steps where the fallback is too stiff").
"""

from __future__ import annotations

import math

import numpy as np

from .minimize_result import max_force

#: Opt-in (0: off): lengthen a step of the positive definite fallback that was accepted in
#: full at once (:func:`_expand`): at most EXPANSIONS trials along it, each to the secant root
#: of the slope along it and at most EXPAND_MAX times the step before it. The fallback's
#: projected contact blocks make it stiffer than H where H is indefinite (pressed turns), so
#: its steps there are short: on the last stage of the N = 2000 continuum ramp (99 % of its
#: 1182 iterations on the fallback, every step accepted in full) the energy fell twice as far
#: as the model predicted (median). Measured with (3, 8) (docs/performance.md, "Long steps
#: where the fallback is too stiff"): without the force guard, the N = 10⁴ default ramp of the
#: continuum wire halves (6224 → 2773 iterations, 453 → 257 s; seed 1 also converges its last
#: stage, which stops at 5000 iterations without), but the paper's full reproduction takes 26 %
#: more CPU and 7 of its 7040 per-node stages stall at the iteration cap; with the guard
#: everything converges and the reproduction's iterations fall 5 %, its evaluations rise 25 %,
#: and the N = 10⁴ ramp gains 14 % in iterations (5366) and nothing in CPU (464 s). No default
#: both gains and keeps the paper's wires as they are, so it is off.
EXPANSIONS = 0
EXPAND_MAX = 8.0
#: With EXPANSIONS: refuse a lengthened trial whose largest force is above the accepted
#: point's (a longer step that is lower in energy but pressed into a contact's barrier, where
#: the per-node wires stalled without it).
EXPAND_FORCE_GUARD = True


def _expand(st, fun, p, step_limit, feasible, armijo, slope, biggest, max_step, alpha, xt, et,
            gt, ft):  # fmt: skip
    """A fallback step accepted in full, lengthened along p while that keeps lowering the energy:
    to the secant root of the slope along p (from the slopes at the start and at the accepted
    point), at most ``EXPAND_MAX`` times the accepted α, up to :data:`EXPANSIONS` times. Each
    trial must be safe (``step_limit`` whole, within ``max_step``), satisfy Armijo, be feasible
    and be lower than the best point so far, and (``EXPAND_FORCE_GUARD``) not raise the largest
    force: a longer step that is lower but pressed into a contact's barrier leaves Newton the
    barrier's curvature to crawl through. The trials are bounded by ``max_step``, not by the
    trust radius: the step was not capped by it, and each trial is checked by the energy
    itself. Returns the best (α, x, E, g, |F|)."""
    d_prev, a_prev = slope, 0.0
    for _ in range(EXPANSIONS):
        d_now = float(np.vdot(gt, p))
        if not d_now < 0.0:
            break
        curv = (d_now - d_prev) / (alpha - a_prev)
        a2 = alpha - d_now / curv if curv > 0.0 else math.inf
        a2 = min(a2, EXPAND_MAX * alpha)
        if max_step is not None:
            a2 = min(a2, max_step / biggest)
        if not a2 > 1.25 * alpha:
            break
        if step_limit is not None and step_limit(st.x, a2 * p) < 1.0:
            break
        x2 = st.x + a2 * p
        e2, g2 = fun(x2)
        st.nfev += 1
        if not (math.isfinite(e2) and e2 < et and e2 <= st.e + armijo * a2 * slope):
            break
        f2 = max_force(g2)
        if EXPAND_FORCE_GUARD and f2 > ft:
            break
        if feasible is not None and not feasible(x2):
            break
        d_prev, a_prev = d_now, alpha
        alpha, xt, et, gt, ft = a2, x2, e2, g2, f2
    return alpha, xt, et, gt, ft
