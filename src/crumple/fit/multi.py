"""Multivariate power laws (the paper's Eq. 4) and the data collapse of Fig. 5."""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import MappingProxyType

import numpy as np
from scipy import stats

from ._checks import (
    _as_1d,
    _check_confidence,
    _select,
)
from .power_law import fit_power_law
from .records import CollapseFit, MultiPowerLawFit

__all__ = ["collapse", "fit_multi_power_law"]


def fit_multi_power_law(y, /, *, confidence: float = 0.95, **factors) -> MultiPowerLawFit:
    """Fit ``y = A prod_k x_k**e_k`` by least squares of ``ln y`` on the ``ln x_k`` (Eq. 4).

    The paper's energy-allocation law ``γ ~ λ^ε_l k_b^ε_b k_s^ε_s`` (Eq. 4, Fig. 4) is
    ``fit_multi_power_law(gamma, lam=lam, k_b=k_b, k_s=k_s)``. The design matrix is
    ``[1, ln x_1, ..., ln x_k]``; the covariance of the coefficients is
    ``s**2 (X^T X)^{-1}`` with ``s**2`` the residual variance on ``n - k - 1`` degrees of
    freedom, and the intervals are Student-t.

    Parameters
    ----------
    y : array_like, shape (n,)
        Positive responses.
    confidence : float
        Level of the intervals.
    **factors : array_like, shape (n,)
        Positive values of each factor, by name. Each must vary over the data, and there must
        be more points than factors + 1.

    Returns
    -------
    MultiPowerLawFit
        With ``ranges`` the ``(min, max)`` of every factor.

    Examples
    --------
    >>> import numpy as np
    >>> lam, kb = np.meshgrid([100.0, 300.0, 1000.0], [1.0, 3.0, 10.0])
    >>> gamma = 1e-3 * lam**0.5 * kb**2.6
    >>> fit = fit_multi_power_law(gamma.ravel(), lam=lam.ravel(), k_b=kb.ravel())
    >>> {k: round(v, 10) for k, v in fit.exponents.items()}
    {'lam': 0.5, 'k_b': 2.6}
    >>> fit.ranges["lam"]
    (100.0, 1000.0)
    """
    confidence = _check_confidence(confidence)
    y = _as_1d("y", y)
    n = y.shape[0]
    if not factors:
        raise ValueError("give at least one factor, e.g. fit_multi_power_law(gamma, lam=lam)")
    cols = [np.ones(n)]
    ranges = {}
    for name, values in factors.items():
        try:
            v = _as_1d(name, values, n)
        except ValueError as err:
            raise ValueError(
                f"factor {name!r} must be an array of {n} positive numbers like y"
                f" (is {name!r} a misspelled keyword?): {err}"
            ) from err
        if np.any(v <= 0):
            raise ValueError(f"factor {name!r} must be positive (it enters through its logarithm)")
        if np.ptp(v) == 0:
            raise ValueError(f"factor {name!r} takes a single value; its exponent cannot be fitted")
        cols.append(np.log(v))
        ranges[name] = (float(v.min()), float(v.max()))
    if np.any(y <= 0):
        raise ValueError("y must be positive (it enters through its logarithm)")
    p = len(cols)
    if n <= p:
        raise ValueError(f"need more data points than coefficients ({p}), got {n}")
    design = np.column_stack(cols)
    if np.linalg.matrix_rank(design) < p:
        raise ValueError(
            "the factors are collinear in log space (e.g. two factors always vary together);"
            " their exponents cannot be separated"
        )
    ly = np.log(y)
    coef, *_ = np.linalg.lstsq(design, ly, rcond=None)
    resid = ly - design @ coef
    dof = n - p
    s2 = float(resid @ resid) / dof
    cov = s2 * np.linalg.inv(design.T @ design)
    cov.setflags(write=False)
    err = np.sqrt(np.diag(cov))
    q = stats.t.ppf(0.5 + 0.5 * confidence, dof)
    names = list(factors)
    return MultiPowerLawFit(
        exponents=MappingProxyType({k: float(coef[i + 1]) for i, k in enumerate(names)}),
        stderrs=MappingProxyType({k: float(err[i + 1]) for i, k in enumerate(names)}),
        ci=MappingProxyType(
            {
                k: (float(coef[i + 1] - q * err[i + 1]), float(coef[i + 1] + q * err[i + 1]))
                for i, k in enumerate(names)
            }
        ),
        covariance=cov,
        prefactor=float(np.exp(coef[0])),
        ranges=MappingProxyType(ranges),
        n_points=int(n),
        residual_rms=float(np.sqrt(np.mean(resid**2))),
        confidence=confidence,
    )


# --------------------------------------------------------------------------------------------


def _scaling_variable(key) -> float:
    parts = key if isinstance(key, tuple) else (key,)
    try:
        values = [float(p) for p in parts]
    except (TypeError, ValueError) as err:
        raise ValueError(f"curve key must be a number or a tuple of numbers, got {key!r}") from err
    if not values or any(not (math.isfinite(v) and v > 0) for v in values):
        raise ValueError(f"curve key must hold positive numbers, got {key!r}")
    return math.prod(values)


