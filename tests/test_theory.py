"""Tests of crumple.theory: the formulas as stated, their scaling, and the loop geometry."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize_scalar

from crumple.fit import fit_multi_power_law, fit_power_law
from crumple.geometry import turning_angles
from crumple.theory import (
    LEMNISCATE_CONSTANT,
    alpha_prediction,
    gamma_exponents,
    gamma_prediction,
    loop_shape,
    loop_size,
)

# --------------------------------------------------------------------------------------------
# Loop size
# --------------------------------------------------------------------------------------------


def test_loop_size_values_and_scaling():
    assert loop_size(16.0, 1.0) == 2.0
    assert isinstance(loop_size(16.0, 1.0), float)
    lam = np.geomspace(1.0, 2000.0, 9)
    ell = loop_size(5.0, lam)
    assert ell.shape == (9,)
    assert fit_power_law(lam, ell).exponent == pytest.approx(-0.25, abs=1e-12)
    assert fit_power_law(
        np.geomspace(1, 10, 5), loop_size(np.geomspace(1, 10, 5), 3.0)
    ).exponent == (pytest.approx(0.25, abs=1e-12))
    # broadcasting k_b (n, 1) against lam (m,)
    assert loop_size(np.array([[1.0], [16.0]]), np.array([1.0, 16.0])).tolist() == [
        [1.0, 0.5],
        [2.0, 1.0],
    ]


def test_loop_size_from_discrete_parameters():
    """Eq. (1)'s k_b and lambda map to the continuum ones as k_b ds and lambda / ds."""
    ds = 1.0 / 100
    assert loop_size(5.0, 1000.0, segment_length=ds) == pytest.approx(
        loop_size(5.0 * ds, 1000.0 / ds)
    )
    assert loop_size(5.0, 1000.0, segment_length=ds) == pytest.approx(
        (5.0 / 1000.0) ** 0.25 * np.sqrt(ds)
    )


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((0.0, 1.0), {}, "k_b"),
        ((1.0, -1.0), {}, "lam"),
        ((1.0, np.nan), {}, "lam"),
        (("stiff", 1.0), {}, "k_b"),
        ((1.0, 1.0), {"segment_length": 0.0}, "segment_length"),
    ],
)
def test_loop_size_rejects_bad_input(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        loop_size(*args, **kwargs)


# --------------------------------------------------------------------------------------------
# Energy allocation
# --------------------------------------------------------------------------------------------


def _paper_grid():
    """The parameter ranges of the paper's Table I."""
    lam, kb, ks = np.meshgrid(
        np.geomspace(1.0, 2e3, 5), np.geomspace(1.0, 10.0, 4), np.geomspace(1e4, 1e7, 4)
    )
    return lam.ravel(), kb.ravel(), ks.ravel()


def test_gamma_prediction_is_the_printed_formula():
    lam, kb, ks = _paper_grid()
    for l0 in (1.0, 0.5):
        printed = np.sqrt(kb * lam) / (ks * (l0 - np.sqrt(kb * lam) / ks))
        assert gamma_prediction(kb, ks, lam, l0) == pytest.approx(printed, rel=1e-12)
    assert gamma_prediction(1.0, 2.0, 1.0) == 1.0
    assert isinstance(gamma_prediction(1.0, 2.0, 1.0), float)


def test_gamma_prediction_domain():
    # x = sqrt(k_b lam) / (k_s L0): positive for x < 1, NaN at and beyond x = 1
    out = gamma_prediction(1.0, 1.0, np.array([0.25, 0.81, 1.0, 4.0]))
    assert out[:2] == pytest.approx([1.0, 9.0])
    assert np.all(np.isnan(out[2:]))
    with pytest.raises(ValueError, match="k_s"):
        gamma_prediction(1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="L0"):
        gamma_prediction(1.0, 1.0, 1.0, L0=-1.0)


def test_gamma_exponents_in_the_paper_range():
    """Over Table I's ranges x < 0.015: the formula's exponents are (1/2, 1/2, -1), which a
    fit of Eq. (4) to the formula recovers; the paper measures (0.55, 2.6, -3.3)."""
    lam, kb, ks = _paper_grid()
    fit = fit_multi_power_law(gamma_prediction(kb, ks, lam), lam=lam, k_b=kb, k_s=ks)
    assert fit.exponents["lam"] == pytest.approx(0.5, abs=0.01)
    assert fit.exponents["k_b"] == pytest.approx(0.5, abs=0.01)
    assert fit.exponents["k_s"] == pytest.approx(-1.0, abs=0.02)


@pytest.mark.parametrize("x", [1e-4, 0.3, 0.9])
def test_gamma_exponents_are_log_derivatives(x):
    kb, ks, lam = 2.0, 10.0, (10.0 * x) ** 2 / 2.0  # sqrt(kb lam) / ks = x
    ex = gamma_exponents(kb, ks, lam)
    h = 1e-6

    def dlog(f, v):
        return (np.log(f(v * np.exp(h))) - np.log(f(v * np.exp(-h)))) / (2 * h)

    assert ex["lam"] == pytest.approx(dlog(lambda v: gamma_prediction(kb, ks, v), lam), rel=1e-6)
    assert ex["k_b"] == pytest.approx(dlog(lambda v: gamma_prediction(v, ks, lam), kb), rel=1e-6)
    assert ex["k_s"] == pytest.approx(dlog(lambda v: gamma_prediction(kb, v, lam), ks), rel=1e-6)
    assert np.isnan(gamma_exponents(1.0, 1.0, 4.0)["lam"])


# --------------------------------------------------------------------------------------------
# alpha
# --------------------------------------------------------------------------------------------


def test_alpha_from_the_papers_energy_balance():
    """Minimising lam R^2 L0 + beta (L0/R^2)^2 R^2 over R gives R ~ lam^(-1/4)."""
    assert alpha_prediction() == -0.25
    beta, l0 = 3e-3, 1.0
    lam = np.geomspace(1.0, 2e3, 8)
    radii = [
        minimize_scalar(
            lambda r, lm=lm: lm * r**2 * l0 + beta * (l0 / r**2) ** 2 * r**2,
            bounds=(1e-4, 10.0),
            method="bounded",
            options={"xatol": 1e-12},
        ).x
        for lm in lam
    ]
    assert fit_power_law(lam, radii).exponent == pytest.approx(alpha_prediction(), abs=1e-5)


# --------------------------------------------------------------------------------------------
# Loop shape
# --------------------------------------------------------------------------------------------


def test_lemniscate_constant():
    value = 2 * quad(lambda t: 1 / np.sqrt(1 - t**4), 0, 1)[0]
    assert value == pytest.approx(LEMNISCATE_CONSTANT, rel=1e-12)


@pytest.mark.parametrize(("k_b", "lam"), [(1.0, 1.0), (5.0, 1000.0), (0.1, 3.0)])
def test_loop_obeys_r2_equals_ell2_sin_2theta(k_b, lam):
    ell = loop_size(k_b, lam)
    x, y = loop_shape(k_b, lam, n_points=401)
    assert x.shape == y.shape == (401,)
    r, theta = np.hypot(x, y), np.arctan2(y, x)
    assert np.all(theta[1:-1] >= 0) and np.all(theta[1:-1] <= np.pi / 2)
    assert r**2 == pytest.approx(ell**2 * np.sin(2 * theta), abs=1e-12 * ell**2)
    assert r.max() == pytest.approx(ell, rel=1e-12)
    assert (x[0], y[0], x[-1], y[-1]) == (0.0, 0.0, 0.0, 0.0)
    # mirror symmetric about the diagonal: (x, y) -> (y, x) runs the loop backwards
    assert np.allclose(x[::-1], y, atol=1e-12 * ell) and np.allclose(y[::-1], x, atol=1e-12 * ell)


def test_loop_is_equally_spaced_in_arc_length_with_length_varpi_ell():
    ell = loop_size(2.0, 7.0)
    x, y = loop_shape(2.0, 7.0, n_points=4001)
    seg = np.hypot(np.diff(x), np.diff(y))
    ds = LEMNISCATE_CONSTANT * ell / 4000
    assert seg == pytest.approx(np.full(4000, ds), rel=1e-5)  # chords of equal arcs
    assert seg.sum() == pytest.approx(LEMNISCATE_CONSTANT * ell, rel=1e-6)


def test_loop_curvature_is_3r_over_ell_squared_and_leaves_along_the_axes():
    ell = loop_size(1.0, 1.0)
    x, y = loop_shape(1.0, 1.0, n_points=2001)
    pts = np.c_[x, y]
    seg = np.hypot(*np.diff(pts, axis=0).T)
    kappa = turning_angles(pts) / seg[:-1]  # turning angle per arc length at interior nodes
    r = np.hypot(x, y)[1:-1]
    assert kappa[10:-10] == pytest.approx(3 * r[10:-10] / ell**2, rel=1e-4, abs=1e-4)
    # a right angle at the origin: out along x, back in along y
    assert np.arctan2(y[1], x[1]) == pytest.approx(0.0, abs=1e-5)
    assert np.arctan2(y[-2], x[-2]) == pytest.approx(np.pi / 2, abs=1e-5)


def test_loop_shape_discrete_parameters_and_errors():
    x, y = loop_shape(5.0, 1000.0, segment_length=0.01)
    assert np.hypot(x, y).max() == pytest.approx(loop_size(5.0, 1000.0, segment_length=0.01))
    with pytest.raises(ValueError, match="n_points"):
        loop_shape(1.0, 1.0, n_points=2)
    with pytest.raises(ValueError, match="lam"):
        loop_shape(1.0, 0.0)
