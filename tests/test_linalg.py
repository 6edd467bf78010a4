"""Tests of crumple.linalg: the sparse LDLᵀ against dense LAPACK, its inertia (Sylvester's law),
the modified factorisation's descent property, and the reuse of the symbolic analysis."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from crumple.linalg import CSC, LDLT
from crumple.linalg_springs import _least_on_segment, _q_change, new_rows, spring_step


def random_symmetric(rng, n, density, shift):
    a = sp.random(n, n, density=density, random_state=rng)
    a = (a + a.T).tocsc()
    return (a + shift * sp.identity(n)).tocsc()


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 60), density=st.floats(0.01, 0.5))
def test_solve_and_inertia_match_dense_linear_algebra(seed, n, density):
    rng = np.random.default_rng(seed)
    a = random_symmetric(rng, n, density, 0.0)
    dense = a.toarray()
    eig = np.linalg.eigvalsh(dense)
    # a shift between two eigenvalues, well away from both: an unambiguous inertia. It is drawn
    # inside the gap, not at its midpoint: a symmetric spectrum such as [[0, v], [v, 0]]'s has
    # the midpoint 0, where an LDLᵀ without pivoting meets a zero leading pivot, which it counts
    # as non-positive by design (the inertia of A + σI is then undefined by its pivots).
    apart = np.diff(eig) > 1e-6 * (1.0 + np.abs(eig).max())
    t = rng.uniform(0.25, 0.75)
    gaps = np.r_[eig[0] - 1.0, (eig[:-1] + t * np.diff(eig))[apart], eig[-1] + 1.0]
    sigma = -float(rng.choice(gaps))
    f = LDLT().factorize(a, shift=np.full(n, sigma))
    assert f.negative == int(np.sum(eig + sigma < 0))
    if f.negative == 0:
        b = rng.standard_normal(n)
        x = f.solve(b)
        np.testing.assert_allclose(
            (dense + sigma * np.eye(n)) @ x, b, atol=1e-8 * (1 + np.abs(x).max())
        )


def test_a_zero_leading_pivot_counts_as_non_positive():
    # [[0, v], [v, 0]] has inertia (1, 1), but an unpivoted LDLᵀ meets d₀ = 0: the count is then
    # conservative (more non-positive pivots, never fewer), so Newton refuses rather than accepts
    a = sp.csc_matrix(np.array([[0.0, 0.95], [0.95, 0.0]]))
    assert LDLT().factorize(a).negative == 2
    assert LDLT().factorize(a, shift=np.full(2, 1e-3)).negative == 1


def test_positive_definite_chain_solves_to_round_off():
    n = 500
    main = np.full(n, 4.0)
    off = np.full(n - 1, -1.0)
    a = sp.diags([off, main, off], [-1, 0, 1], format="csc")
    f = LDLT().factorize(a)
    assert f.positive_definite
    b = np.arange(n, dtype=float)
    np.testing.assert_allclose(a @ f.solve(b), b, rtol=0, atol=1e-10)


def test_modified_factor_gives_a_descent_direction():
    rng = np.random.default_rng(3)
    a = random_symmetric(rng, 40, 0.2, -1.0)  # indefinite
    f = LDLT().factorize(a, floor=np.full(40, 1e-3))
    assert f.modified > 0
    for _ in range(10):
        g = rng.standard_normal(40)
        assert g @ f.solve(g) > 0  # -solve(g) goes downhill


def test_negative_direction_has_negative_curvature():
    rng = np.random.default_rng(5)
    a = random_symmetric(rng, 30, 0.3, -0.5)
    f = LDLT().factorize(a)
    assert f.negative > 0
    v = f.negative_direction()
    assert v @ (a @ v) < 0
    g = LDLT().factorize(a, floor=np.full(30, 1e-6))
    v = g.negative_direction()
    assert v @ (a @ v) < 0


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 50), shift=st.floats(-2.0, 2.0))
def test_a_trial_factorisation_decides_as_the_full_one_and_stops_at_its_first_bad_pivot(
    seed, n, shift
):
    """``trial=True`` stops at the first pivot below the floor: the same verdict, the same first
    modified pivot and, from it, the same negative direction to the bit as the full modified
    factorisation; a passing trial is the full factor; a stopped one refuses to solve."""
    rng = np.random.default_rng(seed)
    a = random_symmetric(rng, n, 0.3, shift)
    floor = np.full(n, 1e-6)
    full = LDLT().factorize(a, floor=floor)
    trial = LDLT().factorize(a, floor=floor, trial=True)
    assert (trial.modified == 0) == (full.modified == 0)
    if full.modified == 0:
        assert trial.complete
        b = rng.standard_normal(n)
        assert np.array_equal(trial.solve(b), full.solve(b))
        return
    assert trial.modified == 1 and not trial.complete
    assert trial.first_modified == full.first_modified
    assert np.array_equal(trial.negative_direction(), full.negative_direction())
    with pytest.raises(ValueError, match="cannot solve"):
        trial.solve(np.ones(n))
    with pytest.raises(ValueError, match="needs a floor"):
        LDLT().factorize(a, trial=True)


def test_symbolic_analysis_is_reused_while_the_pattern_holds():
    rng = np.random.default_rng(7)
    a = random_symmetric(rng, 50, 0.1, 10.0)
    solver = LDLT()
    for k in range(5):
        b = a.copy()
        b.data = b.data * (1.0 + 0.1 * k)
        solver.factorize(b)
    assert solver.analyses == 1 and solver.factorizations == 5
    solver.factorize(random_symmetric(rng, 50, 0.1, 10.0))
    assert solver.analyses == 2


def test_a_new_solver_recalls_a_recent_analysis_of_the_same_pattern_bit_for_bit():
    """A sharing solver takes the analysis another made of the same pattern (the Newton
    minimiser makes one per stage): the same factor, bit for bit, as analysing anew."""
    from crumple.linalg import forget_analyses

    rng = np.random.default_rng(11)
    a = random_symmetric(rng, 40, 0.1, 10.0)
    forget_analyses()
    f1 = LDLT(shared=True).factorize(a)
    second = LDLT(shared=True)
    f2 = second.factorize(a.copy())
    assert f2._sym is f1._sym and second.analyses == 1  # recalled, counted as taken up
    forget_analyses()
    f3 = LDLT(shared=True).factorize(a.copy())  # analysed anew
    assert f3._sym is not f1._sym
    b = np.arange(40.0)
    assert f2.solve(b).tobytes() == f3.solve(b).tobytes() and f2._lx.tobytes() == f3._lx.tobytes()


def test_a_pattern_changed_in_place_by_its_owner_is_not_recalled_for_another():
    """An analysis kept for sharing holds copies of its pattern: the owner of the analysed
    matrix rewriting its arrays in place (to another pattern of the same size) neither makes
    the kept analysis match the new pattern nor a recalled one match it later."""
    from crumple.linalg import forget_analyses

    n = 40
    c = sp.diags([np.ones(n - 1), np.full(n, 4.0), np.ones(n - 1)], [-1, 0, 1]).tocsc()
    d = sp.diags(
        [[1.0], np.ones(n - 2), np.full(n, 4.0), np.ones(n - 2), [1.0]], [1 - n, -2, 0, 2, n - 1]
    ).tocsc()
    assert c.nnz == d.nnz
    b = np.arange(float(n))
    forget_analyses()
    LDLT(shared=True).factorize(c)  # analysed and kept
    c_copy = c.copy()
    c.indptr[:], c.indices[:], c.data[:] = d.indptr, d.indices, d.data  # the owner: c is now d
    other = LDLT(shared=True)
    other.factorize(c_copy)  # recalls the analysis of c's old pattern
    for solver in (other, LDLT(shared=True)):
        f = solver.factorize(d)
        assert np.allclose(d @ f.solve(b), b)  # d's own analysis, not c's
    f = LDLT(shared=True).factorize(c)  # c's arrays, now d's pattern
    assert np.allclose(d @ f.solve(b), b)


def test_solvers_with_points_or_not_sharing_neither_keep_nor_recall_analyses():
    """A solver with ``points`` may order by them (a nested dissection of where the unknowns
    are), so its analysis is not a function of the pattern alone: never shared; nor is that of
    a solver made without ``shared``."""
    import crumple.linalg as la

    rng = np.random.default_rng(12)
    a = random_symmetric(rng, 20, 0.2, 10.0)
    la.forget_analyses()
    LDLT(points=lambda: rng.uniform(size=(20, 1)), shared=True).factorize(a)
    LDLT().factorize(a)
    assert la._recent == []
    kept = LDLT(shared=True).factorize(a)._sym
    assert la._recent == [kept]
    assert LDLT(points=lambda: rng.uniform(size=(20, 1)), shared=True).factorize(a)._sym is not kept
    assert LDLT().factorize(a)._sym is not kept


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 50), nz0=st.integers(0, 6),
       nz1=st.integers(0, 6))  # fmt: skip
def test_two_solves_at_once_are_each_solve_bit_for_bit(seed, n, nz0, nz1):
    """The springs' step solves its new columns two at a time: each the bits of its own solve,
    for sparse right-hand sides (a spring's row) whose zeros each solve skips on its own."""
    from crumple.linalg_solve import _solve, _solve_pair

    rng = np.random.default_rng(seed)
    f = LDLT().factorize(random_symmetric(rng, n, 0.2, 5.0))
    s, u = f._sym, f._sym.unsigned
    b0, b1 = np.zeros(n), np.zeros(n)
    b0[rng.integers(0, n, nz0)] = rng.normal(size=nz0)
    b1[rng.integers(0, n, nz1)] = rng.normal(size=nz1)
    out0, out1 = np.full(n, np.nan), np.full(n, np.nan)
    _solve_pair(s.n, u["lp"], u["li"], f._lx, f._d, u["perm"], b0, b1, out0, out1)
    for b, out in ((b0, out0), (b1, out1)):
        alone = _solve(s.n, u["lp"], u["li"], f._lx, f._d, u["perm"], b)
        assert alone.tobytes() == out.tobytes()  # bits, the signs of zeros included


def test_dense_input_is_accepted():
    f = LDLT().factorize(np.array([[2.0, 1.0], [1.0, 2.0]]))
    assert f.positive_definite
    np.testing.assert_allclose(f.solve(np.array([3.0, 3.0])), [1.0, 1.0])


@pytest.mark.parametrize("seed", range(4))
def test_dense_input_becomes_the_csc_scipy_would_build(seed):
    """:func:`dense_csc` holds SciPy's entries in SciPy's order (NaN kept, ±0 dropped)."""
    from crumple.linalg import dense_csc

    rng = np.random.default_rng(seed)
    a = rng.standard_normal((30, 30)) * (rng.random((30, 30)) < 0.2)
    a[rng.random((30, 30)) < 0.02] = np.nan
    a[3, 3] = -0.0
    want, got = sp.csc_matrix(a), dense_csc(a)
    assert np.array_equal(got.indptr, want.indptr)
    assert np.array_equal(got.indices, want.indices)
    assert np.array_equal(got.data, want.data, equal_nan=True)


@pytest.mark.parametrize("drop", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_pinned_rows_are_the_dense_pinning(seed, drop):
    """:func:`pin_rows` gives the entries of the dense matrix with the masked rows and columns
    made the identity's: on the same index arrays, or (``drop_zeros``) as SciPy would store
    the result; None where a masked row's diagonal is not stored."""
    from crumple.linalg import pin_rows

    rng = np.random.default_rng(seed)
    a = rng.standard_normal((12, 12)) * (rng.random((12, 12)) < 0.4)
    a = a + a.T + np.diag(rng.uniform(1.0, 2.0, 12))
    mask = rng.random(12) < 0.3
    mask[0] = True
    s = sp.csc_matrix(a)
    raw = CSC(s.data, s.indices.astype(np.int64), s.indptr.astype(np.int64))
    want = a.copy()
    want[mask, :] = 0.0
    want[:, mask] = 0.0
    want[mask, mask] = 1.0
    got = pin_rows(raw, mask, drop_zeros=drop)
    assert np.array_equal(got.tocsc().toarray(), want)
    if drop:
        ref = sp.csc_matrix(want)
        assert np.array_equal(got.indices, ref.indices) and np.array_equal(got.data, ref.data)
    else:
        assert got.indices is raw.indices and got.indptr is raw.indptr
    assert np.array_equal(raw.tocsc().toarray(), a)  # the input is untouched
    a[0, 0] = 0.0
    s = sp.csc_matrix(a)
    assert pin_rows(CSC(s.data, s.indices, s.indptr), mask, drop_zeros=drop) is None


@pytest.mark.parametrize("n", [10, 200])
def test_reordering_keeps_a_chain_band_free_of_fill(n):
    a = sp.diags([np.ones(n - 2), np.ones(n - 1), np.full(n, 5.0), np.ones(n - 1), np.ones(n - 2)],
                 [-2, -1, 0, 1, 2], format="csc")  # fmt: skip
    solver = LDLT()
    solver.factorize(a)
    assert solver.symbolic(a).l_nnz <= 2 * n


# --------------------------------------------------------------------------------------------
# One-sided springs (the Newton model of barriers a step is about to enter)
# --------------------------------------------------------------------------------------------


def _spring_kkt_minimiser(a, g, rows, offset, stiff):
    """The minimiser of gᵀs + ½ sᵀAs + Σ k/2 max(0, r - a_iᵀs)² by enumerating active sets:
    the one whose solution is consistent (the model is strictly convex: exactly one is)."""
    m = len(offset)
    for mask in range(2**m):
        act = [(mask >> i) & 1 == 1 for i in range(m)]
        h, rhs = a.copy(), -g.copy()
        for i in range(m):
            if act[i]:
                h += stiff[i] * np.outer(rows[i], rows[i])
                rhs += stiff[i] * offset[i] * rows[i]
        s = np.linalg.solve(h, rhs)
        if all((rows[i] @ s < offset[i]) == act[i] for i in range(m)):
            return s
    raise AssertionError("no consistent active set")


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 12), m=st.integers(1, 6),
       logk=st.floats(0.0, 7.0))  # fmt: skip
