"""Fits with uncertainties: power laws, multivariate power laws, ensemble means, data collapse.

Every fit returns a frozen record that states the range of data it used. Every stochastic
function (the bootstraps) takes ``rng``: a :class:`numpy.random.Generator` or an integer seed
(``None`` draws fresh entropy from the operating system; no global random state is touched).

All power laws are fitted as straight lines in log-log space by (weighted) least squares,

.. math::

    \\ln y = \\ln A + a \\ln x + \\varepsilon ,

so that the errors are assumed multiplicative (log-normal) and the standard errors come from the
scatter of the residuals about the line, as in an ordinary regression. These are the fits of
the paper's Eq. (3) exponent D_M (Fig. 3), of the allocation law Eq. (4) (Fig. 4) and of the
collapse R_g ~ λ^α (k_b k_s)^c of Fig. 5.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from scipy import stats

__all__ = [
    "CollapseFit",
    "MeanEstimate",
    "MultiPowerLawFit",
    "PowerLawFit",
    "bootstrap_power_law",
    "collapse",
    "fit_multi_power_law",
    "fit_power_law",
    "mean_confidence_interval",
]


# --------------------------------------------------------------------------------------------
# Records
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class PowerLawFit:
    """A fitted power law ``y = prefactor * x**exponent``.

    Attributes
    ----------
    exponent : float
        The fitted exponent ``a`` (dimensionless).
    stderr : float
        Its standard error (from the residuals, or the standard deviation of the bootstrap
        distribution when ``method == "bootstrap"``).
    prefactor : float
        ``A`` in ``y = A x**a`` ``[y] / [x]**a``.
    log_prefactor_stderr : float
        Standard error of ``ln A``.
    ci : tuple of float
        ``(low, high)`` confidence interval of the exponent at level ``confidence``.
    confidence : float
        Level of ``ci``, e.g. 0.95.
    fit_range : tuple of float
        ``(min, max)`` of the ``x`` values actually used by the fit ``[x]``.
    n_points : int
        Number of ``x`` values used.
    residual_rms : float
        Root-mean-square residual of ``ln y`` about the fitted line (unweighted).
    method : str
        ``"ols"``, ``"wls"`` (weighted by ``sigma``) or ``"bootstrap"``.
    n_replicas : int or None
        Number of replicas (bootstrap fits only).
    n_boot : int or None
        Number of bootstrap resamples (bootstrap fits only).

    Examples
    --------
    >>> x = np.array([1.0, 2.0, 4.0, 8.0])
    >>> r = fit_power_law(x, 3 * x**0.5)
    >>> round(r.exponent, 12), round(r.prefactor, 12), r.fit_range, r.n_points
    (0.5, 3.0, (1.0, 8.0), 4)
    """

    exponent: float
    stderr: float
    prefactor: float
    log_prefactor_stderr: float
    ci: tuple[float, float]
    confidence: float
    fit_range: tuple[float, float]
    n_points: int
    residual_rms: float
    method: str
    n_replicas: int | None = None
    n_boot: int | None = None

    def __call__(self, x):
        """Evaluate ``prefactor * x**exponent``.

        >>> fit = fit_power_law([1.0, 2.0, 4.0], [3.0, 12.0, 48.0])
        >>> float(fit(3.0))
        27.0
        """
        return self.prefactor * np.asarray(x, dtype=float) ** self.exponent

    def to_dict(self) -> dict:
        """JSON-able summary (plain Python floats and ints).

        >>> sorted(fit_power_law([1.0, 2.0, 4.0], [1.0, 2.0, 4.0]).to_dict())[:3]
        ['ci', 'confidence', 'exponent']
        """
        return {
            "exponent": float(self.exponent),
            "stderr": float(self.stderr),
            "prefactor": float(self.prefactor),
            "ci": [float(self.ci[0]), float(self.ci[1])],
            "confidence": float(self.confidence),
            "fit_range": [float(self.fit_range[0]), float(self.fit_range[1])],
            "n_points": int(self.n_points),
            "residual_rms": float(self.residual_rms),
            "method": self.method,
        }


@dataclass(frozen=True, slots=True, kw_only=True)
class MeanEstimate:
    """The mean of independent samples (e.g. one exponent per replica) with a confidence interval.

    Attributes
    ----------
    value : float
        Sample mean.
    stderr : float
        Standard error of the mean, ``s / sqrt(n)`` (``method == "t"``) or the standard deviation
        of the bootstrap means (``method == "bootstrap"``).
    ci : tuple of float
        ``(low, high)`` confidence interval at level ``confidence``.
    confidence : float
        Level of ``ci``.
    n_samples : int
        Number of samples.
    method : str
        ``"t"`` (Student-t interval) or ``"bootstrap"`` (percentile bootstrap).
    samples : tuple of float
        The samples themselves.

    Examples
    --------
    >>> m = mean_confidence_interval([1.0, 2.0, 3.0])
    >>> m.value, m.n_samples, m.method
    (2.0, 3, 't')
    """

    value: float
    stderr: float
    ci: tuple[float, float]
    confidence: float
    n_samples: int
    method: str
    samples: tuple[float, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class MultiPowerLawFit:
    """A fitted multivariate power law ``y = prefactor * prod_k x_k**exponents[k]`` (Eq. 4).

    Attributes
    ----------
    exponents, stderrs : mapping of str to float
        Exponent of each factor and its standard error, in the order the factors were given.
    ci : mapping of str to (float, float)
        Confidence interval of each exponent at level ``confidence``.
    covariance : ndarray, shape (n_factors + 1, n_factors + 1)
        Covariance of ``(ln prefactor, exponent_1, ..., exponent_k)`` (read-only).
    prefactor : float
        ``A`` in ``y = A prod x_k**e_k``.
    ranges : mapping of str to (float, float)
        ``(min, max)`` of each factor over the data used.
    n_points : int
        Number of data points.
    residual_rms : float
        Root-mean-square residual of ``ln y``.
    confidence : float
        Level of ``ci``.

    Examples
    --------
    >>> lam = np.array([1.0, 2.0, 4.0, 1.0, 2.0, 4.0])
    >>> kb = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])
    >>> r = fit_multi_power_law(2 * lam**0.5 * kb**2, lam=lam, k_b=kb)
    >>> {k: round(v, 9) for k, v in r.exponents.items()}, r.ranges["lam"]
    ({'lam': 0.5, 'k_b': 2.0}, (1.0, 4.0))
    """

    exponents: Mapping[str, float]
    stderrs: Mapping[str, float]
    ci: Mapping[str, tuple[float, float]]
    covariance: np.ndarray
    prefactor: float
    ranges: Mapping[str, tuple[float, float]]
    n_points: int
    residual_rms: float
    confidence: float


@dataclass(frozen=True, slots=True, kw_only=True)
class CollapseFit:
    """Result of :func:`collapse`: the collapse exponent ``c`` of ``y ~ f(x) g**c``.

    Attributes
    ----------
    exponent : float
        Fitted ``c`` (the paper's Fig. 5 reports 1.2 for ``g = k_b k_s``).
    stderr : float
        Standard error of ``c`` (linear error propagation, see :func:`collapse`).
    ci : tuple of float
        Student-t confidence interval of ``c`` at level ``confidence``.
    confidence : float
        Level of ``ci``.
    scatter : float
        Root-mean-square mismatch of ``ln y`` between overlapping rescaled curves at the optimum
        (0 for a perfect collapse): the quality measure.
    scatter_uncollapsed : float
        The same mismatch with ``c = 0`` (no rescaling), for comparison.
    noise : float
        Estimated standard deviation of ``ln y`` of a single point (the scatter corrected for
        the interpolation of the partner curve).
    reference : tuple of float
        Key of the reference curve; the master curve is the reference curve itself.
    n_curves : int
        Number of curves.
    n_pairs : int
        Number of point-versus-curve comparisons entering the cost.
    x_range : tuple of float
        ``(min, max)`` of ``x`` over all points that entered the cost (as compared points or
        as interpolation nodes).
    master : PowerLawFit
        Power law fitted to all rescaled points in ``x_range`` (the paper's R_g ~ λ^α line).
    rescaled : mapping of key to (ndarray, ndarray)
        Each curve's ``(x, y * (g_ref / g)**c)`` restricted to the points used.

    Examples
    --------
    >>> lam = np.geomspace(1, 100, 8)
    >>> curves = {g: (lam, lam**-0.25 * g**1.2) for g in (1.0, 2.0, 4.0)}
    >>> round(collapse(curves, reference=1.0).exponent, 9)
    1.2
    """

    exponent: float
    stderr: float
    ci: tuple[float, float]
    confidence: float
    scatter: float
    scatter_uncollapsed: float
    noise: float
    reference: tuple[float, ...]
    n_curves: int
    n_pairs: int
    x_range: tuple[float, float]
    master: PowerLawFit
    rescaled: Mapping[tuple[float, ...], tuple[np.ndarray, np.ndarray]]


# --------------------------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------------------------


def _check_confidence(confidence: float) -> float:
    c = float(confidence)
    if not 0.0 < c < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got {confidence}")
    return c


def _as_1d(name: str, values, n: int | None = None) -> np.ndarray:
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must be an array of numbers, got {values!r}") from err
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} must have {n} entries, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def _check_range(name: str, bounds) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must be a pair (low, high), got {bounds!r}") from err
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo < hi):
        raise ValueError(f"{name} must satisfy 0 < low < high, got {bounds!r}")
    return lo, hi


def _rng(rng) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, int | np.integer):
        return np.random.default_rng(rng)
    raise ValueError(f"rng must be a numpy.random.Generator, an integer seed or None, got {rng!r}")


def _check_n_boot(n_boot: int) -> int:
    if not isinstance(n_boot, int | np.integer) or n_boot < 10:
        raise ValueError(f"n_boot must be an integer >= 10, got {n_boot!r}")
    return int(n_boot)


def _select(x: np.ndarray, x_range) -> np.ndarray:
    if x_range is None:
        return np.ones(x.shape, dtype=bool)
    lo, hi = _check_range("x_range", x_range)
    return (x >= lo) & (x <= hi)


def _percentile_ci(samples: np.ndarray, confidence: float) -> tuple[float, float]:
    tail = 50.0 * (1.0 - confidence)
    low, high = np.percentile(samples, [tail, 100.0 - tail])
    return float(low), float(high)


# --------------------------------------------------------------------------------------------
# Power laws
# --------------------------------------------------------------------------------------------


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
# Data collapse
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
    n_total = offset
    ly_all = np.concatenate([data[k][1] for k in keys])
    # Each comparison: (coefficient vector over all points as sparse (index, weight)), shift D
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
    t = np.concatenate(w_j1)
    d = np.concatenate(shifts)
    u = ly_all[ii] - (1.0 - t) * ly_all[j0] - t * ly_all[j1]
    dd = float(d @ d)
    if not dd > 0:
        raise ValueError("the overlapping curves all share one g; c cannot be fitted")
    c = float(d @ u) / dd
    r = u - c * d
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
    q = stats.t.ppf(0.5 + 0.5 * confidence, dof)
    ref_log_g = log_g[reference]
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
    xcat = np.concatenate(all_x)
    master = fit_power_law(xcat, np.concatenate(all_y), confidence=confidence)
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
        n_pairs=int(n_terms),
        x_range=(float(xcat.min()), float(xcat.max())),
        master=master,
        rescaled=MappingProxyType(rescaled),
    )