def collapse(
    curves: Mapping,
    *,
    reference,
    x_range=None,
    confidence: float = 0.95,
) -> CollapseFit:
    """Collapse curves ``y(x; g) = f(x) g**c`` onto the reference curve and fit ``c`` (Fig. 5).

    The paper's Fig. 5 collapses R_g(λ) for several ``(k_b, k_s)`` with
    ``R_g ~ λ^α (k_b k_s)^c``, ``c = 1.2``. Curve ``i`` is rescaled to
    ``y_i (g_ref / g_i)**c``; since only ``y`` is rescaled, in log space this is a vertical
    shift ``-c Δ_i`` with ``Δ_i = ln g_i - ln g_ref``. The cost is the spread of the rescaled
    curves over their overlaps: for every point ``x_m`` of every curve ``i`` and every other
    curve ``j`` whose ``x`` range contains ``x_m``,

    .. math::

        r = [\\ln y_i(x_m) - c Δ_i] - [\\ln y_j(x_m) - c Δ_j],

    with ``ln y_j(x_m)`` linearly interpolated in ``ln x`` (the measure of Bhattacharjee and
    Seno, J. Phys. A 34, 6375 (2001)). The cost ``sum r**2`` is quadratic in ``c`` and its
    minimum is found in closed form. ``c`` is then a linear combination of the data,
    ``c = sum_p w_p ln y_p``, so for independent errors of variance ``σ**2`` on ``ln y``,
    ``stderr = σ |w|``. ``σ**2`` is estimated from the residuals, each divided by its own
    variance factor ``1 + sum(interpolation weights**2)``; bias from curvature between the
    interpolation nodes inflates it, so the error is conservative. ``scatter`` (the rms of
    ``r`` at the optimum) is the quality measure, to be compared with
    ``scatter_uncollapsed``.

    Parameters
    ----------
    curves : mapping of key to (x, y)
        ``key`` is a positive number ``g`` or a tuple of positive numbers whose product is
        ``g`` (a ``(k_b, k_s)`` pair gives the paper's ``g = k_b k_s``); ``x`` (e.g. λ) and
        ``y`` (e.g. R_g ``[length]``) are positive arrays of equal length.
    reference : key
        The key of the reference curve (the master curve), e.g. ``(8, 2.4e5)``.
    x_range : (float, float), optional
        Use only points with ``low <= x <= high`` (e.g. the strong-field regime).
    confidence : float
        Level of the Student-t interval of ``c``.

    Returns
    -------
    CollapseFit

    Examples
    --------
    >>> import numpy as np
    >>> lam = np.geomspace(100, 2000, 12)
    >>> keys = [(5, 5e5), (8, 2.4e5), (2, 1e6), (10, 1e4)]
    >>> curves = {k: (lam, 0.3 * lam**-0.25 * (k[0] * k[1]) ** 1.2) for k in keys}
    >>> fit = collapse(curves, reference=(8, 2.4e5))
    >>> round(fit.exponent, 10), round(fit.master.exponent, 10), fit.n_curves
    (1.2, -0.25, 4)
    """
    confidence = _check_confidence(confidence)
    if not isinstance(curves, Mapping) or len(curves) < 2:
        raise ValueError("curves must be a mapping of at least 2 keys to (x, y) pairs")
    if reference not in curves:
        raise ValueError(f"reference {reference!r} is not one of the curve keys {list(curves)}")
    keys = list(curves)
    log_g, data, n_total = _log_curves(curves, keys, x_range)
    ly_all = np.concatenate([data[k][1] for k in keys])
    ii, j0, j1, t, d = _comparisons(keys, log_g, data)
    u = ly_all[ii] - (1.0 - t) * ly_all[j0] - t * ly_all[j1]
    dd = float(d @ d)
    if not dd > 0:
        raise ValueError("the overlapping curves all share one g; c cannot be fitted")
    c = float(d @ u) / dd
    r = u - c * d
    noise, stderr, dof = _shift_error(r, ii, j0, j1, t, d, dd, n_total)
    q = stats.t.ppf(0.5 + 0.5 * confidence, dof)
    rescaled, xcat, ycat = _rescale(keys, log_g, data, c, log_g[reference], ii, j0, j1, n_total)
    master = fit_power_law(xcat, ycat, confidence=confidence)
    return CollapseFit(
        exponent=c,
        stderr=stderr,
        ci=(c - q * stderr, c + q * stderr),
        confidence=confidence,
        scatter=float(np.sqrt(np.mean(r**2))),
        scatter_uncollapsed=float(np.sqrt(np.mean(u**2))),
        noise=noise,
        reference=reference if isinstance(reference, tuple) else (reference,),
        n_curves=len(keys),
        n_pairs=int(r.shape[0]),
        x_range=(float(xcat.min()), float(xcat.max())),
        master=master,
        rescaled=MappingProxyType(rescaled),
    )


