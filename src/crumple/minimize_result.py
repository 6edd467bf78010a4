"""What every minimiser returns, and the checks and force measure they share.

Split from :mod:`crumple.minimize` so that :mod:`crumple.powell` and :mod:`crumple.minimize`
both import it without importing each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = ["MinimizeResult", "max_force"]


@dataclass(frozen=True, slots=True, kw_only=True)
class MinimizeResult:
    """Outcome of a minimisation.

    Attributes
    ----------
    x : ndarray
        Final point, shape of the start.
    energy : float
        Energy at ``x``.
    max_force : float
        max_i |grad[i]| at ``x``.
    iterations, evaluations, hessian_evaluations : int
        Outer iterations; energy-and-gradient (or energy-only, for Powell) calls; Hessians.
    factorizations : int
        Sparse LDLᵀ factorisations (Newton: one per iteration, plus the stability tests).
    force_resolution : float
        Newton: the force change a one-ulp move of the coordinates can make (times 10): the
        floor below which forces are round-off. ``converged`` means
        ``max_force <= max(ftol, force_resolution)``, and, where only the floor holds, that a
        Newton step predicts a decrease within 10² times that of a one-ulp move of the
        coordinates, or within the energy's resolution 16 ε|E| (coherent forces below the
        floor are not a minimum; not tested where the element-form product decides
        stability); the message says which held.
    curved_steps : int
        Newton with a ``retract``: the accepted steps that were the curved point, not the
        straight one.
    krylov_iterations : int
        Newton with a ``hess_action``: the conjugate-gradient iterations of the steps taken with
        the accurate product where the assembled Hessian cannot resolve the soft modes
        (``minimize_krylov``); each is one product and one solve with the factor.
    converged : bool
        ``max_force <= ftol``.
    ftol : float
        The tolerance used.
    message : str
        Why it stopped.
    method : str
    """

    x: np.ndarray
    energy: float
    max_force: float
    iterations: int
    evaluations: int
    hessian_evaluations: int
    converged: bool
    ftol: float
    message: str
    method: str
    factorizations: int = 0
    force_resolution: float = 0.0
    curved_steps: int = 0
    krylov_iterations: int = 0


def max_force(grad) -> float:
    """Largest row norm of a gradient (largest node force); absolute value for 1-D arrays.

    >>> max_force(np.array([[3.0, 4.0], [0.0, 1.0]]))
    5.0
    """
    g = np.asarray(grad)
    if g.ndim == 2 and g.shape[1] == 2 and g.dtype == np.float64 and g.flags.c_contiguous:
        return _max_row_norm2(g)  # the hot path: one compiled pass, same bits
    if g.ndim == 1:
        return float(np.max(np.abs(g))) if g.size else 0.0
    return float(np.sqrt(np.max(np.einsum("ij,ij->i", g, g)))) if g.size else 0.0


@njit(cache=True)
def _all_finite(a):
    """Whether every entry of a float array is finite (``np.isfinite(a).all()`` in one pass)."""
    for v in a.ravel():
        if not math.isfinite(v):
            return False
    return True


@njit(cache=True)
def _equal_kernel(a, b):
    for i in range(a.shape[0]):
        if not a[i] == b[i]:
            return False
    return True


def _equal(a, b) -> bool:
    """``np.array_equal(a, b)`` for two float64 arrays of the same shape, in one compiled pass
    (NaN unequal to itself, -0.0 equal to 0.0, as there).

    >>> a = np.array([[0.0, 1.0], [np.nan, 2.0]])
    >>> _equal(a[:1], -a[:1] + np.array([0.0, 2.0])), _equal(a, a), _equal(a[:1], a[:1] + 1e-16)
    (True, False, False)
    >>> _equal(np.array([-0.0]), np.array([0.0])), _equal(a, a[:1])
    (True, False)
    """
    return a.shape == b.shape and bool(_equal_kernel(a.reshape(-1), b.reshape(-1)))


def all_finite(a) -> bool:
    """``np.isfinite(a).all()`` for the minimisers' float64 arrays, in one compiled pass.

    >>> all_finite(np.array([1.0, np.inf]))
    False
    """
    if isinstance(a, np.ndarray) and a.dtype == np.float64:
        return bool(_all_finite(a))
    return bool(np.isfinite(a).all())


@njit(cache=True)
def _max_row_norm2(g):
    """sqrt(max_i (g_i0² + g_i1²)) of an (n, 2) array, NaN if any row is NaN, 0 if empty: what
    ``sqrt(max(einsum("ij,ij->i", g, g)))`` gives (row sums of two products, in that order;
    the square root commutes with the max)."""
    best = 0.0
    for i in range(g.shape[0]):
        s = g[i, 0] * g[i, 0] + g[i, 1] * g[i, 1]
        if s != s:
            return s
        if s > best:
            best = s
    return math.sqrt(best)


def _row_norms(p):
    return np.abs(p) if p.ndim == 1 else np.sqrt(np.einsum("ij,ij->i", p, p))


def _validate_common(x0, ftol, maxiter):
    x = np.array(x0, dtype=np.float64)
    if x.ndim not in (1, 2) or x.size == 0:
        raise ValueError(f"x0 must be a non-empty 1-D or 2-D array, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("x0 contains NaN or infinite values")
    if not (math.isfinite(ftol) and ftol > 0):
        raise ValueError(f"ftol must be positive, got {ftol}")
    if int(maxiter) < 1:
        raise ValueError(f"maxiter must be >= 1, got {maxiter}")
    return x
