"""Tests of crumple.minimize on problems with known answers: convergence, honest failure
reports, saddle escape, the admissibility hooks, and the monotone-descent invariant.

About the tolerance in the descent invariant: near a minimum the decrease of the energy falls
below the floating-point resolution of E itself. :func:`newton` then accepts a step whose energy
change lies within ``resolution(E) = 16 ε_mach |E|`` if it strictly lowers the largest force
(Hager & Zhang's approximate Wolfe condition). So "an accepted step never raises the energy"
is checked as ``E_{k+1} <= E_k + resolution(E_k)``: the allowance is the round-off of E, not a
physical tolerance.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import rosen, rosen_der, rosen_hess

from crumple.minimize import (
    MinimizeResult,
    _force_resolution,
    max_force,
    newton,
    powell,
    random_directions,
    resolution,
)

# --------------------------------------------------------------------------------------------
# Test problems
# --------------------------------------------------------------------------------------------


def rosenbrock(x):
    return float(rosen(x)), rosen_der(x)


def saddle(x):
    """f = x^2 - y^2 + y^4: a saddle at the origin, minima at (0, ±1/√2) with f = -1/4."""
    return float(x[0] ** 2 - x[1] ** 2 + x[1] ** 4), np.array([2 * x[0], -2 * x[1] + 4 * x[1] ** 3])


def saddle_hess(x):
    return np.diag([2.0, -2.0 + 12.0 * x[1] ** 2])


class Recorder:
    """A callback that keeps every accepted step and checks the descent invariant."""

    def __init__(self, fun, x0):
        self.energies = [fun(np.asarray(x0, dtype=float))[0]]
        self.points = [np.array(x0, dtype=float)]
        self.forces = []
        self.iterations = []

    def __call__(self, it, x, e, fmax):
        self.iterations.append(it)
        self.points.append(np.array(x, copy=True))
        self.energies.append(e)
        self.forces.append(fmax)

    def assert_monotone(self):
        e = np.array(self.energies)
        # an accepted step may raise E by at most its floating-point resolution (see top)
        allowed = np.array([resolution(v) for v in e[:-1]])
        rises = np.diff(e)
        bad = np.nonzero(rises > allowed)[0]
        assert bad.size == 0, f"energy rose at steps {bad}: {rises[bad]} > {allowed[bad]}"


def assert_result_is_honest(r: MinimizeResult):
    assert isinstance(r, MinimizeResult)
    assert isinstance(r.message, str) and r.message
    assert r.converged == (r.max_force <= r.ftol) or (not r.converged and "unstable" in r.message)
    if not r.converged:
        assert "converged" not in r.message or "not" in r.message


# --------------------------------------------------------------------------------------------
# Newton: convergence on known problems
# --------------------------------------------------------------------------------------------


def test_quadratic_in_one_step():
    a = np.array([[4.0, 1.0], [1.0, 3.0]])
    b = np.array([1.0, -2.0])

    def f(x):
        return float(0.5 * x @ a @ x - b @ x), a @ x - b

    r = newton(f, [10.0, -7.0], hess=lambda x: a)
    assert r.converged and r.iterations == 1
    np.testing.assert_allclose(r.x, np.linalg.solve(a, b), rtol=1e-12)
    assert r.max_force == pytest.approx(max_force(f(r.x)[1]))
    assert r.energy == pytest.approx(f(r.x)[0])
    assert r.method == "newton" and r.evaluations >= 2 and r.hessian_evaluations >= 1


@pytest.mark.parametrize("sparse", [False, True])
def test_quadratic_on_node_arrays(sparse):
    """Rows of an (n, 2) array; force = row norm; dense or sparse Hessian."""
    rng = np.random.default_rng(0)
    n = 30
    m = rng.standard_normal((2 * n, 2 * n))
    a = m @ m.T + 2 * n * np.eye(2 * n)
    target = rng.standard_normal((n, 2))

    def f(x):
        d = (x - target).ravel()
        return float(0.5 * d @ a @ d), (a @ d).reshape(n, 2)

    r = newton(f, np.zeros((n, 2)), hess=lambda x: sp.csc_matrix(a) if sparse else a, ftol=1e-10)
    assert r.converged
    assert r.x.shape == (n, 2)
    np.testing.assert_allclose(r.x, target, atol=1e-10)


@pytest.mark.parametrize("x0", [[-1.2, 1.0], [2.0, -1.5], [0.0, 3.0]])
def test_rosenbrock_2d(x0):
    rec = Recorder(rosenbrock, x0)
    r = newton(rosenbrock, x0, hess=rosen_hess, ftol=1e-8, callback=rec)
    assert r.converged, r.message
    np.testing.assert_allclose(r.x, [1.0, 1.0], atol=1e-8)
    assert r.max_force <= 1e-8
    assert "converged" in r.message
    rec.assert_monotone()
    assert len(rec.iterations) == r.iterations
    assert rec.iterations == list(range(1, r.iterations + 1))
    np.testing.assert_array_equal(rec.points[-1], r.x)
    assert rec.energies[-1] == r.energy


@pytest.mark.parametrize("n", [3, 6, 10])
def test_rosenbrock_nd_sparse_hessian(n):
    r = newton(rosenbrock, -np.ones(n), hess=lambda x: sp.csc_matrix(rosen_hess(x)), ftol=1e-9)
    assert r.converged, r.message
    np.testing.assert_allclose(r.x, np.ones(n), atol=1e-8)


def test_too_few_iterations_is_reported_never_silent():
    r = newton(rosenbrock, [-1.2, 1.0], hess=rosen_hess, maxiter=3)
    assert not r.converged
    assert r.iterations == 3
    assert r.max_force > r.ftol
    assert "maximum number of iterations" in r.message
    assert_result_is_honest(r)


def test_unfactorisable_hessian_is_reported():
    r = newton(rosenbrock, [-1.2, 1.0], hess=lambda x: np.full((2, 2), np.nan))
    assert not r.converged
    assert "positive definite" in r.message
    np.testing.assert_array_equal(r.x, [-1.2, 1.0])  # nothing accepted


def test_gradient_inconsistent_with_energy_is_reported():
    """A gradient with the wrong sign: every proposed step goes uphill, no step can be
    accepted, and the solver must stop and say so (not loop, not claim equilibrium)."""

    def f(x):
        return float(x @ x), -2 * x

    rec = Recorder(f, [1.0, -1.0])
    r = newton(f, [1.0, -1.0], hess=lambda x: 2 * np.eye(2), callback=rec, maxiter=100)
    assert not r.converged
    assert r.max_force > r.ftol
    assert_result_is_honest(r)
    rec.assert_monotone()


# --------------------------------------------------------------------------------------------
# Newton: saddle escape
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("sparse", [False, True])
@pytest.mark.parametrize("x0", [[1e-3, 0.0], [0.0, 0.0], [-0.5, 0.0]])
def test_saddle_escape_reaches_a_true_minimum(x0, sparse):
    """Started on the ridge y = 0 (the gradient has no y-component there), plain Newton would
    stop at the saddle (0, 0); the solver must detect the negative curvature and go down to
    a minimum y = ±1/√2."""
    hess = (lambda x: sp.csc_matrix(saddle_hess(x))) if sparse else saddle_hess
    rec = Recorder(saddle, x0)
    r = newton(saddle, x0, hess=hess, callback=rec)
    assert r.converged, r.message
    assert abs(r.x[1]) == pytest.approx(1 / math.sqrt(2), rel=1e-6)
    assert r.x[0] == pytest.approx(0.0, abs=1e-6)
    assert r.energy == pytest.approx(-0.25, abs=1e-10)
    assert "escape" in r.message
    rec.assert_monotone()


def test_every_iterate_is_reported_to_the_callback():
    """The callback is documented to run after *every* accepted step. The solver evaluates the
    Hessian only at its current iterate, so every point where it does (except the start) must
    have been reported first: this includes the saddle-escape step."""
    seen: list[np.ndarray] = []
    hessian_points: list[np.ndarray] = []

    def hess(x):
        hessian_points.append(np.array(x, copy=True))
        return saddle_hess(x)

    def callback(it, x, e, fmax):
        seen.append(np.array(x, copy=True))

    x0 = np.array([0.0, 0.0])
    r = newton(saddle, x0, hess=hess, callback=callback)
    assert r.converged
    for p in hessian_points:
        if np.array_equal(p, x0):
            continue
        assert any(np.array_equal(p, q) for q in seen), f"iterate {p} never reported"


def test_stable_minimum_with_a_zero_mode_is_accepted():
    """A symmetry zero mode (here f depends on |x| only) must not count as instability."""

    def f(x):
        r2 = float(x @ x)
        return (r2 - 1.0) ** 2, 4 * (r2 - 1.0) * x

    def h(x):
        r2 = float(x @ x)
        return 4 * (r2 - 1.0) * np.eye(2) + 8 * np.outer(x, x)

    r = newton(f, [0.3, 0.4], hess=h, ftol=1e-10)
    assert r.converged, r.message
    assert np.hypot(*r.x) == pytest.approx(1.0, rel=1e-9)
    assert "escape" not in r.message


def test_a_zero_mode_with_negative_curvature_keeps_newton_quadratic():
    """Inside the ring of minima of a rotation-invariant f(|x|) the Hessian's only negative
    direction is the rotation (curvature -gᵀ(d²x/dθ²) < 0). Given the zero mode, the step
    fixes its gauge instead of damping the whole step, and the force falls quadratically."""

    def f(x):
        r2 = float(x @ x)
        return 0.25 * (r2 - 1.0) ** 2, (r2 - 1.0) * x

    def h(x):
        return (float(x @ x) - 1.0) * np.eye(2) + 2 * np.outer(x, x)

    x0 = np.array([0.7, 0.1])
    assert np.linalg.eigvalsh(h(x0))[0] < 0  # indefinite, along the rotation only
    forces = []
    r = newton(f, x0, hess=h, ftol=1e-12, zero_modes=lambda x: np.array([[-x[1], x[0]]]),
               callback=lambda it, x, e, fmax: forces.append(fmax))  # fmt: skip
    assert r.converged, r.message
    assert np.hypot(*r.x) == pytest.approx(1.0, rel=1e-12)
    big = [k for k, fk in enumerate(forces) if fk > 1e-6]
    for k in big[1:]:  # quadratic: f_{k+1} <= C f_k^2 once close
        assert forces[k + 1] <= 10 * forces[k] ** 2, forces
    assert r.iterations <= 6, forces


# --------------------------------------------------------------------------------------------
# Newton: step control and admissibility hooks
# --------------------------------------------------------------------------------------------


def test_max_step_caps_every_row_displacement():
    target = np.full((5, 2), 10.0)

    def f(x):
        d = x - target
        return float((d * d).sum()), 2 * d

    rec = Recorder(f, np.zeros((5, 2)))
    r = newton(f, np.zeros((5, 2)), hess=lambda x: 2 * np.eye(10), max_step=0.5, callback=rec)
    assert r.converged
    np.testing.assert_allclose(r.x, target, atol=1e-9)
    steps = [np.max(np.hypot(*(b - a).T)) for a, b in zip(rec.points, rec.points[1:], strict=False)]
    assert max(steps) <= 0.5 * (1 + 1e-12)
    assert r.iterations >= 10 * math.sqrt(2) / 0.5 - 1  # it had to walk


def test_feasible_and_step_limit_keep_iterates_admissible():
    """Minimum at x = 2, wall at x = 1: the solver may approach but never cross; it cannot
    converge and must say so."""

    def f(x):
        return float((x[0] - 2) ** 2 + x[1] ** 2), np.array([2 * (x[0] - 2), 2 * x[1]])

    def step_limit(x, p):
        return 1.0 if x[0] + p[0] < 1 else max(0.0, (1 - x[0]) / p[0])

    def feasible(x):
        return x[0] < 1

    rec = Recorder(f, [0.0, 0.5])
    r = newton(
        f, [0.0, 0.5], hess=lambda x: 2 * np.eye(2), step_limit=step_limit, feasible=feasible,
        callback=rec, maxiter=50,
    )  # fmt: skip
    assert not r.converged
    assert_result_is_honest(r)
    assert all(feasible(p) for p in rec.points)
    assert r.x[0] > 0.99  # it went as far as it could
    rec.assert_monotone()


def test_cut_stops_a_cut_step_where_the_caller_says():
    """Minimum at x = 2, wall at x = 1 (the step_limit cuts the first step, from 0, at half
    of it): the step stops at 0.8 of the contact (x = 0.8) by default, at the caller's
    fraction where that lies between 0.8 t and t (x = 0.99), and at 0.8 t again where the
    caller's lies outside (at t itself, or short of 0.8 t)."""

    def f(x):
        return float((x[0] - 2) ** 2 + x[1] ** 2), np.array([2 * (x[0] - 2), 2 * x[1]])

    def step_limit(x, p):
        return 1.0 if x[0] + p[0] < 1 else max(0.0, (1 - x[0]) / p[0])

    def first(cut):
        r = newton(f, [0.0, 0.0], hess=lambda x: 2 * np.eye(2), step_limit=step_limit,
                   feasible=lambda x: x[0] < 1, maxiter=1, cut=cut)  # fmt: skip
        return r.x[0]

    assert first(None) == pytest.approx(0.8)
    assert first(lambda x, p, t: 0.99 * t) == pytest.approx(0.99)
    assert first(lambda x, p, t: t) == pytest.approx(0.8)
    assert first(lambda x, p, t: 0.5 * t) == pytest.approx(0.8)


