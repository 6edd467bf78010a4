"""Rank-one modifications of the sparse LDLᵀ (``crumple.linalg_update``) and their use in the
refactorised springs' step."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from crumple import linalg_springs
from crumple.linalg import CSC, LDLT
from crumple.linalg_springs import spring_step
from crumple.linalg_update import modified, path_work


def _problem(rng, n, m, logk):
    """A positive definite band (half-width 2) with m rows of 3 entries, the pattern holding
    every a_i a_iᵀ; the rows dense too."""
    band = sp.diags([rng.uniform(-0.5, 0.5, n - abs(k)) for k in (-2, -1, 0, 1, 2)],
                    [-2, -1, 0, 1, 2]).toarray()  # fmt: skip
    a = 0.5 * (band + band.T) + 3.0 * np.eye(n)
    index = np.array([np.sort(rng.choice(n, 3, replace=False)) for _ in range(m)])
    value = rng.standard_normal((m, 3))
    stiff = 10.0 ** rng.uniform(0.0, logk, m)
    pattern = (np.abs(a) > 0).astype(float)
    rows = np.zeros((m, n))
    for i in range(m):
        rows[i, index[i]] = value[i]
        pattern[np.ix_(index[i], index[i])] = 1.0
    return a, sp.csc_matrix(pattern), index, value, stiff, rows


def _factor(pattern, dense, ldl=None):
    """The LDLᵀ of ``dense`` stored in ``pattern`` (every entry of the pattern kept)."""
    data = np.asarray(dense[pattern.indices, np.repeat(np.arange(pattern.shape[0]),
                                                      np.diff(pattern.indptr))])  # fmt: skip
    return (ldl or LDLT()).factorize(CSC(data, pattern.indices, pattern.indptr))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 40), m=st.integers(1, 8),
       logk=st.floats(0.0, 6.0))  # fmt: skip
def test_a_modified_factor_is_the_factor_of_the_modified_matrix(seed, n, m, logk):
    """From the factor of A + Σ_S k_i a_i a_iᵀ, the updates (springs joining) and downdates
    (leaving) to another set S' give a factor that solves A + Σ_S' k_i a_i a_iᵀ to round-off
    (in whatever order the analysis chose), its pivots positive; the factor modified is left
    as it was. To round-off relative to the larger condition number of the two matrices: a
    downdate of a stiff spring inherits the error of the stiffer matrix it starts from (the
    springs' step refines its solve once against the matrix itself)."""
    rng = np.random.default_rng(seed)
    a, pattern, index, value, stiff, rows = _problem(rng, n, m, logk)
    s0, s1 = rng.random(m) < 0.5, rng.random(m) < 0.5

    def matrix(s):
        return a + (rows[s].T * stiff[s]) @ rows[s]

    f0 = _factor(pattern, matrix(s0))
    before = f0._lx.copy(), f0._d.copy()
    f1 = modified(f0, index, value, np.where(s1, stiff, -stiff), s0 != s1)
    assert f1 is not None and np.all(f1._d > 0)
    b = rng.standard_normal(n)
    want = np.linalg.solve(matrix(s1), b)
    cond = max(np.linalg.cond(matrix(s0)), np.linalg.cond(matrix(s1)))
    assert np.linalg.norm(f1.solve(b) - want) <= 1e-12 * cond * np.linalg.norm(want)
    assert np.array_equal(f0._lx, before[0]) and np.array_equal(f0._d, before[1])


def test_a_downdate_past_positive_definite_is_refused():
    """2 I + 3 a aᵀ, a = e_0, downdated by 5 a aᵀ: the pivot falls to 0, and None is returned
    (the caller then factorises and finds the negative pivot itself)."""
    pattern = sp.csc_matrix(np.eye(2))
    f = _factor(pattern, np.diag([5.0, 2.0]))
    index, value = np.array([[0]]), np.array([[1.0]])
    assert modified(f, index, value, np.array([-5.0]), np.array([True])) is None
    assert modified(f, index, value, np.array([-2.0]), np.array([True])) is not None


def test_only_a_complete_unmodified_factor_is_modified():
    pattern = sp.csc_matrix(np.eye(2))
    ldl = LDLT()
    index, value, one = np.array([[0]]), np.array([[1.0]]), np.array([True])
    data = CSC(np.array([-1.0, 2.0]), pattern.indices, pattern.indptr)
    raised = ldl.factorize(data, floor=np.full(2, 1e-3))
    trial = ldl.factorize(data, floor=np.full(2, 1e-3), trial=True)
    negative = ldl.factorize(data)
    for f in (raised, trial, negative):
        assert modified(f, index, value, np.array([1.0]), one) is None


def test_zero_entries_of_a_row_are_not_part_of_it():
    """A row's entry of value 0 (a fixed coordinate's, ``minimize_barriers._masked``) need
    not lie in the pattern: the modification is that of the row without it."""
    n = 6
    chain = np.diag(np.full(n, 4.0)) + np.diag(np.ones(n - 1), 1) + np.diag(np.ones(n - 1), -1)
    pattern = sp.csc_matrix((np.abs(chain) > 0).astype(float))
    f = _factor(pattern, chain)
    g = modified(f, np.array([[1, 2, 5]]), np.array([[1.0, -1.0, 0.0]]), np.array([2.0]),
                 np.array([True]))  # fmt: skip
    u = np.zeros(n)
    u[[1, 2]] = [1.0, -1.0]
    b = np.arange(1.0, n + 1)
    np.testing.assert_allclose(g.solve(b), np.linalg.solve(chain + 2.0 * np.outer(u, u), b),
                               rtol=1e-12)  # fmt: skip


def test_the_path_work_of_a_chain_counts_every_column_above():
    """A tridiagonal chain in its natural order: L has one entry below each pivot but the
    last, the elimination tree is the path j → j + 1, and a modification starting at column j
    touches (n - j) pivots and (n - 1 - j) entries."""
    n = 7
    chain = sp.diags([np.ones(n - 1), np.full(n, 4.0), np.ones(n - 1)], [-1, 0, 1], format="csc")
    f = LDLT().factorize(chain)
    assert np.array_equal(f._sym.perm, np.arange(n))
    np.testing.assert_array_equal(path_work(f._sym), [2 * (n - j) - 1 for j in range(n)])


def test_the_springs_step_modifies_the_last_rounds_factor():
    """Identity model, four stiff springs entered one a round from the segment's least point
    (as in tests/test_linalg.py): with ``updates`` the rounds after the first modify the
    factor, one spring each, and find the same minimiser in the same rounds."""
    n = 4
    eye = sp.csc_matrix(np.eye(n))
    index, value = np.arange(n)[:, None], -np.ones((n, 1))
    offset, stiff = -np.array([0.1, 0.2, 0.3, 0.4]), np.full(n, 1e9)
    out = {}
    for updates in (False, True):
        ldl = LDLT()
        csc = CSC(eye.data.copy(), eye.indices, eye.indptr)
        s, ok, used = spring_step(ldl, csc, None, -np.ones(n), index, value, offset, stiff,
                                  np.ones(n), updates=updates)  # fmt: skip
        out[updates] = s, ok, used, ldl.factorizations, ldl.modifications
    assert out[False][1:] == (True, 4, 4, 0)
    assert out[True][1:] == (True, 4, 1, 3)
    np.testing.assert_allclose(out[True][0], out[False][0], rtol=1e-12)


@pytest.mark.parametrize("cost", [0.0, 1e9])
def test_the_cost_rule_chooses_between_modifying_and_factorising(monkeypatch, cost):
    """``linalg_springs.UPDATE_COST``: at 0 every round after the first modifies; past the
    factorisation's work every round factorises."""
    monkeypatch.setattr(linalg_springs, "UPDATE_COST", cost)
    n = 4
    eye = sp.csc_matrix(np.eye(n))
    ldl = LDLT()
    csc = CSC(eye.data.copy(), eye.indices, eye.indptr)
    _, ok, used = spring_step(ldl, csc, None, -np.ones(n), np.arange(n)[:, None],
                              -np.ones((n, 1)), -np.array([0.1, 0.2, 0.3, 0.4]), np.full(n, 1e9),
                              np.ones(n), updates=True)  # fmt: skip
    assert ok and used == 4
    assert (ldl.factorizations, ldl.modifications) == ((1, 3) if cost == 0.0 else (4, 0))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 30), m=st.integers(1, 6),
       logk=st.floats(0.0, 2.0))  # fmt: skip