def test_spring_solve_is_the_minimiser_of_the_piecewise_model(seed, n, m, logk):
    rng = np.random.default_rng(seed)
    q = rng.standard_normal((n, n))
    a = q @ q.T + 0.5 * np.eye(n)
    g = rng.standard_normal(n)
    w = min(3, n)
    index = np.array([rng.choice(n, w, replace=False) for _ in range(m)])
    value = rng.standard_normal((m, w))
    offset = -rng.uniform(0.0, 0.5, m)  # every spring starts beyond the current point
    stiff = np.full(m, 10.0**logk)
    rows = np.zeros((m, n))
    for i in range(m):
        rows[i, index[i]] = value[i]
    f = LDLT().factorize(sp.csc_matrix(a))
    p0 = f.solve(-g)
    s, ok = f.solve_springs(p0, index, value, offset, stiff)
    if ok:
        want = _spring_kkt_minimiser(a, g, rows, offset, stiff)
        np.testing.assert_allclose(s, want, rtol=1e-6, atol=1e-8 * (1 + np.abs(want).max()))
    # converged or not, the model is zero at s = 0 and the step lowers it: a descent direction
    model = g @ s + 0.5 * s @ a @ s + 0.5 * np.sum(stiff * np.maximum(0, offset - rows @ s) ** 2)
    if ok:
        assert model <= 1e-12 * (1 + abs(g @ p0))
        assert g @ s < 0 or np.allclose(g, 0)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 12), m=st.integers(1, 6),
       logk=st.floats(0.0, 7.0), guess=st.integers(0, 2**6 - 1))  # fmt: skip
