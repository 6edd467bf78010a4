"""The fill-reducing orders of ``crumple.linalg_order``: the nested dissection of the unknowns'
points and its use as a candidate order of the sparse LDLᵀ, and reverse Cuthill–McKee."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from crumple.linalg import CSC, LDLT
from crumple.linalg_order import nested_dissection


def _cloud_pattern(rng, n, dim, reach):
    """Random points, and the unknowns' pattern (dim unknowns per point, both triangles) of a
    chain through them plus every pair closer than ``reach``."""
    pts = rng.random((n, dim))
    i, j = np.nonzero(np.triu(np.linalg.norm(pts[:, None] - pts[None], axis=-1) < reach, 1))
    i = np.concatenate([i, np.arange(n - 1)])
    j = np.concatenate([j, np.arange(1, n)])
    node = sp.coo_matrix((np.ones(i.size), (i, j)), shape=(n, n))
    node = ((node + node.T + sp.eye(n)) != 0).astype(float)
    return pts, sp.kron(node, np.ones((dim, dim)), format="csc")


def _grid(k):
    """The 5-point Laplacian of a k × k grid (one unknown per point), and its points."""
    one = sp.diags([-np.ones(k - 1), np.full(k, 2.0), -np.ones(k - 1)], [-1, 0, 1])
    a = (sp.kron(one, sp.eye(k)) + sp.kron(sp.eye(k), one) + 1e-3 * sp.eye(k * k)).tocsc()
    x, y = np.meshgrid(np.arange(k, dtype=float), np.arange(k, dtype=float), indexing="ij")
    return a, np.column_stack([x.ravel(), y.ravel()])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 120), dim=st.integers(1, 3),
       leaf=st.integers(1, 40), reach=st.floats(0.0, 0.4))  # fmt: skip
def test_the_order_is_a_permutation_keeping_each_points_unknowns_together(seed, n, dim, leaf,
                                                                          reach):  # fmt: skip
    pts, a = _cloud_pattern(np.random.default_rng(seed), n, dim, reach)
    order = nested_dissection(pts, a, leaf=leaf)
    assert sorted(order.tolist()) == list(range(n * dim))
    blocks = order.reshape(n, dim)
    np.testing.assert_array_equal(blocks - blocks[:, :1], np.tile(np.arange(dim), (n, 1)))


def _one_split(pts, node_pattern):
    """One dissection (a NumPy reference): the masks of the points at or below the lower
    median of the widest coordinate less those joined to the others, of the others, and of
    the separator."""
    axis = int(np.argmax(np.ptp(pts, axis=0)))
    lower = pts[:, axis] <= np.sort(pts[:, axis])[(len(pts) - 1) // 2]
    if lower.all():
        lower = np.arange(len(pts)) < len(pts) // 2
    joined = np.asarray((node_pattern[lower][:, ~lower] != 0).sum(axis=1)).ravel() > 0
    sep = np.zeros(len(pts), bool)
    sep[np.flatnonzero(lower)[joined]] = True
    return lower & ~sep, ~lower, sep


def _reference_order(pts, node_pattern, leaf):
    """The whole dissection, recursively, in NumPy: the points' order."""
    if len(pts) <= leaf:
        return np.arange(len(pts))
    out = []
    for mask in _one_split(pts, node_pattern)[:2]:
        idx = np.flatnonzero(mask)
        out.append(idx[_reference_order(pts[idx], node_pattern[idx][:, idx], leaf)])
    return np.concatenate([*out, np.flatnonzero(_one_split(pts, node_pattern)[2])])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 80), reach=st.floats(0.0, 0.3))
def test_one_dissection_splits_at_the_median_with_the_joined_points_last(seed, n, reach):
    """With a leaf of n - 1 points there is exactly one split: the order is the reference's,
    and no entry joins the two halves that precede the separator."""
    pts, a = _cloud_pattern(np.random.default_rng(seed), n, 2, reach)
    node = a[::2, ::2]
    low, up, sep = _one_split(pts, node)
    order = nested_dissection(pts, a, leaf=n - 1)
    idx = np.arange(n)
    np.testing.assert_array_equal(order[::2] // 2, np.concatenate([idx[low], idx[up], idx[sep]]))
    assert node[low][:, up].nnz == 0


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 150), dim=st.integers(1, 3),
       leaf=st.integers(1, 12), reach=st.floats(0.0, 0.3), grid=st.booleans())  # fmt: skip
