"""Rows held fixed in :func:`crumple.minimize.newton` (prescribed degrees of freedom). Private.

The fixed rows as a mask over ``x.ravel()``, and the energy, Hessians and Hessian product with
those entries removed: a zero gradient there, the identity in their rows and columns, so that
every step is exactly zero on them and the stability test concerns the free rows only.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .linalg import CSC, pin_rows


def _fixed_mask(fixed, x):
    """The fixed rows as a boolean mask over ``x.ravel()``, or None when nothing is fixed."""
    if fixed is None:
        return None
    f = np.asarray(fixed)
    if f.dtype != np.bool_ or f.shape != x.shape[:1]:
        raise ValueError(f"fixed must be a boolean array of shape {x.shape[:1]}, got {f.dtype} "
                         f"{f.shape}")  # fmt: skip
    if not f.any():
        return None
    if f.all():
        raise ValueError("every row is fixed: nothing to minimise")
    return np.repeat(f, x.shape[1]) if x.ndim == 2 else f.copy()


def _constrained(mask, fun, hess, hess_fallback):
    """``fun`` and the Hessians with the fixed entries removed: zero gradient there, and the
    identity in their rows and columns of the Hessian (same sparsity pattern where the
    diagonal is stored, so a symbolic analysis is still reused)."""

    def cfun(x):
        e, g = fun(x)
        g = np.array(g, dtype=np.float64)
        g.reshape(-1)[mask] = 0.0
        return e, g

    def chess(h):
        if isinstance(h, CSC):
            pinned = pin_rows(h, mask)  # the fast path below, on the raw arrays
            if pinned is not None:
                return pinned
            h = h.tocsc()
        if sp.issparse(h):
            h = h.tocsc()
            col = np.repeat(np.arange(h.shape[1]), np.diff(h.indptr))
            row = h.indices
            if np.count_nonzero(mask[row] & (row == col)) == np.count_nonzero(mask):
                # same index arrays (not copies): the factorisation sees the same pattern
                data = h.data.copy()
                touched = mask[row] | mask[col]
                data[touched] = np.where(row[touched] == col[touched], 1.0, 0.0)
                return sp.csc_matrix((data, h.indices, h.indptr), shape=h.shape, copy=False)
            keep = sp.diags((~mask).astype(np.float64))
            return (keep @ h @ keep + sp.diags(mask.astype(np.float64))).tocsc()
        h = np.array(h, dtype=np.float64)
        h[mask, :] = 0.0
        h[:, mask] = 0.0
        h[mask, mask] = 1.0
        return h

    def chessian(x):
        return chess(hess(x))

    if hess_fallback is None or hess_fallback is hess:  # the exact one: still the same object
        fallback = None if hess_fallback is None else chessian
    else:
        fallback = lambda x: chess(hess_fallback(x))  # noqa: E731
    return cfun, chessian, fallback


def _constrained_action(mask, hess_action):
    """``hess_action`` of the constrained Hessian (:func:`_constrained`): v's fixed
    entries removed, and the identity's on them."""
    if hess_action is None:
        return None

    def action(x, v):
        w = np.array(v, dtype=np.float64).ravel()
        w[mask] = 0.0
        out = np.array(hess_action(x, w), dtype=np.float64).ravel()
        out[mask] = np.asarray(v, dtype=np.float64).ravel()[mask]
        return out

    return action