def test_a_warm_started_spring_solve_finds_the_same_minimiser(seed, n, m, logk, guess):
    """Any first active set (``start``, here an arbitrary mask) leads to the minimiser of the
    cold start where both converge, and ``return_active`` is the set {i: a_iᵀs < r_i} at s."""
    _, _, a, g, index, value, offset, stiff, rows = _spring_problem(
        np.random.default_rng(seed), n, m, logk
    )
    f = LDLT().factorize(sp.csc_matrix(a))
    p0 = f.solve(-g)
    cold, ok_cold = f.solve_springs(p0, index, value, offset, stiff)
    start = np.array([(guess >> i) & 1 == 1 for i in range(m)])
    warm, ok, active = f.solve_springs(p0, index, value, offset, stiff, start=start,
                                       return_active=True)  # fmt: skip
    if ok:
        want = _spring_kkt_minimiser(a, g, rows, offset, stiff)
        np.testing.assert_allclose(warm, want, rtol=1e-6, atol=1e-8 * (1 + np.abs(want).max()))
        np.testing.assert_array_equal(active, rows @ warm < offset)
        if ok_cold:
            np.testing.assert_allclose(warm, cold, rtol=1e-9, atol=1e-12 * np.abs(cold).max())


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 12), m=st.integers(1, 6),
       extra=st.integers(0, 4), logk=st.floats(0.0, 7.0))  # fmt: skip
