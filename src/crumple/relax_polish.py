"""The polish of a Newton minimum that float64 positions cannot resolve: Newton again, in the
displacement from it. Private; used by :func:`crumple.relax.minimize_wire`.

A stage of a wire of N segments converges to the force resolution of its positions (the force
a one-ulp move makes, ``MinimizeResult.force_resolution``), ~ 10 × 16 ε k_b/l0² |x| from the
bending blocks: 2 × 10⁻² per node at N = 5 × 10⁴ against ftol = 10⁻⁶. Where a stage stopped
there, :func:`_polished` minimises again in u = x − x₁ from its end point x₁, with the elastic
terms from the segments' sums (:meth:`crumple.energy.WireEnergy.displaced`): the resolution of
that pass is set by |u| (10⁻¹¹ after the first pass), not |x|. Every criterion is Newton's own
(force, stability, the decrease test), in the displacement, on the same energy; the result is
taken only if that pass converged with a lower largest force.

Where the first pass did not converge (refused by the decrease test, or stopped at an unstable
equilibrium) and the polish lowered its energy and its largest force without converging by its
own test, the polish's end point is tried again by the first pass's criteria
(:func:`_retried`: Newton in the coordinates from there). The polish can stall
above its own force floor at a point that the coordinates' criteria accept (N = 10⁵,
λ = 33.39, at a contact of the wire's end: docs/performance.md, "The polish's budget"). That
pass is a fresh ``newton``: its trust radius, saddle escapes and refusals start again.
Otherwise the first pass stands.

What it does not change: the stage's positions are still float64 (x₁ + u rounded), so forces
re-evaluated from them sit at the old resolution; the polish's ``max_force`` is that of the
configuration x₁ + u (the sum in exact arithmetic). The hard core and the wall are evaluated at
the rounded sum, so where their curvature dominates the resolution the polish in the
displacement gains nothing by its own test.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .minimize import MinimizeResult, newton

#: Polish a Newton stage that stopped with its forces above ftol but below their resolution
#: (False: the engine before the tenth stop).
POLISH = True
#: The polish, and the retry after it, stop once this many iterations have passed without the
#: energy going below its lowest value by more than its resolution (``newton(patience=...)``),
#: within the stage's own budget, which holds for all its passes. Measured (docs/performance.md,
#: "The polish's budget"): polishes that stalled ran the stage's whole budget (4863 and 4970
#: iterations at N = 10⁵) without converging by their own test, the energy constant to 14
#: digits (λ = 33.39); and a polish that does converge can take hundreds of iterations of real
#: descent (λ = 420.6), which a cap on its iterations (100, tried first) cut short.
POLISH_PATIENCE = 20
#: Where the polish lowered the energy and the forces of an unconverged first pass without
#: converging by its own test, Newton again in the coordinates from its end point
#: (:func:`_retried`), by the first pass's criteria (False: the first pass stands).
RETRY = True
#: The callables of ``newton`` that take the point as their first argument.
_AT_POINT = ("hess", "feasible", "zero_modes", "hess_action", "step_limit", "barriers")


def _needs_polish(first: MinimizeResult, ftol: float) -> bool:
    """Whether the stage stopped with its forces above ftol but below their resolution: at the
    force resolution of its positions (converged so, or refused there by the decrease test). A
    stage that stopped with larger forces (out of iterations, a failed line search) is not the
    polish's to mend."""
    return POLISH and ftol < first.max_force <= first.force_resolution


