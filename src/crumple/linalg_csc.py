"""The raw CSC matrix of :mod:`crumple.linalg` (:class:`CSC`, both triangles, unchecked) and
its Numba kernels: the product, the weighted row sums, a dense matrix into CSC, and rows and
columns pinned to the identity's. :mod:`crumple.linalg` re-exports the public names."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit


@njit(cache=True)
def _position(indptr, indices, row, col):
    """Where entry (row, col) is in a CSC matrix's data (rows sorted within each column), or
    -1 where the pattern does not store it: a binary search of the column."""
    lo, hi = indptr[col], indptr[col + 1]
    while lo < hi:  # the first stored row >= row
        mid = (lo + hi) // 2
        if indices[mid] < row:
            lo = mid + 1
        else:
            hi = mid
    return lo if lo < indptr[col + 1] and indices[lo] == row else -1


@njit(cache=True)
def _dense_to_csc(a):
    """The stored entries of a dense square array as CSC arrays (data, indices, indptr): its
    nonzeros (NaN included) column by column, rows ascending; what
    ``scipy.sparse.csc_matrix(a)`` holds."""
    n = a.shape[0]
    indptr = np.zeros(n + 1, dtype=np.int64)
    for j in range(n):
        c = 0
        for i in range(n):
            c += a[i, j] != 0.0
        indptr[j + 1] = indptr[j] + c
    indices = np.empty(indptr[n], dtype=np.int64)
    data = np.empty(indptr[n])
    p = 0
    for j in range(n):
        for i in range(n):
            if a[i, j] != 0.0:
                indices[p] = i
                data[p] = a[i, j]
                p += 1
    return data, indices, indptr


@njit(cache=True)
def _pin(indptr, indices, data, mask, drop_zeros):
    """(data, indices, indptr, ok) of the CSC matrix with the rows and columns of ``mask``
    made the identity's: 1 on their stored diagonal, 0 elsewhere in them. ``drop_zeros``: the
    entries that are then zero are dropped (new index arrays), else the input's pattern is
    kept and the index arrays returned are empty. ``ok`` is False where a masked row's
    diagonal is not stored (the identity then needs an entry the pattern does not have)."""
    n = indptr.shape[0] - 1
    out_x = np.empty(data.shape[0])
    out_i = np.empty(indices.shape[0] if drop_zeros else 0, dtype=np.int64)
    out_p = np.zeros(n + 1 if drop_zeros else 0, dtype=np.int64)
    q = 0
    for j in range(n):
        seen = not mask[j]
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            v = data[p]
            if i == j and mask[j]:
                v = 1.0
                seen = True
            elif mask[i] or mask[j]:
                v = 0.0
            if not drop_zeros:
                out_x[p] = v
            elif v != 0.0:
                out_i[q] = i
                out_x[q] = v
                q += 1
        if not seen:
            return out_x, out_i, out_p, False
        if drop_zeros:
            out_p[j + 1] = q
    if drop_zeros:
        return out_x[:q], out_i[:q], out_p, True
    return out_x, out_i, out_p, True


@njit(cache=True)
def _csc_matvec(indptr, indices, data, v):
    """A v for A in CSC: SciPy's ``csc_matvec`` loop, the same products added in its order.
    Called by the cached ``minimize_modes._pin_parts``: Numba's cache does not see a change to
    a callee, so after editing this function clear ``__pycache__``."""
    out = np.zeros(indptr.shape[0] - 1)
    for j in range(indptr.shape[0] - 1):
        vj = v[j]
        for p in range(indptr[j], indptr[j + 1]):
            out[indices[p]] += data[p] * vj
    return out


@njit(cache=True)
def _diagonal_entry(indptr, indices, data, j):
    """A_jj of a CSC matrix whose rows are sorted within each column (0 if not stored). Called
    by the cached ``minimize_modes._pin_parts``: after editing it clear ``__pycache__``."""
    for p in range(indptr[j], indptr[j + 1]):
        if indices[p] >= j:
            return data[p] if indices[p] == j else 0.0
    return 0.0


@njit(cache=True)
def _abs_weighted_row_max(indptr, indices, data, u):
    """max_i Σ_j |A_ij| u_j of a symmetric CSC matrix, as column sums Σ_i |A_ij| u_i (the
    same products added in the same order as ``np.bincount`` over the entries); 0 if empty,
    NaN if any sum is NaN."""
    n = indptr.shape[0] - 1
    best = 0.0
    for j in range(n):
        s = 0.0
        for p in range(indptr[j], indptr[j + 1]):
            s += abs(data[p]) * u[indices[p]]
        if s != s:
            return s
        best = max(best, s)
    return best


@njit(cache=True)
def _abs_row_max_ulp(indptr, indices, data, x):
    """:func:`_abs_weighted_row_max` with u = ``np.spacing(np.abs(x)).ravel()``, computed here
    (spacing is exact: the same u for every finite x; at an infinite one Numba's NaN carries
    the sign bit, NumPy's not, and the maximum is NaN either way)."""
    xf = x.ravel()
    u = np.empty(xf.shape[0])
    for i in range(xf.shape[0]):
        u[i] = np.spacing(abs(xf[i]))
    return _abs_weighted_row_max(indptr, indices, data, u)


_UNSIGNED = {1: np.uint8, 2: np.uint16, 4: np.uint32, 8: np.uint64}


def unsigned_view(index: np.ndarray) -> np.ndarray:
    """An array of non-negative integers as an unsigned view of the same memory (made
    contiguous first): the same numbers, read by a kernel without Numba's wrap-around check of
    a signed index (:attr:`crumple.linalg_symbolic._Symbolic.unsigned`)."""
    index = np.ascontiguousarray(index)
    if index.dtype.kind not in "iu":
        raise TypeError(f"an index array must hold integers, got {index.dtype}")
    return index.view(_UNSIGNED[index.dtype.itemsize])


class CSC:
    """A square sparse matrix held as its raw CSC arrays (both triangles), unchecked.

    What a Newton iteration needs of its Hessian without the cost of building a SciPy matrix
    (its index checks cost more than the assembly at N = 100): :meth:`LDLT.factorize` takes
    it as it is, and :meth:`tocsc` gives the SciPy matrix, on the same arrays, where an
    external API needs one. The caller guarantees the CSC invariants (rows sorted and
    unique within each column, ``indptr`` of length n + 1) and a structurally symmetric
    pattern (entry (i, j) stored whenever (j, i) is, as an assembly of symmetric blocks gives).

    >>> a = CSC(np.array([2.0, 1.0, 1.0, 3.0]), np.array([0, 1, 0, 1]), np.array([0, 2, 4]))
    >>> a.shape, a.nnz, (a @ np.ones(2)).tolist()
    ((2, 2), 4, [3.0, 4.0])
    """

    __slots__ = ("_scipy", "_unsigned", "data", "indices", "indptr", "shape")
    format = "csc"

    def __init__(self, data, indices, indptr, *, unsigned=None):
        # unsigned: None, or the caller's (indptr, indices) as unsigned views (unsigned_view)
        # of these very arrays, kept with their pattern (:attr:`unsigned`)
        self.data, self.indices, self.indptr = data, indices, indptr
        n = indptr.shape[0] - 1
        self.shape = (n, n)
        self._scipy = None
        self._unsigned = unsigned

    @property
    def unsigned(self) -> tuple[np.ndarray, np.ndarray]:
        """(indptr, indices) as unsigned views of the same memory, for the kernels: Numba
        checks a signed index for wrap-around at every access, an unsigned one not (the same
        numbers, so the same results; :attr:`crumple.linalg_symbolic._Symbolic.unsigned`)."""
        if self._unsigned is None:
            self._unsigned = (unsigned_view(self.indptr), unsigned_view(self.indices))
        return self._unsigned

    @property
    def nnz(self) -> int:
        return int(self.indptr[-1])

    def tocsc(self) -> sp.csc_matrix:
        """The SciPy CSC matrix on the same arrays (built once)."""
        if self._scipy is None:
            self._scipy = sp.csc_matrix(
                (self.data, self.indices, self.indptr), shape=self.shape, copy=False
            )
        return self._scipy

    def __matmul__(self, v):
        v = np.asarray(v)
        if v.ndim == 1 and v.dtype == np.float64 and v.shape[0] == self.shape[1]:
            return _csc_matvec(*self.unsigned, self.data, v)
        return self.tocsc() @ v

    def abs_row_max_ulp(self, x) -> float:
        """max_i Σ_j |A_ij| u_j (A symmetric), u = ulp(|x|) flattened: the most a row of A x
        can change when every coordinate moves by one unit in its last place."""
        return float(_abs_row_max_ulp(*self.unsigned, self.data, np.ascontiguousarray(x)))

    def diagonal_entry(self, j: int) -> float:
        """A_jj (0 where the pattern does not store it)."""
        return float(_diagonal_entry(*self.unsigned, self.data, j))


def dense_csc(a) -> CSC:
    """A dense square array as :class:`CSC` (its nonzeros), without SciPy's COO conversion:
    the same entries, in the same order, as ``scipy.sparse.csc_matrix(a)``.

    >>> dense_csc(np.array([[2.0, 1.0], [1.0, 0.0]])).indices.tolist()
    [0, 1, 0]
    """
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"a square matrix is needed, got shape {a.shape}")
    return CSC(*_dense_to_csc(a))


def pin_rows(a: CSC, mask, *, drop_zeros: bool = False) -> CSC | None:
    """``a`` with the rows and columns of ``mask`` (boolean, one per row) made the identity's:
    1 on their diagonal, 0 elsewhere in them; what a minimiser's fixed rows need. The index
    arrays are ``a``'s (a symbolic analysis still matches), or with ``drop_zeros`` those of
    the nonzeros alone. None where a masked row's diagonal is not stored.

    >>> a = CSC(np.array([2.0, 1.0, 1.0, 3.0]), np.array([0, 1, 0, 1]), np.array([0, 2, 4]))
    >>> pin_rows(a, np.array([True, False])).data.tolist()
    [1.0, 0.0, 0.0, 3.0]
    >>> pin_rows(a, np.array([True, False]), drop_zeros=True).indices.tolist()
    [0, 1]
    """
    mask = np.asarray(mask, dtype=np.bool_)
    data, indices, indptr, ok = _pin(a.indptr, a.indices, a.data, mask, bool(drop_zeros))
    if not ok:
        return None
    return CSC(data, indices, indptr) if drop_zeros else CSC(data, a.indices, a.indptr)