def test_releasing_springs_are_modified_as_the_matrix_or_refused_where_it_is_not_definite(
    seed, n, m, logk
):
    """Springs of negative stiffness (releasing rows) joining and leaving: where the modified
    matrix is positive definite the modification solves it (or is refused only for a
    cancelled pivot); where it is not, the modification is refused."""
    rng = np.random.default_rng(seed)
    a, pattern, index, value, stiff, rows = _problem(rng, n, m, logk)
    stiff = stiff * rng.choice([-1.0, 1.0], m)
    s0, s1 = rng.random(m) < 0.5, rng.random(m) < 0.5

    def matrix(s):
        return a + (rows[s].T * stiff[s]) @ rows[s]

    if np.linalg.eigvalsh(matrix(s0)).min() <= 1e-6:
        return  # the factor to modify must be of a positive definite matrix
    f1 = modified(_factor(pattern, matrix(s0)), index, value, np.where(s1, stiff, -stiff),
                  s0 != s1)  # fmt: skip
    if np.linalg.eigvalsh(matrix(s1)).min() <= 0.0:
        assert f1 is None
    elif f1 is not None:
        b = rng.standard_normal(n)
        want = np.linalg.solve(matrix(s1), b)
        cond = max(np.linalg.cond(matrix(s0)), np.linalg.cond(matrix(s1)))
        assert np.linalg.norm(f1.solve(b) - want) <= 1e-10 * cond * np.linalg.norm(want)


