"""Powell's method as in Numerical Recipes (Press et al., 2nd ed., §10.5), one source, two speeds.

The loop (:func:`_powell_loop`), its line minimisation (:func:`_line_min`: a bracket, then
Brent's method) and the bracket are plain Python written in the subset Numba compiles. The
problem enters only through three callables and an opaque ``params``:

``prepare(x, d, params) -> (lo, hi, aux)``
    Before a line search along ``d`` from ``x``: the admissible interval ``lo <= 0 <= hi`` of
    the step ``t`` (a continuous collision bound, say) and any data the evaluations reuse
    (a neighbour list valid over that interval).
``evaluate(x, d, t, params, aux) -> float``
    The energy at ``x + t d`` (``+inf`` where inadmissible).
``admissible(y, params) -> bool``
    An exact test of the point a line search ends at; a failing point is not taken.

With plain Python callables :func:`_powell_loop` runs as Python (any energy, slowly); with
Numba-compiled ones, :data:`_powell_loop_nb` runs the whole minimisation compiled. Nothing here
knows what a wire is.

Every line search returns a point whose energy is no higher than its start (else it stays
put), and the extrapolated point of a sweep is only probed, never taken, so the energy never
rises. NR's stopping rule ends a minimisation when a sweep lowers the energy by less than the
fraction ``rtol`` (2 (f_p - f) <= rtol (|f_p| + |f|) + 1e-25); NR aborts after ITMAX = 200
sweeps, here ``maxiter`` ends it with status 1.
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable

import numpy as np
from numba import njit

from .minimize_result import MinimizeResult, _row_norms, _validate_common, max_force

__all__ = ["STATUS", "powell", "random_directions"]

GOLD = 1.618034  # NR's default magnification of successive bracket intervals
CGOLD = 0.3819660  # NR's golden-section fraction
ZEPS = 1e-10  # NR's absolute floor of Brent's tolerance (the step of a unit direction)
TINY = 1e-25  # NR's guard of the relative stopping rule
MAX_EXPAND = 60
BRENT_ITMAX = 100  # NR's ITMAX of brent
MIN_STEP = 1e-12  # smallest first trial step of a line search (units of the direction)

#: What the status code of :func:`_powell_loop` means.
STATUS = {
    0: "relative decrease of a sweep below rtol",
    1: "maximum number of sweeps reached",
    2: "maximum number of energy evaluations reached",
}


def _brent(x0, d, a, b, xb, fb, evaluate, params, aux, tol):
    """Brent's minimisation of t -> evaluate(x0 + t d) in the bracket [a, b] around xb.

    NR's ``brent`` with one change: a parabola through a non-finite value (an inadmissible
    point) is never used; a golden-section step is taken instead. Returns (t, f(t), evals).
    """
    x = w = v = xb
    fx = fw = fv = fb
    e = 0.0
    dd = 0.0
    nev = 0
    for _ in range(BRENT_ITMAX):
        xm = 0.5 * (a + b)
        tol1 = tol * abs(x) + ZEPS
        tol2 = 2.0 * tol1
        if abs(x - xm) <= tol2 - 0.5 * (b - a):
            break
        golden = True
        if abs(e) > tol1:
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            etemp = e
            e = dd
            ok = math.isfinite(p) and math.isfinite(q)
            if ok and not (abs(p) >= abs(0.5 * q * etemp) or p <= q * (a - x) or p >= q * (b - x)):
                dd = p / q
                u = x + dd
                if u - a < tol2 or b - u < tol2:
                    dd = tol1 if xm - x >= 0.0 else -tol1
                golden = False
        if golden:
            e = a - x if x >= xm else b - x
            dd = CGOLD * e
        u = x + dd if abs(dd) >= tol1 else x + (tol1 if dd >= 0.0 else -tol1)
        fu = evaluate(x0, d, u, params, aux)
        nev += 1
        if fu <= fx:
            if u >= x:
                a = x
            else:
                b = x
            v, w, x = w, x, u
            fv, fw, fx = fw, fx, fu
        else:
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v, w = w, u
                fv, fw = fw, fu
            elif fu <= fv or v == x or v == w:
                v = u
                fv = fu
    return x, fx, nev


def _expand(x0, d, f0, h, limit, evaluate, params, aux):
    """Walk downhill from t = 0 by h, h(1 + GOLD), ... (never past ``limit``, same sign as h).

    Returns (a, b, c, fb, evals, found): found when f(b) < f(a) and f(b) <= f(c) (a bracket of
    a minimum, b inside), else b is the best point seen and (a, c) the interval searched.
    """
    a, fa = 0.0, f0
    b = h
    if abs(b) > abs(limit):
        b = limit
    fb = evaluate(x0, d, b, params, aux)
    nev = 1
    if not fb < fa:
        return a, 0.0, b, fa, nev, False
    for _ in range(MAX_EXPAND):
        if b == limit:
            return a, b, b, fb, nev, False
        c = b + GOLD * (b - a)
        if abs(c) > abs(limit):
            c = limit
        fc = evaluate(x0, d, c, params, aux)
        nev += 1
        if fc >= fb:
            return a, b, c, fb, nev, True
        a, fa, b, fb = b, fb, c, fc
    return a, b, b, fb, nev, False


def _line_min(x, d, h, prepare, evaluate, params, tol):
    """Minimise along ``d`` from ``x``: bracket the minimum from the trial step ``h`` (> 0), then
    Brent. Returns (t, f(x + t d), f(x), evaluations); t = 0 when nothing lower was found."""
    lo, hi, aux = prepare(x, d, params)
    f0 = evaluate(x, d, 0.0, params, aux)
    nev = 1
    if not (hi > 0.0 or lo < 0.0):
        return 0.0, f0, f0, nev
    best_t, best_f = 0.0, f0
    for sign in (1.0, -1.0):
        limit = hi if sign > 0 else lo
        if limit == 0.0:
            continue
        a, b, c, fb, k, found = _expand(x, d, f0, sign * h, limit, evaluate, params, aux)
        nev += k
        if found:
            left, right = min(a, c), max(a, c)
            t, ft, k = _brent(x, d, left, right, b, fb, evaluate, params, aux, tol)
            nev += k
            if ft < best_f:
                best_t, best_f = t, ft
            return best_t, best_f, f0, nev
        if fb < best_f:  # ran into the interval's end still going downhill
            best_t, best_f = b, fb
            return best_t, best_f, f0, nev
    # uphill both ways at ±h: the minimum lies within (-h, h) around 0
    left = max(lo, -h)
    right = min(hi, h)
    t, ft, k = _brent(x, d, left, right, 0.0, f0, evaluate, params, aux, tol)
    nev += k
    if ft < best_f:
        best_t, best_f = t, ft
    return best_t, best_f, f0, nev


def _powell_loop(x, direc, steps, prepare, evaluate, admissible, params, maxiter, rtol, tol,
                 maxfev):  # fmt: skip
    """NR's ``powell`` from ``x`` (1-D, modified in place) with the directions ``direc`` (rows).

    ``steps[i]``: the first trial step along direction i, updated to twice the last step
    taken (so that a bracket costs a few evaluations). Returns (energy, sweeps, evaluations,
    status, rejected), status a key of :data:`STATUS`, rejected the line-search end points
    ``admissible`` refused.
    """
    n = direc.shape[0]
    _, _, aux = prepare(x, direc[0], params)
    fret = evaluate(x, direc[0], 0.0, params, aux)
    nev = 1
    rejected = 0
    pt = x.copy()
    it = 0
    status = 1
    while it < maxiter:
        it += 1
        fp = fret
        ibig = 0
        delta = 0.0
        for i in range(n):
            d = direc[i]
            t, ft, f0, k = _line_min(x, d, steps[i], prepare, evaluate, params, tol)
            nev += k
            fret = f0
            moved = False
            if t != 0.0 and ft < f0:
                y = x + t * d
                if admissible(y, params):
                    x[:] = y
                    fret = ft
                    moved = True
                else:
                    rejected += 1
            # the next trial step: twice this one, or half the last trial if nothing was lower
            steps[i] = max(2.0 * abs(t) if moved else 0.5 * steps[i], MIN_STEP)
            if f0 - fret > delta:
                delta = f0 - fret
                ibig = i
            if nev >= maxfev:
                break
        if nev >= maxfev:
            status = 2
            break
        if 2.0 * (fp - fret) <= rtol * (abs(fp) + abs(fret)) + TINY:
            status = 0
            break
        xit = x - pt
        pt[:] = x
        _, hi, aux = prepare(x, xit, params)
        # NR's extrapolated point 2 x - pt, probed only where the path to it is admissible
        fptt = evaluate(x, xit, 1.0, params, aux) if hi >= 1.0 else math.inf
        nev += 1
        if fptt < fp:
            tt = 2.0 * (fp - 2.0 * fret + fptt) * (fp - fret - delta) ** 2
            tt -= delta * (fp - fptt) ** 2
            if tt < 0.0:
                norm = math.sqrt(float(np.sum(xit * xit)))
                if norm > 0.0:
                    u = xit / norm
                    t, ft, f0, k = _line_min(x, u, norm, prepare, evaluate, params, tol)
                    nev += k
                    if t != 0.0 and ft < f0:
                        y = x + t * u
                        if admissible(y, params):
                            x[:] = y
                            fret = ft
                        else:
                            rejected += 1
                    direc[ibig] = direc[n - 1]
                    steps[ibig] = steps[n - 1]
                    direc[n - 1] = u
                    steps[n - 1] = max(2.0 * abs(t), MIN_STEP)
    return fret, it, nev, status, rejected


def _compiled(names):
    """Numba copies of the functions ``names`` that call each other's copies (same code).

    Not cached on disk: a cached function whose arguments are other compiled functions can
    come back from Numba's cache holding a dead reference to them ("ReferenceError:
    underlying object has vanished", seen in Dask workers); compiling costs ~10 s once per
    process."""
    space = dict(globals())
    for name in names:
        f = space[name]
        space[name] = njit(types.FunctionType(f.__code__, space, name, f.__defaults__))
    return space[names[-1]]


#: :func:`_powell_loop` compiled: for compiled ``prepare``, ``evaluate`` and ``admissible``.
_powell_loop_nb = _compiled(("_brent", "_expand", "_line_min", "_powell_loop"))


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
    step_limit: Callable[[np.ndarray, np.ndarray], float] | None = None,
    compiled: tuple | None = None,
    ftol: float = 1e-6,
    rtol: float = 1e-10,
    maxiter: int = 50,
    maxfev: int | None = None,
    xtol: float = 2e-4,
    step: float = 1.0,
    reach: float = math.inf,
) -> MinimizeResult:
    """The paper's method: Powell's, as in Numerical Recipes, from a random set of directions.

    NR's ``powell`` (Press et al., 2nd ed., §10.5; :mod:`crumple.powell`): sweeps of
    line minimisations (a bracket, then Brent to the fractional precision ``xtol`` of the
    step) along a set of directions, the initial set a seeded random orthonormal basis (the
    paper's "random set of searching directions"); after each sweep the direction of largest
    decrease may be replaced by the sweep's net displacement. It stops when a sweep lowers the
    energy by less than the fraction ``rtol`` (NR's ``ftol``), or after ``maxiter`` sweeps.
    The energy never rises: a line search that finds nothing lower stays put.

    Admissibility: a line search only looks at steps t with ``step_limit(x, t d) = 1`` (with a
    finite ``reach``: no row of ``x`` moves further than ``reach``), points where ``feasible``
    is false have energy +inf, and the point a line search ends at is taken only if
    ``feasible``. ``compiled`` replaces all of this by Numba functions (``(prepare, evaluate,
    admissible, params)``, the protocol of :mod:`crumple.powell`), and the whole
    minimisation then runs compiled; ``energy`` is still used for the final value.

    Powell uses no gradient; ``gradient`` (if given) is used once at the end to report the
    largest force, and ``converged`` means the same as for :func:`newton`:
    ``max_force <= ftol``. Powell's own stopping reason is in ``message``.

    Parameters
    ----------
    energy : callable
        ``energy(x) -> float``.
    x0 : array_like, shape (n, dim) or (n,)
    rng : numpy.random.Generator
        Source of the random directions.
    gradient : callable, optional
        ``gradient(x) -> array`` of the shape of ``x``, for the report.
    feasible : callable, optional
        ``feasible(x) -> bool``: an exact test of a point.
    step_limit : callable, optional
        ``step_limit(x, p) -> t`` in (0, 1]: the fraction of ``p`` that is safe (continuous
        collision detection); needs a finite ``reach``.
    compiled : tuple, optional
        ``(prepare, evaluate, admissible, params)``, Numba-compiled.
    ftol : float
        Force tolerance of the report (as in :func:`newton`).
    rtol : float
        NR's stopping rule: a sweep lowering the energy by less than this fraction ends it.
        0: always run ``maxiter`` sweeps.
    maxiter, maxfev : int
        Sweeps and energy evaluations at most.
    xtol : float
        Brent's fractional tolerance on the step (NR's linmin: 2e-4).
    step : float
        First trial step of every line search, in the units of ``x`` (unit directions); each
        direction then starts from twice its last step.
    reach : float
        Largest displacement of any row in one line search (Python path).

    Examples
    --------
    >>> f = lambda x: float((x[0] - 1) ** 2 + 10 * (x[1] + 2) ** 2)
    >>> g = lambda x: np.array([2 * (x[0] - 1), 20 * (x[1] + 2)])
    >>> r = powell(f, [0.0, 0.0], rng=np.random.default_rng(1), gradient=g)
    >>> r.converged, np.round(r.x, 6).tolist()
    (True, [1.0, -2.0])
    """
    x = _validate_common(x0, ftol, maxiter)
    if not (math.isfinite(rtol) and rtol >= 0):
        raise ValueError(f"rtol must be >= 0, got {rtol}")
    if not (xtol > 0 and step > 0 and reach > 0):
        raise ValueError(f"xtol, step and reach must be positive, got {xtol}, {step}, {reach}")
    if step_limit is not None and not math.isfinite(reach):
        raise ValueError("step_limit needs a finite reach (the longest step it is asked about)")
    shape = x.shape
    flat = np.ascontiguousarray(x.ravel())
    direc = np.ascontiguousarray(random_directions(flat.size, rng))
    steps = np.full(flat.size, float(step))
    fev = int(maxfev) if maxfev is not None else 2**62
    if compiled is not None:
        prepare, evaluate, admissible, params = compiled
        loop = _powell_loop_nb
    else:
        prepare, evaluate, admissible = _python_line(energy, feasible, step_limit, reach, shape)
        params, loop = None, _powell_loop
    with np.errstate(invalid="ignore", over="ignore"):  # inf - inf at inadmissible points
        ef, nit, nfev, status, rejected = loop(
            flat, direc, steps, prepare, evaluate, admissible, params, int(maxiter),
            float(rtol), float(xtol), fev,
        )  # fmt: skip
    xf = flat.reshape(shape)
    ef = energy(xf)
    fmax = max_force(gradient(xf)) if gradient is not None else math.nan
    note = f" ({rejected} line-search end points refused as inadmissible)" if rejected else ""
    return MinimizeResult(
        x=xf,
        energy=float(ef),
        max_force=fmax,
        iterations=int(nit),
        evaluations=int(nfev),
        hessian_evaluations=0,
        converged=bool(fmax <= ftol),
        ftol=ftol,
        message=f"powell: {STATUS[int(status)]} after {nit} sweeps{note}",
        method="powell",
    )


def _python_line(energy, feasible, step_limit, reach, shape):
    """The line protocol of :mod:`crumple.powell` for Python callables."""

    def prepare(x, d, params):
        if step_limit is None:
            return -math.inf, math.inf, None
        dmax = float(np.max(_row_norms(d.reshape(shape))))
        if dmax == 0.0:
            return 0.0, 0.0, None
        span = reach / dmax
        xs, ds = x.reshape(shape), (span * d).reshape(shape)
        return -step_limit(xs, -ds) * span, step_limit(xs, ds) * span, None

    def evaluate(x, d, t, params, aux):
        y = (x + t * d).reshape(shape)
        if feasible is not None and not feasible(y):
            return math.inf
        e = float(energy(y))
        return e if math.isfinite(e) else math.inf

    def admissible(y, params):
        return feasible is None or bool(feasible(y.reshape(shape)))

    return prepare, evaluate, admissible