def test_cut_is_given_the_step_capped_at_the_trust_radius():
    """With max_step = 0.75 the first step (2, 0) is capped to (0.75, 0), and a wall at
    x = 0.5 cuts that at t = 2/3: ``cut`` gets the capped step, and a cut that stops at
    x = 0.495 (s = 0.66 of it) lands there (0.8 t would give x = 0.4)."""

    def f(x):
        return float((x[0] - 2) ** 2), np.array([2 * (x[0] - 2)])

    def step_limit(x, p):
        return 1.0 if x[0] + p[0] < 0.5 else max(0.0, (0.5 - x[0]) / p[0])

    seen = []

    def cut(x, p, t):
        seen.append(float(p[0]))
        return (0.495 - x[0]) / p[0]

    r = newton(f, [0.0], hess=lambda x: np.array([[2.0]]), step_limit=step_limit,
               max_step=0.75, maxiter=1, cut=cut)  # fmt: skip
    assert seen == [pytest.approx(0.75)]
    assert r.x[0] == pytest.approx(0.495)


def test_feasible_alone_rejects_bad_points():
    def f(x):
        return float((x[0] - 2) ** 2), np.array([2 * (x[0] - 2)])

    rec = Recorder(f, [0.0])
    r = newton(
        f, [0.0], hess=lambda x: np.array([[2.0]]), feasible=lambda x: x[0] < 1, callback=rec
    )
    assert not r.converged
    assert all(p[0] < 1 for p in rec.points)
    assert_result_is_honest(r)


def test_input_validation():
    with pytest.raises(ValueError, match="feasible"):
        newton(rosenbrock, [0.0, 0.0], hess=rosen_hess, feasible=lambda x: False)
    with pytest.raises(ValueError, match="NaN"):
        newton(rosenbrock, [np.nan, 0.0], hess=rosen_hess)
    with pytest.raises(ValueError, match="ftol"):
        newton(rosenbrock, [0.0, 0.0], hess=rosen_hess, ftol=0.0)
    with pytest.raises(ValueError, match="maxiter"):
        newton(rosenbrock, [0.0, 0.0], hess=rosen_hess, maxiter=0)
    with pytest.raises(ValueError, match="max_step"):
        newton(rosenbrock, [0.0, 0.0], hess=rosen_hess, max_step=-1.0)
    with pytest.raises(ValueError, match="energy"):
        newton(lambda x: (math.inf, np.zeros(2)), [0.0, 0.0], hess=rosen_hess)
    with pytest.raises(ValueError):
        newton(rosenbrock, [], hess=rosen_hess)


# --------------------------------------------------------------------------------------------
# Fixed degrees of freedom
# --------------------------------------------------------------------------------------------


def bowl(n_rows: int, seed: int):
    """E = ½ (x - a)ᵀ A (x - a) over x of shape (n_rows, 2), A symmetric positive definite and
    fully coupled."""
    rng = np.random.default_rng(seed)
    q = rng.standard_normal((2 * n_rows, 2 * n_rows))
    a_mat = q @ q.T + 0.5 * np.eye(2 * n_rows)
    centre = rng.standard_normal(2 * n_rows)

    def f(x):
        d = x.ravel() - centre
        return 0.5 * float(d @ a_mat @ d), (a_mat @ d).reshape(x.shape)

    return f, a_mat, centre


@pytest.mark.parametrize("sparse", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_fixed_rows_give_the_constrained_minimum_of_a_bowl(sparse, seed):
    """Rows fixed at x_c: the minimum of the bowl over the free rows is the solution of
    A_ff (x_f - a_f) = -A_fc (x_c - a_c); the fixed rows do not move by one bit."""
    n = 5
    f, a_mat, centre = bowl(n, seed)
    x0 = np.random.default_rng(seed + 10).standard_normal((n, 2))
    fixed = np.zeros(n, dtype=bool)
    fixed[[0, 3]] = True
    hess = (lambda x: sp.csc_matrix(a_mat)) if sparse else (lambda x: a_mat)
    r = newton(f, x0, hess=hess, fixed=fixed, ftol=1e-10)
    assert r.converged, r.message
    np.testing.assert_array_equal(r.x[fixed], x0[fixed])
    c = np.repeat(fixed, 2)
    coupling = a_mat[np.ix_(~c, c)] @ (x0.ravel()[c] - centre[c])
    want = centre[~c] - np.linalg.solve(a_mat[np.ix_(~c, ~c)], coupling)
    np.testing.assert_allclose(r.x.ravel()[~c], want, atol=1e-9)
    # the force is reported on the free rows only: the fixed rows still carry a reaction
    g = f(r.x)[1]
    assert r.max_force == pytest.approx(max_force(g[~fixed]), abs=1e-12)
    assert max_force(g[fixed]) > 1e-3


@pytest.mark.parametrize("stored", [True, False])
def test_fixed_rows_of_a_raw_csc_hessian_are_those_of_scipys(stored):
    """The constrained Hessian of a :class:`crumple.linalg.CSC` holds the entries the SciPy
    route gives, on the same arrays where every fixed row's diagonal is stored; else it
    takes the SciPy route (a new pattern)."""
    from crumple.linalg import CSC
    from crumple.minimize_fixed import _constrained

    a = np.random.default_rng(0).standard_normal((8, 8))
    a = a + a.T
    if not stored:
        a[2, 2] = 0.0
    mask = np.zeros(8, dtype=bool)
    mask[[2, 5]] = True
    s = sp.csc_matrix(a)
    raw = CSC(s.data, s.indices.astype(np.int64), s.indptr.astype(np.int64))
    _, chess, _ = _constrained(mask, None, lambda h: h, None)
    got, want = chess(raw), chess(s)
    if stored:
        assert isinstance(got, CSC) and got.indices is raw.indices
    assert np.array_equal(got.tocsc().toarray(), want.toarray())
    assert np.array_equal(want.toarray()[mask][:, mask], np.eye(2))


def test_a_fixed_coordinate_of_a_one_dimensional_problem():
    def f(x):  # (x0 - 1)² + 10 (x1 + 2)² + x0 x1
        return (float((x[0] - 1) ** 2 + 10 * (x[1] + 2) ** 2 + x[0] * x[1]),
                np.array([2 * (x[0] - 1) + x[1], 20 * (x[1] + 2) + x[0]]))  # fmt: skip

    h = np.array([[2.0, 1.0], [1.0, 20.0]])
    r = newton(f, [3.0, 0.0], hess=lambda x: h, fixed=np.array([True, False]))
    assert r.converged and r.x[0] == 3.0
    assert r.x[1] == pytest.approx(-2.0 - 3.0 / 20.0, abs=1e-9)


def test_stability_concerns_the_free_rows_only():
    """A saddle of the full problem whose unstable direction is fixed is a minimum."""

    def f(x):  # x0² - x1²: a saddle, stable in x0
        return float(x[0] ** 2 - x[1] ** 2), np.array([2 * x[0], -2 * x[1]])

    h = np.diag([2.0, -2.0])
    r = newton(f, [0.5, 0.0], hess=lambda x: h, fixed=np.array([False, True]))
    assert r.converged and r.x.tolist() == [0.0, 0.0] and "escape" not in r.message


def test_fixed_mask_validation():
    f, a_mat, _ = bowl(3, 0)
    x0 = np.zeros((3, 2))
    with pytest.raises(ValueError, match="boolean"):
        newton(f, x0, hess=lambda x: a_mat, fixed=[0, 1, 0])
    with pytest.raises(ValueError, match="shape"):
        newton(f, x0, hess=lambda x: a_mat, fixed=np.zeros(6, dtype=bool))
    with pytest.raises(ValueError, match="every row"):
        newton(f, x0, hess=lambda x: a_mat, fixed=np.ones(3, dtype=bool))
    r = newton(f, x0, hess=lambda x: a_mat, fixed=np.zeros(3, dtype=bool))
    assert r.converged


# --------------------------------------------------------------------------------------------
# Newton: the descent invariant as a property
# --------------------------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(
    x0=st.lists(st.floats(-3, 3), min_size=2, max_size=8),
    max_step=st.one_of(st.none(), st.floats(0.1, 2.0)),
    sparse=st.booleans(),
)
def test_accepted_steps_never_raise_the_energy(x0, max_step, sparse):
    hess = (lambda x: sp.csc_matrix(rosen_hess(x))) if sparse else rosen_hess
    rec = Recorder(rosenbrock, x0)
    # a capped step walks the curved valley slowly (measured: 376 iterations from (3, 0, 0)
    # with max_step = 0.125), hence the generous maxiter
    r = newton(rosenbrock, x0, hess=hess, max_step=max_step, ftol=1e-9, callback=rec, maxiter=3000)
    rec.assert_monotone()
    assert_result_is_honest(r)
    assert r.converged, r.message
    assert r.energy <= rec.energies[0] + resolution(rec.energies[0])


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 12))
def test_accepted_steps_never_raise_the_energy_nonconvex(seed, n):
    """A random smooth non-convex function: Σ a_i cos(x_i) + quartic bowl + random coupling."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(1, 5, n)
    c = rng.standard_normal((n, n)) * 0.3
    c = c + c.T

    def f(x):
        e = float(np.sum(a * np.cos(3 * x)) + 0.1 * np.sum(x**4) + 0.5 * x @ c @ x)
        return e, -3 * a * np.sin(3 * x) + 0.4 * x**3 + c @ x

    def h(x):
        return np.diag(-9 * a * np.cos(3 * x) + 1.2 * x**2) + c

    x0 = rng.uniform(-2, 2, n)
    rec = Recorder(f, x0)
    r = newton(f, x0, hess=h, ftol=1e-9, callback=rec)
    rec.assert_monotone()
    assert r.converged, r.message
    # a true minimum: the Hessian there is positive semi-definite
    assert np.linalg.eigvalsh(h(r.x)).min() > -1e-8


# --------------------------------------------------------------------------------------------
# Powell (the paper's method)
# --------------------------------------------------------------------------------------------


def quad(x):
    return float((x[0] - 1) ** 2 + 10 * (x[1] + 2) ** 2 + 0.5 * x[2] ** 2)


def quad_grad(x):
    return np.array([2 * (x[0] - 1), 20 * (x[1] + 2), x[2]])


def test_powell_typed_result_with_force_from_the_gradient():
    r = powell(quad, [0.0, 0.0, 3.0], rng=np.random.default_rng(1), gradient=quad_grad)
    assert isinstance(r, MinimizeResult)
    assert r.method == "powell"
    assert r.converged, r.message
    np.testing.assert_allclose(r.x, [1.0, -2.0, 0.0], atol=1e-6)
    assert r.max_force == max_force(quad_grad(r.x))
    assert r.energy == quad(r.x)
    assert r.evaluations > 0 and r.iterations > 0 and r.hessian_evaluations == 0
    assert r.message.startswith("powell")


def test_powell_without_gradient_cannot_claim_convergence():
    r = powell(quad, [0.0, 0.0, 3.0], rng=np.random.default_rng(1))
    assert math.isnan(r.max_force)
    assert not r.converged


def test_powell_stopped_early_reports_it():
    r = powell(
        lambda x: float(rosen(x)),
        -np.ones(6),
        rng=np.random.default_rng(2),
        gradient=rosen_der,
        maxiter=2,
    )
    assert not r.converged
    assert r.max_force > r.ftol
    assert_result_is_honest(r)


def test_powell_respects_feasibility_and_is_seeded():
    """Infeasible points get energy +inf; Powell must handle that quietly (the project turns
    warnings into errors, and a ramp with method="powell" probes crossings all the time)."""

    def feasible(x):
        return x[0] <= 0.5

    runs = [
        powell(
            quad,
            [0.0, 0.0, 3.0],
            rng=np.random.default_rng(s),
            gradient=quad_grad,
            feasible=feasible,
        )
        for s in (5, 5, 6)
    ]
    for r in runs:
        assert feasible(r.x)
        assert r.x[0] > 0.4
        assert not r.converged  # the constrained optimum is not a force-free point
    np.testing.assert_array_equal(runs[0].x, runs[1].x)
    assert runs[0].evaluations == runs[1].evaluations


def test_random_directions_orthonormal_and_seeded():
    q = random_directions(7, np.random.default_rng(3))
    np.testing.assert_allclose(q @ q.T, np.eye(7), atol=1e-12)
    np.testing.assert_array_equal(q, random_directions(7, np.random.default_rng(3)))
    assert not np.allclose(q, random_directions(7, np.random.default_rng(4)))


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def test_max_force_and_resolution():
    assert max_force(np.array([[3.0, 4.0], [0.0, 1.0]])) == 5.0
    assert max_force(np.array([-2.0, 1.0])) == 2.0
    assert max_force(np.zeros((0, 2))) == 0.0
    assert resolution(1.0) == 16 * np.finfo(float).eps
    assert resolution(-3.0) == 48 * np.finfo(float).eps
    assert resolution(0.0) > 0


def test_max_force_compiled_path_has_the_bits_of_numpy():
    """(n, 2) float arrays take one compiled pass: the same value as sqrt(max(einsum)), bit
    for bit, over 300 decades, and NaN when a row is NaN."""
    rng = np.random.default_rng(3)
    g = rng.standard_normal((5000, 2)) * 10.0 ** rng.uniform(-150, 150, (5000, 1))
    for rows in np.array_split(g, 50):
        ref = float(np.sqrt(np.max(np.einsum("ij,ij->i", rows, rows))))
        assert max_force(rows) == ref
        assert max_force(rows.T.copy().T) == ref  # not C-contiguous: the NumPy path
    g[7, 1] = np.nan
    assert math.isnan(max_force(g))


# --------------------------------------------------------------------------------------------
# Barriers seen before they are entered (one-sided springs in the Newton model)
# --------------------------------------------------------------------------------------------


def _wall_problem(d=1e-3, eps=1e-2, target=-1.0):
    """A point pulled towards x = target < 0 by a unit spring, against a wall at 0 whose
    barrier ε b(x/d), b(u) = (1 - u)²/u, acts only within d of it (C¹ at x = d, like the hard
    core). Returns fun, hess, step_limit (never reach the wall) and barriers."""

    def fun(x):
        e, g = 0.5 * (x[0] - target) ** 2, x[0] - target
        if x[0] <= 0:
            return math.inf, np.array([g])
        if x[0] < d:
            u = x[0] / d
            e += eps * (1 - u) ** 2 / u
            g += eps * (1 - 1 / u**2) / d
        return e, np.array([g])

    def hess(x):
        h = 1.0 + (2 * eps / (x[0] / d) ** 3 / d**2 if 0 < x[0] < d else 0.0)
        return np.array([[h]])

    def step_limit(x, p):
        return 1.0 if x[0] + p[0] > 0 else x[0] / -p[0]

    def barriers(x, p):
        if x[0] < d or x[0] + p[0] >= d:
            return np.zeros((0, 1), int), np.zeros((0, 1)), np.zeros(0), np.zeros(0)
        return np.array([[0]]), np.array([[1.0]]), np.array([d - x[0]]), np.array([2 * eps / d**2])

    return fun, hess, step_limit, barriers


def test_barrier_seen_before_it_is_entered_saves_the_crawl_to_the_wall():
    """Without the spring, every step runs into the wall, is cut to 0.8 of the way and the
    point crawls towards it (a factor 5 per iteration) before the barrier's curvature is seen;
    with it, the first step stops at the barrier's edge. Same minimum, never at the wall."""
    fun, hess, step_limit, barriers = _wall_problem()
    seen = []
    runs = {}
    for name, b in (("plain", None), ("springs", barriers)):
        runs[name] = newton(fun, [0.5], hess=hess, step_limit=step_limit, barriers=b, ftol=1e-10,
                            callback=lambda i, x, e, f: seen.append(x[0]))  # fmt: skip
        assert runs[name].converged
    assert min(seen) > 0
    assert runs["springs"].x[0] == pytest.approx(runs["plain"].x[0], rel=1e-9)
    assert runs["springs"].iterations < runs["plain"].iterations - 2


