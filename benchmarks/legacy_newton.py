"""The Newton solver as landed before issue 9 (main 5e1df83), frozen for side-by-side benchmarks.

Not part of the package: ``benchmarks/bench_scale.py`` runs it in the same process as the new
engine to print ratios. ``legacy_minimize_wire`` calls it exactly as ``crumple.protocol`` did:
step cap of half a segment, dense LAPACK up to 800 dof and SuperLU above, a Levenberg shift
scaled by the median diagonal and contact blocks projected on failure, stability test
H + 1e-13 max(diag H) I positive definite. The Hessian is assembled as it was (COO to CSC).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg.lapack import dpotrf as _potrf
from scipy.linalg.lapack import dpotrs as _potrs

from crumple.energy import DENSE_LIMIT, WireEnergy, _hessian_triplets
from crumple.geometry import has_crossings, max_safe_fraction
from crumple.minimize import MinimizeResult, max_force, resolution

FACTORIZATIONS = [0]


def _row_norms(p):
    return np.abs(p) if p.ndim == 1 else np.sqrt(np.einsum("ij,ij->i", p, p))


def _factor(h, shift):
    """Factorise h + shift I if positive definite; return a solver or None."""
    FACTORIZATIONS[0] += 1
    if sp.issparse(h):
        a = (h + shift * sp.identity(h.shape[0], format="csc")).tocsc()
        try:
            lu = spla.splu(
                a,
                permc_spec="MMD_AT_PLUS_A",
                diag_pivot_thresh=0.0,
                options={"SymmetricMode": True},
            )
        except RuntimeError:  # exactly singular
            return None
        # symmetric pivoting makes this an LDLᵀ: positive pivots ⇔ positive definite (Sylvester)
        if not (np.all(lu.perm_r == lu.perm_c) and np.all(lu.U.diagonal() > 0)):
            return None
        return lu.solve
    a = np.array(h, dtype=np.float64, order="F")  # LAPACK factorises in place
    if shift:
        a.flat[:: a.shape[0] + 1] += shift
    c, info = _potrf(a, lower=False, overwrite_a=True, clean=False)
    if info != 0 or not np.all(np.isfinite(np.diagonal(c))):
        return None
    return lambda b: _potrs(c, b, lower=False)[0]


def _validate_common(x0, ftol, maxiter):
    x = np.array(x0, dtype=np.float64)
    if x.ndim not in (1, 2) or x.size == 0:
        raise ValueError(f"x0 must be a non-empty 1-D or 2-D array, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("x0 contains NaN or infinite values")
    if not (math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be positive, got {ftol}")
    if int(maxiter) < 1:
        raise ValueError(f"maxiter must be >= 1, got {maxiter}")
    return x


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
    curvature_tol: float = 1e-13,
    max_escapes: int = 20,
    callback: Callable[[int, np.ndarray, float, float], None] | None = None,
) -> MinimizeResult:
    """Minimise ``fun`` by a shifted Newton method with a backtracking line search.

    Each iteration factorises ``H + μ s I`` (``s`` the largest diagonal entry of H) by Cholesky
    (dense) or by LDLᵀ-pivoted sparse LU, raising μ from 0 (or a tenth of the last successful
    value) until the matrix is positive definite, so the step is always a descent direction.
    The step is scaled so that no row moves further than ``max_step``, then cut to 0.8 of
    ``step_limit(x, p)`` when that is below 1, then halved until the Armijo condition holds
    and ``feasible`` accepts the point. Near convergence the decrease of the energy falls below
    its floating-point resolution ``16 ε_mach |E|``; a step is then accepted when its energy
    change lies within that resolution and it strictly lowers the largest force (the
    approximate Wolfe condition of Hager & Zhang, 2005). So an accepted step never raises the
    energy by more than ``resolution(E)``.

    A point where the forces vanish is accepted as a minimum only if ``H + τ s I`` is positive
    definite (τ = ``curvature_tol``): at a saddle (the straight wire above its buckling load,
    say) the solver steps along the eigenvector of the most negative eigenvalue, downhill, and
    goes on. Zero modes of a symmetry (a rigid rotation in an isotropic trap) pass the test.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (energy, gradient)``, gradient of the shape of ``x``.
    x0 : array_like, shape (n, dim) or (n,)
        Start; must be admissible (``feasible(x0)``).
    hess : callable
        ``hess(x)`` -> Hessian over ``x.ravel()``: dense ndarray or SciPy sparse matrix.
    hess_fallback : callable, optional
        A positive semi-definite-leaning approximation used (with the shift) whenever the
        exact Hessian is not positive definite; the exact one is always tried first, so
        convergence near a stable minimum stays quadratic.
    ftol : float
        Convergence tolerance on the largest row force ``[energy/length]``.
    maxiter : int
        Newton iterations at most.
    max_step : float, optional
        Largest displacement of any row in one step.
    step_limit : callable, optional
        ``step_limit(x, p) -> t`` in (0, 1]: the fraction of ``p`` that is safe to take.
    feasible : callable, optional
        ``feasible(x) -> bool``, checked on every point before it is accepted.
    curvature_tol : float
        Relative tolerance τ of the stability test at convergence.
    max_escapes : int
        Steps along negative curvature allowed before giving up on stability.
    callback : callable, optional
        ``callback(iteration, x, energy, max_force)`` after every accepted step.

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
    x = np.array(x0, dtype=np.float64)
    if max_step is not None and not (max_step > 0):
        raise ValueError(f"max_step must be positive, got {max_step}")
    if feasible is not None and not feasible(x):
        raise ValueError("the starting point is not feasible")
    e, g = fun(x)
    nfev, nhev = 1, 0
    if not math.isfinite(e):
        raise ValueError(f"the energy at the starting point is {e}")
    fmax = max_force(g)
    mu = 0.0
    message = "maximum number of iterations reached"
    it = 0
    escapes = 0
    unstable = False
    while True:
        if fmax <= ftol:
            h = hess(x)
            nhev += 1
            scale = _diag_scale(h)
            if _factor(h, curvature_tol * scale) is not None:
                message = f"converged: max force {fmax:.3g} <= {ftol:.3g}"
                break
            if escapes >= max_escapes:
                unstable = True
                message = f"stopped at an unstable equilibrium after {escapes} escapes"
                break
            step = _escape(fun, x, e, g, h, max_step, feasible)
            nfev += step[3]
            if step[0] is None:
                unstable = True
                message = "stopped at an equilibrium with negative curvature that no step lowers"
                break
            x, e, g = step[:3]
            fmax = max_force(g)
            escapes += 1
            if callback is not None:
                callback(it, x, e, fmax)
            continue
        if it >= maxiter:
            break
        it += 1
        h = hess(x)
        nhev += 1
        solve = _factor(h, 0.0)
        if solve is not None:
            mu = 0.0
        else:
            # the median, not the largest, diagonal entry sets the shift's scale: a few very
            # stiff rows (contacts) must not make the shift swamp the soft modes
            scale = _diag_scale(h, np.median)
            if hess_fallback is not None:
                h = hess_fallback(x)
                nhev += 1
            mu = mu / 10.0 if mu > 1e-14 else 0.0
            solve = _factor(h, mu * scale)
        while solve is None:
            mu = max(10.0 * mu, 1e-12)
            if mu > 1e12:
                break
            solve = _factor(h, mu * scale)
        if solve is None:
            message = "could not make the Hessian positive definite"
            break
        p = -solve(g.ravel()).reshape(x.shape)
        slope = float(np.vdot(g, p))
        if not (slope < 0 and np.all(np.isfinite(p))):
            message = "the Newton step is not a descent direction (numerical breakdown)"
            break
        alpha = 1.0
        if max_step is not None:
            biggest = float(np.max(_row_norms(p)))
            if biggest > max_step:
                alpha = max_step / biggest
        if step_limit is not None:
            safe = step_limit(x, alpha * p)
            if safe < 1.0:
                alpha *= 0.8 * safe
        accepted = False
        for _ in range(max_backtracks):
            xt = x + alpha * p
            et, gt = fun(xt)
            nfev += 1
            if math.isfinite(et):
                sufficient = et <= e + armijo * alpha * slope
                # below the energy's floating-point resolution only the force can tell a
                # better point (Hager & Zhang's approximate Wolfe condition)
                roundoff = et <= e + resolution(e) and max_force(gt) < fmax
                if (sufficient or roundoff) and (feasible is None or feasible(xt)):
                    accepted = True
                    break
            alpha *= 0.5
            mu = max(mu, 1e-10)  # a failed full step: bias the next ones towards gradient
        if not accepted:
            message = f"line search failed at max force {fmax:.3g} (> {ftol:.3g})"
            break
        x, e, g = xt, float(et), gt
        fmax = max_force(g)
        if callback is not None:
            callback(it, x, e, fmax)
    if escapes and not unstable:
        message += f" ({escapes} saddle escape{'s' if escapes > 1 else ''})"
    return MinimizeResult(
        x=x,
        energy=float(e),
        max_force=fmax,
        iterations=it,
        evaluations=nfev,
        hessian_evaluations=nhev,
        converged=fmax <= ftol and not unstable,
        ftol=ftol,
        message=message,
        method="newton",
    )


