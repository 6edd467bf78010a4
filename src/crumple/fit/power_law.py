"""Power laws ``y = A x**a``: one fit, its bootstrap, and the mean of an ensemble."""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from ._checks import (
    _as_1d,
    _check_confidence,
    _check_n_boot,
    _percentile_ci,
    _rng,
    _select,
)
from .records import MeanEstimate, PowerLawFit

__all__ = ["bootstrap_power_law", "fit_power_law", "mean_confidence_interval"]


def fit_power_law(
    x,
    y,
    *,
    x_range=None,
    sigma=None,
    absolute_sigma: bool = False,
    confidence: float = 0.95,
) -> PowerLawFit:
    """Fit ``y = A x**a`` by least squares of ``ln y`` against ``ln x``.

    The exponent's standard error is the regression one, ``sqrt(s**2 / S_xx)`` with
    ``s**2 = sum(w r**2) / (n - 2)`` the residual variance; the confidence interval is
    ``a ± t_{n-2} * stderr`` (Student t with ``n - 2`` degrees of freedom). With ``sigma`` the
    fit is weighted by ``w = (y / sigma)**2`` (``sigma / y`` is the standard deviation of
    ``ln y`` to first order); with ``absolute_sigma=True`` the ``sigma`` are taken as exact
    (``s**2 = 1`` and a normal quantile), as in :func:`scipy.optimize.curve_fit`.

    The errors are only meaningful when the residuals are independent. For the cumulative
    mass function M(R) of the paper's Eq. (3) they are not, and the stderr then measures the
    departure of the data from a straight line rather than a statistical error.

    Parameters
    ----------
    x, y : array_like, shape (n,)
        Positive data. Units are arbitrary (the exponent is dimensionless).
    x_range : (float, float), optional
        Use only points with ``low <= x <= high`` (inclusive).
    sigma : array_like, shape (n,), optional
        Standard deviations of ``y``, positive.
    absolute_sigma : bool
        Treat ``sigma`` as absolute rather than relative weights.
    confidence : float
        Level of the confidence interval, in (0, 1).

    Returns
    -------
    PowerLawFit
        With ``fit_range`` the smallest and largest ``x`` used.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.array([1.0, 2.0, 4.0, 8.0])
    >>> fit = fit_power_law(x, 3.0 * x**1.5)
    >>> round(fit.exponent, 12), round(fit.prefactor, 12), fit.n_points
    (1.5, 3.0, 4)
    >>> fit_power_law(x, 3.0 * x**1.5, x_range=(2, 8)).fit_range
    (2.0, 8.0)
    """
    confidence = _check_confidence(confidence)
    x = _as_1d("x", x)
    y = _as_1d("y", y, x.shape[0])
    keep = _select(x, x_range)
    if sigma is not None:
        sigma = _as_1d("sigma", sigma, x.shape[0])
        if np.any(sigma[keep] <= 0):
            raise ValueError("sigma must be positive")
        sigma = sigma[keep]
    x, y = x[keep], y[keep]
    if x.shape[0] < 3:
        raise ValueError(
            f"a power-law fit with an error estimate needs at least 3 points, got {x.shape[0]}"
            + (f" in x_range={x_range}" if x_range is not None else "")
        )
    if np.any(x <= 0) or np.any(y <= 0):
        raise ValueError("a power-law fit needs positive x and y (it works on their logarithms)")
    lx, ly = np.log(x), np.log(y)
    w = np.ones_like(lx) if sigma is None else (y / sigma) ** 2
    n = lx.shape[0]
    sw = w.sum()
    mx = (w * lx).sum() / sw
    my = (w * ly).sum() / sw
    sxx = (w * (lx - mx) ** 2).sum()
    if not sxx > 0:
        raise ValueError("x takes a single value: the exponent cannot be fitted")
    slope = (w * (lx - mx) * (ly - my)).sum() / sxx
    intercept = my - slope * mx
    resid = ly - intercept - slope * lx
    if sigma is not None and absolute_sigma:
        s2 = 1.0
        quantile = stats.norm.ppf(0.5 + 0.5 * confidence)
    else:
        s2 = (w * resid**2).sum() / (n - 2)
        quantile = stats.t.ppf(0.5 + 0.5 * confidence, n - 2)
    stderr = math.sqrt(s2 / sxx)
    log_a_stderr = math.sqrt(s2 * (1.0 / sw + mx**2 / sxx))
    return PowerLawFit(
        exponent=float(slope),
        stderr=stderr,
        prefactor=float(np.exp(intercept)),
        log_prefactor_stderr=log_a_stderr,
        ci=(float(slope - quantile * stderr), float(slope + quantile * stderr)),
        confidence=confidence,
        fit_range=(float(x.min()), float(x.max())),
        n_points=int(n),
        residual_rms=float(np.sqrt(np.mean(resid**2))),
        method="ols" if sigma is None else "wls",
    )


