"""The Newton step where the assembled Hessian cannot resolve the soft modes: a truncated
conjugate-gradient solve with the accurate product. Private, model-blind.

At large N the assembled H carries a round-off of about ε max|H_jj| per entry (the bending
blocks' k_b/l0² at N = 5 × 10⁴ is 6 × 10¹²: an absolute error of ~10⁻³ per entry), larger than
the curvature of the wire's soft modes (λ l0 per node, ~10⁻⁴). Its factor is then exact on the
stiff modes and wrong on the soft ones; at a saddle, the shift σM that makes it positive
definite is set by that round-off (measured: σ ≈ 10³ per unit length against the buckling
mode's μ = −1.26), so the step along the unstable mode is 10⁻³ of the one it should be and the
buckle grows by ~0.1 % per iteration.

:func:`_accurate_step` solves H p = −g with H applied by ``hess_action`` (the element-form
product, accurate to round-off of the elements themselves) by conjugate gradients
preconditioned by that factor: Steihaug's truncated CG (Steihaug, SIAM J. Numer. Anal. 20, 626
(1983); Nocedal & Wright, Numerical Optimization, Alg. 7.2). From 0, every iterate is a descent
direction; the solve stops once an iterate leaves the trust radius (that iterate is returned,
and the line search scales the whole step back to the radius), or where the accurate H has
negative curvature along the CG direction d: it then returns s + (Δ/|d|∞) d (the unstable mode
of a saddle), or d itself at the first iteration. Both are descent directions but differ from
Steihaug's boundary point (the root of |s + τd| = Δ), which would be up to 2× shorter; that
variant was not measured. The factor stays the preconditioner only: on the stiff modes it is
exact (CG converges in a few iterations), on the soft ones the product decides.
"""

from __future__ import annotations

import numpy as np

from .linalg import CSC
from .linalg_springs import _line_minimum, _q_change, _rows_dot, _spring_rhs, _with_springs
from .minimize_accurate import _assembly_resolution, _complement
from .minimize_modes import _modes
from .minimize_result import max_force

#: Take the truncated-CG step where the assembled H cannot resolve τ (its resolution
#: ``minimize_accurate._assembly_resolution`` above the stability tolerance) and a product is
#: given. False: the factor's step everywhere (the engine before the tenth stop).
ACCURATE_STEPS = True
#: Refine the contact springs' model step with the accurate product, where the accurate
#: steps apply (:func:`_accurate_spring_step`). False: the factor's spring step everywhere (the
#: engine before the twelfth stop).
ACCURATE_SPRING_STEPS = True
#: Where the refined springs' step is not lower than q in the model of every listed spring
#: (it entered a spring q had not), take the least point of that model on the segment from q
#: to it instead of q; and where the CG met negative curvature, try first a step on along it
#: by the trust radius's length (:func:`_accurate_spring_step`). Why: at N = 10⁵ the
#: refinement was thrown away in most steps of a snap-through (the steps were then q, the
#: factor's springs' step, damped by a shift σM set by the assembled H's round-off).
#: Measured (docs/performance.md, "The accurate springs' step on its way"): the N = 10⁴
#: default ramps 7-9 % fewer contact iterations (seeds 0, 1), the N = 10⁴ cold start 685
#: iterations against 722; at N = 10⁵ mixed, stage by stage from the same points: λ = 234.4
#: 390 s against 706 s, λ = 754.8 928 s against 934 s, λ = 917.2 869 s against 502 s (each
#: one path; the sum about equal). False: q kept (the engine before the nineteenth stop).
ACCURATE_SPRING_SEGMENT = True
#: Conjugate-gradient iterations per step at most (measured at N = 5 × 10⁴: 2–3 on average).
ACCURATE_STEP_MAXITER = 50
#: The solve has converged when the residual's largest row, the force the quadratic model
#: predicts after the step, is below this fraction of the largest force (an inexact Newton
#: step with a fixed forcing term: Dembo, Eisenstat & Steihaug, SIAM J. Numer. Anal. 19, 400
#: (1982)).
ACCURATE_STEP_FORCING = 1e-2
#: What ends the solve: ``"residual"`` (above) or ``"preconditioned"``, rᵀz below
#: ``ACCURATE_STEP_RTOL`` × its value at 0 (the engine before the twelfth stop). The factor's
#: weights 1/σ on the soft modes make rᵀz blind to them: measured at N = 10⁵, λ = 192.9, the
#: solve stopped there after ~11 iterations with the soft residual barely reduced, and the
#: polish's force fell by 1 % per Newton iteration, each a full step.
ACCURATE_STEP_STOP = "residual"
ACCURATE_STEP_RTOL = 1e-10
#: ``"model"``: Nash & Sofer's test (Oper. Res. Lett. 9, 219 (1990)), on the model's gain.
ACCURATE_STEP_MODEL_TOL = 0.1