def test_barriers_leave_a_problem_without_contacts_unchanged():
    fun, hess, step_limit, barriers = _wall_problem(target=2.0)
    a = newton(fun, [0.5], hess=hess, step_limit=step_limit, ftol=1e-12)
    b = newton(fun, [0.5], hess=hess, step_limit=step_limit, barriers=barriers, ftol=1e-12)
    assert a.x.tolist() == b.x.tolist() and a.iterations == b.iterations


def test_the_gauge_is_fixed_where_the_mode_is_largest_now():
    """The shift sits on the entry where each zero mode is largest in the current state, and
    is large enough to give the mode positive curvature even where H is negative there."""
    from crumple.minimize_modes import _gauge_pin

    rng = np.random.default_rng(3)
    h = sp.csc_matrix(-np.eye(6) + 0.1 * np.ones((6, 6)))
    for _ in range(5):
        w = rng.standard_normal(6)
        pin = _gauge_pin(h, w[None])
        j = int(np.argmax(np.abs(w)))
        assert np.flatnonzero(pin).tolist() == [j]
        assert w @ (h @ w) + pin[j] * w[j] ** 2 > 0
    assert _gauge_pin(h, np.zeros((0, 6))) is None


def test_the_gauge_of_one_mode_is_the_same_on_raw_csc_arrays():
    """The compiled one-mode path (a :class:`CSC` Hessian, the minimiser's hot path) gives the
    shift of the general one to the bit, a diagonal entry missing from the pattern included,
    and no shift for a mode that vanishes."""
    from crumple.linalg import CSC
    from crumple.minimize_modes import _gauge_pin

    rng = np.random.default_rng(5)
    a = rng.standard_normal((7, 7))
    a = sp.csc_matrix(a + a.T)
    a[3, 3] = 0.0
    a.eliminate_zeros()
    a.sort_indices()
    raw = CSC(a.data, a.indices, a.indptr)
    for k in range(6):
        w = rng.standard_normal(7)
        if k == 0:
            w = np.zeros(7)
            w[3] = 1.0  # the largest entry where H stores no diagonal
        general, fast = _gauge_pin(a, w[None]), _gauge_pin(raw, w[None])
        assert general.tobytes() == fast.tobytes()
        assert raw.diagonal_entry(k) == a[k, k]
    assert _gauge_pin(raw, np.zeros((1, 7))) is None


# --------------------------------------------------------------------------------------------
# Newton: stability where the assembled Hessian cannot resolve it (hess_action)
# --------------------------------------------------------------------------------------------
# A stiff chain in a tiny metric: its resolution ASSEMBLY_ROUNDOFF ε max|H_jj| / min M ≈ 1.8 per
# unit metric exceeds τ = 1e-3, so an inertia count that finds negative curvature is checked
# with the accurate product. The 'assembled' Hessian is made wrong along the soft modes on
# purpose (±0.5), so that the tests see which of the two decided.

N_CHAIN, STIFF, METRIC = 20, 1e6, 1e-9


def stiff_chain(soft):
    """E = ½ Σ STIFF (x_{i+1} - x_i)² + ½ soft Σ x_i² + ¼ Σ x_i⁴ (the quartic bounds a negative
    soft): (fun, exact Hessian, its product by differences)."""
    n = N_CHAIN
    lap = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    lap[0, 0] = lap[-1, -1] = 1.0

    def fun(x):
        e = 0.5 * STIFF * float(np.sum(np.diff(x) ** 2)) + 0.5 * soft * float(x @ x)
        return e + 0.25 * float(np.sum(x**4)), STIFF * (lap @ x) + soft * x + x**3

    def exact(x):
        return STIFF * lap + np.diag(soft + 3 * x**2)

    def action(x, v):
        d = np.diff(v)
        stiff = np.concatenate([[0.0], d]) - np.concatenate([d, [0.0]])
        return STIFF * stiff + (soft + 3 * x**2) * v

    return fun, exact, action


def uniform_mode(scale):
    return scale * np.full((N_CHAIN, N_CHAIN), 1.0 / N_CHAIN)


def chain_newton(fun, hess, **kw):
    size = kw.pop("size", N_CHAIN)
    return newton(fun, np.zeros(size), hess=hess, curvature_tol=1e-3,
                  metric=np.full(size, METRIC), **kw)  # fmt: skip


def test_stability_below_the_assembled_resolution_is_decided_by_the_accurate_product():
    """At the true minimum x = 0 (soft 0.1) the 'assembled' H has a negative eigenvalue along
    the uniform mode: without an accurate product the solver cannot step down and says so;
    with one, LOBPCG on it finds 0.1 / METRIC and the point is accepted."""
    fun, exact, action = stiff_chain(soft=0.1)
    hess = lambda x: sp.csc_matrix(exact(x) - uniform_mode(0.5))  # noqa: E731
    blind = chain_newton(fun, hess)
    assert not blind.converged
    assert "negative curvature that no step lowers" in blind.message
    r = chain_newton(fun, hess, hess_action=action)
    assert r.converged, r.message
    assert "stable by the accurate Hessian product: lowest eigenvalue 1e+08 " in r.message
    np.testing.assert_array_equal(r.x, 0.0)


def test_a_true_negative_curvature_is_not_hidden_by_the_accurate_product():
    """Soft spring negative (-0.1), H exact: x = 0 is a maximum along the uniform mode, the
    accurate product confirms the count, and the escape and the rest are those without it
    (with the factor's steps, the default); with the product's steps (``accurate_steps``,
    ``minimize_krylov``) the same escape reaches the same minimum."""
    fun, exact, action = stiff_chain(soft=-0.1)
    hess = lambda x: sp.csc_matrix(exact(x))  # noqa: E731
    blind = chain_newton(fun, hess)
    stepped = chain_newton(fun, hess, hess_action=action, accurate_steps=True)
    r = chain_newton(fun, hess, hess_action=action)
    assert "escape" in blind.message
    assert r.message == blind.message
    np.testing.assert_array_equal(r.x, blind.x)
    assert (r.iterations, r.evaluations) == (blind.iterations, blind.evaluations)
    assert stepped.converged and "(1 saddle escape)" in stepped.message
    assert stepped.krylov_iterations > 0 and r.krylov_iterations == 0
    assert stepped.energy == pytest.approx(blind.energy, rel=1e-12)
    np.testing.assert_allclose(stepped.x, blind.x, atol=1e-9)


def test_fixed_rows_reach_the_accurate_product_as_the_identity():
    """A fixed coordinate (here one decoupled from the chain) is the identity in the product
    too: the accurate check of the constrained problem accepts the minimum."""
    fun, exact, action = stiff_chain(soft=0.1)
    n = N_CHAIN

    def fun2(x):
        e, g = fun(x[:n])
        return e + 0.5 * x[n] ** 2, np.append(g, x[n])

    def action2(x, v):
        assert v[n] == 0.0  # the fixed entry is removed before the caller's product
        return np.append(action(x[:n], v[:n]), v[n])

    def hess2(x):
        return sp.block_diag([exact(x[:n]) - uniform_mode(0.5), sp.eye(1)]).tocsc()

    fixed = np.zeros(n + 1, dtype=bool)
    fixed[n] = True
    x0 = np.zeros(n + 1)
    x0[n] = 0.3
    r = newton(fun2, x0, hess=hess2, curvature_tol=1e-3, metric=np.full(n + 1, METRIC),
               hess_action=action2, fixed=fixed)  # fmt: skip
    assert r.converged, r.message
    assert "stable by the accurate Hessian product: lowest eigenvalue 1e+08 " in r.message
    assert r.x[n] == 0.3