def test_a_second_springs_solve_on_a_factor_reuses_its_columns_bit_for_bit(seed, n, m, extra,
                                                                         logk):  # fmt: skip
    """A relisting solves again with the same factor, the springs of the first call and more:
    the columns A⁻¹a_i kept from the first call give the same step, bit for bit, as a fresh
    factor that has none; a spring whose row of values changed is solved again, not reused."""
    rng = np.random.default_rng(seed)
    _, _, a, g, index, value, offset, stiff, _ = _spring_problem(rng, n, m + extra, logk)
    f = LDLT().factorize(sp.csc_matrix(a))
    p0 = f.solve(-g)
    f.solve_springs(p0, index[:m], value[:m], offset[:m], stiff[:m])  # the first listing
    again = f.solve_springs(p0, index, value, offset, stiff)
    fresh = LDLT().factorize(sp.csc_matrix(a)).solve_springs(p0, index, value, offset, stiff)
    assert again[1] == fresh[1] and np.array_equal(again[0], fresh[0])
    changed = value.copy()
    changed[0] *= 1.5
    again = f.solve_springs(p0, index, changed, offset, stiff)
    fresh = LDLT().factorize(sp.csc_matrix(a)).solve_springs(p0, index, changed, offset, stiff)
    assert again[1] == fresh[1] and np.array_equal(again[0], fresh[0])


def test_a_warm_start_with_the_right_active_set_takes_one_round():
    """Identity model, p0 = (1, 1), springs at x_0 = 0.25 and x_1 = 0.5: cold, one round
    finds only the first spring; started from both, one round confirms the minimiser."""
    f = LDLT().factorize(sp.csc_matrix(np.eye(2)))
    args = (np.array([[0], [1]]), np.array([[-1.0], [-1.0]]), np.array([-0.25, -0.5]),
            np.full(2, 1e9))  # fmt: skip
    s, ok = f.solve_springs(np.ones(2), *args, rounds=1)
    assert not ok
    s, ok, active = f.solve_springs(np.ones(2), *args, rounds=1, start=np.ones(2, bool),
                                    return_active=True)  # fmt: skip
    assert ok and active.tolist() == [True, True]
    assert s == pytest.approx([0.25, 0.5], rel=1e-8)
    with pytest.raises(ValueError, match="start must be a boolean mask over the 2 springs"):
        f.solve_springs(np.ones(2), *args, start=np.ones(3, bool))


def test_a_warm_start_without_a_minimiser_is_dropped_for_the_cold_rounds():
    """A = 2 I, one releasing spring of k = -3 (no minimiser with it active) and one stiff
    positive spring: started with both active, the solve drops the start and finds, from no
    spring, what the cold start finds."""
    f = LDLT().factorize(sp.csc_matrix(np.diag([2.0, 2.0])))
    args = (np.array([[0], [1]]), np.array([[-1.0], [-1.0]]), np.array([-0.25, -0.25]),
            np.array([-3.0, 1e9]))  # fmt: skip
    cold, ok_cold = f.solve_springs(np.array([0.5, 0.5]), *args)
    warm, ok = f.solve_springs(np.array([0.5, 0.5]), *args, start=np.ones(2, bool))
    assert ok == ok_cold and warm.tolist() == cold.tolist()


def test_spring_solve_stops_a_step_at_a_stiff_spring_and_ignores_far_ones():
    """Identity model, step p0 = (1, 1): a stiff spring at x_0 = 0.25 holds that entry there
    (less the spring's give, force / k); a spring the step does not reach stays inactive."""
    f = LDLT().factorize(sp.csc_matrix(np.eye(2)))
    index = np.array([[0], [1]])
    value = np.array([[-1.0], [-1.0]])
    offset = np.array([-0.25, -2.0])
    s, ok = f.solve_springs(np.ones(2), index, value, offset, np.full(2, 1e9))
    assert ok
    assert s[0] == pytest.approx(0.25 + 0.75 / (1 + 1e9), rel=1e-12)
    assert s[1] == 1.0


@pytest.mark.parametrize("bad", [-1, 2])
def test_spring_rows_outside_the_unknowns_are_refused(bad):
    """The kernels read the springs' rows as unsigned indices (no wrap-around, no bounds check):
    a row naming no unknown is refused before them, not read out of bounds."""
    f = LDLT().factorize(sp.csc_matrix(np.eye(2)))
    with pytest.raises(ValueError, match="index the 2 unknowns"):
        f.solve_springs(np.ones(2), np.array([[0], [bad]]), np.array([[-1.0], [-1.0]]),
                        np.array([-0.25, -0.25]), np.full(2, 1e9))  # fmt: skip