def _applies(st, m, floor) -> bool:
    """Whether the accurate product makes the step: ``st.hess_action`` given (and
    ``newton(accurate_steps=True)``), the direction's factor positive definite with its sparse
    matrix known (``st.model``), and the assembled H's resolution above τ = floor/m."""
    if not (ACCURATE_STEPS and st.accurate_steps) or st.hess_action is None or st.model is None:
        return False
    return _assembly_resolution(st.model[0], m) > float(floor[0] / m[0])


def _accurate_step(st, p, m, floor) -> np.ndarray:
    """The truncated-CG step of the accurate H, or p where it does not apply
    (:func:`_applies`). Counts the CG iterations in ``st.krylov``."""
    if not _applies(st, m, floor):
        return p
    project = _complement(_modes(st.zero_modes, st.x, m))
    r = project(-np.asarray(st.g, dtype=np.float64).ravel())
    s, d, k, why = _cg(st, lambda v: _product(st, v), st.factor, project, np.zeros_like(r), r,
                       p.shape)  # fmt: skip
    if why == "none":
        return p
    if why == "negative":  # along d by the trust radius's length (the factor's step at first)
        if k == 0:
            s = d  # the line search caps it at the radius
        elif np.isfinite(st.radius):
            s = s + (st.radius / _rows(d, p.shape)) * d
    return s.reshape(p.shape) if np.all(np.isfinite(s)) and np.any(s) else p


def _accurate_spring_step(st, q, springs, ldl, m, floor) -> np.ndarray:
    """The springs' model step ``q`` (:func:`crumple.minimize_barriers._barrier_step`) refined
    with the accurate product, or q where that does not apply (:func:`_applies`) or does not
    lower the model.

    ``springs`` = (index, value, offset, stiffness), the rows the step was found with. The
    springs active at q (a_iᵀq < r_i) are held: the step is the minimiser of the quadratic
    gᵀs + ½ sᵀHs + Σ_S k_i/2 (r_i - a_iᵀs)², H applied by the element-form product, by
    conjugate gradients from q, preconditioned by the factor of the assembled H + shift plus
    those springs (their rows lie in its pattern: the symbolic analysis is reused; one
    factorisation), in the complement of the zero modes (the springs' rows are orthogonal to
    the rigid motions). Where q's residual in that model already passes the solve's test, q
    is kept without a factorisation. The CG stops at the trust radius or at negative
    curvature, keeping its last iterate s. The refined step is s if it is a descent direction
    and lowers the piecewise model of every listed spring, evaluated with the accurate
    product, below q's (docs/performance.md, "Accurate steps with contacts"); else q. With
    :data:`ACCURATE_SPRING_SEGMENT`, at negative curvature the point s + (Δ/|d|∞) d (d the
    direction of negative curvature, Δ the trust radius) is tried first, then s; and where
    neither passes (it entered a listed spring that q did not, and the CG's model holds only
    q's), the step is the least point of that model on the segment from q to either
    (:func:`_least_between`), the first that is a descent direction, before q."""
    if not (ACCURATE_SPRING_STEPS and _applies(st, m, floor)):
        return q
    index, value, offset, stiff = springs
    qf = np.asarray(q, dtype=np.float64).ravel()
    active = _rows_dot(index, value, qf) < offset
    zero = np.zeros_like(qf)

    def held(v):  # Σ_S k_i a_i a_iᵀ v
        return _spring_rhs(zero, index, value, _rows_dot(index, value, v), stiff, active)

    g = np.asarray(st.g, dtype=np.float64).ravel()
    hq = _product(st, qf)
    project = _complement(_modes(st.zero_modes, st.x, m))
    r = project(_spring_rhs(-g, index, value, offset, stiff, active) - hq - held(qf))
    if _done(st, r, r, q.shape):
        return q
    f = _held_factor(st, ldl, springs, active)
    if f is None:
        return q
    s, d, _, why = _cg(st, lambda v: _product(st, v) + held(v), f, project, qf, r, q.shape)
    if why == "none" or not np.all(np.isfinite(s)):
        return q
    tries = [s]  # the CG's iterate; first, at negative curvature, on along d by the radius
    if why == "negative" and ACCURATE_SPRING_SEGMENT and np.isfinite(st.radius):
        tries.insert(0, s + (st.radius / _rows(d, q.shape)) * d)
    before = _spring_model(g, qf, hq, index, value, offset, stiff)
    tried = []
    for t in tries:
        downhill = float(g @ t) < 0.0
        if not (downhill or ACCURATE_SPRING_SEGMENT):  # no product the answer cannot use
            continue
        ht = _product(st, t)
        if downhill and _spring_model(g, t, ht, index, value, offset, stiff) < before:
            return t.reshape(q.shape)
        tried.append((t, ht))
    if not ACCURATE_SPRING_SEGMENT:
        return q
    for t, ht in tried:  # the least point on the way to each, the first that is a step down
        least = _least_between(g, qf, hq, t, ht, index, value, offset, stiff)
        if least is not None and float(g @ least) < 0.0:
            return least.reshape(q.shape)
    return q