def _log_curves(curves, keys, x_range):
    """Every curve checked, cut to ``x_range`` and sorted in x, in logarithms: ``ln g`` by key,
    ``(ln x, ln y, offset)`` by key (offset: where its points start in the concatenation of
    all curves), and the number of points."""
    log_g = {}
    data = {}
    offset = 0
    for key in keys:
        log_g[key] = math.log(_scaling_variable(key))
        try:
            cx, cy = curves[key]
        except (TypeError, ValueError) as err:
            raise ValueError(f"curve {key!r} must be a pair (x, y)") from err
        cx = _as_1d(f"x of curve {key!r}", cx)
        cy = _as_1d(f"y of curve {key!r}", cy, cx.shape[0])
        keep = _select(cx, x_range)
        cx, cy = cx[keep], cy[keep]
        if np.any(cx <= 0) or np.any(cy <= 0):
            raise ValueError(f"curve {key!r} must have positive x and y (logarithms are taken)")
        order = np.argsort(cx, kind="stable")
        lx, ly = np.log(cx[order]), np.log(cy[order])
        if lx.shape[0] >= 2 and np.any(np.diff(lx) == 0):
            raise ValueError(f"curve {key!r} has repeated x values; average them first")
        data[key] = (lx, ly, offset)
        offset += lx.shape[0]
    if len({round(v, 12) for v in log_g.values()}) < 2:
        raise ValueError("all curves have the same scaling variable g; c cannot be fitted")
    return log_g, data, offset


def _comparisons(keys, log_g, data):
    """Every point x_m of every curve i inside the x range of another curve j, compared with
    j interpolated there in ln x: the point's index ``ii``, j's bracketing points ``j0``,
    ``j1`` and interpolation weight ``t`` (on j1), and the shift ``d = ln g_i - ln g_j``."""
    rows_i: list[np.ndarray] = []
    rows_j0: list[np.ndarray] = []
    rows_j1: list[np.ndarray] = []
    w_j1: list[np.ndarray] = []
    shifts: list[np.ndarray] = []
    for ki in keys:
        lxi, _, oi = data[ki]
        for kj in keys:
            lxj, _, oj = data[kj]
            if kj == ki or lxj.shape[0] < 2:
                continue
            inside = (lxi >= lxj[0]) & (lxi <= lxj[-1])
            if not inside.any():
                continue
            xm = lxi[inside]
            k = np.clip(np.searchsorted(lxj, xm, side="right") - 1, 0, lxj.shape[0] - 2)
            t = (xm - lxj[k]) / (lxj[k + 1] - lxj[k])
            rows_i.append(oi + np.flatnonzero(inside))
            rows_j0.append(oj + k)
            rows_j1.append(oj + k + 1)
            w_j1.append(t)
            shifts.append(np.full(xm.shape, log_g[ki] - log_g[kj]))
    if not shifts:
        raise ValueError("no two curves overlap in x; a collapse cannot be measured")
    ii, j0, j1 = (np.concatenate(a) for a in (rows_i, rows_j0, rows_j1))
    return ii, j0, j1, np.concatenate(w_j1), np.concatenate(shifts)


def _shift_error(r, ii, j0, j1, t, d, dd, n_total):
    """The noise σ on ln y estimated from the residuals r, the standard error σ |w| of
    c = Σ_p w_p ln y_p, and the degrees of freedom of its interval."""
    # c = sum_p g_p ln y_p: accumulate the weight of each data point
    gvec = np.zeros(n_total)
    np.add.at(gvec, ii, d / dd)
    np.add.at(gvec, j0, -(1.0 - t) * d / dd)
    np.add.at(gvec, j1, -t * d / dd)
    var_factor = 1.0 + (1.0 - t) ** 2 + t**2
    n_terms = r.shape[0]
    n_used = np.unique(np.concatenate([ii, j0, j1])).shape[0]
    dof = max(1, n_used - 2)
    noise = math.sqrt(float(np.sum(r**2 / var_factor)) / max(1, n_terms - 1))
    stderr = noise * math.sqrt(float(gvec @ gvec))
    return noise, stderr, dof


def _rescale(keys, log_g, data, c, ref_log_g, ii, j0, j1, n_total):
    """The points used by some comparison, rescaled onto the reference curve: (x, y) by key
    (read-only arrays), and all of them concatenated in key order."""
    rescaled = {}
    all_x, all_y = [], []
    used = np.zeros(n_total, dtype=bool)
    used[ii] = True
    used[j0] = True
    used[j1] = True
    for key in keys:
        lx, ly, o = data[key]
        sel = used[o : o + lx.shape[0]]
        yy = np.exp(ly[sel] - c * (log_g[key] - ref_log_g))
        xx = np.exp(lx[sel])
        xx.setflags(write=False)
        yy.setflags(write=False)
        rescaled[key] = (xx, yy)
        all_x.append(xx)
        all_y.append(yy)
    return rescaled, np.concatenate(all_x), np.concatenate(all_y)