@pytest.mark.parametrize("sparse", [False, True])
@pytest.mark.parametrize("x0", [[1e-3, 0.0], [0.0, 0.0], [-0.5, 0.0]])
def test_an_accurate_product_leaves_a_resolved_problem_bitwise_unchanged(x0, sparse):
    """Where the assembled matrix resolves τ (here everywhere), hess_action is never called:
    the saddle escape and every number of the result are those without it."""
    hess = (lambda x: sp.csc_matrix(saddle_hess(x))) if sparse else saddle_hess

    def action(x, v):
        raise AssertionError("called where the assembled Hessian resolves τ")

    a = newton(saddle, x0, hess=hess)
    b = newton(saddle, x0, hess=hess, hess_action=action)
    assert a.message == b.message and "escape" in a.message
    np.testing.assert_array_equal(a.x, b.x)
    assert (a.energy, a.iterations, a.evaluations, a.factorizations) == (
        b.energy, b.iterations, b.evaluations, b.factorizations,
    )  # fmt: skip


def test_the_accurate_escape_steps_down_where_the_assembled_mode_cannot(monkeypatch):
    """Two stiff chains: A truly unstable (soft -0.1), B stable (soft 0.1); the 'assembled' H
    shows them the other way round (±0.5 along their uniform modes). Its lowest mode (B's)
    goes up: no step lowers the energy, and without the accurate product the solver stops
    there. With it, the escape then takes the accurate lowest mode (A's), goes down to A's
    minimum, B untouched, and the accurate product accepts it. The opt-in
    ``minimize_accurate.ACCURATE_ESCAPE`` takes the accurate mode first: the same minimum,
    without the failed trials along the assembled mode."""
    import crumple.minimize_accurate as ma

    fa, exact_a, act_a = stiff_chain(soft=-0.1)
    fb, exact_b, act_b = stiff_chain(soft=0.1)
    n = N_CHAIN

    def fun(x):
        (ea, ga), (eb, gb) = fa(x[:n]), fb(x[n:])
        return ea + eb, np.concatenate([ga, gb])

    def hess(x):
        a = exact_a(x[:n]) + uniform_mode(0.5)
        return sp.block_diag([a, exact_b(x[n:]) - uniform_mode(0.5)]).tocsc()

    def action(x, v):
        return np.concatenate([act_a(x[:n], v[:n]), act_b(x[n:], v[n:])])

    blind = chain_newton(fun, hess, size=2 * n)
    assert "negative curvature that no step lowers" in blind.message and blind.energy == 0.0
    rescued = chain_newton(fun, hess, hess_action=action, size=2 * n)
    monkeypatch.setattr(ma, "ACCURATE_ESCAPE", True)
    first = chain_newton(fun, hess, hess_action=action, size=2 * n)
    for r in (rescued, first):
        assert r.converged, r.message
        assert "stable by the accurate Hessian product" in r.message
        np.testing.assert_allclose(np.abs(r.x[:n]), math.sqrt(0.1), rtol=1e-4)  # ftol / 0.2
        np.testing.assert_allclose(r.x[n:], 0.0, atol=1e-6)  # the accurate mode is ~0 on B
    assert "1 along the accurate Hessian product's mode" in rescued.message
    assert "along the accurate" not in first.message  # taken first, not as a rescue
    assert rescued.evaluations > first.evaluations  # the failed trials along B's mode


def test_after_a_rescue_the_escapes_take_the_accurate_mode_first(monkeypatch):
    """Three stiff chains: A1 and A2 truly unstable (soft -0.2 and -0.1), B stable (0.1), the
    'assembled' H wrong by ±0.5 along each uniform mode, so that its lowest mode is always
    B's, which goes up. The first escape is a rescue (the assembled mode fails, then A1's
    accurate mode); at A1's minimum A2 is still unstable, and the second escape takes A2's
    accurate mode at once, without the eigensolve of the assembled H and its failed trials
    (at N = 10⁵ that eigensolve was half of a contact stage's CPU). Both end at the minimum."""
    import crumple.minimize_modes as mm

    chains = [stiff_chain(soft=v) for v in (-0.2, -0.1, 0.1)]
    n = N_CHAIN
    parts = [slice(0, n), slice(n, 2 * n), slice(2 * n, 3 * n)]

    def fun(x):
        out = [f(x[p]) for (f, _, _), p in zip(chains, parts, strict=True)]
        return sum(e for e, _ in out), np.concatenate([g for _, g in out])

    def hess(x):
        shifts = (0.5, 0.5, -0.5)
        return sp.block_diag(
            [
                exact(x[p]) + uniform_mode(v)
                for (_, exact, _), p, v in zip(chains, parts, shifts, strict=True)
            ]
        ).tocsc()

    def action(x, v):
        return np.concatenate(
            [act(x[p], v[p]) for (_, _, act), p in zip(chains, parts, strict=True)]
        )

    calls = []
    lowest = mm._lowest_mode
    monkeypatch.setattr(mm, "_lowest_mode", lambda *a, **k: calls.append(1) or lowest(*a, **k))
    r = chain_newton(fun, hess, hess_action=action, size=3 * n)
    assert r.converged, r.message
    assert "2 saddle escapes, 2 along the accurate Hessian product's mode" in r.message
    np.testing.assert_allclose(np.abs(r.x[parts[0]]), math.sqrt(0.2), rtol=1e-4)
    np.testing.assert_allclose(np.abs(r.x[parts[1]]), math.sqrt(0.1), rtol=1e-4)
    np.testing.assert_allclose(r.x[parts[2]], 0.0, atol=1e-6)
    assert len(calls) == 1  # the assembled H's eigensolve for the first escape only


def test_an_escape_along_the_assembled_mode_is_unchanged_where_the_accurate_mode_is_known(
    monkeypatch,
):
    """Soft -0.1, the assembled H exact: the count finds the negative curvature, the accurate
    product confirms it and has its mode, and the escape along the assembled mode goes down.
    The rescue must not touch that path: the run is the same, bit for bit, as one whose
    accurate check offers no mode at all (the engine before the rescue)."""
    import crumple.minimize as mz
    import crumple.minimize_accurate as ma

    fun, exact, action = stiff_chain(soft=-0.1)
    hess = lambda x: sp.csc_matrix(exact(x))  # noqa: E731
    offered = []
    check = ma._accurate_check

    def recorded(*args):
        out = check(*args)
        offered.append(out[1] is not None)
        return out

    monkeypatch.setattr(mz, "_accurate_check", recorded)
    with_mode = chain_newton(fun, hess, hess_action=action)
    monkeypatch.setattr(mz, "_accurate_check", lambda *a: (lambda o: (o[0], None, o[2]))(check(*a)))
    without = chain_newton(fun, hess, hess_action=action)
    assert any(offered), "the accurate check never offered a mode: the test tests nothing"
    assert "saddle escape" in with_mode.message and "along the accurate" not in with_mode.message
    assert with_mode.message == without.message
    np.testing.assert_array_equal(with_mode.x, without.x)
    assert (with_mode.energy, with_mode.iterations, with_mode.evaluations) == (
        without.energy, without.iterations, without.evaluations,
    )  # fmt: skip


def test_the_opt_in_recheck_of_a_positive_count_finds_the_curvature_it_missed(monkeypatch):
    """Soft -0.1, the 'assembled' H +0.5 along the uniform mode: its count finds no negative
    pivot at the maximum x = 0, which is accepted by default. With
    ``ACCURATE_WHEN_POSITIVE`` the accurate product finds -0.1 / METRIC: the point is refused;
    the assembled H has no direction to escape along, so the solver goes down the accurate
    mode to the minimum |x_i| = √0.1 and accepts it there; with ``ACCURATE_ESCAPE`` as well,
    the same, along the accurate mode from the first."""
    import crumple.minimize_accurate as ma

    fun, exact, action = stiff_chain(soft=-0.1)
    hess = lambda x: sp.csc_matrix(exact(x) + uniform_mode(0.5))  # noqa: E731
    default = chain_newton(fun, hess, hess_action=action)
    assert default.converged and "accurate" not in default.message  # the count's verdict
    monkeypatch.setattr(ma, "ACCURATE_WHEN_POSITIVE", True)
    rechecked = chain_newton(fun, hess, hess_action=action)
    monkeypatch.setattr(ma, "ACCURATE_ESCAPE", True)
    both = chain_newton(fun, hess, hess_action=action)
    for r in (rechecked, both):
        assert r.converged, r.message
        assert "stable by the accurate Hessian product" in r.message
        np.testing.assert_allclose(np.abs(r.x), math.sqrt(0.1), rtol=1e-4)  # ftol / 0.2
    assert "along the accurate Hessian product's mode" in rechecked.message


def test_the_accurate_steps_recheck_every_minimum_the_count_accepts():
    """The chain above, whose 'assembled' H hides the maximum x = 0 from the count: with the
    accurate steps on (``newton(accurate_steps=True)``, the engine above 10³ segments) every
    minimum the count accepts is also checked by the accurate product, so the maximum is
    refused and the minimum |x_i| = √0.1 found, without the opt-in switch (measured at
    N = 10⁵: the straight wire at λ = 6.39 … 11.9 passed the count)."""
    fun, exact, action = stiff_chain(soft=-0.1)
    hess = lambda x: sp.csc_matrix(exact(x) + uniform_mode(0.5))  # noqa: E731
    r = chain_newton(fun, hess, hess_action=action, accurate_steps=True)
    assert r.converged, r.message
    assert "stable by the accurate Hessian product" in r.message
    np.testing.assert_allclose(np.abs(r.x), math.sqrt(0.1), rtol=1e-4)


def _too_short_step(a):
    """A quadratic bowl 0.5 |x - a|² at x = 0 and a step of a twentieth of the way to its
    minimum (what a model twenty times too stiff gives), accepted in full: the state after it."""
    from crumple.minimize import _State

    def fun(x):
        return 0.5 * float((x - a) @ (x - a)), x - a

    x0 = np.zeros_like(a)
    e0, g0 = fun(x0)
    p = 0.05 * a
    st = _State(x=x0, e=e0, g=g0, fmax=float(np.max(np.abs(g0))))
    et, gt = fun(p)
    return st, fun, p, (1.0, p, et, gt, float(np.max(np.abs(gt))))


def test_a_too_short_fallback_step_is_lengthened_to_the_minimum_along_it(monkeypatch):
    """Two secant trials reach the bowl's minimum from a twentieth of the way (8× capped, then
    the exact root); each trial is one evaluation; the energy falls at each."""
    import crumple.minimize_expand as mz
    from crumple.minimize_expand import _expand

    monkeypatch.setattr(mz, "EXPANSIONS", 3)

    a = np.array([3.0, -4.0])
    st, fun, p, accepted = _too_short_step(a)
    alpha, x, e, _, _ = _expand(st, fun, p, None, None, 1e-4, float(st.g @ p), max_force(p),
                                None, *accepted)  # fmt: skip
    assert alpha == pytest.approx(20.0)
    np.testing.assert_allclose(x, a, atol=1e-12)
    assert e < accepted[2] and e == pytest.approx(0.0, abs=1e-20)
    assert st.nfev == 1 + 2  # two trials: 8×, then the root (the third finds a zero slope)


@pytest.mark.parametrize("block", ["step_limit", "feasible", "max_step"])
def test_a_fallback_step_is_not_lengthened_past_a_contact_a_crossing_or_the_cap(block, monkeypatch):
    """An unsafe (collision detection short of the whole step), infeasible or over-long trial
    ends the lengthening: the accepted step is kept as it was."""
    import crumple.minimize_expand as mz
    from crumple.minimize_expand import _expand

    monkeypatch.setattr(mz, "EXPANSIONS", 3)

    a = np.array([3.0, -4.0])
    st, fun, p, accepted = _too_short_step(a)
    limit = (lambda x, q: 0.5) if block == "step_limit" else None
    feasible = (lambda x: False) if block == "feasible" else None
    cap = 0.22 if block == "max_step" else None  # the step moves 0.2: no room for a trial
    out = _expand(st, fun, p, limit, feasible, 1e-4, float(st.g @ p), max_force(p), cap,
                  *accepted)  # fmt: skip
    assert out[0] == 1.0 and out[1] is p and out[2] == accepted[2]
    assert st.nfev == (2 if block == "feasible" else 1)  # the infeasible trial was evaluated


def test_a_lengthened_step_stops_at_the_cap(monkeypatch):
    """The trial towards the bowl's minimum (20× the step) is clipped to max_step (2×)."""
    import crumple.minimize_expand as mz
    from crumple.minimize_expand import _expand

    monkeypatch.setattr(mz, "EXPANSIONS", 3)
    st, fun, p, accepted = _too_short_step(np.array([3.0, -4.0]))
    out = _expand(st, fun, p, None, None, 1e-4, float(st.g @ p), max_force(p), 0.4, *accepted)
    assert out[0] == 2.0 and out[2] < accepted[2] and st.nfev == 2