def test_a_row_off_the_pattern_is_refused_and_leaves_the_work_clean():
    """Two blocks with no entry between them: a row across both is refused; the next, inside
    one block, is modified exactly (the work vector was left at zero)."""
    a = np.kron(np.eye(2), np.array([[4.0, 1.0], [1.0, 4.0]]))
    pattern = sp.csc_matrix((np.abs(a) > 0).astype(float))
    f = _factor(pattern, a)
    index, value = np.array([[0, 3], [0, 1]]), np.array([[1.0, 1.0], [1.0, -2.0]])
    assert modified(f, index, value, np.array([1.0, 1.0]), np.array([True, False])) is None
    g = modified(f, index, value, np.array([1.0, 3.0]), np.array([False, True]))
    u = np.array([1.0, -2.0, 0.0, 0.0])
    b = np.arange(1.0, 5.0)
    np.testing.assert_allclose(g.solve(b), np.linalg.solve(a + 3.0 * np.outer(u, u), b),
                               rtol=1e-13)  # fmt: skip


@pytest.mark.parametrize("k", [1e3, 3e5, 1e7])
def test_a_stiff_spring_leaving_is_downdated_and_refined_or_refused(monkeypatch, k):
    """Model I / 3, g = (1, 0.3), one spring holding x_0 <= 0.5, active at the start (1, 0)
    and not at the minimiser (-3, -0.9). The second round downdates it: its pivot 1/3 + k
    falls back to 1/3 with the round-off of 1/3 + k (k ε; 2 × 10⁻¹⁰ at k = 3 × 10⁵ unrefined),
    which the refinement against the matrix removes; at k = 10⁷ the pivot keeps less than
    ``CANCELLATION`` of its value and the round factorises instead. Either way the step of
    the rounds factorised afresh, to round-off."""
    monkeypatch.setattr(linalg_springs, "UPDATE_COST", 0.0)
    out = {}
    for updates in (False, True):
        third = sp.csc_matrix(np.eye(2) / 3.0)
        ldl = LDLT()
        s, ok, used = spring_step(ldl, CSC(third.data.copy(), third.indices, third.indptr),
                                  None, np.array([1.0, 0.3]), np.array([[0]]),
                                  np.array([[-1.0]]), np.array([-0.5]), np.array([k]),
                                  np.array([1.0, 0.0]), from_segment=False,
                                  updates=updates)  # fmt: skip
        assert ok and used == 2
        out[updates] = s, ldl.modifications
    np.testing.assert_allclose(out[True][0], out[False][0], rtol=1e-14)
    np.testing.assert_allclose(out[False][0], [-3.0, -0.9], rtol=1e-14)
    assert out[True][1] == (0 if k > 1e6 else 1)
