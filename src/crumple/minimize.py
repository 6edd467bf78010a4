"""Minimisers for any energy-and-gradient callable. Nothing here knows what a wire is.

The variables are an array ``x`` of shape ``(n, dim)`` (or ``(n,)``); the *force* on row ``i`` is
``-grad[i]`` and the convergence criterion is always the same, explicit one:

    converged  ⇔  max_i |grad[i]| <= ftol        (Euclidean norm over the row)

(for :func:`newton`, or below the force's floating-point resolution when ftol is finer than
float64 coordinates can resolve: see :attr:`MinimizeResult.force_resolution`).

:func:`newton` is the default: a Newton method on a sparse LDLᵀ whose symbolic analysis is
reused (:mod:`crumple.linalg`), with a fallback where the Hessian is indefinite, an adaptive
trust radius on the displacement of any row (a length), an Armijo backtracking line search, a
stability test by exact inertia count in a caller-given metric, and two hooks through which a
caller keeps the iterates admissible: ``step_limit(x, p)`` (the largest safe fraction of a
step, e.g. continuous collision detection) and ``feasible(x)`` (an exact test of an accepted
point). An accepted step never raises the energy beyond its floating-point resolution.

:func:`powell` is Numerical Recipes' derivative-free Powell method from a seeded random set of
initial directions, the method of the paper (:mod:`crumple.powell`, compiled when the
caller gives a compiled energy along a line); it is reported on the same criterion.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from . import minimize_accurate
from .linalg import LDLT
from .minimize_accurate import (
    _accurate_check,
    _accurate_resolved,
    _recheck,
)
from .minimize_barriers import _barrier_step, _merged_rows
from .minimize_direction import _direction
from .minimize_fixed import _constrained, _constrained_action, _fixed_mask
from .minimize_krylov import _accurate_spring_step, _accurate_step, _applies
from .minimize_line import _line_search, resolution
from .minimize_modes import _escape, _modes, _negative_count
from .minimize_resolution import _force_resolution, _resolved
from .minimize_result import MinimizeResult, _validate_common, all_finite, max_force
from .minimize_state import _State
from .powell import powell, random_directions

__all__ = ["MinimizeResult", "max_force", "newton", "powell", "random_directions", "resolution"]

#: The default of ``newton(shift_descents=)``: how many times the fallback's shift is lowered
#: once positive definite (:func:`crumple.minimize_direction._lower_shift`; 0: kept).
SHIFT_DESCENTS = 0


def newton(
    fun: Callable[[np.ndarray], tuple[float, np.ndarray]],
    x0,
    *,
    hess: Callable[[np.ndarray], object],
    hess_fallback: Callable[[np.ndarray], object] | None = None,
    ftol: float = 1e-6,
    maxiter: int = 500,
    max_step: float | None = None,
    step_limit: Callable[[np.ndarray, np.ndarray], float] | None = None,
    feasible: Callable[[np.ndarray], bool] | None = None,
    armijo: float = 1e-4,
    max_backtracks: int = 40,
    curvature_tol: float = 1e-8,
    metric=None,
    zero_modes: Callable[[np.ndarray], np.ndarray] | None = None,
    max_escapes: int = 20,
    callback: Callable[[int, np.ndarray, float, float], None] | None = None,
    fixed=None,
    barriers: Callable[[np.ndarray, np.ndarray], tuple] | None = None,
    hess_action: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    retract: Callable[[np.ndarray, np.ndarray, float], np.ndarray] | None = None,
    shift_descents: int | None = None,
    accurate_steps: bool = False,
    springs_from_segment: bool = False,
    springs_updates: bool = False,
    springs_solve_limit: int | None = None,
    patience: int | None = None,
    cut: Callable[[np.ndarray, np.ndarray, float], float] | None = None,
    order_by_points: bool = False,
) -> MinimizeResult:
    """Minimise ``fun`` by Newton's method: one sparse LDLᵀ per iteration, a trust radius.

    **About one factorisation per iteration.** Each iteration factorises the exact Hessian H
    by a sparse LDLᵀ (:class:`crumple.linalg.LDLT`, symbolic analysis reused). Where it is
    positive definite (every pivot above ``curvature_tol × metric``) this is Newton's step.
    With ``zero_modes``, an H that is not is factorised once more with the zero modes' gauge
    fixed (one diagonal entry per mode raised, ``minimize_modes._gauge_pin``): away from
    equilibrium a symmetry's mode can have negative curvature that means nothing (a rigid
    rotation, when the forces have an outward moment), and the step need not move along it.
    Where H is still not positive definite, the step is that of ``hess_fallback`` (a positive
    definite approximation, with the same gauge), and the next few iterations use the
    fallback directly before trying H again. Without a fallback, the pivots below the floor
    are raised as the factorisation goes (modified LDLᵀ).

    **Trust radius in the units of x.** No row moves further than a radius Δ per step: Δ starts
    at ``max_step``, shrinks to the displacement that was accepted when the line search had
    to backtrack, and doubles back towards ``max_step`` after a capped step accepted at once.
    It is a length in the caller's units, so it means the same whatever the number of rows.
    The step is then cut to 0.8 of ``step_limit(x, p)`` when that is below 1 (or where ``cut``
    says, between that and the contact), and halved until
    the Armijo condition holds and ``feasible`` accepts the point. Near convergence the
    decrease of the energy falls below its floating-point resolution ``16 ε_mach |E|``; a step
    is then accepted when its energy change lies within that resolution and it strictly
    lowers the largest force (the approximate Wolfe condition of Hager & Zhang, 2005). So an
    accepted step never raises the energy by more than ``resolution(E)``. Opt-in
    (``minimize_expand.EXPANSIONS``, off), a step of the fallback (below) accepted in full at
    once is then lengthened along its direction while the energy keeps falling (secant trials,
    each safe, feasible, Armijo, lower than the best point so far, not raising the largest
    force).

    **Stability.** A point where the forces vanish is accepted as a minimum only if
    ``H + τ M`` is positive definite, τ = ``curvature_tol`` and M = diag(``metric``): no
    eigenvalue of the pencil (H, M) below -τ. This is an exact inertia count of one LDLᵀ
    (Sylvester's law), not an eigensolver's estimate; τ is absolute, in the units of H per
    unit of the metric, and does not scale with the size or the stiffest entry of H. At a
    saddle (the straight wire above its buckling load, say) the solver steps downhill along
    the lowest mode of (H, M) (LOBPCG, preconditioned by the modified factor) and goes on.
    Zero modes of a symmetry (a rigid rotation in an isotropic trap) pass the test.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (energy, gradient)``, gradient of the shape of ``x``.
    x0 : array_like, shape (n, dim) or (n,)
        Start; must be admissible (``feasible(x0)``).
    hess : callable
        ``hess(x)`` -> Hessian over ``x.ravel()``: dense ndarray, SciPy sparse matrix, or
        :class:`crumple.linalg.CSC` (raw arrays, no SciPy object built per iteration). A
        sparse one whose index arrays do not change between calls is analysed once.
    hess_fallback : callable, optional
        A positive (semi-)definite approximation, in the same pattern, used where the exact
        Hessian is not positive definite (e.g. every element block projected on its positive
        part). Without it the modified factorisation of H is the fallback.
    ftol : float
        Convergence tolerance on the largest row force ``[energy/length]``.
    maxiter : int
        Newton iterations at most.
    max_step : float, optional
        Largest displacement of any row in one step (the largest trust radius), in the units
        of ``x``. None: no cap.
    step_limit : callable, optional
        ``step_limit(x, p) -> t`` in (0, 1]: the fraction of ``p`` that is safe to take. A
        step it cuts (t < 1) is taken to 0.8 t, or further with ``cut``.
    feasible : callable, optional
        ``feasible(x) -> bool``, checked on every point before it is accepted.
    curvature_tol : float
        τ, the stability tolerance (absolute, units of H / metric), and the pivot floor of the
        modified factorisation.
    metric : array_like, optional
        Positive weight of every row (shape ``(n,)``) or entry (shape ``x.size``) of x: the
        mass matrix M of the stability test, e.g. the length each node stands for, so that
        the eigenvalues of (H, M) are those of the continuum and independent of n. Default 1.
    zero_modes : callable, optional
        ``zero_modes(x) -> array (k, x.size)``: directions along which the energy is invariant
        (a rigid rotation about the centre of an isotropic trap). The steps fix their gauge
        where H is indefinite (above). The stability test and the escape work in their
        M-orthogonal complement: such a mode's curvature is zero in
        exact arithmetic but only zero to round-off in H, which at large n exceeds any useful
        τ (measured: -0.06 per unit length for the rotation of a straight wire at N = 10⁴).
        Inertia of H + τM restricted to the complement: neg(H + τM) - neg(Wᵀ(H + τM)⁻¹W).
    max_escapes : int
        Steps along negative curvature allowed before giving up on stability.
    callback : callable, optional
        ``callback(iteration, x, energy, max_force)`` after every accepted step.
    fixed : array_like of bool, shape (n,), optional
        Rows of ``x`` held at their starting values (prescribed degrees of freedom). Their
        gradient entries are set to zero and their Hessian rows and columns replaced by the
        identity, so every step is exactly zero there; the largest force, the reported
        ``max_force``, the stability test and the escapes concern the free rows only. Zero
        modes are the caller's: give only those of the constrained problem.
    barriers : callable, optional
        ``barriers(x, p) -> (index, value, offset, stiffness)``: the barriers that act only
        beyond the current point and that the step ``p`` may enter, as one-sided springs the
        Newton model adds, Σ_i k_i/2 max(0, r_i - a_iᵀs)² over the step s (a_i sparse, its
        entries ``value[i]`` at ``index[i]`` of ``x.ravel()``, arrays of shape (m, w); r_i =
        ``offset[i]`` <= 0, k_i = ``stiffness[i]``). A contact barrier that starts at a
        distance d is invisible to a quadratic model taken outside it, so without this the
        step runs into it and is cut by ``step_limit``; with it the model sees the barrier's
        curvature at its edge before entering. The energy is unchanged: only the step is.
    hess_action : callable, optional
        ``hess_action(x, v) -> H v`` (flat, x.size): the Hessian's product, computed more
        accurately than the assembled ``hess(x)`` can be (e.g. element by element). Used only
        where the inertia count finds negative curvature that the assembled matrix cannot
        resolve (its resolution, ``minimize_accurate._assembly_resolution``, above τ): the
        lowest eigenvalue of (H, M) is then found by LOBPCG on this product, and the point is
        a minimum if it is >= -τ (LOBPCG settled); else the escape is as without it, except
        where no step along the assembled H's lowest mode lowers the energy (a round-off
        direction): it then steps along the accurate lowest mode.
    retract : callable, optional
        ``retract(x, p, alpha) -> x'``: a point on a curve through x whose tangent is p
        (x' = x + αp + O(α²)), e.g. a chain with its segments turned instead of their ends
        moved (:func:`crumple.geometry.curved_step`), or None where it offers none (the
        straight line search is then unchanged). Each trial of the line search then also
        evaluates x' and takes, of x + αp and x', the lower energy of those that pass the same
        tests (Armijo on the slope gᵀp, ``step_limit`` on the whole chord x' - x, ``feasible``).
        Not with ``fixed``: a curve need not keep the fixed rows.
    shift_descents : int, optional
        The fallback's search for σ: once σM makes it positive definite, divide σ by
        ``SHIFT_DESCENT`` up to this many times while the step stays inside the trust radius
        over ``SHIFT_ROOM`` and the factor positive definite. Default :data:`SHIFT_DESCENTS`.
    accurate_steps : bool
        With ``hess_action``, where the assembled H cannot resolve τ: the step is Steihaug's
        truncated CG on the product, preconditioned by the direction's factor, instead of the
        factor's own (``minimize_krylov``; at a saddle the factor's shift is set by round-off
        and its step along the unstable mode is ~10⁻³ of the right one). Where ``barriers``
        lists springs, the springs' step is refined by CG on the product instead
        (``minimize_krylov._accurate_spring_step``). Off by default
        (``crumple.relax.minimize_wire`` turns it on above 10³ segments).
    springs_from_segment : bool
        Where the springs' solve with the factor runs out of rounds, the refactorised step
        (``crumple.linalg_springs.spring_step``) starts from the least point of its model on
        the segment from x to the point the solve reached, where the model is lower there,
        instead of that point (``from_segment``). Off by default
        (``crumple.relax.minimize_wire`` turns it on above 10³ segments).
    springs_updates : bool
        A round of the refactorised step modifies the last round's factor, a rank-one update
        or downdate per spring that joined or left (``crumple.linalg_update``), where that
        touches fewer entries of L than a factorisation costs (``updates``). Off by default
        (``crumple.relax.minimize_wire`` turns it on above 10³ segments).
    springs_solve_limit : int, optional
        Where more springs than this are listed, the springs' step skips the solve with the
        factor (one solve per spring that joins, two joining a round: it runs out of rounds
        when hundreds join) and is the refactorised step at once, a relisting's started from
        the step of the listing before. None (the default): always the solve first
        (``crumple.relax.minimize_wire`` sets it above 10³ segments).
    patience : int, optional
        Stop, unconverged, once this many iterations have passed without the energy going
        below its lowest value by more than its resolution (:func:`resolution`): a pass that
        no longer makes progress (the polish of ``crumple.relax_polish``). None: no such stop.
    cut : callable, optional
        ``cut(x, p, t) -> s``: where to stop a line search's step ``p`` (already capped at the
        trust radius) that ``step_limit`` cuts at ``t < 1``, as a fraction of p; taken where
        0.8 t < s < t strictly, else 0.8 t. E.g. where the pairs that would touch at t are
        brought to the edge of the ``barriers`` listing, so that the next step's model sees
        them (:func:`crumple.geometry.approach_fraction`). The saddle escapes keep 0.8 t.
    order_by_points : bool, optional
        The rows of ``x`` (n, dim) are points in space, and an entry of the Hessian joins
        points that are close: the factorisation's fill-reducing order is then also sought by
        a nested dissection of the iterate's points (:class:`crumple.linalg.LDLT`), kept
        where it gives the fewest nonzeros in L. A different order changes the iterates: by
        round-off, and through it the pivot tests near their thresholds.

    Returns
    -------
    MinimizeResult

    Examples
    --------
    >>> def f(x):       # an anisotropic quadratic bowl
    ...     return float(x[0] ** 2 + 100 * x[1] ** 2), np.array([2 * x[0], 200 * x[1]])
    >>> r = newton(f, [1.0, 1.0], hess=lambda x: np.diag([2.0, 200.0]))
    >>> r.converged, r.iterations, r.x.tolist()
    (True, 1, [0.0, 0.0])
    """
    st, fun, hess, hess_fallback, m = _start(
        fun, x0, hess, hess_fallback, ftol, maxiter, max_step, feasible, curvature_tol, metric,
        zero_modes, fixed, hess_action, retract, shift_descents, accurate_steps,
        springs_from_segment, springs_updates, springs_solve_limit, patience, cut,
    )  # fmt: skip
    if patience is not None:
        patience = int(patience)
    points = (lambda: st.x if st.x.ndim == 2 else None) if order_by_points else None
    ldl = LDLT(points=points, shared=True)  # a ramp's next stage recalls this one's analyses
    floor = curvature_tol * m
    message = "maximum number of iterations reached"
    while True:
        if st.fmax <= max(ftol, st.fres) and not st.refine:
            h = hess(st.x)
            st.nhev += 1
            st.fres = _force_resolution(h, st.x)
        if st.fmax <= max(ftol, st.fres) and not st.refine:
            stop = _equilibrium(st, fun, h, ftol, m, ldl, floor, zero_modes, max_escapes,
                                step_limit, feasible)  # fmt: skip
            if stop is not None:
                message = stop
                break
            if callback is not None and not st.refine:
                callback(st.it, st.x, st.e, st.fmax)
            continue
        if st.it >= maxiter:
            if st.refine:
                message += f" (the last point {st.refine_note})"
            break
        failure = _newton_step(st, fun, hess, hess_fallback, ldl, floor, m, barriers, step_limit,
                               feasible, armijo, max_backtracks, max_step, retract)  # fmt: skip
        if failure:
            message = failure + (f" (the point returned {st.refine_note})" if st.refine else "")
            break
        st.refine = False
        if callback is not None:  # an accepted step, the last one of a pass out of patience too
            callback(st.it, st.x, st.e, st.fmax)
        if _out_of_patience(st, patience):
            message = (f"stopped: no decrease beyond the energy's resolution in {patience} "
                       "iterations")  # fmt: skip
            break
    return _result(st, ldl, ftol, message)


def _start(fun, x0, hess, hess_fallback, ftol, maxiter, max_step, feasible, curvature_tol,
           metric, zero_modes, fixed, hess_action, retract, shift_descents, accurate_steps,
           springs_from_segment, springs_updates, springs_solve_limit, patience, cut):  # fmt: skip
    """:func:`newton`'s arguments checked and its state at the start: (state, fun, hess,
    hess_fallback, metric), the three callables wrapped where rows are fixed."""
    x = _validate_common(x0, ftol, maxiter)
    if max_step is not None and not (max_step > 0):
        raise ValueError(f"max_step must be positive, got {max_step}")
    if not (math.isfinite(curvature_tol) and curvature_tol > 0):
        raise ValueError(f"curvature_tol must be positive, got {curvature_tol}")
    m = _metric(metric, x)
    mask = _fixed_mask(fixed, x)
    if mask is not None and retract is not None:
        raise ValueError("retract cannot be combined with fixed rows (a curve can move them)")
    if mask is not None:
        fun, hess, hess_fallback = _constrained(mask, fun, hess, hess_fallback)
        hess_action = _constrained_action(mask, hess_action)
    if feasible is not None and not feasible(x):
        raise ValueError("the starting point is not feasible")
    e, g = fun(x)
    if not math.isfinite(e):
        raise ValueError(f"the energy at the starting point is {e}")
    st = _State(x=x, e=float(e), g=g, fmax=max_force(g), mask=mask)
    st.radius = math.inf if max_step is None else float(max_step)
    st.zero_modes = zero_modes
    st.hess_action = hess_action
    st.descents = SHIFT_DESCENTS if shift_descents is None else int(shift_descents)
    st.accurate_steps = bool(accurate_steps)
    st.springs_from_segment = bool(springs_from_segment)
    st.springs_updates = bool(springs_updates)
    if springs_solve_limit is not None and int(springs_solve_limit) < 0:
        raise ValueError(f"springs_solve_limit must be >= 0 or None, got {springs_solve_limit!r}")
    st.springs_solve_limit = None if springs_solve_limit is None else int(springs_solve_limit)
    st.cut = cut
    if patience is not None:
        if int(patience) < 1:
            raise ValueError(f"patience must be >= 1, got {patience!r}")
        st.best = st.e
    return st, fun, hess, hess_fallback, m


def _out_of_patience(st, patience) -> bool:
    """Whether ``patience`` iterations have passed since the energy last went below its lowest
    value by more than its resolution (``st.best``, ``st.best_it`` updated); never for None."""
    if patience is None:
        return False
    if st.e < st.best - resolution(st.best):  # st.best: the start's energy, set by newton
        st.best, st.best_it = st.e, st.it
    return st.it - st.best_it >= patience


def _equilibrium(st, fun, h, ftol, m, ldl, floor, zero_modes, max_escapes, step_limit, feasible):
    """At a point where the forces vanish (H = ``h``): the stop message if it is a minimum
    (H + τM positive definite off the zero modes) or if no escape is left or possible, else
    None after one escape step downhill along the lowest mode (``st`` moved, counted)."""
    check = ldl.factorize(h, shift=floor)
    modes = _modes(zero_modes, st.x, m)
    if _negative_count(check, modes) == 0 and not _recheck(st, h, m, floor):
        return _minimum(st, ftol, lambda: _resolved(st, h, check, modes), "")
    stable, mode, model = _accurate_check(st, h, m, ldl, floor, modes, check)  # H cannot tell
    if stable is not None:
        return _minimum(st, ftol, lambda: _accurate_resolved(st, model, modes, floor), stable)
    if st.escapes >= max_escapes:
        st.unstable = True
        return f"stopped at an unstable equilibrium after {st.escapes} escapes{_along(st)}"
    # the accurate mode first where asked, or once the assembled one has failed in this run
    first = mode if minimize_accurate.ACCURATE_ESCAPE or st.accurate_escapes else None
    escaped = _escape(st, fun, h, m, ldl, check, floor, modes, step_limit, feasible, first)
    if first is not None and not minimize_accurate.ACCURATE_ESCAPE:
        st.accurate_escapes += escaped
        if not escaped:  # the assembled H's mode after all
            escaped = _escape(st, fun, h, m, ldl, check, floor, modes, step_limit, feasible)
    elif not escaped and first is None and mode is not None:
        # the rescue: the assembled mode gives no step down (round-off at large N)
        escaped = _escape(st, fun, h, m, ldl, check, floor, modes, step_limit, feasible, mode)
        st.accurate_escapes += escaped
    if not escaped:
        st.unstable = True
        return "stopped at an equilibrium with negative curvature that no step lowers"
    st.escapes += 1
    return None


def _minimum(st, ftol, test, stable) -> str | None:
    """At a stable point (``stable``: how it was found so, for the message): the converged
    message, or None (``st.refine`` set, go on) where the forces are only below their
    resolution and ``test()`` -> (resolved, note) finds that a Newton step still predicts a
    decrease. Where the accurate product decided (``stable`` not empty), each refusal costs an
    eigensolve: after ``minimize_accurate.ACCURATE_REFUSALS`` of them in a stage (not
    necessarily in a row) it stops, unconverged, even if it was still approaching ftol."""
    if st.fmax <= ftol:
        return _converged(st, ftol) + stable
    resolved, note = test()
    if resolved:
        return _converged(st, ftol) + stable + note
    st.refine, st.refine_note = True, note  # forces below their resolution, but coherent
    if stable:
        st.refusals += 1
        if st.refusals >= minimize_accurate.ACCURATE_REFUSALS:
            return (f"stopped after {st.refusals} points stable by the accurate Hessian product "
                    "whose forces were below their resolution but coherent (the last point "
                    f"{note})")  # fmt: skip
    return None


def _converged(st, ftol) -> str:
    """The stop message of a minimum: converged, or converged to the force resolution."""
    if st.fmax > ftol:
        return (
            f"converged to the force resolution: max force {st.fmax:.3g} <= "
            f"{st.fres:.3g}, the force change of a one-ulp move ({ftol:.3g} is "
            "below what float64 positions resolve)"
        )
    return f"converged: max force {st.fmax:.3g} <= {ftol:.3g}"


def _newton_step(st, fun, hess, hess_fallback, ldl, floor, m, barriers, step_limit, feasible,
                 armijo, max_backtracks, max_step, retract=None):  # fmt: skip
    """One Newton iteration: the direction (with the barriers' springs, zero on the fixed
    entries) and its line search; ``st`` updated; None, or why the iteration failed."""
    st.it += 1
    p = _direction(st, hess, hess_fallback, ldl, floor, m)
    pending, q = _pending_step(st, barriers, ldl, m, floor)
    taken = pending is not None
    if taken:  # the refused point's own step, q its springs' step
        p = pending
    else:
        q = p if barriers is None else _barrier_step(st, p, barriers, ldl)
    if q is p and not taken:  # no spring: the accurate product's step where the assembled H
        s = _accurate_step(st, p, m, floor)  # cannot resolve (p itself where it does not apply)
        # a longer step may reach pairs p did not: then p, whose barriers were listed
        q = p if s is p or (barriers is not None and len(barriers(st.x, s)[2])) else s
    elif q is not p and st.springs is not None:  # the springs' step, refined with the product
        s = _accurate_spring_step(st, q, st.springs, ldl, m, floor)
        # kept only if it enters no pair the springs' step was not listed with
        q = q if s is q or _merged_rows(st.springs, barriers(st.x, s))[1] else s
    p = q
    if st.mask is not None:  # zero already in exact arithmetic; made exact in floating point
        p.reshape(-1)[st.mask] = 0.0
    if not all_finite(p):
        return "could not make the Hessian positive definite (non-finite factor)"
    return _line_search(st, fun, p, step_limit, feasible, armijo, max_backtracks, max_step,
                        retract)  # fmt: skip


def _pending_step(st, barriers, ldl, m, floor):
    """The step a refused point handed on (``minimize_accurate.REFUSED_STEPS``) and its
    springs' step (itself where none is listed), or (None, None) where it is not taken.

    Taken where :func:`_takes` accepts it, unless no spring is listed for it and the accurate
    product makes the step (:func:`crumple.minimize_krylov._applies`): that step solves the
    same system by truncated CG to its own test, where the refused point's solve stopped as
    soon as the decrease bound was passed (measured: the first smooth stage after buckling at
    N = 10⁵, 20 iterations with the handed-on step, 8 without; docs/performance.md)."""
    pending, st.pending = st.pending, None
    if pending is None or not _takes(st, pending):
        return None, None
    q = pending if barriers is None else _barrier_step(st, pending, barriers, ldl)
    if st.springs is None and _applies(st, m, floor):
        return None, None
    return pending, q


def _takes(st, step) -> bool:
    """Whether the step handed on by a refused point (``minimize_accurate.REFUSED_STEPS``) is
    taken: finite, a descent direction, zero on the fixed entries. Where the caller lists
    barriers for it, the springs' model starts from it (its corrections by the factor: the
    contacts' response is stiff and local, where the factor is exact)."""
    flat = step.reshape(-1)
    if not (all_finite(flat) and float(np.dot(st.g.ravel(), flat)) < 0.0):
        return False
    return st.mask is None or not np.any(flat[st.mask])


