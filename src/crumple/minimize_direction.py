"""The Newton direction of :func:`crumple.minimize.newton`: the exact Hessian's step where it
is positive definite, else the fallback's with a shift σM (a Levenberg-Marquardt step in the
metric M). Private; model-blind, like :mod:`crumple.minimize`.

Its constants are read at call time: set ``crumple.minimize_direction.SHIFTS`` (say) to change
them for a run.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .linalg import CSC
from .minimize_modes import _gauge_pin
from .minimize_resolution import _force_resolution
from .minimize_result import max_force

#: After the exact Hessian has been found indefinite, the iterations that go straight to the
#: fallback double up to this many (:func:`_direction`).
SKIP_MAX = 8
#: Shifts σM :func:`_direction` tries on the fallback before it solves with the modified factor.
SHIFTS = 60
#: Once a shift σM makes the fallback positive definite, :func:`_lower_shift` tries σ divided
#: by ``SHIFT_DESCENT``, up to ``newton(shift_descents=)`` times
#: (:data:`crumple.minimize.SHIFT_DESCENTS` by default), while the step is shorter than the
#: trust radius over ``SHIFT_ROOM``.
SHIFT_DESCENT = 4.0
SHIFT_ROOM = 4.0


def _direction(st, hess, hess_fallback, ldl, floor, m) -> np.ndarray:
    """The Newton step of the exact Hessian if it is positive definite, else a fallback's.

    The fallback is ``hess_fallback`` (or H itself) shifted by σM, σ the smallest of 0, half
    the last one, or twice the negative curvature its factor revealed, that makes it positive
    definite (a Levenberg-Marquardt step in the metric M). A region of global negative
    curvature (the buckling of a straight wire) keeps it: the shifted step moves far along the
    unstable mode. After the exact Hessian has been found indefinite, the next ``st.skip``
    iterations go straight to the fallback (1, 2, 4, 8 after successive failures; 0 after a
    success), so that such a region costs about one factorisation per iteration.
    """
    g = st.g.ravel()
    w = None  # the zero modes at x, evaluated once per direction
    h = None  # the exact Hessian at x, where it was evaluated
    if st.skip_left > 0:
        st.skip_left -= 1
    else:
        st.nhev += 1
        h = hess(st.x)
        st.fres = _force_resolution(h, st.x)
        f = ldl.factorize(h, floor=floor, trial=True)  # only used if it passes
        pin = None
        if f.modified and st.zero_modes is not None:  # indefinite along a zero mode only?
            w = st.zero_modes(st.x)
            pin = _gauge_pin(h, w)
        if pin is not None:
            f = ldl.factorize(h, shift=pin, floor=floor, trial=True)
        if f.modified == 0:
            st.skip = 0
            st.factor, st.model, st.exact = f, _model_of(h, pin), True
            return -f.solve(g).reshape(st.x.shape)
        if hess_fallback is not None:
            st.skip = min(max(1, 2 * st.skip), SKIP_MAX)
            st.skip_left = st.skip
    if h is None or (hess_fallback is not None and hess_fallback is not hess):
        h = hess(st.x) if hess_fallback is None else hess_fallback(st.x)
        st.nhev += 1
    st.exact = False
    hs = h if sp.issparse(h) or isinstance(h, CSC) else sp.csc_matrix(h)
    if w is None and st.zero_modes is not None:
        w = st.zero_modes(st.x)
    pin = None if w is None else _gauge_pin(hs, w)
    pin = 0.0 if pin is None else pin
    sigma = 0.5 * st.sigma if st.sigma > 1e-300 else 0.0
    for attempt in range(SHIFTS):  # the last one complete: its modified factor is the step's
        f = ldl.factorize(hs, shift=sigma * m + pin, floor=floor, trial=attempt < SHIFTS - 1)
        if f.modified == 0:
            p = -f.solve(g)
            if st.descents and sigma > 0.0:
                sigma, f, p = _lower_shift(st, ldl, hs, g, m, pin, floor, sigma, f, p)
            st.sigma = sigma
            st.factor, st.model = f, _model_of(hs, sigma * m + pin)
            return p.reshape(st.x.shape)
        v = f.negative_direction()
        mu = float(v @ (hs @ v) + v @ (pin * v)) / float(v @ (m * v)) if v is not None else 0.0
        sigma = max(2.0 * sigma, -2.0 * mu, floor[0] / m[0])
    st.sigma = sigma
    st.factor, st.model = f, None
    return -f.solve(g).reshape(st.x.shape)  # modified: still a descent direction


def _lower_shift(st, ldl, hs, g, m, pin, floor, sigma, f, p):
    """The shift lowered, by ``SHIFT_DESCENT`` at a time and ``st.descents`` times at most,
    while the shifted step stays well inside the trust radius (its largest row displacement
    below ``st.radius / SHIFT_ROOM``) and the lowered matrix is still positive definite: a
    trust-region search for σ, which the doubling from half the last σ only overshoots.
    Returns (σ, its factor, its step)."""
    for _ in range(st.descents):
        if not max_force(p.reshape(st.x.shape)) * SHIFT_ROOM < st.radius:
            break
        lower = sigma / SHIFT_DESCENT
        trial = ldl.factorize(hs, shift=lower * m + pin, floor=floor, trial=True)
        if trial.modified:
            break
        sigma, f, p = lower, trial, -trial.solve(g)
    return sigma, f, p


def _model_of(h, shift):
    """(matrix, shift) of a factor, where the spring step can refactorise it (sparse)."""
    if isinstance(h, CSC) or (sp.issparse(h) and h.format == "csc"):
        return h, shift  # None or an array: the callers pass no scalar shift
    return None