def _least_between(g, q, hq, s, hs, index, value, offset, stiff):
    """The point of the segment from q to s where the piecewise model of every listed spring
    is least (H by the accurate products ``hq`` = Hq and ``hs`` = Hs, so that Hd = hs - hq
    costs no product), or None where it is not strictly lower there than at q.

    Along the segment the model is g·(q + td) + ½ (q + td)ᵀH(q + td) + the springs' terms, its
    slope piecewise linear in t (:func:`crumple.linalg_springs._line_minimum` finds its
    root). With positive springs and dᵀHd >= 0 that root is the least point; with a releasing
    spring or dᵀHd < 0 it need not be, which is why the change at it is checked."""
    d = s - q
    u, v = _rows_dot(index, value, q), _rows_dot(index, value, d)
    hd = hs - hq
    c0, c1 = float((g + hq) @ d), float(d @ hd)
    t = _line_minimum(c0, c1, u, v, offset, stiff)
    if not t > 0.0:
        return None
    change = _q_change(t * c0, t * t * c1, u, t * v, offset, stiff)
    return q + t * d if change < 0.0 else None


def _held_factor(st, ldl, springs, active):
    """The factor of the direction's matrix plus the held springs (the direction's own where
    none is held); None where a spring's rows fall outside its pattern or the sum is not
    positive definite."""
    if not active.any():
        return st.factor
    index, value, _, stiff = springs
    a, shift = st.model
    merged, ok = _with_springs(a.indptr, a.indices, np.ascontiguousarray(a.data), index, value,
                               stiff, active)  # fmt: skip
    if not ok:
        return None
    f = ldl.factorize(CSC(merged, a.indices, a.indptr), shift=shift)
    return None if f.negative else f


def _product(st, v) -> np.ndarray:
    """The accurate H v, flat."""
    return np.asarray(st.hess_action(st.x, v), dtype=np.float64).ravel()


def _rows(v, shape) -> float:
    """The trust radius's measure: the largest row displacement (or entry, for flat x)."""
    return max_force(v.reshape(shape)) if len(shape) == 2 else float(np.max(np.abs(v)))


def _done(st, r, rz, shape, rz0=None, gain=None) -> bool:
    """The solve's test (:data:`ACCURATE_STEP_STOP`): the residual r's largest row below the
    forcing term times the largest force, rᵀz below its tolerance times its value rz0, or
    (``"model"``) the last iteration's gain in the quadratic model, times the iterations
    made, below ``ACCURATE_STEP_MODEL_TOL`` × the gain so far (``gain`` = (last, total, k))."""
    if ACCURATE_STEP_STOP == "preconditioned":
        return rz0 is not None and rz < ACCURATE_STEP_RTOL * rz0
    if ACCURATE_STEP_STOP == "model":
        if gain is None:
            return False
        last, total, k = gain
        return total > 0 and (k + 1) * last <= ACCURATE_STEP_MODEL_TOL * total
    return _rows(r, shape) <= ACCURATE_STEP_FORCING * st.fmax


def _cg(st, action, f, project, s, r, shape):
    """Preconditioned CG on ``action`` s = b from s, r = b - action(s) (projected).

    Returns (s, d, k, why): the iterate, the last direction, its index and why it stopped:
    ``"converged"`` (:func:`_done`, or ``ACCURATE_STEP_MAXITER`` iterations), ``"radius"`` (the
    iterate beyond the trust radius returned: the line search caps it), ``"negative"`` (dᵀAd
    <= 0: s is the iterate before d), ``"none"`` (no residual to reduce). Counts the
    iterations in ``st.krylov``."""
    z = project(f.solve(r))
    d = z.copy()
    rz = rz0 = float(r @ z)
    if not rz > 0:
        return s, d, 0, "none"
    total = 0.0
    for k in range(ACCURATE_STEP_MAXITER):
        ad = action(d)
        dad = float(d @ ad)
        st.krylov += 1
        if not dad > 0:
            return s, d, k, "negative"
        alpha = rz / dad
        s = s + alpha * d
        if _rows(s, shape) > st.radius:
            return s, d, k, "radius"
        r = project(r - alpha * ad)
        z = project(f.solve(r))
        rz_new = float(r @ z)
        last = 0.5 * alpha * rz  # the quadratic model's fall along this direction
        total += last
        if _done(st, r, rz_new, shape, rz0, (last, total, k)):
            break
        d = z + (rz_new / rz) * d
        rz = rz_new
    return s, d, k, "converged"


def _spring_model(g, s, hs, index, value, offset, stiff) -> float:
    """gᵀs + ½ sᵀ(Hs) + Σ_i k_i/2 max(0, r_i - a_iᵀs)², over every listed spring."""
    gap = np.maximum(0.0, offset - _rows_dot(index, value, s))
    return float(g @ s + 0.5 * (s @ hs) + 0.5 * np.sum(stiff * gap * gap))
