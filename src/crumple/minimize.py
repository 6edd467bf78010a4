"""Minimisers for any energy-and-gradient callable. Nothing here knows what a wire is.

The variables are an array ``x`` of shape ``(n, dim)`` (or ``(n,)``); the *force* on row ``i`` is
``-grad[i]`` and the convergence criterion is always the same, explicit one:

    converged  ⇔  max_i |grad[i]| <= ftol        (Euclidean norm over the row)

:func:`newton` is the default: a Newton method with a Levenberg shift that keeps the
model Hessian positive definite, an Armijo backtracking line search, an optional cap on the
displacement of any row per step, and two hooks through which a caller keeps the iterates
admissible: ``step_limit(x, p)`` (the largest safe fraction of a step, e.g. continuous collision
detection) and ``feasible(x)`` (an exact test of an accepted point). An accepted step never
raises the energy.

:func:`powell` wraps SciPy's derivative-free Powell method with a seeded random set of
initial directions, the method of the paper; it is reported on the same criterion.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg.lapack import dpotrf as _potrf
from scipy.linalg.lapack import dpotrs as _potrs
from scipy.optimize import minimize as _scipy_minimize

__all__ = ["MinimizeResult", "max_force", "newton", "powell", "random_directions", "resolution"]

_EPS = float(np.finfo(float).eps)


@dataclass(frozen=True, slots=True, kw_only=True)
class MinimizeResult:
    """Outcome of a minimisation.

    Attributes
    ----------
    x : ndarray
        Final point, shape of the start.
    energy : float
        Energy at ``x``.
    max_force : float
        max_i |grad[i]| at ``x``.
    iterations, evaluations, hessian_evaluations : int
        Outer iterations; energy-and-gradient (or energy-only, for Powell) calls; Hessians.
    converged : bool
        ``max_force <= ftol``.
    ftol : float
        The tolerance used.
    message : str
        Why it stopped.
    method : str
    """

    x: np.ndarray
    energy: float
    max_force: float
    iterations: int
    evaluations: int
    hessian_evaluations: int
    converged: bool
    ftol: float
    message: str
    method: str


def max_force(grad) -> float:
    """Largest row norm of a gradient (largest node force); absolute value for 1-D arrays.

    >>> max_force(np.array([[3.0, 4.0], [0.0, 1.0]]))
    5.0
    """
    g = np.asarray(grad)
    if g.ndim == 1:
        return float(np.max(np.abs(g))) if g.size else 0.0
    return float(np.sqrt(np.max(np.einsum("ij,ij->i", g, g)))) if g.size else 0.0


def _row_norms(p):
    return np.abs(p) if p.ndim == 1 else np.sqrt(np.einsum("ij,ij->i", p, p))


def _factor(h, shift):
    """Factorise h + shift I if positive definite; return a solver or None."""
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
    x = _validate_common(x0, ftol, maxiter)
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


def resolution(energy: float) -> float:
    """Floating-point resolution of an energy value: 16 ε_mach |E| (and at least 1e-300).

    >>> bool(resolution(1.0) == 16 * np.finfo(float).eps)
    True
    """
    return max(16.0 * _EPS * abs(energy), 1e-300)


def random_directions(n: int, rng: np.random.Generator) -> np.ndarray:
    """A random orthonormal basis of R^n (Haar-distributed), one direction per row.

    >>> q = random_directions(4, np.random.default_rng(0))
    >>> bool(np.allclose(q @ q.T, np.eye(4)))
    True
    """
    a = rng.standard_normal((n, n))
    q, r = np.linalg.qr(a)
    return (q * np.sign(np.diag(r))).T


def powell(
    energy: Callable[[np.ndarray], float],
    x0,
    *,
    rng: np.random.Generator,
    gradient: Callable[[np.ndarray], np.ndarray] | None = None,
    feasible: Callable[[np.ndarray], bool] | None = None,
    ftol: float = 1e-6,
    maxiter: int = 50,
    maxfev: int | None = None,
    xtol: float = 1e-10,
) -> MinimizeResult:
    """The paper's method: SciPy's Powell with a random initial set of search directions.

    Inadmissible points (``feasible(x)`` false) get energy +inf, so Powell's line searches
    never step onto them. Powell uses no gradient; ``gradient`` (if given) is used once at the
    end to report the largest force, and ``converged`` means the same as for :func:`newton`:
    ``max_force <= ftol``. Powell's own stopping reason is kept in ``message``.

    Parameters
    ----------
    energy : callable
        ``energy(x) -> float``.
    x0 : array_like, shape (n, dim) or (n,)
    rng : numpy.random.Generator
        Source of the random directions.
    gradient : callable, optional
        ``gradient(x) -> array`` of the shape of ``x``, for the report.
    ftol : float
        Force tolerance of the report (as in :func:`newton`).
    maxiter, maxfev : int
        Powell's iteration and evaluation limits.
    xtol : float
        Powell's line-search tolerance.

    Examples
    --------
    >>> f = lambda x: float((x[0] - 1) ** 2 + 10 * (x[1] + 2) ** 2)
    >>> g = lambda x: np.array([2 * (x[0] - 1), 20 * (x[1] + 2)])
    >>> r = powell(f, [0.0, 0.0], rng=np.random.default_rng(1), gradient=g)
    >>> r.converged, np.round(r.x, 6).tolist()
    (True, [1.0, -2.0])
    """
    x = _validate_common(x0, ftol, maxiter)
    shape = x.shape
    nfev = 0

    def f(flat):
        nonlocal nfev
        nfev += 1
        y = flat.reshape(shape)
        if feasible is not None and not feasible(y):
            return math.inf
        return energy(y)

    direc = random_directions(x.size, rng)
    opts = {"direc": direc, "maxiter": int(maxiter), "xtol": xtol, "ftol": 1e-14}
    if maxfev is not None:
        opts["maxfev"] = int(maxfev)
    # Brent's parabolic step meets inf - inf at an inadmissible point and falls back to a
    # golden-section step; the NaN it computes on the way is expected, not an error
    with np.errstate(invalid="ignore", over="ignore"):
        res = _scipy_minimize(f, x.ravel(), method="Powell", options=opts)
    xf = np.asarray(res.x, dtype=np.float64).reshape(shape)
    ef = energy(xf)
    fmax = max_force(gradient(xf)) if gradient is not None else math.nan
    return MinimizeResult(
        x=xf,
        energy=float(ef),
        max_force=fmax,
        iterations=int(res.nit),
        evaluations=nfev,
        hessian_evaluations=0,
        converged=bool(fmax <= ftol),
        ftol=ftol,
        message=f"powell: {res.message}",
        method="powell",
    )