def _diag_scale(h, how=np.max) -> float:
    diag = np.abs(h.diagonal())
    scale = float(how(diag)) if diag.size else 1.0
    return scale if scale > 0 else 1.0


def _lowest_mode(h):
    """A unit vector of (most) negative curvature of a symmetric matrix, and its curvature.

    Dense: LAPACK's lowest eigenpair. Sparse: inverse iteration on h + μ I with μ the smallest
    power-of-ten multiple of the diagonal scale that makes it positive definite (ARPACK's
    smallest-algebraic mode does not converge on these stiff matrices); it only has to find
    a direction of negative curvature, which it does as soon as the Rayleigh quotient is < 0.
    """
    if not sp.issparse(h):
        vals, vecs = sla.eigh(h, subset_by_index=[0, 0])
        return float(vals[0]), vecs[:, 0]
    scale = _diag_scale(h)
    mu, solve = 1e-12, None
    while solve is None and mu <= 1e3:
        solve = _factor(h, mu * scale)
        mu *= 10.0
    if solve is None:
        return 0.0, np.zeros(h.shape[0])
    v = np.random.default_rng(0).standard_normal(h.shape[0])  # fixed: results reproducible
    v /= np.linalg.norm(v)
    rq = float(v @ (h @ v))
    for _ in range(100):
        v = solve(v)
        v /= np.linalg.norm(v)
        new = float(v @ (h @ v))
        if new < 0 and abs(new - rq) <= 1e-6 * abs(new):
            rq = new
            break
        rq = new
    return rq, v