def _result(st, ldl, ftol, message) -> MinimizeResult:
    """The result of :func:`newton` from its final state and stop message."""
    if st.escapes and not st.unstable:
        message += f" ({st.escapes} saddle escape{'s' if st.escapes > 1 else ''}{_along(st)})"
    return MinimizeResult(
        x=st.x,
        energy=st.e,
        max_force=st.fmax,
        iterations=st.it,
        evaluations=st.nfev,
        hessian_evaluations=st.nhev,
        converged=st.fmax <= max(ftol, st.fres) and not st.unstable and not st.refine,
        ftol=ftol,
        message=message,
        method="newton",
        factorizations=ldl.factorizations,
        force_resolution=st.fres,
        curved_steps=st.curved,
        krylov_iterations=st.krylov,
    )


def _along(st) -> str:
    """The escape message's note of the escapes the accurate mode took (the rescue, and every
    escape after it in the run), or ""."""
    if not st.accurate_escapes:
        return ""
    return (f", {st.accurate_escapes} along the accurate Hessian product's mode, the assembled "
            "one's having given no step down")  # fmt: skip


def _metric(metric, x) -> np.ndarray:
    """The metric as one positive weight per entry of ``x.ravel()``."""
    if metric is None:
        return np.ones(x.size)
    w = np.asarray(metric, dtype=np.float64).ravel()
    if x.ndim == 2 and w.size == x.shape[0]:
        w = np.repeat(w, x.shape[1])
    if w.size != x.size or not np.all(np.isfinite(w)) or not np.all(w > 0):
        raise ValueError(f"metric must hold {x.size} (or one per row) positive weights")
    return w