def test_spring_solve_out_of_rounds_still_stops_at_the_first_contact():
    """Identity model, p0 = (1, 1), springs at x_0 = 0.25 and x_1 = 0.5: with one round the
    active set is not found (the second spring is still entered), and the step returned holds
    the spring it enters first and is a descent direction. (Newton keeps p0 in that case:
    using this step instead was measured and dropped, docs/performance.md.)"""
    f = LDLT().factorize(sp.csc_matrix(np.eye(2)))
    args = (np.array([[0], [1]]), np.array([[-1.0], [-1.0]]), np.array([-0.25, -0.5]))
    s, ok = f.solve_springs(np.ones(2), *args, np.full(2, 1e9), rounds=1)
    assert not ok
    assert s[0] == pytest.approx(0.25, rel=1e-8) and s[1] == 1.0
    assert np.dot(-np.ones(2), s) < 0
    s, ok = f.solve_springs(np.ones(2), *args, np.full(2, 1e9))
    assert ok and s == pytest.approx([0.25, 0.5], rel=1e-8)


def _releasing_problem(rng, n, m, fraction):
    """A problem of :func:`_spring_problem` with about half of its springs of negative
    stiffness (releasing a curvature of A, ``WireEnergy.barriers(releasing=True)``), scaled so
    that A + Σ_(k<0) k_i a_i a_iᵀ keeps ``fraction`` of A's least eigenvalue: the piecewise
    model is then strictly convex whatever the active set."""
    _, _, a, g, index, value, offset, _, rows = _spring_problem(rng, n, m, 0.0)
    negative = rng.random(m) < 0.5
    stiff = 10.0 ** rng.uniform(0.0, 4.0, m)
    size = np.sum(rows**2, axis=1)
    lowest = np.linalg.eigvalsh(a)[0]
    stiff[negative] = -(1.0 - fraction) * lowest / (size[negative] * max(negative.sum(), 1))
    return a, g, index, value, offset, stiff, rows


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 10), m=st.integers(1, 6))
def test_spring_solve_with_releasing_springs_is_the_minimiser_where_the_model_is_convex(seed, n, m):
    """Negative springs that leave the model strictly convex: the solve's step, where it
    finds the active set, is the enumerated minimiser, and it is a descent direction."""
    rng = np.random.default_rng(seed)
    a, g, index, value, offset, stiff, rows = _releasing_problem(rng, n, m, 0.2)
    neg = stiff < 0
    assert np.linalg.eigvalsh(a + (rows[neg].T * stiff[neg]) @ rows[neg])[0] > 0
    f = LDLT().factorize(sp.csc_matrix(a))
    p0 = f.solve(-g)
    s, ok = f.solve_springs(p0, index, value, offset, stiff)
    assert np.all(np.isfinite(s))
    if ok:
        want = _spring_kkt_minimiser(a, g, rows, offset, stiff)
        np.testing.assert_allclose(s, want, rtol=1e-6, atol=1e-8 * (1 + np.abs(want).max()))
        assert g @ s < 0


@pytest.mark.parametrize("k", [-2.0, -3.0, -1e3])
def test_spring_solve_refuses_an_active_set_without_a_minimiser(k):
    """A = 2 I, p0 = (1/2, 1/2), one releasing spring that the step enters beyond x_0 = 1/4:
    with k = -2 the model is linear there (singular system), with k < -2 unbounded below.
    The solve neither raises nor returns the system's stationary point: it keeps the last
    active set that has a minimiser (none active: p0) and says it did not converge."""
    f = LDLT().factorize(sp.csc_matrix(np.diag([2.0, 2.0])))
    s, ok = f.solve_springs(np.array([0.5, 0.5]), np.array([[0]]), np.array([[-1.0]]),
                            np.array([-0.25]), np.array([k]))  # fmt: skip
    assert not ok
    assert s.tolist() == [0.5, 0.5]


def test_spring_solve_with_a_singular_system_of_positive_springs_stops_instead_of_raising():
    """Two copies of one spring, stiff beyond float64 (1/k = 10⁻³⁰⁰ next to A⁻¹ = 1): their
    Woodbury system [[1, 1], [1, 1]] is singular in floating point, as it is where A's factor
    has raised pivots (``minimize_direction.SHIFTS = 1``) and A⁻¹ dwarfs 1/k. The solve used
    to raise LinAlgError out of the Newton step; it returns p0 and says it did not converge."""
    f = LDLT().factorize(sp.csc_matrix(np.eye(2)))
    rows = (np.array([[0], [0]]), np.array([[-1.0], [-1.0]]), np.array([-0.25, -0.25]))
    s, ok = f.solve_springs(np.array([1.0, 1.0]), *rows, np.array([1e300, 1e300]))
    assert not ok
    assert s.tolist() == [1.0, 1.0]
    f.solve_springs(np.array([1.0, 1.0]), rows[0][:1], rows[1][:1], rows[2][:1], np.array([1e12]))
    kept = f._columns  # the columns of a solve that worked
    assert kept is not None
    s, ok, active = f.solve_springs(np.array([1.0, 1.0]), *rows, np.array([1e300, 1e300]),
                                    return_active=True)  # fmt: skip
    assert not ok and s.tolist() == [1.0, 1.0] and active.tolist() == [False, False]
    assert f._columns is kept


