"""Sparse symmetric LDLᵀ for the Newton minimiser: symbolic analysis reused, inertia, modification.

Nothing here knows what a wire is. A Newton iteration needs three things of its Hessian H,
each from **one** factorisation:

* the Newton step H⁻¹g when H is positive definite;
* a descent step when it is not (Gill & Murray's idea: a *modified* LDLᵀ that raises every
  pivot below a floor to ``max(|d_k|, floor_k)`` as it goes, so the factor is that of a
  positive definite H + E with E zero whenever H is safely positive definite);
* the inertia: by Sylvester's law the number of negative pivots of an unmodified LDLᵀ of
  H + σ M is the number of eigenvalues of the pencil (H, M) below -σ. That is the stability
  test of :func:`crumple.minimize.newton`, exact and without an eigensolver.

The factorisation is the up-looking algorithm of QDLDL (Stellato, Banjac et al., OSQP), written
in Numba: an elimination tree and column counts once per sparsity pattern (the *symbolic*
analysis, :mod:`crumple.linalg_symbolic`), then a numeric factorisation per call that only
fills in values. No pivoting: a fill-reducing order is chosen once per pattern, the one with
the fewest nonzeros in L among the natural order (optimal for a chain: a band), SciPy's
reverse Cuthill–McKee and, where the caller gives the points the unknowns sit at, a nested
dissection of them (a packed wire).

A pattern is recognised by the identity of the CSC index arrays of the matrix (or, failing
that, their contents), so a caller that assembles into a fixed pattern
(:class:`crumple.energy.WireEnergy`) pays the analysis once per neighbour list; solvers made
with ``shared=True`` (the Newton minimiser's, one per minimisation) also recall the last
analyses of each other's patterns (:data:`RECENT`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

from .linalg_csc import CSC, dense_csc, pin_rows, unsigned_view
from .linalg_order import nested_dissection
from .linalg_solve import _known_slots, _solve, _spring_solve, _unit_back_solve
from .linalg_symbolic import _Symbolic

__all__ = ["CSC", "LDLT", "Factorization", "dense_csc", "forget_analyses", "pin_rows"]


# --------------------------------------------------------------------------------------------
# Kernels (upper-triangular CSC, diagonal included)
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _factor(n, ap, ai, ax, shift, floor, modify, rp, rc, rpos, lp, li, lx, d, first,
            first_value, stop=False):  # fmt: skip
    """Numeric LDLᵀ of A + diag(shift) into (lp, li, lx, d); returns (negative, modified).

    QDLDL's up-looking factorisation with its symbolic part precomputed
    (:func:`crumple.linalg_symbolic._row_patterns`: the same operations in the same order,
    without the elimination-tree walks).
    ``negative`` counts pivots <= 0 as computed (before any modification); with ``modify``
    a pivot below ``floor[k]`` is replaced by max(|d_k|, floor[k]) and counted in ``modified``;
    the first such pivot's index and value go to ``first[0]`` and ``first_value[0]``. With
    ``stop`` the factorisation ends there (rows of L up to k done, the rest set to zero,
    ``modified`` = 1).
    """
    y = np.zeros(n)
    dinv = np.empty(n)
    negative = 0
    modified = 0
    for k in range(n):
        dk = shift[k]
        for p in range(ap[k], ap[k + 1]):
            b = ai[p]
            if b == k:
                dk += ax[p]
            else:
                y[b] = ax[p]
        for q in range(rp[k], rp[k + 1]):
            c = rc[q]
            yc = y[c]
            end = rpos[q]
            for p in range(lp[c], end):
                y[li[p]] -= lx[p] * yc
            lk = yc * dinv[c]
            lx[end] = lk
            dk -= yc * lk
            y[c] = 0.0
        if not dk > 0.0:  # also NaN
            negative += 1
        if modify and not dk >= floor[k]:
            if modified == 0:
                first[0] = k
                first_value[0] = dk
            modified += 1
            if stop:  # rows past k are not computed: zeros, so a back solve from k reads 0
                d[k] = dk
                for r in range(k + 1, n):
                    for q in range(rp[r], rp[r + 1]):
                        lx[rpos[q]] = 0.0
                return negative, modified
            dk = max(abs(dk), floor[k]) if dk == dk else floor[k]
        d[k] = dk
        dinv[k] = 1.0 / dk if dk != 0.0 else np.inf
    return negative, modified


@njit(cache=True)
def _factor_permuted(src, data, perm, shift, floor, n, ap, ai, rp, rc, rpos, lp, li, lx, d,
                     stop):  # fmt: skip
    """:func:`_factor` of the matrix with entries ``data`` (the upper permuted pattern's
    entry e is ``data[src[e]]``), shift and floor given in the original order (empty: none;
    an empty floor: no modification), gathered and permuted here. Returns (negative,
    modified, the first modified pivot or -1)."""
    ax = data[src]
    sh = shift[perm] if shift.shape[0] else np.zeros(n)
    modify = floor.shape[0] > 0
    fl = floor[perm] if modify else np.zeros(n)
    first = np.full(1, -1, dtype=np.int64)
    first_value = np.zeros(1)
    negative, modified = _factor(n, ap, ai, ax, sh, fl, modify, rp, rc, rpos, lp, li, lx, d, first,
                                 first_value, stop)  # fmt: skip
    return negative, modified, first[0]


@njit(cache=True)
def _rows_within(index, n):
    """Every entry of ``index`` in [0, n) (true for an empty one)."""
    for v in index.ravel():
        if v < 0 or v >= n:
            return False
    return True


_EMPTY = np.empty(0)
_NO_START = np.zeros(0, dtype=np.bool_)
_NO_SLOT = np.zeros(0, dtype=np.int64)
_NO_COLUMNS = np.zeros((0, 0))


# --------------------------------------------------------------------------------------------
# The factorisation object (the symbolic analysis: linalg_symbolic; the raw CSC matrix:
# linalg_csc)
# --------------------------------------------------------------------------------------------


class Factorization:
    """LDLᵀ of P (A + diag(shift)) Pᵀ, possibly modified.

    Attributes
    ----------
    negative : int
        Pivots <= 0 as computed: the number of eigenvalues of A + diag(shift) that are <= 0
        (Sylvester), exact up to round-off, when ``modified == 0``.
    modified : int
        Pivots raised to their floor (0: this is the factor of the matrix itself).
    complete : bool
        False for a trial (``LDLT.factorize(..., trial=True)``) that stopped at its first pivot
        below the floor: ``modified`` is then 1, ``negative`` counts the pivots up to it, and
        only :meth:`negative_direction` may be used.
    """

    __slots__ = ("_columns", "_d", "_lx", "_sym", "complete", "first_modified", "modified",
                 "negative")  # fmt: skip

    def __init__(self, sym, lx, d, negative, modified):
        self._sym, self._lx, self._d = sym, lx, d
        self._columns = None  # the last springs' solve: (index, value, slot, A⁻¹a columns)
        self.negative, self.modified = int(negative), int(modified)
        self.complete = True  # False: a trial stopped at its first modified pivot

    def _check_complete(self):
        if not self.complete:
            raise ValueError("a trial factorisation stopped at its first modified pivot: "
                             "it cannot solve")  # fmt: skip

    @property
    def positive_definite(self) -> bool:
        return self.negative == 0 and self.modified == 0

    def solve(self, b) -> np.ndarray:
        """(the factored matrix)⁻¹ b for a vector b of length n."""
        self._check_complete()
        s = self._sym
        b = np.ascontiguousarray(b, dtype=np.float64).ravel()
        u = s.unsigned
        return _solve(s.n, u["lp"], u["li"], self._lx, self._d, u["perm"], b)

    def solve_springs(self, p0, index, value, offset, stiffness, *, rounds=50, window=0.1,
                      max_new=2, start=None, return_active=False):  # fmt: skip
        """The minimiser s of gᵀs + ½ sᵀAs + Σ_i k_i/2 max(0, r_i - a_iᵀs)², p0 = -A⁻¹g.

        A is the factored matrix (positive definite); the one-sided springs have rows a_i with
        entries ``value[i]`` at ``index[i]`` (arrays of shape (m, w)), r_i = ``offset[i]``
        (<= 0: the springs start beyond s = 0), k_i = ``stiffness[i]``. Returns
        ``(s, converged)``: converged when the active set {i: a_iᵀs < r_i} was found within
        ``rounds`` rounds (springs are added in the order the step enters them, those within
        ``window`` of the first together, at most ``max_new`` per round; see
        :func:`crumple.linalg_solve._spring_solve`). ``start``, a boolean mask over the springs,
        is a first guess of the active set (a warm start: with positive springs the minimiser
        is unique, and the start changes only the rounds it takes). With ``return_active``,
        returns ``(s, converged, active)``, ``active`` the mask of the springs active at s.
        The columns A⁻¹a_i solved are kept with the factor: a later call with some of the same
        springs (rows of ``index`` and ``value`` equal, as a relisting of a step's springs
        gives) reuses them, bit for bit. Where the springs' small system is singular in
        floating point (A⁻¹ dwarfing 1/k, as with a factor whose pivots were raised), it
        returns p0, not converged (the rounds before are dropped, and the columns kept are
        those of before the call).

        >>> f = LDLT().factorize(sp.csc_matrix(np.eye(2)))
        >>> s, ok = f.solve_springs(np.array([1.0, 1.0]), np.array([[0]]), np.array([[-1.0]]),
        ...                         np.array([-0.25]), np.array([1e12]))
        >>> ok, np.round(s, 6).tolist()          # the spring stops x_0 at 0.25
        (True, [0.25, 1.0])
        """
        self._check_complete()
        sym = self._sym
        m = np.shape(offset)[0]
        first = _NO_START if start is None else np.asarray(start, dtype=np.bool_)
        if first.shape[0] not in (0, m):
            raise ValueError(f"start must be a boolean mask over the {m} springs")
        index = np.ascontiguousarray(index, dtype=np.int64)
        if not _rows_within(index, sym.n):
            raise ValueError(f"the springs' rows must index the {sym.n} unknowns")
        value = np.ascontiguousarray(value, dtype=np.float64)
        known_slot, known_cols = self._known_columns(index, value)
        p0 = np.ascontiguousarray(p0, dtype=np.float64).ravel()
        u = sym.unsigned
        try:
            s, converged, active, slot, cols = _spring_solve(
                sym.n, u["lp"], u["li"], self._lx, self._d, u["perm"], p0, unsigned_view(index),
                value,
                np.ascontiguousarray(offset, dtype=np.float64),
                np.ascontiguousarray(stiffness, dtype=np.float64), int(rounds), float(window),
                int(max_new), np.ascontiguousarray(first), known_slot, known_cols,
            )  # fmt: skip
        except np.linalg.LinAlgError:  # a system singular in floating point: A⁻¹ dwarfs 1/k
            s, active = p0.copy(), np.zeros(m, dtype=np.bool_)  # (a factor's raised pivots)
            return (s, False, active) if return_active else (s, False)
        self._columns = (index.copy(), value.copy(), slot, cols) if cols.shape[0] else None
        return (s, converged, active) if return_active else (s, converged)

    def _known_columns(self, index, value):
        """The columns A⁻¹a_i of the last springs' solve, and for each spring of ``index``,
        ``value`` the one that is its (-1: none)."""
        if self._columns is None or index.shape[1:] != self._columns[0].shape[1:]:
            return _NO_SLOT, _NO_COLUMNS
        old_index, old_value, old_slot, cols = self._columns
        slot, known = _known_slots(old_index, index, old_value, value, old_slot)
        return (slot, cols) if known else (_NO_SLOT, _NO_COLUMNS)

    def negative_direction(self) -> np.ndarray | None:
        """A direction of low curvature: v = Pᵀ L⁻ᵀ e_k, for which vᵀ(A + diag(shift))v = d_k.

        k is the first modified pivot of a modified factor (its value as computed, before the
        modification: rows up to k of L do not depend on it), else the most negative pivot.
        None when no pivot was modified or negative.
        """
        if self.modified:
            k = self.first_modified
        else:
            k = int(np.argmin(self._d))
            if not self._d[k] < 0:
                return None
        s = self._sym
        u = s.unsigned
        return _unit_back_solve(s.n, u["lp"], u["li"], self._lx, u["perm"], k)


#: How many symbolic analyses of sharing solvers (``LDLT(shared=True)``) are kept for any of them
#: to recall: the Newton minimiser makes a solver per minimisation, so per stage of a ramp, and
#: its first pattern is most often the one the stage before ended with (measured, the default
#: N = 100 ramp: 37 of its 138 analyses were of the pattern analysed just before). A kept
#: analysis holds copies of its pattern's arrays, so that no caller's later change of its own
#: arrays in place can make it match another pattern; patterns are compared entry by entry.
RECENT = 2
_recent: list[_Symbolic] = []  # most recent first


def _recall(a) -> _Symbolic | None:
    """The kept analysis of ``a``'s pattern, moved to the front, or None."""
    for k, sym in enumerate(_recent):
        if sym.matches(a):
            _recent.insert(0, _recent.pop(k))
            return sym
    return None