def test_exact_newton_steps_are_never_lengthened(monkeypatch):
    """On a convex problem every step is the exact Hessian's: the lengthening, switched on,
    evaluates nothing more (the same iterates and counts)."""
    import crumple.minimize_expand as mz

    x0 = np.array([-1.2, 1.0, -0.5, 0.8])
    a = np.diag([1.0, 10.0, 100.0, 1000.0])

    def fun(x):
        return 0.25 * float(x @ x) ** 2 + 0.5 * float(x @ a @ x), (x @ x) * x + a @ x

    def hess(x):
        return 2.0 * np.outer(x, x) + float(x @ x) * np.eye(4) + a

    off = newton(fun, x0, hess=hess)
    monkeypatch.setattr(mz, "EXPANSIONS", 3)
    on = newton(fun, x0, hess=hess)
    assert off.converged and on.converged
    assert on.evaluations == off.evaluations and np.array_equal(on.x, off.x)


def test_a_lengthened_step_that_raises_the_largest_force_is_refused(monkeypatch):
    """E = -x + 5 max(0, x - 1/2)² from x = 0, a step to 0.1 accepted: the slope is the same
    there (no curvature seen), so the trial goes 8× further, to 0.8, lower in energy (-0.35
    against -0.1) but pressed into the wall (force 2 against 1). Refused (it is where the
    per-node wires' lengthened steps stalled); accepted without the guard."""
    import crumple.minimize_expand as mz
    from crumple.minimize import _State
    from crumple.minimize_expand import _expand

    def fun(x):
        over = max(0.0, float(x[0]) - 0.5)
        return -float(x[0]) + 5.0 * over**2, np.array([-1.0 + 10.0 * over])

    monkeypatch.setattr(mz, "EXPANSIONS", 3)
    x0, p = np.zeros(1), np.array([0.1])
    e0, g0 = fun(x0)
    et, gt = fun(p)
    accepted = (1.0, p, et, gt, 1.0)

    def lengthen():
        st = _State(x=x0, e=e0, g=g0, fmax=1.0)
        return _expand(st, fun, p, None, None, 1e-4, float(g0 @ p), 0.1, None, *accepted)

    assert lengthen()[0] == 1.0
    monkeypatch.setattr(mz, "EXPAND_FORCE_GUARD", False)
    alpha, _, e, _, f = lengthen()
    assert alpha == 8.0 and e == pytest.approx(-0.35) and f == pytest.approx(2.0)


def test_lengthened_steps_keep_a_ramp_at_true_equilibria(monkeypatch):
    """With the opt-in lengthening on, a contact ramp (N = 100, λ to 2000) still ends every
    stage converged and stable, never crosses, and its iterates differ from the default's (the
    switch is live); off is the default."""
    import crumple.minimize_expand as mz
    from crumple.geometry import has_crossings
    from crumple.model import Wire
    from crumple.protocol import Ramp, run_ramp

    assert mz.EXPANSIONS == 0
    wire, ramp = Wire(k_b=5, k_s=5e5), Ramp(lambdas=(1.0, 10.0, 100.0, 300.0, 1000.0, 2000.0))
    off = run_ramp(wire, ramp, seed=4)
    monkeypatch.setattr(mz, "EXPANSIONS", 3)
    on = run_ramp(wire, ramp, seed=4)
    assert on.converged and off.converged
    assert not any(has_crossings(s.positions) for s in on.stages)
    assert on.stages[-1].energy.hard_core > 0
    assert any(a.result.evaluations != b.result.evaluations
               for a, b in zip(on.stages, off.stages, strict=True))  # fmt: skip


# --------------------------------------------------------------------------------------------
# Curved trial points (retract)
# --------------------------------------------------------------------------------------------


def _ring(k=1e4):
    """A stiff ring valley k (|x| - 1)² plus a soft tilt -x_1 (minimum at (0, 1 + 1/(2k))):
    straight steps along the valley leave it, curved ones (rotations about 0) follow it."""

    def fun(x):
        r = math.hypot(*x)
        return k * (r - 1.0) ** 2 - x[1], 2 * k * (r - 1.0) * x / r - np.array([0.0, 1.0])

    def hess(x):
        r = math.hypot(*x)
        u = x / r
        return 2 * k * np.outer(u, u) + 2 * k * (r - 1.0) / r * (np.eye(2) - np.outer(u, u))

    def turn(x, p, alpha):  # rotate by the step's angular part, move radially by its radial part
        r, u = math.hypot(*x), x / math.hypot(*x)
        t = np.array([-u[1], u[0]])
        phi = alpha * float(p @ t) / r
        c, s = math.cos(phi), math.sin(phi)
        return (r + alpha * float(p @ u)) * np.array([c * u[0] - s * u[1], s * u[0] + c * u[1]])

    return fun, hess, turn


def test_curved_trial_points_follow_a_curved_valley_and_never_raise_the_energy():
    """From the far side of the ring, curved trials reach the same minimum as straight ones,
    in fewer iterations, taking curved steps; every accepted step lowers the energy."""
    fun, hess, turn = _ring()
    x0 = np.array([0.0, -1.0]) + np.array([1e-3, 0.0])
    seen = []
    curved = newton(fun, x0, hess=hess, retract=turn, maxiter=500,
                    callback=lambda it, x, e, f: seen.append(e))  # fmt: skip
    straight = newton(fun, x0, hess=hess, maxiter=500)
    assert curved.converged and straight.converged
    np.testing.assert_allclose(curved.x, straight.x, atol=1e-5)  # ftol 1e-6, unit curvature
    assert curved.curved_steps > 0 and straight.curved_steps == 0
    assert curved.iterations < straight.iterations
    assert all(b <= a + resolution(a) for a, b in itertools.pairwise(seen))


def test_a_curve_that_is_never_better_is_never_taken():
    """A curve that leaves the ring's valley (x + αp pushed outward by 0.1 α) is never lower
    than the straight point: every trial refuses it, and the iterates are those of the
    straight line search, bit for bit (only the evaluations count the refused trials)."""
    fun, hess, _ = _ring()
    x0 = np.array([0.3, -0.9])

    def outward(x, p, a):
        return x + a * p + 0.1 * a * x / math.hypot(*x)

    r = newton(fun, x0, hess=hess, retract=outward, maxiter=500)
    ref = newton(fun, x0, hess=hess, maxiter=500)
    assert r.converged and r.curved_steps == 0
    assert np.array_equal(r.x, ref.x) and r.iterations == ref.iterations
    assert r.evaluations > ref.evaluations


def test_retract_cannot_be_combined_with_fixed_rows():
    f, a_mat, _ = bowl(3, 0)
    with pytest.raises(ValueError, match="retract cannot be combined"):
        newton(f, np.ones((3, 2)), hess=lambda x: a_mat, fixed=np.array([True, False, False]),
               retract=lambda x, p, a: x + a * p)  # fmt: skip


def test_a_retraction_that_offers_no_point_leaves_newton_bit_for_bit_unchanged():
    """``retract`` may return None (no curved point here): the iterates are then exactly those
    of the straight line search."""
    fun, hess, _ = _ring()
    x0 = np.array([0.3, -0.9])
    r = newton(fun, x0, hess=hess, retract=lambda x, p, a: None, maxiter=500)
    ref = newton(fun, x0, hess=hess, maxiter=500)
    assert np.array_equal(r.x, ref.x) and r.iterations == ref.iterations
    assert r.evaluations == ref.evaluations and r.curved_steps == 0


def _coherent_below_resolution(power, n=400, stiff=1e6, soft=1e-3):
    """A chain of n rows at ~10⁶ (ulp 1.2·10⁻¹⁰): stiff springs (K = 10⁶) between neighbours,
    so that a row's force resolution is ~5·10⁻³, and a soft term (k/power) Σ (x_i - c_i)^power
    whose minimum is a uniform shift of 1 away: a force of 10⁻³ on every row, below the
    resolution, yet coherent, the energy k n / power above the minimum."""
    c = 1e6 + np.arange(n, dtype=np.float64) + 1.0

    def fun(x):
        s, t = np.diff(x) - 1.0, x - c
        e = 0.5 * stiff * float(s @ s) + soft / power * float(np.sum(t**power))
        g = soft * t ** (power - 1)
        g[:-1] -= stiff * s
        g[1:] += stiff * s
        return e, g

    def hess(x):
        d = soft * (power - 1) * (x - c) ** (power - 2) + 2.0 * stiff
        d[[0, -1]] -= stiff
        off = np.full(n - 1, -stiff)
        return sp.diags([off, d, off], [-1, 0, 1], format="csc")

    return fun, hess, c - 1.0


def test_forces_below_their_resolution_but_coherent_are_not_a_minimum():
    """The force resolution accepts a point only if a Newton step from it predicts a decrease
    within 100 times that of a one-ulp move of the coordinates: a soft quartic on a stiff chain
    at x ~ 10⁶, after one Newton step (a third of the way), has every force below its
    resolution and the energy 0.05 above the minimum (measured at N = 10⁴ on the continuum
    wire: a stage so accepted sat 0.0039 above its minimum)."""
    fun, hess, x0 = _coherent_below_resolution(4, n=1000)
    assert 1e-6 < max_force(fun(x0)[1]) < 0.25 * _force_resolution(hess(x0), x0)
    r = newton(fun, x0, hess=hess, maxiter=1)
    assert not r.converged and "not a minimum" in r.message
    assert r.max_force <= r.force_resolution  # what the force test alone accepted
    r = newton(fun, x0, hess=hess, maxiter=200)  # on to ftol
    assert r.converged and r.max_force <= 1e-6 and r.energy < 1e-3 * fun(x0)[0]


def test_a_point_the_accurate_product_finds_stable_is_still_tested_for_its_decrease():
    """Where the assembled H cannot resolve τ and the accurate product decides stability (N ~
    10⁵), a point accepted only below the force floor must still pass the decrease test: the
    soft quartic of the chain above (every force below its resolution, yet coherent), in a
    metric that puts the assembled resolution above τ, and an 'assembled' H wrong along the
    uniform mode (a negative pivot that is round-off): the accurate product finds the point
    stable, but a Newton step from it predicts a decrease far above a one-ulp move's. (The
    factor's steps, the default, which stay there: the product's own steps leave it, test
    below.)"""
    fun, _, x0, kw = _wrong_along_the_uniform_mode()
    assert max_force(fun(x0)[1]) < 0.25 * _force_resolution(kw["hess"](x0), x0)
    r = newton(fun, x0, maxiter=3, **kw)
    assert not r.converged, r.message
    assert "stable by the accurate Hessian product" not in r.message
    assert "not a minimum" in r.message
    assert r.max_force <= r.force_resolution  # what the force test and the product accepted
    assert r.energy > 1e-3  # and rightly refused: the minimum is E = 0 at x = x0 + 1


def test_the_accurate_steps_reach_the_minimum_the_factor_cannot(monkeypatch):
    """The chain above: the factor of the 'assembled' H, wrong along the soft uniform mode,
    steps by round-off there and the stage stops after 20 points the decrease test refused
    (energy 0.043 above the minimum E = 0). Newton's step by truncated CG on the accurate
    product, preconditioned by that factor, converges (measured: 6 iterations, 6 CG)."""
    import crumple.minimize_accurate as ma
    import crumple.minimize_krylov as mk

    fun, _, x0, kw = _wrong_along_the_uniform_mode()
    r = newton(fun, x0, maxiter=50, accurate_steps=True, **kw)
    assert r.converged, r.message
    assert "stable by the accurate Hessian product" in r.message
    assert r.energy < 1e-5 and 0 < r.krylov_iterations <= 10 * r.iterations
    monkeypatch.setattr(ma, "REFUSED_STEPS", False)  # (they mend it too: the test below)
    old = newton(fun, x0, maxiter=50, **kw)  # the default: the factor's steps
    assert not old.converged and old.energy > 1e-2, old.message
    assert old.krylov_iterations == 0
    monkeypatch.setattr(mk, "ACCURATE_STEPS", False)  # the module's switch overrides the call
    off = newton(fun, x0, maxiter=50, accurate_steps=True, **kw)
    assert off.krylov_iterations == 0 and off.energy == old.energy