def _slopes(lx: np.ndarray, ly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OLS slopes and intercepts of each row of ``ly`` (shape (m, n)) against ``lx`` (n,)."""
    dx = lx - lx.mean()
    slope = (ly - ly.mean(axis=1, keepdims=True)) @ dx / (dx @ dx)
    return slope, ly.mean(axis=1) - slope * lx.mean()


def bootstrap_power_law(
    x,
    y_replicas,
    *,
    x_range=None,
    n_boot: int = 1000,
    confidence: float = 0.95,
    rng=None,
) -> PowerLawFit:
    """Power law of the ensemble-mean curve, with a bootstrap over replicas.

    The point estimate is the OLS exponent of ``ln <y>`` against ``ln x``, where ``<y>`` is the
    mean over replicas (e.g. the ensemble-averaged M(R) of Eq. 3). The uncertainty comes from
    resampling whole replicas with replacement ``n_boot`` times and refitting: ``stderr`` is
    the standard deviation of the resampled exponents and ``ci`` their percentile interval.
    Resampling replicas (not points) keeps the correlations along each curve.

    Parameters
    ----------
    x : array_like, shape (n_x,)
        Positive abscissae shared by all replicas.
    y_replicas : array_like, shape (n_replicas, n_x)
        One curve per row, positive where fitted.
    x_range : (float, float), optional
        Use only ``low <= x <= high``.
    n_boot : int
        Number of bootstrap resamples (>= 10).
    confidence : float
        Level of the percentile interval.
    rng : numpy.random.Generator or int or None
        Source of randomness (a seed gives reproducible intervals).

    Returns
    -------
    PowerLawFit
        ``method == "bootstrap"``; ``fit_range`` is the ``x`` range used.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.geomspace(1, 10, 8)
    >>> noise = np.exp(0.05 * np.random.default_rng(0).standard_normal((20, 8)))
    >>> fit = bootstrap_power_law(x, 2 * x**0.75 * noise, rng=1)
    >>> fit.ci[0] < 0.75 < fit.ci[1], fit.n_replicas
    (True, 20)
    """
    confidence = _check_confidence(confidence)
    n_boot = _check_n_boot(n_boot)
    gen = _rng(rng)
    x = _as_1d("x", x)
    try:
        yr = np.asarray(y_replicas, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError("y_replicas must be a 2-D array of numbers") from err
    if yr.ndim != 2 or yr.shape[1] != x.shape[0]:
        raise ValueError(f"y_replicas must have shape (n_replicas, {x.shape[0]}), got {yr.shape}")
    if yr.shape[0] < 2:
        raise ValueError(f"a bootstrap over replicas needs at least 2 replicas, got {yr.shape[0]}")
    keep = _select(x, x_range)
    x, yr = x[keep], yr[:, keep]
    if x.shape[0] < 3:
        raise ValueError(f"need at least 3 points in x_range={x_range}, got {x.shape[0]}")
    if not np.all(np.isfinite(yr)):
        raise ValueError("y_replicas contains NaN or infinite values")
    if np.any(x <= 0) or np.any(yr <= 0):
        raise ValueError("a power-law fit needs positive x and y (it works on their logarithms)")
    base = fit_power_law(x, yr.mean(axis=0), confidence=confidence)
    n_rep = yr.shape[0]
    lx = np.log(x)
    slopes = np.empty(n_boot)
    chunk = max(1, 2_000_000 // (n_rep * x.shape[0]))
    for start in range(0, n_boot, chunk):
        stop = min(n_boot, start + chunk)
        idx = gen.integers(0, n_rep, size=(stop - start, n_rep))
        means = yr[idx].mean(axis=1)
        slopes[start:stop] = _slopes(lx, np.log(means))[0]
    return PowerLawFit(
        exponent=base.exponent,
        stderr=float(slopes.std(ddof=1)),
        prefactor=base.prefactor,
        log_prefactor_stderr=base.log_prefactor_stderr,
        ci=_percentile_ci(slopes, confidence),
        confidence=confidence,
        fit_range=base.fit_range,
        n_points=base.n_points,
        residual_rms=base.residual_rms,
        method="bootstrap",
        n_replicas=int(n_rep),
        n_boot=n_boot,
    )


def mean_confidence_interval(
    samples,
    *,
    confidence: float = 0.95,
    method: str = "t",
    n_boot: int = 2000,
    rng=None,
) -> MeanEstimate:
    """Mean of independent samples with a confidence interval.

    ``method="t"``: ``mean ± t_{n-1} s / sqrt(n)`` (exact for normal samples).
    ``method="bootstrap"``: the percentile interval of ``n_boot`` resampled means (no
    normality assumption; slightly too narrow for very few samples).
    Use it for one exponent per replica (:func:`crumple.observables.ensemble_mass_size_exponent`)
    or for the energy ratio γ of one stage over an ensemble (Sec. III.B).

    Parameters
    ----------
    samples : array_like, shape (n,)
        Finite values, ``n >= 2``.
    confidence : float
        Level of the interval.
    method : {"t", "bootstrap"}
    n_boot : int
        Bootstrap resamples (``method="bootstrap"`` only).
    rng : numpy.random.Generator or int or None
        Source of randomness (bootstrap only).

    Returns
    -------
    MeanEstimate

    Examples
    --------
    >>> est = mean_confidence_interval([1.30, 1.35, 1.32, 1.36])
    >>> round(est.value, 4), round(est.stderr, 4), est.n_samples
    (1.3325, 0.0138, 4)
    >>> [round(v, 3) for v in est.ci]
    [1.289, 1.376]
    """
    confidence = _check_confidence(confidence)
    s = _as_1d("samples", samples)
    n = s.shape[0]
    if n < 2:
        raise ValueError(f"a confidence interval needs at least 2 samples, got {n}")
    mean = float(s.mean())
    if method == "t":
        stderr = float(s.std(ddof=1) / math.sqrt(n))
        q = stats.t.ppf(0.5 + 0.5 * confidence, n - 1)
        ci = (mean - q * stderr, mean + q * stderr)
    elif method == "bootstrap":
        n_boot = _check_n_boot(n_boot)
        gen = _rng(rng)
        means = s[gen.integers(0, n, size=(n_boot, n))].mean(axis=1)
        stderr = float(means.std(ddof=1))
        ci = _percentile_ci(means, confidence)
    else:
        raise ValueError(f"method must be 't' or 'bootstrap', got {method!r}")
    return MeanEstimate(
        value=mean,
        stderr=stderr,
        ci=(float(ci[0]), float(ci[1])),
        confidence=confidence,
        n_samples=int(n),
        method=method,
        samples=tuple(float(v) for v in s),
    )