def test_the_whole_dissection_is_the_recursive_reference(seed, n, dim, leaf, reach, grid):
    """Every level, against a recursive NumPy reference, also with points on a coarse grid
    (ties on the median, coincident points)."""
    rng = np.random.default_rng(seed)
    pts, a = _cloud_pattern(rng, n, dim, reach)
    if grid:
        pts = np.round(3.0 * pts) / 3.0
    node = a[::dim, ::dim]
    order = nested_dissection(pts, a, leaf=leaf)
    np.testing.assert_array_equal(order[::dim] // dim, _reference_order(pts, node, leaf))


@pytest.mark.parametrize("bad", [np.nan, np.inf, 1.7e308])
def test_points_that_are_not_finite_are_refused_and_huge_ones_are_split(bad):
    """A NaN or infinite coordinate is refused (and the LDLT then keeps its own orders); a
    coordinate near the largest float still gives a permutation (the median is a point's own
    coordinate, not an average that overflows)."""
    pts, a = _cloud_pattern(np.random.default_rng(0), 40, 2, 0.2)
    pts[::3, 0] = bad
    pts[1::3, 0] = -bad
    if np.isfinite(bad):
        assert sorted(nested_dissection(pts, a).tolist()) == list(range(80))
        return
    with pytest.raises(ValueError, match="finite"):
        nested_dissection(pts, a)
    np.testing.assert_array_equal(LDLT(points=lambda: pts).symbolic(a).perm,
                                  LDLT().symbolic(a).perm)  # fmt: skip


def test_a_grid_fills_far_less_than_reverse_cuthill_mckee():
    """On the 5-point grid, the classic case: nested dissection's L is well below the band of
    reverse Cuthill–McKee (k³ nonzeros), and the LDLᵀ given the points keeps it."""
    a, pts = _grid(60)
    plain, by_points = LDLT(), LDLT(points=lambda: pts)
    rcm = plain.symbolic(a).l_nnz
    nd = by_points.symbolic(a)
    assert nd.l_nnz < 0.6 * rcm
    np.testing.assert_array_equal(nd.perm, nested_dissection(pts, a))


@pytest.mark.parametrize("n", [10, 200])
def test_a_chain_keeps_its_band_with_points_given(n):
    a = sp.diags([np.ones(n - 1), np.full(n, 5.0), np.ones(n - 1)], [-1, 0, 1], format="csc")
    pts = np.column_stack([np.cos(np.arange(n)), np.sin(np.arange(n))])  # far apart along it
    solver = LDLT(points=lambda: pts[:, :1])
    assert solver.symbolic(a).l_nnz <= n


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 60), reach=st.floats(0.0, 0.4),
       shift=st.floats(-3.0, 3.0))  # fmt: skip
def test_the_factor_in_the_dissections_order_solves_and_counts_the_inertia(seed, n, reach, shift):
    """Whatever order is kept, the factor solves to round-off and its negative pivots are the
    negative eigenvalues (Sylvester)."""
    rng = np.random.default_rng(seed)
    pts, pattern = _cloud_pattern(rng, n, 2, reach)
    vals = rng.standard_normal(pattern.nnz)
    a = sp.csc_matrix((vals, pattern.indices, pattern.indptr), shape=pattern.shape)
    a = ((a + a.T) * 0.5 + sp.diags(np.full(2 * n, shift))).tocsc()
    a.sort_indices()
    f = LDLT(points=lambda: pts).factorize(a)
    w = np.linalg.eigvalsh(a.toarray())
    if np.min(np.abs(w)) < 1e-6:
        return  # a near-singular draw: the count is not decided by round-off
    assert f.negative == int(np.sum(w < 0))
    b = rng.standard_normal(2 * n)
    x = f.solve(b)
    assert np.linalg.norm(a @ x - b) <= 1e-8 * np.linalg.norm(b) * np.linalg.cond(a.toarray())


def test_points_that_do_not_hold_the_unknowns_are_refused_or_skipped():
    a, pts = _grid(5)
    with pytest.raises(ValueError, match="do not hold"):
        nested_dissection(pts[:-1], a)
    plain = LDLT().symbolic(a).perm
    np.testing.assert_array_equal(LDLT(points=lambda: pts[:-1]).symbolic(a).perm, plain)
    np.testing.assert_array_equal(LDLT(points=lambda: None).symbolic(a).perm, plain)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 300), extra=st.floats(0.0, 0.5),
       cut=st.booleans(), blocks=st.integers(1, 4))  # fmt: skip
def test_reverse_cuthill_mckee_is_scipys_order(seed, n, extra, cut, blocks):
    """The compiled RCM gives SciPy's permutation exactly (so the iterates do not change) on
    chain bands with random contacts, several components, isolated nodes and missing diagonal
    entries."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    from crumple.linalg_order import _rcm

    rng = np.random.default_rng(seed)
    band = min(5, n - 1)
    a = sp.diags([np.ones(n - abs(k)) for k in range(-band, band + 1)],
                 list(range(-band, band + 1))).tolil()  # fmt: skip
    for _ in range(int(extra * n)):
        i, j = rng.integers(0, n, 2)
        a[i, j] = a[j, i] = 1.0
    for b in range(1, blocks):  # split the chain into components
        k = b * n // blocks
        if 0 < k < n:
            a[:k, k:] = 0.0
            a[k:, :k] = 0.0
    if cut:
        k = int(rng.integers(0, n))
        a[k, :] = 0.0
        a[:, k] = 0.0
        a[k, k] = float(rng.random() < 0.5)
        j = int(rng.integers(0, n))  # a connected node without its diagonal entry
        a[j, j] = 0.0
    a = a.tocsc()
    a.eliminate_zeros()
    a.sort_indices()
    expected = reverse_cuthill_mckee(a.tocsr(), symmetric_mode=True)
    np.testing.assert_array_equal(_rcm(a), expected)
    np.testing.assert_array_equal(_rcm(CSC(a.data, a.indices, a.indptr)), expected)
