"""The Λ-collapse section's measures on curves whose answer is known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from crumple import paper
from crumple.reproduce.lambda_collapse import _rescaled, collapses, log_scatter


def test_identical_curves_have_no_scatter():
    x = np.geomspace(1, 100, 20)
    assert log_scatter({1: (x, x**-0.25), 2: (x, x**-0.25)}) == pytest.approx(0.0, abs=1e-15)


def test_scatter_of_curves_offset_by_a_constant_factor():
    # ln y differs by ±a between two curves: the standard deviation across them is a at every x
    x = np.geomspace(1, 100, 20)
    a = 0.3
    got = log_scatter({1: (x, np.exp(a) * x**-0.25), 2: (x, np.exp(-a) * x**-0.25)})
    assert got == pytest.approx(a, rel=1e-12)


def test_scatter_uses_only_the_common_range():
    x1, x2 = np.geomspace(1, 100, 30), np.geomspace(10, 1000, 30)
    y2 = np.where(x2 > 300, 50.0, x2**0.5)  # differs only well outside the overlap [10, 100]
    assert log_scatter({1: (x1, x1**0.5), 2: (x2, y2)}) == pytest.approx(0.0, abs=1e-12)
    assert math.isnan(log_scatter({1: (x1[:5], x1[:5]), 2: (x2[-5:], x2[-5:])}))


def test_collapse_criterion():
    assert collapses(0.3, 0.04)
    assert not collapses(0.3, 0.06)  # above the absolute bound
    assert not collapses(0.09, 0.04)  # not a third of the raw scatter
    assert not collapses(0.3, math.nan)


def test_paper_rescaling_collapses_curves_built_to_obey_it():
    # r_max = λ^-1/4 (k_b k_s)^c: the paper's rescaling with the same c makes them one curve
    lam = np.geomspace(1, 2000, 30)
    c = 0.2
    f5 = {k: {"lam": lam, "r_max": lam**-0.25 * (k[0] * k[1]) ** c} for k in paper.FIG3_POINTS}
    assert log_scatter(_rescaled(f5, c)) == pytest.approx(0.0, abs=1e-12)
    assert log_scatter(_rescaled(f5, 0.0)) > 0.5
