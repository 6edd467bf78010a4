"""The frozen records the fits return; each states the range of data it used."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = ["CollapseFit", "MeanEstimate", "MultiPowerLawFit", "PowerLawFit"]


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
    >>> from crumple.fit import fit_power_law
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

        >>> from crumple.fit import fit_power_law
        >>> fit = fit_power_law([1.0, 2.0, 4.0], [3.0, 12.0, 48.0])
        >>> float(fit(3.0))
        27.0
        """
        return self.prefactor * np.asarray(x, dtype=float) ** self.exponent

    def to_dict(self) -> dict:
        """JSON-able summary (plain Python floats and ints).

        >>> from crumple.fit import fit_power_law
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
    >>> from crumple.fit import mean_confidence_interval
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
    >>> from crumple.fit import fit_multi_power_law
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
    >>> from crumple.fit import collapse
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
