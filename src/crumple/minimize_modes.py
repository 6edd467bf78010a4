"""The zero modes and the stability of :func:`crumple.minimize.newton`. Private.

A symmetry's zero modes W (a rigid rotation about the centre of an isotropic trap): the gauge
that keeps them out of the Newton step, the inertia of a factored matrix in their complement
(the stability test), and the escape from an equilibrium that fails it along the lowest mode
of (H, M). Model-blind, like :mod:`crumple.minimize`.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numba import njit

from .linalg import CSC
from .linalg_csc import _csc_matvec, _diagonal_entry
from .minimize_result import _row_norms, max_force


def _gauge_entries(w) -> list[tuple[int, int]]:
    """Where to fix the gauge of the zero modes (rows of ``w``): (mode, entry) pairs, the entry
    where the mode is largest now, the entries of the modes before it excluded."""
    w = np.abs(w)
    if w.shape[0] == 1:  # one mode (the rotation): the loop below without its bookkeeping
        j = int(np.argmax(w[0]))
        return [(0, j)] if w[0, j] > 0 else []
    pairs: list[tuple[int, int]] = []
    for k, mode in enumerate(w):
        mode[[j for _, j in pairs]] = 0.0
        if np.max(mode, initial=0.0) > 0:
            pairs.append((k, int(np.argmax(mode))))
    return pairs


def _gauge_pin(h, modes) -> np.ndarray | None:
    """The gauge shift: c_j on the entry j where each zero mode (row of ``modes``) is largest,
    0 elsewhere; None without modes.

    A zero mode w of the energy (a rigid rotation) is not a zero mode of its Hessian away from
    equilibrium: its curvature there is -gᵀ(d²x/dθ²), negative whenever the forces have an
    outward moment, which makes an exact Hessian indefinite for no physical reason (measured:
    the lowest mode of the default ramp's contact stages, overlap 0.96–1.0 with the rotation).
    Adding c_j e_j e_jᵀ on an entry where w_j ≠ 0 leaves the model unchanged in the complement
    {s: s_j = 0} of w, a choice of gauge (the energy does not depend on the rotation, so the
    step need not either), and gives w the curvature wᵀHw + c_j w_j². c_j = max(|H_jj|,
    -2 wᵀHw / w_j²): the scale of H, and at least enough to make w's curvature positive. The
    entry is chosen anew for each factorisation: an entry fixed once can see w_j → 0 as the
    configuration changes (a straight wire coiling up), and c_j then grows without bound.
    """
    hs = h if isinstance(h, CSC) else (h.tocsc() if sp.issparse(h) else sp.csc_matrix(h))
    w = np.asarray(modes, dtype=np.float64).reshape(-1, hs.shape[0])
    if w.shape[0] == 1 and isinstance(hs, CSC):  # the rotation alone: the loop below, unrolled
        mode = np.ascontiguousarray(w[0])
        j, hjj, hw = _pin_parts(*hs.unsigned, hs.data, mode)
        if not abs(mode[j]) > 0:
            return None
        pin = np.zeros(hs.shape[0])
        pin[j] = max(abs(hjj), -2.0 * float(mode @ hw) / mode[j] ** 2)
        return pin
    pairs = _gauge_entries(w)
    if not pairs:
        return None
    pin = np.zeros(hs.shape[0])
    for k, j in pairs:
        mode = w[k]
        lo, hi = hs.indptr[j], hs.indptr[j + 1]
        at = lo + int(np.searchsorted(hs.indices[lo:hi], j))
        hjj = abs(float(hs.data[at])) if at < hi and hs.indices[at] == j else 0.0
        pin[j] = max(hjj, -2.0 * float(mode @ (hs @ mode)) / mode[j] ** 2)
    return pin


@njit(cache=True)
def _pin_parts(indptr, indices, data, mode):
    """For :func:`_gauge_pin`'s one mode: j = ``np.argmax(np.abs(mode))`` (the first largest,
    or the first NaN), A_jj, and A ``mode`` (``linalg_csc._csc_matvec``'s sums), in one call."""
    j = 0
    best = -1.0
    for i in range(mode.shape[0]):
        a = abs(mode[i])
        if a != a:
            j = i
            break
        if a > best:
            best = a
            j = i
    return j, _diagonal_entry(indptr, indices, data, j), _csc_matvec(indptr, indices, data, mode)


def _modes(zero_modes, x, m):
    """The zero modes as the columns of an (x.size, k) array, or None."""
    if zero_modes is None:
        return None
    w = np.asarray(zero_modes(x), dtype=np.float64).reshape(-1, x.size).T
    return w if w.shape[1] else None


def _negative_count(f, modes) -> int:
    """Negative eigenvalues of the factored (unmodified) matrix A in the A-complement of the
    modes W: neg(A) - neg(Wᵀ A⁻¹ W) (Haynsworth's inertia additivity, A + βWWᵀ as β → ∞)."""
    if f.negative == 0 or modes is None:
        return f.negative
    s = modes.T @ np.column_stack([f.solve(w) for w in modes.T])
    return f.negative - int(np.sum(np.linalg.eigvalsh(0.5 * (s + s.T)) < 0))


def _deflate(v, modes, m):
    """v with its M-projection on the modes removed."""
    if modes is None:
        return v
    mw = m[:, None] * modes
    return v - modes @ np.linalg.solve(modes.T @ mw, mw.T @ v)


def _lowest_mode(h, m, ldl, check, floor, modes=None):
    """Lowest eigenpair estimate (μ, v) of the pencil (H, M), from a factor with a negative pivot.

    The start is the factor's own direction of negative curvature (Pᵀ L⁻ᵀ e_k); LOBPCG,
    preconditioned by the modified factor of H, improves it towards the lowest mode (the
    buckling mode, not a local wiggle). The direction returned always has vᵀHv < 0.
    """
    v0 = check.negative_direction()
    if v0 is None:
        return 0.0, None
    hs = h.tocsc() if isinstance(h, CSC) else (h if sp.issparse(h) else sp.csc_matrix(h))
    n = hs.shape[0]
    v0 = _deflate(v0, modes, m)
    mu0 = _rayleigh(hs, m, v0)
    if n < 8:
        return mu0, v0
    pre = ldl.factorize(hs, floor=floor)
    rng = np.random.default_rng(0)  # fixed: results reproducible
    block = _deflate(np.column_stack([v0, rng.standard_normal((n, 2))]), modes, m)
    try:
        vals, vecs = spla.lobpcg(
            hs, block, B=sp.diags(m), M=spla.LinearOperator((n, n), matvec=pre.solve),
            Y=modes, largest=False, maxiter=60, tol=1e-4 * math.sqrt(n), verbosityLevel=0,
        )  # fmt: skip
    except (np.linalg.LinAlgError, ValueError):  # pragma: no cover - keep the pivot direction
        return mu0, v0
    v = _deflate(vecs[:, int(np.argmin(vals))], modes, m)
    mu = _rayleigh(hs, m, v)
    return (mu, v) if mu < mu0 else (mu0, v0)


def _rayleigh(h, m, v) -> float:
    den = float(v @ (m * v))
    return float(v @ (h @ v)) / den if den > 0 else 0.0


def _escape(st, fun, h, m, ldl, check, floor, modes, step_limit, feasible, mode=None) -> bool:
    """Step downhill along the lowest mode from an unstable equilibrium; False if no step can.
    ``mode``: (μ, v) found already (``minimize_accurate``), instead of :func:`_lowest_mode`."""
    import warnings

    if mode is not None:
        mu, v = mode
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # LOBPCG's "did not converge" is not an error here
            mu, v = _lowest_mode(h, m, ldl, check, floor, modes)
    if v is None or not mu < 0:
        return False
    d = v.reshape(st.x.shape).copy()
    if st.mask is not None:
        d.reshape(-1)[st.mask] = 0.0
    if float(np.vdot(st.g, d)) > 0:
        d = -d
    biggest = float(np.max(_row_norms(d)))
    if not biggest > 0:
        return False
    length = st.radius if math.isfinite(st.radius) else 1e-3 * (1.0 + float(np.max(np.abs(st.x))))
    d = d * (length / biggest)
    if step_limit is not None:
        safe = step_limit(st.x, d)
        if safe < 1.0:
            d = 0.8 * safe * d
    for _ in range(40):
        xt = st.x + d
        et, gt = fun(xt)
        st.nfev += 1
        if math.isfinite(et) and et < st.e and (feasible is None or feasible(xt)):
            st.x, st.e, st.g, st.fmax = xt, float(et), gt, max_force(gt)
            return True
        d = 0.5 * d
    return False