def test_spring_solve_takes_a_releasing_spring_that_keeps_the_model_convex():
    """The same with k = -1: beyond x_0 = 1/4 the model is -s + s² - (s - 1/4)²/2, whose
    minimiser is s = 3/4 (the curvature 2 - 1 = 1 left): by hand."""
    f = LDLT().factorize(sp.csc_matrix(np.diag([2.0, 2.0])))
    s, ok = f.solve_springs(np.array([0.5, 0.5]), np.array([[0]]), np.array([[-1.0]]),
                            np.array([-0.25]), np.array([-1.0]))  # fmt: skip
    assert ok
    assert s == pytest.approx([0.75, 0.5], rel=1e-14)


def test_refactorised_spring_step_stops_where_the_springs_make_the_model_indefinite():
    """spring_step from a start where a releasing spring of k = -3 is active on A = 2 I: the
    factor of A + k a aᵀ has a negative pivot, and the step stops there, not converged,
    returning its start instead of a saddle of the model."""
    eye = sp.csc_matrix(2.0 * np.eye(2))
    csc = CSC(eye.data.copy(), eye.indices, eye.indptr)
    ldl = LDLT()
    ldl.factorize(csc)
    start = np.array([0.5, 0.5])
    s, ok, used = spring_step(ldl, csc, None, -np.ones(2), np.array([[0]]), np.array([[-1.0]]),
                              np.array([-0.25]), np.array([-3.0]), start)  # fmt: skip
    assert not ok and used == 1
    assert s.tolist() == start.tolist()


def _spring_problem(rng, n, m, logk, shift=False):
    """A random positive definite model in raw CSC (every entry stored: springs fit its pattern),
    m springs of 3 entries that all start beyond s = 0, and the dense rows of the springs."""
    q = rng.standard_normal((n, n))
    a = q @ q.T + 0.5 * np.eye(n)
    diag = rng.uniform(0.0, 2.0, n) if shift else None
    full = sp.csc_matrix(np.where(a == 0.0, 1e-300, a))  # keep every entry in the pattern
    csc = CSC(full.data.copy(), full.indices, full.indptr)
    g = rng.standard_normal(n)
    w = min(3, n)
    index = np.array([rng.choice(n, w, replace=False) for _ in range(m)])
    value = rng.standard_normal((m, w))
    offset = -rng.uniform(0.0, 0.5, m)
    stiff = np.full(m, 10.0**logk)
    rows = np.zeros((m, n))
    for i in range(m):
        rows[i, index[i]] = value[i]
    dense = a + (np.diag(diag) if shift else 0.0)
    return csc, diag, dense, g, index, value, offset, stiff, rows


def _spring_model(dense, g, rows, offset, stiff, s):
    gap = np.maximum(0.0, offset - rows @ s)
    return g @ s + 0.5 * s @ dense @ s + 0.5 * np.sum(stiff * gap**2)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 12), m=st.integers(1, 6),
       logk=st.floats(0.0, 7.0), shift=st.booleans(), from_segment=st.booleans(),
       updates=st.booleans())  # fmt: skip
def test_refactorised_spring_step_is_the_minimiser_from_any_start(seed, n, m, logk, shift,
                                                                  from_segment,
                                                                  updates):  # fmt: skip
    """linalg_springs.spring_step (one factorisation of A + Σ_S k a aᵀ per round) finds the
    same minimiser as enumerating the active sets, from a random start, and never raises the
    model above its value at the start (monotone, so usable when it runs out of rounds); from
    the start as given and from the segment's least point; and with ``updates`` (every round
    after the first modifying the last one's factor, ``UPDATE_COST`` = 0)."""
    import crumple.linalg_springs as springs

    rng = np.random.default_rng(seed)
    csc, diag, dense, g, index, value, offset, stiff, rows = _spring_problem(rng, n, m, logk, shift)
    ldl = LDLT()
    ldl.factorize(csc, shift=diag)
    start = rng.standard_normal(n)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(springs, "UPDATE_COST", 0.0)
        s, ok, used = spring_step(ldl, csc, diag, g, index, value, offset, stiff, start,
                                  from_segment=from_segment, updates=updates)  # fmt: skip
    assert s is not None
    q0 = _spring_model(dense, g, rows, offset, stiff, start)
    assert _spring_model(dense, g, rows, offset, stiff, s) <= q0 + 1e-9 * (1 + abs(q0))
    assert ok, f"active set not found in {used} rounds"
    want = _spring_kkt_minimiser(dense, g, rows, offset, stiff)
    np.testing.assert_allclose(s, want, rtol=1e-6, atol=1e-8 * (1 + np.abs(want).max()))
    assert ldl.analyses == 1  # every round reused the model's symbolic analysis


def test_refactorised_spring_step_never_raises_the_model_when_stopped_early():
    """Stopped after 1, 2 or 3 rounds, before the active set is found, the point returned is
    no worse than the start: what Newton uses when the rounds run out. (A full step to each
    round's quadratic minimiser, without the line search, raises the model on about one in
    twenty of these problems.)"""
    for seed in range(150):
        rng = np.random.default_rng(seed)
        csc, diag, dense, g, index, value, offset, stiff, rows = _spring_problem(
            rng, 8, 12, rng.uniform(0.0, 7.0), shift=True
        )
        start = rng.standard_normal(8)
        q0 = _spring_model(dense, g, rows, offset, stiff, start)
        for rounds, from_segment in itertools.product((1, 2, 3), (False, True)):
            ldl = LDLT()
            ldl.factorize(csc, shift=diag)
            s, _, used = spring_step(ldl, csc, diag, g, index, value, offset, stiff, start,
                                     rounds=rounds, from_segment=from_segment)  # fmt: skip
            assert used <= rounds
            assert _spring_model(dense, g, rows, offset, stiff, s) <= q0 + 1e-9 * (1 + abs(q0))