def test_a_refused_point_hands_its_own_step_to_the_next_iteration(monkeypatch):
    """The chain the factor's steps cannot bring to its minimum (above), with the factor's
    steps (no ``accurate_steps``): every point the decrease test refuses passes on the step
    the test measured, the Galerkin solution of (H + τM)s = -g over the eigensolve's Ritz
    block (``minimize_accurate.REFUSED_STEPS``), and the next iteration takes it: the minimum
    E = 0 is reached. Without it the stage stops after 20 refused points, 0.043 above it."""
    import crumple.minimize_accurate as ma

    fun, _, x0, kw = _wrong_along_the_uniform_mode()
    r = newton(fun, x0, maxiter=50, **kw)
    assert r.converged and r.energy < 1e-5, r.message
    assert r.krylov_iterations == 0  # not the accurate steps': the refused points'
    monkeypatch.setattr(ma, "REFUSED_STEPS", False)
    old = newton(fun, x0, maxiter=50, **kw)
    assert not old.converged and old.energy > 1e-2, old.message


def test_a_refused_point_s_step_gives_way_to_the_accurate_step_where_no_spring_is_listed(
    monkeypatch,
):
    """The same chain with the accurate steps on: the points the decrease test refuses still
    hand on their steps, but where no spring is listed the step is the accurate product's
    truncated CG (solved to its own test), not the handed-on one: the run is the same, bit
    for bit, as with ``REFUSED_STEPS`` off. (Measured at N = 10⁵: 20 iterations against 8 on
    the first smooth stage after buckling when the handed-on step was taken.)"""
    import crumple.minimize as mn
    import crumple.minimize_accurate as ma

    fun, _, x0, kw = _wrong_along_the_uniform_mode()
    handed = []
    takes = mn._takes
    monkeypatch.setattr(mn, "_takes", lambda st, step: handed.append(1) or takes(st, step))
    r = newton(fun, x0, maxiter=50, accurate_steps=True, **kw)
    assert r.converged, r.message
    assert handed, "no refused point handed on a step: the test does not reach the rule"
    monkeypatch.setattr(ma, "REFUSED_STEPS", False)
    off = newton(fun, x0, maxiter=50, accurate_steps=True, **kw)
    assert (off.iterations, off.krylov_iterations) == (r.iterations, r.krylov_iterations)
    assert np.array_equal(off.x, r.x)


def test_the_accurate_step_is_the_newton_step_of_the_accurate_hessian():
    """Inside the trust radius and where the accurate H is positive definite, the step is
    -H⁻¹g of the accurate product, not the wrong factor's (here 160 times apart along the soft
    mode); beyond the radius it stops on the way there, a descent direction."""
    from crumple.linalg import LDLT
    from crumple.minimize import _State
    from crumple.minimize_krylov import _accurate_step

    fun, hess, x0, kw = _wrong_along_the_uniform_mode()
    n = x0.size
    m = np.full(n, 1e-9)
    floor = 1e-3 * m
    wrong = kw["hess"](x0)
    shift = 1.0 * np.ones(n)  # the fallback's σM that makes it positive definite
    f = LDLT().factorize(wrong, shift=shift)
    assert f.positive_definite
    e, g = fun(x0)
    st = _State(x=x0, e=e, g=g, fmax=max_force(g), radius=np.inf, accurate_steps=True)
    st.factor, st.model, st.hess_action = f, (wrong, shift), kw["hess_action"]
    p = -f.solve(g)
    s = _accurate_step(st, p, m, floor)
    newton_step = -np.linalg.solve(hess(x0).toarray(), g)
    np.testing.assert_allclose(s, newton_step, rtol=1e-6, atol=1e-9 * np.abs(newton_step).max())
    assert np.abs(s).mean() > 100 * np.abs(p).mean()  # the factor's step is round-off there
    st.radius = 0.1 * np.abs(newton_step).max()
    short = _accurate_step(st, p, m, floor)
    assert float(g @ short) < 0 and np.abs(short).max() < np.abs(newton_step).max()


def _spring_state(radius=np.inf):
    """The chain of :func:`_wrong_along_the_uniform_mode` at its start, with the factor of its
    'assembled' H (+ the fallback's shift) as the direction's, and the springs' step q of one
    one-sided spring that holds x_0 from moving up by more than 10⁻³, which the step enters
    (a = -e_0, r = -10⁻³, k = 10⁻²: as stiff as the soft mode)."""
    from crumple.linalg import LDLT
    from crumple.minimize import _State

    fun, hess, x0, kw = _wrong_along_the_uniform_mode()
    n = x0.size
    wrong, shift = kw["hess"](x0), np.ones(n)
    ldl = LDLT()
    f = ldl.factorize(wrong, shift=shift)
    e, g = fun(x0)
    st = _State(x=x0, e=e, g=g, fmax=max_force(g), radius=radius, accurate_steps=True)
    st.factor, st.model, st.hess_action = f, (wrong, shift), kw["hess_action"]
    springs = (np.array([[0]]), np.array([[-1.0]]), np.array([-1e-3]), np.array([1e-2]))
    q, ok = f.solve_springs(-f.solve(g), *springs)
    assert ok
    return st, ldl, hess(x0).toarray(), springs, q


def test_the_accurate_spring_step_is_the_minimiser_of_the_accurate_spring_model():
    """With contacts the step is the springs' model's (``minimize_barriers``), solved with the
    factor; where the assembled H is wrong along a soft mode, so is that step. Refined by CG on
    the accurate product with the springs active at it held (``_accurate_spring_step``), it is
    the minimiser of gᵀs + ½ sᵀHs + k/2 (r - aᵀs)² with the accurate H (a dense solve here),
    its spring still active; the factor's step is far from it along the soft mode."""
    from crumple.minimize_krylov import _accurate_spring_step

    st, ldl, h, springs, q = _spring_state()
    index, value, offset, stiff = springs
    m = np.full(q.size, 1e-9)
    a = np.zeros(q.size)
    a[index[0]] = value[0]
    assert a @ q < offset[0]  # the factor's step enters the spring
    exact = np.linalg.solve(h + stiff[0] * np.outer(a, a), -st.g + stiff[0] * offset[0] * a)
    assert a @ exact < offset[0]  # and so does the accurate model's minimiser
    s = _accurate_spring_step(st, q, springs, ldl, m, 1e-3 * m)
    np.testing.assert_allclose(s, exact, rtol=1e-6, atol=1e-9 * np.abs(exact).max())
    assert np.abs(q - exact).max() > 0.1 * np.abs(exact).max()  # the factor's step is not it
    assert st.krylov > 0 and float(st.g @ s) < 0


def test_the_accurate_spring_step_keeps_the_factor_s_step_where_it_does_not_apply(monkeypatch):
    """The refinement is made only where the accurate steps are (the assembled H's resolution
    above τ, ``accurate_steps``, the module's switch on): otherwise the springs' step q itself
    is returned, and no CG iteration is spent."""
    import crumple.minimize_krylov as mk

    st, ldl, _, springs, q = _spring_state()
    m = np.full(q.size, 1e-9)
    assert mk._accurate_spring_step(st, q, springs, ldl, m, 1e6 * m) is q  # τ above it
    monkeypatch.setattr(mk, "ACCURATE_SPRING_STEPS", False)
    assert mk._accurate_spring_step(st, q, springs, ldl, m, 1e-3 * m) is q
    assert st.krylov == 0


def _piecewise_model(h, g, springs, x):
    """gᵀx + ½ xᵀHx + Σ k_i/2 max(0, r_i - a_iᵀx)², densely (``minimize_krylov._spring_model``)."""
    index, value, offset, stiff = springs
    u = np.array([value[i] @ x[index[i]] for i in range(len(offset))])
    return float(g @ x + 0.5 * x @ h @ x + 0.5 * np.sum(stiff * np.maximum(0.0, offset - u) ** 2))


def test_the_least_point_between_two_steps_is_the_piecewise_model_s_least_on_the_segment():
    """``_least_between`` (q, s): the point of the segment from q to s where the springs'
    piecewise quadratic model is least, against a dense grid of the segment, with a stiff
    spring that s enters and q does not (the kink stops it short of s) and with none (the
    smooth minimiser on the segment); None where the model rises from q towards s."""
    from crumple.minimize_krylov import _least_between

    rng = np.random.default_rng(3)
    b = rng.normal(size=(4, 4))
    h = b @ b.T + 4 * np.eye(4)
    g = rng.normal(size=4)
    q = 0.1 * rng.normal(size=4)  # not 0: Hq enters the slope and, through Hd = Hs - Hq, the
    d = -2.0 * np.linalg.solve(h, g + h @ q)  # curvature; twice the Newton step from q, so
    s = q + d  # the smooth least point is t = ½
    j = int(np.argmax(np.abs(d)))
    sign = np.sign(d[j])
    stiff_spring = (np.array([[j]]), np.array([[-sign]]), np.array([-sign * q[j] - 0.25 *
                    abs(d[j])]), np.array([1e6]))  # fmt: skip  # a quarter of the way along d
    loose = (np.array([[j]]), np.array([[-sign]]), np.array([-sign * q[j] - 10.0 * abs(d[j])]),
             np.array([1e6]))  # fmt: skip
    grid = np.linspace(0.0, 1.0, 20001)
    for springs, smooth in ((stiff_spring, False), (loose, True)):
        x = _least_between(g, q, h @ q, s, h @ s, *springs)
        assert x is not None
        t = float((x - q) @ (s - q) / ((s - q) @ (s - q)))
        np.testing.assert_allclose(x, q + t * (s - q), atol=1e-12 * np.abs(s).max())
        values = [_piecewise_model(h, g, springs, q + u * (s - q)) for u in grid]
        best = grid[int(np.argmin(values))]
        assert abs(t - best) <= 2 * (grid[1] - grid[0])
        assert _piecewise_model(h, g, springs, x) <= min(values) + 1e-12 * abs(min(values))
        assert _piecewise_model(h, g, springs, x) < _piecewise_model(h, g, springs, q)
        if smooth:
            assert abs(t - 0.5) < 1e-9
        else:
            assert t < 0.25 + 0.01  # stopped at the kink, a quarter of the way
    newton_point = -np.linalg.solve(h, g)  # the model's minimiser: it rises towards any s
    assert _least_between(g, newton_point, h @ newton_point, s, h @ s, *loose) is None


def test_the_accurate_spring_step_stops_on_its_way_where_a_listed_spring_holds_it(monkeypatch):
    """The accurate refinement of the springs' step q holds the springs active at q only; the
    step it finds can enter a listed spring that q did not. The piecewise model of every
    listed spring is then higher there than at q, and the refinement was thrown away (q kept:
    measured at N = 10⁵, in most contact steps of a snap-through). With
    ``ACCURATE_SPRING_SEGMENT`` the step is the least point of that model on the segment from
    q to the refined step: on it, stopped at the spring's kink, strictly lower than q."""
    import crumple.minimize_krylov as mk

    st, ldl, h, springs, q = _spring_state()
    m = np.full(q.size, 1e-9)
    monkeypatch.setattr(mk, "ACCURATE_SPRING_SEGMENT", False)
    refined = mk._accurate_spring_step(st, q, springs, ldl, m, 1e-3 * m)
    assert refined is not q
    move = refined - q
    j = int(np.argmax(np.abs(move)))
    sign = np.sign(move[j])
    stop = q[j] + 0.5 * move[j]  # a stiff spring halfway along the refinement, not entered at q
    held = tuple(np.concatenate([a, b]) for a, b in zip(springs, (
        np.array([[j]]), np.array([[-sign]]), np.array([-sign * stop]), np.array([1e12])),
        strict=True))  # fmt: skip
    g = st.g.ravel()
    before = _piecewise_model(h, g, held, q.ravel())
    assert _piecewise_model(h, g, held, refined.ravel()) > before
    st.krylov = 0
    assert mk._accurate_spring_step(st, q, held, ldl, m, 1e-3 * m) is q  # thrown away
    assert st.krylov > 0
    monkeypatch.setattr(mk, "ACCURATE_SPRING_SEGMENT", True)
    s = mk._accurate_spring_step(st, q, held, ldl, m, 1e-3 * m)
    t = float((s - q).ravel() @ move.ravel() / (move.ravel() @ move.ravel()))
    np.testing.assert_allclose(s, q + t * move, atol=1e-9 * np.abs(move).max())
    assert 0.4 < t <= 0.5 + 1e-6  # at the kink, where the spring holds it
    assert _piecewise_model(h, g, held, s.ravel()) < before and float(g @ s.ravel()) < 0


