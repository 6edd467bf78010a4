"""Tests of crumple.fit: exact recovery, agreement with reference implementations, and the
coverage of the reported confidence intervals on synthetic data with known exponents."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from crumple.fit import (
    CollapseFit,
    MeanEstimate,
    MultiPowerLawFit,
    PowerLawFit,
    bootstrap_power_law,
    collapse,
    fit_multi_power_law,
    fit_power_law,
    mean_confidence_interval,
)

N_TRIALS = 200
CONFIDENCE = 0.95


def _coverage_bounds(n_trials: int = N_TRIALS, p: float = CONFIDENCE) -> tuple[int, int]:
    """Range holding the number of covering intervals with probability 0.999 if the nominal
    coverage p is right (binomial)."""
    low, high = stats.binom.interval(0.999, n_trials, p)
    return int(low), int(high)


def _streams(seed: int, n: int = N_TRIALS) -> list[np.random.Generator]:
    return [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(n)]


# --------------------------------------------------------------------------------------------
# fit_power_law
# --------------------------------------------------------------------------------------------


def test_power_law_exact_recovery():
    x = np.geomspace(0.1, 30.0, 17)
    fit = fit_power_law(x, 0.7 * x**-1.25)
    assert isinstance(fit, PowerLawFit)
    assert fit.exponent == pytest.approx(-1.25, abs=1e-12)
    assert fit.prefactor == pytest.approx(0.7, rel=1e-12)
    assert fit.stderr == pytest.approx(0.0, abs=1e-12)
    assert fit.n_points == 17
    assert fit.fit_range == (pytest.approx(0.1), pytest.approx(30.0))
    assert fit.method == "ols"
    assert fit(2.0) == pytest.approx(0.7 * 2.0**-1.25)


def test_power_law_matches_linregress():
    rng = np.random.default_rng(3)
    x = np.geomspace(1.0, 100.0, 25)
    y = 2.0 * x**0.6 * np.exp(0.2 * rng.standard_normal(25))
    fit = fit_power_law(x, y)
    ref = stats.linregress(np.log(x), np.log(y))
    assert fit.exponent == pytest.approx(ref.slope, rel=1e-12)
    assert fit.stderr == pytest.approx(ref.stderr, rel=1e-10)
    assert np.log(fit.prefactor) == pytest.approx(ref.intercept, rel=1e-12)
    assert fit.log_prefactor_stderr == pytest.approx(ref.intercept_stderr, rel=1e-10)
    q = stats.t.ppf(0.975, 23)
    assert fit.ci == pytest.approx((ref.slope - q * ref.stderr, ref.slope + q * ref.stderr))


def test_power_law_x_range_reports_the_data_used():
    x = np.arange(1.0, 11.0)
    y = np.where(x <= 5, x**2, x**3)  # two regimes
    fit = fit_power_law(x, y, x_range=(6, 10))
    assert fit.exponent == pytest.approx(3.0)
    assert fit.fit_range == (6.0, 10.0)
    assert fit.n_points == 5
    # inclusive ends, and the actual extremes (not the requested ones) are reported
    assert fit_power_law(x, y, x_range=(5.5, 20)).fit_range == (6.0, 10.0)


def test_weighted_fit_and_absolute_sigma():
    x = np.geomspace(1, 10, 6)
    y = 3 * x**2.0
    y_bad = y.copy()
    y_bad[0] *= 2.0
    sigma = np.full(6, 1e-3) * y
    sigma[0] = 1e3 * y[0]  # the outlier is down-weighted to nothing
    fit = fit_power_law(x, y_bad, sigma=sigma)
    assert fit.method == "wls"
    assert fit.exponent == pytest.approx(2.0, abs=1e-6)
    abs_fit = fit_power_law(x, y, sigma=0.01 * y, absolute_sigma=True)
    lx = np.log(x)
    assert abs_fit.stderr == pytest.approx(0.01 / np.sqrt(np.sum((lx - lx.mean()) ** 2)))


def test_power_law_ci_coverage():
    """The true exponent lies in the 95% interval in ~95% of noisy trials."""
    x = np.geomspace(1.0, 50.0, 12)
    covered = 0
    for rng in _streams(11):
        y = 1.5 * x**-0.8 * np.exp(0.15 * rng.standard_normal(x.shape))
        fit = fit_power_law(x, y, confidence=CONFIDENCE)
        covered += fit.ci[0] <= -0.8 <= fit.ci[1]
    low, high = _coverage_bounds()
    assert low <= covered <= high


@pytest.mark.parametrize(
    ("x", "y", "kwargs", "match"),
    [
        ([1, 2], [1, 2], {}, "at least 3 points"),
        ([1, 2, 3, 4], [1, 2, 3, 4], {"x_range": (3.5, 10)}, "at least 3 points"),
        ([1, 2, 3], [1, -2, 3], {}, "positive"),
        ([0, 2, 3], [1, 2, 3], {}, "positive"),
        ([2, 2, 2], [1, 2, 3], {}, "single value"),
        ([1, 2, 3], [1, 2], {}, "3 entries"),
        ([1, 2, np.nan], [1, 2, 3], {}, "NaN"),
        ([1, 2, 3], [1, 2, 3], {"confidence": 1.5}, "confidence"),
        ([1, 2, 3], [1, 2, 3], {"x_range": (3, 1)}, "x_range"),
        ([1, 2, 3], [1, 2, 3], {"sigma": [1, 0, 1]}, "sigma"),
        ([[1, 2, 3]], [1, 2, 3], {}, "one-dimensional"),
    ],
)
def test_power_law_rejects_bad_input(x, y, kwargs, match):
    with pytest.raises(ValueError, match=match):
        fit_power_law(x, y, **kwargs)


# --------------------------------------------------------------------------------------------
# bootstrap_power_law and mean_confidence_interval
# --------------------------------------------------------------------------------------------


def test_bootstrap_is_reproducible_and_brackets_the_estimate():
    x = np.geomspace(1, 10, 8)
    yr = 2 * x**0.75 * np.exp(0.1 * np.random.default_rng(0).standard_normal((15, 8)))
    a = bootstrap_power_law(x, yr, rng=42, n_boot=300)
    b = bootstrap_power_law(x, yr, rng=np.random.default_rng(42), n_boot=300)
    assert a == b
    assert a.method == "bootstrap" and a.n_replicas == 15 and a.n_boot == 300
    assert a.ci[0] < a.exponent < a.ci[1]
    assert a.exponent == pytest.approx(fit_power_law(x, yr.mean(axis=0)).exponent)


def test_bootstrap_ci_coverage():
    """Resampling 30 replicas: the 95% percentile interval covers the true exponent ~95%."""
    x = np.geomspace(1.0, 10.0, 10)
    covered = 0
    for rng in _streams(7):
        yr = 2.0 * x**0.75 * np.exp(0.1 * rng.standard_normal((30, x.size)))
        fit = bootstrap_power_law(x, yr, rng=rng, n_boot=400)
        covered += fit.ci[0] <= 0.75 <= fit.ci[1]
    low, high = _coverage_bounds()
    assert low <= covered <= high


def test_bootstrap_rejects_bad_input():
    x = np.geomspace(1, 10, 5)
    with pytest.raises(ValueError, match="shape"):
        bootstrap_power_law(x, np.ones((3, 4)))
    with pytest.raises(ValueError, match="2 replicas"):
        bootstrap_power_law(x, np.ones((1, 5)))
    with pytest.raises(ValueError, match="n_boot"):
        bootstrap_power_law(x, np.ones((3, 5)), n_boot=2)
    with pytest.raises(ValueError, match="rng"):
        bootstrap_power_law(x, np.ones((3, 5)), rng="seed")


def test_mean_ci_t_and_bootstrap():
    s = [1.30, 1.35, 1.32, 1.36]
    est = mean_confidence_interval(s)
    assert isinstance(est, MeanEstimate)
    ref = stats.t.interval(0.95, 3, loc=np.mean(s), scale=stats.sem(s))
    assert est.ci == pytest.approx(ref)
    boot = mean_confidence_interval(s, method="bootstrap", rng=1)
    assert boot == mean_confidence_interval(s, method="bootstrap", rng=1)
    assert min(s) <= boot.ci[0] <= boot.value <= boot.ci[1] <= max(s)
    with pytest.raises(ValueError, match="2 samples"):
        mean_confidence_interval([1.0])
    with pytest.raises(ValueError, match="method"):
        mean_confidence_interval(s, method="jackknife")


def test_mean_ci_t_coverage():
    covered = 0
    for rng in _streams(5):
        est = mean_confidence_interval(1.33 + 0.05 * rng.standard_normal(10))
        covered += est.ci[0] <= 1.33 <= est.ci[1]
    low, high = _coverage_bounds()
    assert low <= covered <= high


# --------------------------------------------------------------------------------------------
# fit_multi_power_law (Eq. 4)
# --------------------------------------------------------------------------------------------


def _grid():
    lam, kb, ks = np.meshgrid([100.0, 300.0, 1000.0, 2000.0], [1.0, 3.0, 10.0], [1e4, 1e5, 1e6])
    return lam.ravel(), kb.ravel(), ks.ravel()


def test_multi_power_law_exact():
    lam, kb, ks = _grid()
    gamma = 2e-3 * lam**0.55 * kb**2.6 * ks**-3.3
    fit = fit_multi_power_law(gamma, lam=lam, k_b=kb, k_s=ks)
    assert isinstance(fit, MultiPowerLawFit)
    assert list(fit.exponents) == ["lam", "k_b", "k_s"]
    assert fit.exponents["lam"] == pytest.approx(0.55, abs=1e-10)
    assert fit.exponents["k_b"] == pytest.approx(2.6, abs=1e-10)
    assert fit.exponents["k_s"] == pytest.approx(-3.3, abs=1e-10)
    assert fit.prefactor == pytest.approx(2e-3, rel=1e-8)
    assert fit.ranges == {"lam": (100.0, 2000.0), "k_b": (1.0, 10.0), "k_s": (1e4, 1e6)}
    assert fit.n_points == 36
    assert fit.covariance.shape == (4, 4)
    with pytest.raises(ValueError):
        fit.covariance[0, 0] = 1.0  # read-only


def test_multi_power_law_matches_lstsq_and_covers():
    lam, kb, ks = _grid()
    truth = {"lam": 0.55, "k_b": 2.6, "k_s": -3.3}
    covered = dict.fromkeys(truth, 0)
    for rng in _streams(13):
        gamma = lam**0.55 * kb**2.6 * ks**-3.3 * np.exp(0.3 * rng.standard_normal(lam.size))
        fit = fit_multi_power_law(gamma, lam=lam, k_b=kb, k_s=ks)
        for name, value in truth.items():
            covered[name] += fit.ci[name][0] <= value <= fit.ci[name][1]
    low, high = _coverage_bounds()
    for name in truth:
        assert low <= covered[name] <= high, name
    # the last fit against a direct least-squares solution
    design = np.column_stack([np.ones(lam.size), np.log(lam), np.log(kb), np.log(ks)])
    coef, res, *_ = np.linalg.lstsq(design, np.log(gamma), rcond=None)
    assert [fit.exponents[k] for k in truth] == pytest.approx(coef[1:])
    cov = res[0] / (lam.size - 4) * np.linalg.inv(design.T @ design)
    assert [fit.stderrs[k] for k in truth] == pytest.approx(np.sqrt(np.diag(cov))[1:])


def test_multi_power_law_rejects_bad_input():
    lam = _grid()[0]
    g = lam**0.5
    with pytest.raises(ValueError, match="single value"):
        fit_multi_power_law(g, lam=lam, k_b=np.ones_like(lam))
    with pytest.raises(ValueError, match="collinear"):
        fit_multi_power_law(g, lam=lam, twice=2 * lam**2)
    with pytest.raises(ValueError, match="misspelled"):
        fit_multi_power_law(g, lam=lam, confidance=0.9)
    with pytest.raises(ValueError, match="at least one factor"):
        fit_multi_power_law(g)
    with pytest.raises(ValueError, match="positive"):
        fit_multi_power_law(-g, lam=lam)
    with pytest.raises(ValueError, match="more data points"):
        fit_multi_power_law([1.0, 2.0], lam=[1.0, 2.0])


# --------------------------------------------------------------------------------------------
# collapse (Fig. 5)
# --------------------------------------------------------------------------------------------

KEYS = [(5.0, 5e5), (8.0, 2.4e5), (2.0, 1e6), (10.0, 1e4), (1.0, 3e5)]
REF = (8.0, 2.4e5)


def test_collapse_exact_power_law_and_scaling():
    lam = np.geomspace(50, 2000, 15)
    curves = {k: (lam, 0.3 * lam**-0.25 * (k[0] * k[1]) ** 1.2) for k in KEYS}
    fit = collapse(curves, reference=REF)
    assert isinstance(fit, CollapseFit)
    assert fit.exponent == pytest.approx(1.2, abs=1e-10)
    assert fit.scatter == pytest.approx(0.0, abs=1e-10)
    assert fit.scatter_uncollapsed > 1.0
    assert fit.master.exponent == pytest.approx(-0.25, abs=1e-10)
    assert fit.x_range == (pytest.approx(50.0), pytest.approx(2000.0))
    assert fit.n_curves == 5 and fit.reference == REF
    # every rescaled curve lies on the reference curve
    x_ref, y_ref = fit.rescaled[REF]
    for key in KEYS:
        x, y = fit.rescaled[key]
        assert np.allclose(y, np.interp(x, x_ref, y_ref), rtol=1e-10)


def test_collapse_of_a_nonlinear_master_curve_on_different_grids():
    """A curved master function, curves sampled on shifted grids that overlap only in part."""
    rng = np.random.default_rng(2)
    curves = {}
    for i, key in enumerate(KEYS):
        lam = np.sort(np.exp(rng.uniform(np.log(20 * (i + 1)), np.log(400 * (i + 1)), 40)))
        f = np.exp(-0.3 * np.log(lam) + 0.02 * np.log(lam) ** 2)
        curves[key] = (lam, f * (key[0] * key[1]) ** -0.7)
    fit = collapse(curves, reference=REF)
    assert fit.exponent == pytest.approx(-0.7, abs=2e-3)
    assert fit.scatter < 0.01 * fit.scatter_uncollapsed


def test_collapse_x_range():
    lam = np.geomspace(1, 2000, 30)
    # power law only above lam = 100; below, a different dependence on g
    curves = {}
    for k in KEYS:
        g = k[0] * k[1]
        curves[k] = (lam, np.where(lam >= 100, lam**-0.25 * g**1.2, lam**-0.1 * g**0.3))
    fit = collapse(curves, reference=REF, x_range=(100, 2000))
    assert fit.exponent == pytest.approx(1.2, abs=1e-10)
    assert fit.x_range[0] >= 100


def test_collapse_ci_coverage():
    """c lies in the 95% interval in ~95% of trials with independent log-normal noise."""
    covered = 0
    for rng in _streams(21):
        curves = {}
        for key in KEYS:
            lam = np.exp(np.sort(rng.uniform(np.log(50), np.log(2000), 15)))
            noise = np.exp(0.05 * rng.standard_normal(lam.size))
            curves[key] = (lam, 0.3 * lam**-0.25 * (key[0] * key[1]) ** 1.2 * noise)
        fit = collapse(curves, reference=REF)
        covered += fit.ci[0] <= 1.2 <= fit.ci[1]
    low, high = _coverage_bounds()
    assert low <= covered <= high
    assert fit.noise == pytest.approx(0.05, rel=0.3)


def test_collapse_accepts_scalar_keys():
    lam = np.geomspace(10, 100, 5)
    fit = collapse({1.0: (lam, lam**-0.25), 10.0: (lam, lam**-0.25 * 10**0.5)}, reference=1.0)
    assert fit.exponent == pytest.approx(0.5)
    assert fit.reference == (1.0,)


def test_collapse_rejects_bad_input():
    lam = np.geomspace(10, 100, 5)
    ok = {(1.0, 2.0): (lam, lam), (3.0, 4.0): (lam, lam)}
    with pytest.raises(ValueError, match="reference"):
        collapse(ok, reference=(9.0, 9.0))
    with pytest.raises(ValueError, match="at least 2"):
        collapse({(1.0, 2.0): (lam, lam)}, reference=(1.0, 2.0))
    with pytest.raises(ValueError, match="overlap"):
        collapse({1.0: (lam, lam), 2.0: (lam * 1e3, lam)}, reference=1.0)
    with pytest.raises(ValueError, match="same scaling variable"):
        collapse({(1.0, 2.0): (lam, lam), (2.0, 1.0): (lam, lam)}, reference=(1.0, 2.0))
    with pytest.raises(ValueError, match="positive"):
        collapse({(1.0, -2.0): (lam, lam), (3.0, 4.0): (lam, lam)}, reference=(3.0, 4.0))
    with pytest.raises(ValueError, match="repeated"):
        collapse({1.0: ([1.0, 1.0, 2.0], [1, 2, 3]), 2.0: (lam, lam)}, reference=1.0)