def _identity_springs(n, stop):
    """The identity model in raw CSC, its LDLT, and stiff springs holding x_i <= stop[i]."""
    eye = sp.csc_matrix(np.eye(n))
    csc = CSC(eye.data.copy(), eye.indices, eye.indptr)
    ldl = LDLT()
    f = ldl.factorize(csc)
    index, value = np.arange(n)[:, None], -np.ones((n, 1))
    return csc, ldl, f, index, value, -np.asarray(stop, dtype=np.float64), np.full(n, 1e9)


def test_refactorised_spring_step_finishes_what_the_solves_ran_out_of_rounds_for():
    """Identity model, p0 = (1, 1, 1, 1), four stiff springs the step enters one after the other:
    one round of the solve per spring finds the first only. From the point it stopped at,
    whose springs are the minimiser's, the refactorised step finds all four in one round; from
    the segment's least point (the default) it adds them again, one a round (the price of
    ``from_segment``, docs/performance.md)."""
    n = 4
    csc, ldl, f, index, value, offset, stiff = _identity_springs(n, [0.1, 0.2, 0.3, 0.4])
    s0, ok = f.solve_springs(np.ones(n), index, value, offset, stiff, rounds=1, max_new=1)
    assert not ok
    for from_segment, rounds in ((False, 1), (True, n)):
        s, ok, used = spring_step(ldl, csc, None, -np.ones(n), index, value, offset, stiff, s0,
                                  from_segment=from_segment)  # fmt: skip
        assert ok and used == rounds
        assert s == pytest.approx([0.1, 0.2, 0.3, 0.4], rel=1e-8)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8), m=st.integers(1, 6),
       released=st.booleans())  # fmt: skip
def test_the_model_change_is_the_difference_of_the_model(seed, n, m, released):
    """linalg_springs._q_change(c0, c1, u, v) = q(s + d) - q(s) for random s, d and springs,
    some of them releasing (negative stiffness), against q evaluated densely."""
    rng = np.random.default_rng(seed)
    _, _, dense, g, _, _, offset, stiff, rows = _spring_problem(rng, n, m, 3.0)
    if released:
        stiff = stiff * rng.choice([-1.0, 1.0], m)
    s, d = rng.standard_normal(n), rng.standard_normal(n)
    want = _spring_model(dense, g, rows, offset, stiff, s + d)
    want -= _spring_model(dense, g, rows, offset, stiff, s)
    got = _q_change(float((g + dense @ s) @ d), float(d @ dense @ d), rows @ s, rows @ d, offset,
                    stiff)  # fmt: skip
    assert got == pytest.approx(want, rel=1e-9, abs=1e-9 * (1 + abs(want)))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8), m=st.integers(1, 6),
       logk=st.floats(0.0, 7.0), scale=st.floats(0.1, 10.0))  # fmt: skip
def test_the_segment_start_is_the_least_point_of_the_segment(seed, n, m, logk, scale):
    """With positive springs q is convex along the segment from 0 to the start, and
    _least_on_segment gives its least point: no point of a 2001-point grid on the segment is
    lower, and neither is the start."""
    rng = np.random.default_rng(seed)
    _, _, dense, g, index, value, offset, stiff, rows = _spring_problem(rng, n, m, logk)
    s = scale * rng.standard_normal(n)
    got = _least_on_segment(s, lambda v: dense @ v, g, index, value, offset, stiff)
    q = _spring_model(dense, g, rows, offset, stiff, got)
    grid = min(_spring_model(dense, g, rows, offset, stiff, t * s) for t in np.linspace(0, 1, 2001))
    assert q <= min(grid, _spring_model(dense, g, rows, offset, stiff, s)) + 1e-9 * (1 + abs(q))


def test_the_segment_start_is_kept_only_where_it_is_lower():
    """One coordinate, A = 1, g = -1, a releasing spring (k = -10) beyond x = 1.5 and a stiff
    one beyond x = 1.9, from x = 1.92: along the segment the search stops at the local minimum
    x = 1 (q = -1/2), above q at the start (-0.7588; the least point, x ≈ 1.903, is beyond a
    non-convex stretch the search does not see), so the start itself is returned."""
    index, value = np.array([[0], [0]]), np.array([[-1.0], [-1.0]])
    offset, stiff = np.array([-1.5, -1.9]), np.array([-10.0, 1e3])
    g, s = np.array([-1.0]), np.array([1.92])
    rows = np.array([[-1.0], [-1.0]])
    q = [_spring_model(np.eye(1), g, rows, offset, stiff, np.array([x])) for x in (1.0, 1.92)]
    assert q[0] == pytest.approx(-0.5) and q[1] == pytest.approx(-0.7588)
    assert _least_on_segment(s, lambda v: v.copy(), g, index, value, offset, stiff) is s
    # with the releasing spring made positive the segment is convex and its least point taken
    t_s = _least_on_segment(s, lambda v: v.copy(), g, index, value, offset, np.abs(stiff))
    assert t_s[0] == pytest.approx(1.0, abs=1e-12)