def test_the_accurate_spring_step_goes_on_along_negative_curvature_by_the_radius(monkeypatch):
    """Where the accurate H (here the fixture's less one along its uniform mode: lowest
    eigenvalue -1) has negative curvature along the CG's first direction d, the CG stops
    there with nothing but q: without ``ACCURATE_SPRING_SEGMENT`` q is kept; with it the step
    is q + (Δ/|d|∞) d, a largest row displacement of the trust radius Δ from q, a descent
    direction that lowers the springs' model below q's."""
    import crumple.minimize_krylov as mk

    st, ldl, h, springs, q = _spring_state(radius=1.0)
    w = np.full(q.size, 1.0 / np.sqrt(q.size))
    negative = h - np.outer(w, w)
    assert np.linalg.eigvalsh(negative).min() < -0.9
    st.hess_action = lambda x, v: negative @ v
    m = np.full(q.size, 1e-9)
    stops = []
    cg = mk._cg
    monkeypatch.setattr(mk, "_cg", lambda *a: stops.append(cg(*a)[2:]) or cg(*a))
    monkeypatch.setattr(mk, "ACCURATE_SPRING_SEGMENT", False)
    assert mk._accurate_spring_step(st, q, springs, ldl, m, 1e-3 * m) is q
    assert stops[-1] == (0, "negative")
    monkeypatch.setattr(mk, "ACCURATE_SPRING_SEGMENT", True)
    s = mk._accurate_spring_step(st, q, springs, ldl, m, 1e-3 * m)
    g = st.g.ravel()
    assert np.abs(s - q).max() == pytest.approx(st.radius, rel=1e-12)
    model = lambda x: _piecewise_model(negative, g, springs, x.ravel())  # noqa: E731
    assert model(s) < model(q) and float(g @ s.ravel()) < 0


def test_a_listing_above_the_solve_limit_goes_straight_to_the_refactorised_step(monkeypatch):
    """``springs_solve_limit``: a listing with more springs than the limit skips the solve with
    the factor (never called) and gets the refactorised step's, the model's exact minimiser
    here (one spring), started from the step it is given (``last``: the listing before's) or
    from the Newton step. At or below the limit the solve decides, bit for bit as without it."""
    import crumple.minimize_barriers as mb
    from crumple.linalg import Factorization

    st, ldl, _, springs, q = _spring_state()
    p = -st.factor.solve(st.g)
    index, value, offset, stiff = springs
    a = np.zeros(q.size)
    a[index[0]] = value[0]
    model = st.model[0].toarray() + np.diag(st.model[1])
    exact = np.linalg.solve(model + stiff[0] * np.outer(a, a), -st.g + stiff[0] * offset[0] * a)
    starts, solves = [], []
    step, solve = mb.spring_step, Factorization.solve_springs

    def recorded(*args, **kwargs):
        starts.append(np.array(args[8], copy=True))
        return step(*args, **kwargs)

    def counted(self, *args, **kwargs):
        solves.append(1)
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(mb, "spring_step", recorded)
    monkeypatch.setattr(Factorization, "solve_springs", counted)
    st.springs_solve_limit = 0
    s, _ = mb._spring_model_step(st, p, springs, ldl)
    assert not solves and np.array_equal(starts[-1], p.ravel())
    np.testing.assert_allclose(s, exact, rtol=1e-9, atol=1e-12 * np.abs(exact).max())
    last = 0.5 * p
    mb._spring_model_step(st, p, springs, ldl, None, last)
    assert not solves and np.array_equal(starts[-1], last.ravel())
    st.springs_solve_limit = 1  # one spring listed: not above the limit
    s, _ = mb._spring_model_step(st, p, springs, ldl, None, last)
    assert len(solves) == 1 and len(starts) == 2 and np.array_equal(s, q)


def test_a_relisting_above_the_solve_limit_starts_from_the_listing_before_s_step(monkeypatch):
    """With the solve skipped, a relisting (the step found enters a pair the first listing did
    not have) starts its refactorised step from the step the listing before found, not from
    the Newton step again; the step kept is the minimiser of the model with both."""
    import crumple.minimize_barriers as mb

    st, ldl, _, springs, _ = _spring_state()
    st.springs_solve_limit = 0
    p = -st.factor.solve(st.g)
    second = (np.array([[1]]), np.array([[-1.0]]), np.array([-1e-3]), np.array([1e-2]))
    both = tuple(np.concatenate([u, v]) for u, v in zip(springs, second, strict=True))
    listings = []

    def barriers(x, step):
        listings.append(step)
        return springs if len(listings) == 1 else both

    starts, found = [], []
    step = mb.spring_step

    def recorded(*args, **kwargs):
        starts.append(np.array(args[8], copy=True))
        found.append(step(*args, **kwargs)[0])
        return found[-1], True, 1

    monkeypatch.setattr(mb, "spring_step", recorded)
    s = mb._barrier_step(st, p, barriers, ldl)
    assert len(starts) >= 2 and np.array_equal(starts[0], p.ravel())
    assert np.array_equal(starts[1], found[0])
    a = np.zeros((2, s.size))
    a[0, 0] = a[1, 1] = -1.0
    dense = st.model[0].toarray() + np.diag(st.model[1]) + 1e-2 * a.T @ a
    exact = np.linalg.solve(dense, -st.g - 1e-5 * a.sum(axis=0))  # k r a_i, r = -10⁻³
    assert np.all(a @ exact < -1e-3)  # the model's minimiser enters both springs
    np.testing.assert_allclose(s.ravel(), exact, rtol=1e-9, atol=1e-12 * np.abs(exact).max())


def test_a_negative_springs_solve_limit_is_refused():
    fun, _, x0, kw = _wrong_along_the_uniform_mode()
    with pytest.raises(ValueError, match="springs_solve_limit"):
        newton(fun, x0, springs_solve_limit=-1, **kw)


def test_the_accurate_steps_reach_the_minimum_with_springs_listed(monkeypatch):
    """The chain that the factor's steps cannot bring to its minimum (test above), now with a
    caller's barrier listed at every step (a spring far away, never entered): the steps are
    the springs' model's, which the accurate product refines as it does the plain Newton
    step. Without the refinement (the engine before the twelfth stop) the stage stops short,
    refused by the decrease test."""
    import crumple.minimize_accurate as ma
    import crumple.minimize_krylov as mk

    fun, _, x0, kw = _wrong_along_the_uniform_mode()
    far = (np.array([[0, 1]]), np.array([[1.0, -1.0]]), np.array([-1e3]), np.array([1e6]))
    monkeypatch.setattr(ma, "REFUSED_STEPS", False)  # the refinement alone
    r = newton(fun, x0, maxiter=50, accurate_steps=True, barriers=lambda x, p: far, **kw)
    assert r.converged and r.energy < 1e-5, r.message
    monkeypatch.setattr(mk, "ACCURATE_SPRING_STEPS", False)
    old = newton(fun, x0, maxiter=50, accurate_steps=True, barriers=lambda x, p: far, **kw)
    assert not old.converged and old.energy > 1e-2, old.message


def _wrong_along_the_uniform_mode(n=200, metric=1e-9):
    """The chain of the test above with the accurate product and an 'assembled' H that is
    wrong (-0.5) along its softest mode, the uniform one (exact curvature 3 × 10⁻³)."""
    fun, hess, x0 = _coherent_below_resolution(4, n=n)

    def action(x, v):
        return np.asarray(hess(x) @ v).ravel()

    def assembled(x):
        return sp.csc_matrix(hess(x).toarray() - 0.5 / n)

    kw = dict(hess=assembled, hess_action=action, metric=np.full(n, metric), curvature_tol=1e-3)
    return fun, hess, x0, kw


def test_the_decrease_estimate_drops_a_singular_direction_of_its_ritz_block():
    """The coarse correction solves with YᵀAY, Y the eigensolve's Ritz block: where A is
    singular on part of Y that solve raised (measured: an N = 10⁵ ramp stopped on an
    exception at λ = 754.8). With A = diag(0, 1, 2, 3, 4), a right-hand side b outside its
    null space and Y holding the null direction, the estimate is bᵀA⁻¹b on the rest, the
    null direction dropped (and with another, regular direction in Y, that one kept)."""
    from crumple.minimize_accurate import _coarse_block, _decrease_estimate

    a = np.diag([0.0, 1.0, 2.0, 3.0, 4.0])
    b = np.array([0.0, 1.0, 1.0, 1.0, 1.0])
    exact = 1 + 1 / 2 + 1 / 3 + 1 / 4
    ident = lambda v: v  # noqa: E731
    null = np.eye(5)[:, :1]
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.solve(null.T @ a @ null, null.T @ b)  # what the correction solved before
    for ritz in (null, np.eye(5)[:, [0, 2]]):
        est, why = _decrease_estimate(lambda v: a @ v, b, ident, ident, ritz)
        assert why == "" and est == pytest.approx(exact, rel=1e-10)
    y, _, cy = _coarse_block(np.eye(5)[:, [0, 2]], a @ np.eye(5)[:, [0, 2]])
    np.testing.assert_allclose(np.abs(y.ravel()), np.eye(5)[:, 2])  # the regular one kept
    assert cy.shape == (1, 1) and cy[0, 0] == pytest.approx(2.0)
    assert _coarse_block(null, a @ null) == (None, None, None)
    regular = np.eye(5)[:, [1, 3]]
    kept = _coarse_block(regular, a @ regular)
    assert kept[0] is regular  # a regular block as it is: the same iterates as before


def test_the_accurate_decrease_is_the_newton_decrease_along_a_soft_mode():
    """On the accurate product, preconditioned by the floored factor of the wrong assembled
    H + σM, the estimate is ½ gᵀH⁻¹g's (0.0333 at the start, nearly all along the soft mode),
    where that factor alone predicts 163 times less; it is a lower bound, it may stop as soon
    as it passes a bound, and a preconditioner or a matrix that is not positive is reported,
    not used."""
    from crumple.linalg import LDLT
    from crumple.minimize_accurate import _cg_quadratic, _decrease_estimate

    fun, hess, x0, kw = _wrong_along_the_uniform_mode()
    g = fun(x0)[1]
    exact = float(g @ np.linalg.solve(hess(x0).toarray(), g))
    n = g.size
    pre = LDLT().factorize(kw["hess"](x0), shift=np.full(n, 0.178e-9), floor=np.full(n, 1e-12))
    assert exact > 100 * float(g @ pre.solve(g))
    ident = lambda v: v  # noqa: E731
    act = lambda v: kw["hess_action"](x0, v)  # noqa: E731
    est, why = _decrease_estimate(act, g, pre.solve, ident, None)
    assert why == "" and est <= exact * (1 + 1e-9)
    np.testing.assert_allclose(est, exact, rtol=1e-3)
    early, why = _decrease_estimate(act, g, pre.solve, ident, None, 0.1 * exact)
    assert why == "" and 0.1 * exact < early <= est
    assert "not positive" in _cg_quadratic(lambda v: -v, g, ident, ident)[2]
    assert "lost its sign" in _cg_quadratic(act, g, lambda r: -r, ident)[2]
    assert _cg_quadratic(act, np.zeros(n), ident, ident)[::2] == (0.0, "")


def test_the_ritz_block_lifts_the_plateau_of_a_hidden_soft_mode():
    """A soft mode (curvature 10⁻¹¹) that the preconditioner sees as stiff holds nearly all of
    bᵀA⁻¹b with a tiny weight in b: conjugate gradients alone plateau and 'settle' far below
    (found by the review: 17 times too low); with the eigensolve's Ritz vector of that mode as
    a coarse correction the estimate is the exact value, and it never exceeds it."""
    from crumple.minimize_accurate import _decrease_estimate

    rng = np.random.default_rng(1)
    n = 2000  # diagonal: the well preconditioned part, and one soft mode last
    d = np.concatenate([np.geomspace(0.05, 1.0, n), [1e-11]])
    b = np.concatenate([rng.standard_normal(n) / np.sqrt(n), [np.sqrt(1e-9)]])
    exact = float(b @ (b / d))
    ident = lambda v: v  # noqa: E731
    alone, why = _decrease_estimate(lambda v: d * v, b, ident, ident, None)
    assert why == "" and alone < 0.2 * exact  # the plateau: 'settled', far below
    ritz = np.zeros((n + 1, 1))
    ritz[-1] = 1.0
    ritz[:-1, 0] = 1e-6 * rng.standard_normal(n)  # an eigensolve's estimate of the mode
    lifted, why = _decrease_estimate(lambda v: d * v, b, ident, ident, ritz)
    assert why == "" and lifted <= exact * (1 + 1e-9)
    np.testing.assert_allclose(lifted, exact, rtol=1e-3)


