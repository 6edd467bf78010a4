"""The symbolic analysis of the LDLᵀ (``crumple.linalg_symbolic``): the analysis in one kernel,
with and without a caller's candidate order, against its steps composed."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from crumple.linalg import CSC


def _reference_analysis(a, candidate=None):
    """The analysis as the kernels' composition: a caller's candidate order, RCM and the
    natural order, each permuted and counted in full, the later kept on a tie, then its row
    patterns."""
    from crumple.linalg_order import _rcm
    from crumple.linalg_symbolic import _etree, _permuted_upper, _row_patterns

    n = a.shape[0]
    best = None
    for perm in ((candidate,) if candidate is not None else ()) + (_rcm(a), np.arange(n)):
        ap, ai, src = _permuted_upper(a, perm)
        parent, lnz, total = _etree(n, ap, ai)
        if best is None or total <= best[-1]:
            best = (perm, ap, ai, src, parent, lnz, total)
    perm, ap, ai, src, parent, lnz, total = best
    lp = np.r_[0, np.cumsum(lnz)]
    return (perm, ap, ai, src, parent, lp, *_row_patterns(n, ap, ai, parent, lp)), total


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 120), extra=st.floats(0.0, 0.3),
       wide=st.booleans(), shuffle=st.booleans(), holes=st.booleans(),
       blocks=st.integers(1, 3), raw=st.booleans(),
       candidate=st.sampled_from([None, "random", "band"]))  # fmt: skip
def test_the_analysis_in_one_kernel_is_the_composition_of_its_steps(seed, n, extra, wide,
                                                                    shuffle, holes, blocks,
                                                                    raw, candidate):  # fmt: skip
    """``_Symbolic`` without a candidate (one kernel: RCM, the natural order counted on A
    itself, row patterns) gives the arrays of the steps composed, on chain bands with random
    contacts (the natural order wins on most) and on the same with their unknowns shuffled
    (RCM wins on most), with missing diagonal entries and empty rows, in several components,
    for int32 and int64 indices, SciPy's matrix and :class:`CSC`; with a caller's candidate
    order, a random one (it loses) or the shuffled band's own order reversed (it wins or ties)."""
    from crumple.linalg_symbolic import _Symbolic

    rng = np.random.default_rng(seed)
    band = max(0, min(3, n - 1))
    a = sp.diags([np.ones(n - abs(k)) for k in range(-band, band + 1)],
                 list(range(-band, band + 1)), shape=(n, n)).tolil()  # fmt: skip
    for _ in range(int(extra * n)):
        i, j = rng.integers(0, n, 2)
        a[i, j] = a[j, i] = 1.0
    for b in range(1, blocks):  # split the chain into components
        k = b * n // blocks
        a[:k, k:] = 0.0
        a[k:, :k] = 0.0
    if holes and n:
        for k in rng.integers(0, n, 1 + n // 10):
            a[k, k] = 0.0  # a missing diagonal entry
        k = int(rng.integers(0, n))
        a[k, :] = 0.0  # an empty row and column
        a[:, k] = 0.0
    a = a.tocsc()
    order = rng.permutation(n) if shuffle else np.arange(n)
    if shuffle:
        a = a[order][:, order].tocsc()
    a.eliminate_zeros()
    a.sort_indices()
    if wide:
        a.indptr, a.indices = a.indptr.astype(np.int64), a.indices.astype(np.int64)
    if candidate == "random":
        candidate = rng.permutation(n)
    elif candidate == "band":  # the unknown of the shuffled matrix at each place of the band
        candidate = np.argsort(order)[::-1].copy()
    want, total = _reference_analysis(a, candidate)
    sym = _Symbolic(CSC(a.data, a.indices, a.indptr) if raw else a, candidate)
    got = (sym.perm, sym.ap, sym.ai, sym.src, sym.parent, sym.lp, sym.rp, sym.rc, sym.rpos,
           sym.ai_l)  # fmt: skip
    for w, g in zip(want, got, strict=True):
        np.testing.assert_array_equal(g, w)
    assert sym.l_nnz == total