def _escape(fun, x, e, g, h, max_step, feasible):
    """Step downhill along the most negative curvature: (x, e, g, evaluations) or (None, ...)."""
    lam, v = _lowest_mode(h)
    if not lam < 0:
        return None, e, g, 0
    d = v.reshape(x.shape)
    if float(np.vdot(g, d)) > 0:
        d = -d
    biggest = float(np.max(_row_norms(d)))
    length = max_step if max_step is not None else 1e-3 * (1.0 + float(np.max(np.abs(x))))
    d = d * (length / biggest)
    nfev = 0
    for _ in range(30):
        xt = x + d
        et, gt = fun(xt)
        nfev += 1
        if math.isfinite(et) and et < e and (feasible is None or feasible(xt)):
            return xt, float(et), gt, nfev
        d = 0.5 * d
    return None, e, g, nfev


def _legacy_hessian(energy, x, project_contacts=False):
    w = energy.wire
    x = np.ascontiguousarray(x, dtype=np.float64)
    ks, js = energy._pairs(x)
    rows, cols, vals = _hessian_triplets(
        x, w.k_b, energy._s, energy._tp, energy.rest_angles, w.k_s, w.rest_length, energy.lam,
        energy.weights, ks, js, w.hard_core, w.hard_core_energy, project_contacts,
    )  # fmt: skip
    ndof = x.size
    if ndof <= DENSE_LIMIT:
        h = np.bincount(rows * ndof + cols, weights=vals, minlength=ndof * ndof)
        return h.reshape(ndof, ndof)
    return sp.csc_matrix((vals, (rows, cols)), shape=(ndof, ndof))


def legacy_minimize_wire(wire, positions, lam, *, ftol=1e-6, maxiter=5000, max_step=0.5,
                         rest_angles=None):  # fmt: skip
    """``crumple.protocol.minimize_wire(method="newton")`` as landed before issue 9."""
    energy = WireEnergy(wire, lam, rest_angles=rest_angles)
    x0 = np.array(positions, dtype=np.float64)
    return newton(
        energy,
        x0,
        hess=lambda x: _legacy_hessian(energy, x),
        hess_fallback=lambda x: _legacy_hessian(energy, x, project_contacts=True),
        ftol=ftol,
        maxiter=maxiter,
        max_step=max_step * wire.rest_length,
        step_limit=max_safe_fraction,
        feasible=lambda x: not has_crossings(x),
    )


def legacy_run_ramp(wire, lambdas, *, seed=0, initial_noise=0.01):
    """A ramp through ``legacy_minimize_wire`` (Newton only, no stage noise)."""
    from crumple.protocol import initial_state

    rng = np.random.default_rng(seed)
    x = initial_state(wire, initial_noise, seed=rng)
    out = []
    for lam in lambdas:
        r = legacy_minimize_wire(wire, x, lam)
        x = r.x
        out.append(r)
    return out