def test_the_accurate_decrease_is_taken_in_the_complement_of_the_zero_modes():
    """With a zero mode W the estimate is gᵀZ(ZᵀAZ)⁻¹Zᵀg, Z a basis of W's complement (what
    the count's branch computes by its Schur form), though A is soft along W."""
    from crumple.minimize_accurate import _decrease_estimate

    rng = np.random.default_rng(2)
    n = 30
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))  # q[:, 0] is the zero mode W
    lam = np.concatenate([[1e-8], np.linspace(0.1, 1.0, n - 1)])
    a = (q * lam) @ q.T
    g = rng.standard_normal(n)
    w = q[:, :1]
    project = lambda v: v - w @ (w.T @ v)  # noqa: E731
    want = float(np.sum((q[:, 1:].T @ g) ** 2 / lam[1:]))
    got, why = _decrease_estimate(lambda v: a @ v, project(g), lambda r: r, project, None)
    assert why == ""
    np.testing.assert_allclose(got, want, rtol=1e-6)
    assert float(g @ np.linalg.solve(a, g)) > 1e6 * want  # W's own share, left out


def test_a_true_minimum_passes_the_accurate_decrease_test_and_a_coherent_point_does_not():
    """The test itself, at two points of the chain: its minimum moved by a few ulps (forces
    ~10⁻⁴, noise, below the floor) passes; the start (forces 10⁻³ along the soft mode) does
    not. The one-ulp moves' decrease is ½ δᵀ(H + τM)δ on the accurate product."""
    from types import SimpleNamespace

    from crumple.linalg import LDLT
    from crumple.minimize_accurate import _accurate_resolved
    from crumple.minimize_resolution import _ulp_moves

    fun, hess, x0, kw = _wrong_along_the_uniform_mode()
    n = x0.size
    floor = np.full(n, 1e-3 * 1e-9)  # τ M
    x = x0 + 1.0  # the minimum, exactly representable
    x[::7] = np.nextafter(x[::7], np.inf)
    x[3::7] = np.nextafter(np.nextafter(x[3::7], -np.inf), -np.inf)
    verdicts = []
    for point in (x, x0):
        e, g = fun(point)
        h = kw["hess"](point)
        fres = _force_resolution(h, point)
        assert 1e-6 < max_force(g) < fres
        st = SimpleNamespace(x=point, g=g, e=e, fmax=max_force(g), fres=fres, mask=None,
                             hess_action=kw["hess_action"])  # fmt: skip
        pre = LDLT().factorize(h, shift=np.full(n, 0.178e-9), floor=floor)
        verdicts.append(_accurate_resolved(st, (pre, None), None, floor))
    (ok, note), (refused, why) = verdicts
    assert ok and "a Newton step predicts a decrease of" in note
    assert not refused and "not a minimum" in why
    a = hess(x).toarray() + np.diag(floor)
    noise = np.mean([0.5 * d @ a @ d for d in _ulp_moves(SimpleNamespace(x=x, mask=None))])
    assert f"<= {max(16 * np.finfo(float).eps * fun(x)[0], 100 * noise):.3g} " in note


def test_refusals_where_the_accurate_product_decides_are_capped(monkeypatch):
    """Each refusal there costs an eigensolve; after ACCURATE_REFUSALS of them the stage
    stops, unconverged, and says why."""
    from crumple import minimize_accurate

    monkeypatch.setattr(minimize_accurate, "ACCURATE_REFUSALS", 3)
    fun, _, x0, kw = _wrong_along_the_uniform_mode()
    r = newton(fun, x0, maxiter=500, **kw)
    assert not r.converged and r.iterations == 3
    assert r.message.startswith("stopped after 3 points stable by the accurate Hessian product")
    assert "not a minimum" in r.message  # the last point's reason
    monkeypatch.setattr(minimize_accurate, "ACCURATE_REFUSALS", 1)  # the count's refusals: free
    fun, hess, x0 = _coherent_below_resolution(4, n=1000)
    assert not newton(fun, x0, hess=hess, maxiter=1).converged  # refused there at least once
    assert newton(fun, x0, hess=hess, maxiter=200).converged


def test_newton_decrease_is_taken_in_the_complement_of_the_zero_modes():
    """A = H + τM may have a negative pivot along a zero mode W while it is positive definite
    in W's complement (the inertia test counts there): the predicted decrease is that of the
    complement, ½ vᵀ[A⁻¹ - A⁻¹W(WᵀA⁻¹W)⁻¹WᵀA⁻¹]v (the limit of (A + βWWᵀ)⁻¹), the decrease
    of the quadratic model over the steps s with Wᵀs = 0; never negative."""
    from types import SimpleNamespace

    from crumple.linalg import LDLT
    from crumple.minimize_modes import _negative_count
    from crumple.minimize_resolution import _newton_decrease

    a = np.array([[-1.0, 0.2, 0.0], [0.2, 2.0, 0.1], [0.0, 0.1, 3.0]])  # negative along e_0
    w = np.array([[1.0], [0.0], [0.0]])
    f = LDLT().factorize(sp.csc_matrix(a))
    assert f.negative == 1 and _negative_count(f, w) == 0
    g = np.array([0.0, 1e-3, -2e-3])
    st = SimpleNamespace(g=g, x=np.array([0.5, 0.5, 0.5]), mask=None)
    dec, noise = _newton_decrease(st, sp.csc_matrix(a), f, w)
    want = 0.5 * float(g[1:] @ np.linalg.solve(a[1:, 1:], g[1:]))  # the steps with s_0 = 0
    assert dec > 0 and noise >= 0
    np.testing.assert_allclose(dec, want, rtol=1e-12)


@settings(max_examples=100, deadline=None)
@given(
    values=st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=40),
    two_d=st.booleans(), strided=st.booleans(),
)  # fmt: skip
def test_all_finite_is_numpys_isfinite_all(values, two_d, strided):
    from crumple.minimize_result import all_finite

    a = np.array(values, dtype=np.float64)
    if two_d and a.size % 2 == 0:
        a = a.reshape(-1, 2)
    if strided:
        a = a[::2]
    assert all_finite(a) == bool(np.isfinite(a).all())
    assert all_finite(a.tolist()) == bool(np.isfinite(a).all())


def test_lower_shift_takes_the_smallest_positive_definite_shift_that_fits_the_radius():
    """The σ search (``newton(shift_descents=4)``, the exact fallback's): from an overshooting
    σ = 1 on H = diag(1, -0.01) it divides by 4 while H + σ stays positive definite (1/4, 1/16,
    1/64; 1/256 < 0.01 is not) and the step stays below radius / 4; a small radius keeps σ."""
    from crumple import minimize_direction as md
    from crumple import minimize_state as ms
    from crumple.linalg import LDLT

    h = sp.csc_matrix(np.diag([1.0, -0.01]))
    g = np.array([0.0, -1e-4])
    m = np.ones(2)
    floor = 1e-12 * m
    ldl = LDLT()
    f = ldl.factorize(h, shift=1.0 * m, floor=floor)
    p = -f.solve(g)
    wide = ms._State(x=np.zeros(2), e=0.0, g=g, fmax=1e-4, radius=1.0, descents=4)
    sigma, f2, p2 = md._lower_shift(wide, ldl, h, g, m, 0.0, floor, 1.0, f, p)
    assert sigma == 1.0 / 64 and f2.positive_definite
    assert np.allclose((h.toarray() + sigma * np.eye(2)) @ p2, -g)
    assert abs(p2[1]) > 10 * abs(p[1])  # a longer step along the soft direction
    tight = ms._State(x=np.zeros(2), e=0.0, g=g, fmax=1e-4, radius=2e-4, descents=4)
    assert md._lower_shift(tight, ldl, h, g, m, 0.0, floor, 1.0, f, p)[0] == 1.0
    off = ms._State(x=np.zeros(2), e=0.0, g=g, fmax=1e-4, radius=1.0)  # the projected one's
    assert md._lower_shift(off, ldl, h, g, m, 0.0, floor, 1.0, f, p)[0] == 1.0


@pytest.mark.parametrize("fixed", [None, np.array([False, False, False, True])])
def test_an_exact_fallback_reuses_the_hessian_it_has_just_evaluated(fixed):
    """``hess_fallback=hess`` (the very object, as ``relax.EXACT_FALLBACK`` passes it): where
    the exact Hessian is indefinite its shifted factor is the fallback, with no second
    evaluation at the same point. The iterates are those of an equal function passed as a
    distinct object, which is evaluated again; fixed entries keep the reuse."""
    calls = {"same": 0, "other": 0}

    def counted(key):
        def hess(x):
            calls[key] += 1
            return sp.csc_matrix(rosen_hess(x))

        return hess

    x0 = np.array([-1.2, 1.0, -0.5, 0.8])
    same = counted("same")
    a = newton(rosenbrock, x0, hess=same, hess_fallback=same, ftol=1e-9, fixed=fixed)
    other = counted("other")
    b = newton(rosenbrock, x0, hess=other, hess_fallback=counted("other"), ftol=1e-9,
               fixed=fixed)  # fmt: skip
    assert a.converged and b.converged
    assert np.array_equal(a.x, b.x) and a.iterations == b.iterations
    assert a.hessian_evaluations == calls["same"] < calls["other"] == b.hessian_evaluations


def test_newton_stops_where_it_no_longer_makes_progress():
    """``patience``: a pass whose energy stays within its resolution (16 ε|E|) for that many
    iterations stops, unconverged, and says so. On 10²⁰ + |x|²/2 with a Hessian 10⁶ too stiff,
    every step lowers the energy by ~|x|²/10⁶, far below 16 ε × 10²⁰: without ``patience``
    the pass runs to ``maxiter``; on |x|²/2 itself each step is a real decrease, and
    ``patience`` does not stop it."""
    from crumple.minimize import newton

    def flat(x):
        return float(1e20 + 0.5 * x @ x), x.copy()

    def bowl(x):
        return float(0.5 * x @ x), x.copy()

    def stiff(x):
        return 1e6 * np.eye(2)

    seen = []
    r = newton(flat, np.ones(2), hess=stiff, maxiter=200, patience=5,
               callback=lambda it, x, e, f: seen.append((it, x.copy())))  # fmt: skip
    assert not r.converged and r.iterations == 5
    assert r.message == "stopped: no decrease beyond the energy's resolution in 5 iterations"
    # every accepted step is reported, the last one (the result) too
    assert [s[0] for s in seen] == [1, 2, 3, 4, 5]
    np.testing.assert_array_equal(seen[-1][1], r.x)
    assert newton(flat, np.ones(2), hess=stiff, maxiter=200).iterations == 200
    r = newton(bowl, np.ones(2), hess=lambda x: 1e3 * np.eye(2), maxiter=30, patience=5)
    assert r.iterations == 30 and r.message == "maximum number of iterations reached"
    with pytest.raises(ValueError, match="patience"):
        newton(bowl, np.ones(2), hess=stiff, patience=0)


def test_merged_listings_append_the_springs_not_listed_before_in_their_order():
    """A relisting's springs join the first listing's: those whose row of ``index`` is new,
    after the first's, in the relisting's order, with their values, offsets and stiffnesses;
    a relisting with nothing new leaves the first listing as it is."""
    from crumple.minimize_barriers import _merged_rows

    rng = np.random.default_rng(5)
    index = rng.integers(0, 40, (6, 6))
    first = (index[:4], rng.normal(size=(4, 6)), -rng.uniform(size=4), rng.uniform(1, 2, 4))
    again = (index[[2, 5, 0, 4]], rng.normal(size=(4, 6)), -rng.uniform(size=4),
             rng.uniform(1, 2, 4))  # fmt: skip
    merged, grown = _merged_rows(first, again)
    assert grown
    for got, a, b in zip(merged, first, again, strict=True):
        assert np.array_equal(got, np.concatenate([a, b[[1, 3]]]))
    same = (index[[3, 1]], rng.normal(size=(2, 6)), -rng.uniform(size=2), rng.uniform(1, 2, 2))
    kept, grown = _merged_rows(first, same)
    assert kept is first and not grown
    assert _merged_rows(first, tuple(a[:0] for a in same)) == (first, False)