def _remember(sym: _Symbolic) -> None:
    sym.indptr, sym.indices = sym.indptr.copy(), sym.indices.copy()
    _recent.insert(0, sym)
    del _recent[RECENT:]


def forget_analyses() -> None:
    """Drop the analyses kept for sharing solvers (:data:`RECENT`): their memory, or a test's
    clean start."""
    _recent.clear()


class LDLT:
    """A reusable sparse LDLᵀ: the symbolic analysis is redone only when the pattern changes.

    Parameters
    ----------
    points : callable, optional
        ``points()`` gives the points the unknowns sit at when a pattern is analysed (an
        array (n_points, dim), unknown k at row k // (n / n_points); None, or points that do
        not hold the unknowns or are not finite: none). The fill-reducing order is then also
        sought by a nested dissection of them
        (:func:`crumple.linalg_order.nested_dissection`), kept where its L is smallest.
    shared : bool
        Without ``points``: take a new pattern's analysis from the last :data:`RECENT` that
        sharing solvers made, where one is of the same pattern (an analysis is a function of
        the pattern alone, so the factors are the same bit for bit), and keep this solver's
        for them. Off by default (a kept analysis holds memory: :func:`forget_analyses`); the
        Newton minimiser turns it on.

    Examples
    --------
    >>> a = sp.csc_matrix(np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]]))
    >>> f = LDLT().factorize(a)
    >>> f.positive_definite, np.allclose(a @ f.solve(np.ones(3)), 1.0)
    (True, True)
    >>> LDLT().factorize(a, shift=np.full(3, -2.5)).negative    # eigenvalues 1.27, 3, 4.73
    1
    """

    def __init__(self, points=None, *, shared: bool = False):
        self._sym: _Symbolic | None = None
        self._arrays = (None, None)  # the index arrays that ``_sym`` was last matched with
        self._points = points
        self._shared = bool(shared) and points is None
        self.analyses = 0
        self.factorizations = 0
        self.modifications = 0  # rank-one modifications of a factor (crumple.linalg_update)

    def symbolic(self, a) -> _Symbolic:
        """The symbolic analysis of ``a``'s pattern: this solver's last one while the pattern
        holds, else (``shared``) one of the :data:`RECENT` analyses kept by sharing solvers if
        its pattern is ``a``'s, else a new one. ``analyses`` counts the patterns taken up,
        recalled or analysed."""
        if self._sym is not None and a.indptr is self._arrays[0] and a.indices is self._arrays[1]:
            return self._sym  # the arrays last taken up: the pattern holds (the hot path)
        if self._sym is None or not self._sym.matches(a):
            sym = _recall(a) if self._shared else None
            if sym is None:
                sym = _Symbolic(a, self._candidate(a))
                if self._shared:
                    _remember(sym)
            self._sym = sym
            self.analyses += 1
        self._arrays = (a.indptr, a.indices)
        return self._sym

    def _candidate(self, a):
        """The nested dissection of the unknowns' points (``points()``), where it has them."""
        if self._points is None:
            return None
        pts = self._points()
        if (pts is None or np.ndim(pts) != 2 or len(pts) == 0 or a.shape[0] == 0
                or a.shape[0] % len(pts) or not np.isfinite(pts).all()):  # fmt: skip
            return None
        return nested_dissection(pts, a)

    def factorize(self, a, *, shift=None, floor=None, trial=False) -> Factorization:
        """Factorise ``a + diag(shift)`` (a symmetric CSC matrix holding both triangles: SciPy
        or :class:`CSC`; a dense array is converted).

        With ``floor`` (a vector), pivots below it are raised (modified LDLᵀ): the result is
        always positive definite and solves a nearby positive definite system. With
        ``trial`` (and a floor) the factorisation stops at the first pivot below the floor:
        enough to know whether the matrix passes and, if not, its
        :meth:`Factorization.negative_direction`, but not to solve with (``complete`` False).
        It counts as a factorisation.
        """
        if trial and floor is None:
            raise ValueError("a trial factorisation needs a floor")
        if isinstance(a, CSC):
            pass
        elif not sp.issparse(a):
            a = dense_csc(a)
        elif a.format != "csc":
            a = a.tocsc()
        s = self.symbolic(a)
        lx = np.empty(s.l_nnz)
        d = np.empty(s.n)
        u = s.unsigned
        neg, mod, first = _factor_permuted(
            u["src"], np.ascontiguousarray(a.data, dtype=np.float64), u["perm"],
            _EMPTY if shift is None else np.ascontiguousarray(shift, dtype=np.float64),
            _EMPTY if floor is None else np.ascontiguousarray(floor, dtype=np.float64),
            *u["factor"], lx, d, bool(trial),
        )  # fmt: skip
        self.factorizations += 1
        f = Factorization(s, lx, d, neg, mod)
        f.first_modified = int(first)
        f.complete = not (trial and mod)
        return f