def test_refactorised_spring_step_from_the_segment_sheds_what_the_start_overshot():
    """Identity model, p0 = (1, 1, 1, 1), stiff springs at x_i <= 1.5 that the minimiser x = p0
    does not touch, from a start x = 2 that goes into all of them (a step that ran past its
    contacts): the least point of q on the segment from 0 to the start is x = 1 (q = -t·4·2 +
    (2t)²·4/2 there, least at t = 1/2 before any spring), the minimiser, found in one round; from
    the start itself the round is held by the four springs and a second one is needed."""
    n = 4
    csc, ldl, _, index, value, offset, stiff = _identity_springs(n, np.full(n, 1.5))
    for from_segment, rounds in ((True, 1), (False, 2)):
        s, ok, used = spring_step(ldl, csc, None, -np.ones(n), index, value, offset, stiff,
                                  np.full(n, 2.0), from_segment=from_segment)  # fmt: skip
        assert ok and used == rounds
        assert s == pytest.approx(np.ones(n), rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(0, 80), k=st.integers(0, 80),
       w=st.integers(1, 6), values=st.booleans())  # fmt: skip
def test_row_positions_finds_the_first_equal_row_directly_and_by_hash(seed, m, k, w, values):
    """linalg_solve._row_positions against a scan, with repeated rows (the first of them is
    found) and, with values, rows of equal indices but unequal values; up to 1024 pairs of rows
    it compares them directly, above by hash: sizes up to 80 × 80 take both paths."""
    from crumple.linalg_solve import _row_positions

    rng = np.random.default_rng(seed)
    old = rng.integers(0, 3, (m, w))
    new = np.concatenate([old[rng.integers(0, m, k // 2)] if m else old[:0],
                          rng.integers(0, 3, (k - k // 2 if m else k, w))])  # fmt: skip
    old_value = rng.integers(0, 2, (m, w)).astype(float) if values else np.empty((0, 0))
    new_value = rng.integers(0, 2, (k, w)).astype(float) if values else np.empty((0, 0))
    want = [next((r for r in range(m) if (old[r] == new[i]).all()
                  and (not values or (old_value[r] == new_value[i]).all())), -1)
            for i in range(k)]  # fmt: skip
    assert _row_positions(old, new, old_value, new_value).tolist() == want


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(0, 80), k=st.integers(0, 80),
       w=st.integers(1, 6))  # fmt: skip
def test_new_rows_are_exactly_the_rows_not_listed_before(seed, m, k, w):
    """linalg_springs.new_rows (a relisting's springs not in the first listing) against a set
    of tuples, with repeated rows and small entries so that many rows coincide."""
    rng = np.random.default_rng(seed)
    old = rng.integers(0, 3, (m, w))
    new = np.concatenate([old[rng.integers(0, m, k // 2)] if m else old[:0],
                          rng.integers(0, 3, (k - k // 2 if m else k, w))])  # fmt: skip
    seen = {tuple(r) for r in old.tolist()}
    assert new_rows(old, new).tolist() == [tuple(r) not in seen for r in new.tolist()]


def test_refactorised_spring_step_refuses_a_spring_outside_the_pattern():
    """A spring coupling two entries the matrix has no entry for cannot be added without a new
    analysis: the step says so (None) instead of factorising another pattern."""
    eye = sp.csc_matrix(np.eye(3))
    csc = CSC(eye.data.copy(), eye.indices, eye.indptr)
    ldl = LDLT()
    ldl.factorize(csc)
    start = np.array([0.0, 0.0, 1.0])  # the spring is active there
    s, ok, _ = spring_step(ldl, csc, None, -np.ones(3), np.array([[0, 2]]),
                           np.array([[1.0, -1.0]]), np.array([-0.1]), np.array([1e3]),
                           start)  # fmt: skip
    assert s is None and not ok


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 60), density=st.floats(0.01, 0.5))
def test_raw_csc_gives_the_bits_of_the_scipy_matrix(seed, n, density):
    """linalg.CSC (the Newton hot path's Hessian) factorises, multiplies and bounds exactly as
    the SciPy matrix on the same arrays: the iterates cannot depend on which one is passed."""
    from crumple.linalg import CSC
    from crumple.minimize_resolution import _force_resolution

    rng = np.random.default_rng(seed)
    a = random_symmetric(rng, n, density, 3.0)
    a.sort_indices()
    a.data *= 10.0 ** rng.uniform(-6, 6, a.data.shape)
    raw = CSC(a.data, a.indices, a.indptr)
    v = rng.standard_normal(n)
    assert np.array_equal(raw @ v, a @ v)
    floor = np.full(n, 1e-3)
    f, g = LDLT().factorize(raw, floor=floor), LDLT().factorize(a, floor=floor)
    assert (f.negative, f.modified) == (g.negative, g.modified)
    assert np.array_equal(f.solve(v), g.solve(v))
    col = np.repeat(np.arange(n), np.diff(a.indptr))
    x = v * 10.0 ** rng.uniform(-3, 3, n)
    ulp = np.spacing(np.abs(x))
    sums = np.bincount(col, weights=np.abs(a.data) * ulp[a.indices], minlength=n)
    assert raw.abs_row_max_ulp(x) == float(np.max(sums))
    assert _force_resolution(raw, x) == _force_resolution(a, x)  # either branch, the same
    assert raw.tocsc() is raw.tocsc() and raw.nnz == a.nnz