def _polished(
    energy, first: MinimizeResult, kw: dict, ftol: float, callback=None
) -> MinimizeResult:
    """Newton in the displacement from ``first.x`` (``kw``: the first pass's keywords); the
    polished result if it converged below the first's largest force; else, where due
    (:func:`_retry_due`), the retry's from the polish's end point if that converged; else
    ``first``. The counts of every pass are added, and the message says what each did.
    ``callback(iteration, positions, energy, max_force)``: each pass's accepted steps, their
    iterations counted on from the passes before, the polish's positions ``first.x + u``."""
    ref = np.array(first.x, dtype=np.float64)
    left = int(kw.get("maxiter", 500)) - first.iterations  # the stage's budget holds for all
    if left < 1:
        return first
    plain = kw
    # straight steps (a pass near a minimum), stopped where it no longer makes progress
    kw = dict(kw, retract=None, maxiter=left, patience=POLISH_PATIENCE)

    def at(c):
        return None if c is None else (lambda u, *args: c(ref + u, *args))

    same = kw.get("hess_fallback") is kw.get("hess")  # the exact fallback is H itself
    for name in _AT_POINT:
        kw[name] = at(kw.get(name))
    kw["hess_fallback"] = kw["hess"] if same else at(kw.get("hess_fallback"))
    seen = _counted_on(callback, first.iterations, ref)
    res = newton(energy.displaced(ref), np.zeros_like(ref), **kw, callback=seen)
    cost = _cost(first, res)
    if res.converged and res.max_force < first.max_force:
        message = (f"{res.message}; polished in the displacement ({res.iterations} iterations) "
                   f"after a first pass of {first.iterations}: {first.message}")  # fmt: skip
        return dataclasses.replace(res, x=ref + res.x, ftol=ftol, message=message, **cost)
    polish = f"({res.iterations} iterations in the displacement: {res.message})"
    note = ""
    if _retry_due(first, res):
        third = _retried(energy, ref + res.x, plain, cost, callback)
        if third is not None:
            cost = _cost(first, res, third)
            if third.converged:
                message = (f"{third.message}; retried in the coordinates ({third.iterations} "
                           f"iterations) from the end of a polish {polish}, after a first pass "
                           f"of {first.iterations}: {first.message}")  # fmt: skip
                return dataclasses.replace(third, ftol=ftol, message=message, **cost)
            note = f"; retried in the coordinates ({third.iterations} iterations: {third.message})"
    message = f"{first.message}; not polished {polish}{note}"
    return dataclasses.replace(first, message=message, **cost)


def _counted_on(callback, before: int, ref=None):
    """``callback`` for a pass after ``before`` iterations: its iterations counted on, and
    (``ref`` given: a pass in the displacement) its points as positions ``ref + u``."""
    if callback is None:
        return None
    if ref is None:
        return lambda it, x, e, fmax: callback(before + it, x, e, fmax)
    return lambda it, u, e, fmax: callback(before + it, ref + u, e, fmax)


def _cost(*passes: MinimizeResult) -> dict:
    """The counts of a stage made of several Newton passes, added up."""
    names = ("iterations", "evaluations", "hessian_evaluations", "factorizations",
             "krylov_iterations", "curved_steps")  # fmt: skip
    return {k: sum(getattr(p, k) for p in passes) for k in names}


def _retry_due(first: MinimizeResult, res: MinimizeResult) -> bool:
    """Whether the polish ``res`` of an unconverged first pass ended lower in energy and in
    force without converging by its own test: then its end point is tried again."""
    return (RETRY and not first.converged and res.energy < first.energy
            and res.max_force < first.max_force)  # fmt: skip


def _retried(energy, x, kw: dict, cost: dict, callback=None) -> MinimizeResult | None:
    """Newton in the coordinates from ``x`` (the end point of a polish) with the first pass's
    keywords ``kw`` and criteria, stopped by the polish's patience (``POLISH_PATIENCE``) and
    within what is left of the stage's budget after ``cost``; None when nothing is left.
    ``callback``: its accepted steps, counted on from ``cost["iterations"]``."""
    left = int(kw.get("maxiter", 500)) - cost["iterations"]
    if left < 1:
        return None
    seen = _counted_on(callback, cost["iterations"])
    return newton(energy, x, **dict(kw, maxiter=left, patience=POLISH_PATIENCE), callback=seen)
