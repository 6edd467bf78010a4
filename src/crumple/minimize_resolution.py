"""The force's floating-point floor, and when a point below it is a minimum. Private to
:func:`crumple.minimize.newton`, model-blind.

Above N ≈ 5000 (the continuum wire) ftol = 10⁻⁶ is below what float64 coordinates resolve: a
one-ulp move changes a row's force by Σ_j |H_ij| ulp(x_j). Newton then accepts a point whose
forces are below 10 × that floor (:func:`_force_resolution`), but only if a Newton step from it
predicts no decrease beyond 10² times that of a one-ulp move (:func:`_resolved`): a coherent
force along a soft mode can sit below the floor on every row while the minimum is far away
(docs/performance.md, "True minima below the force resolution").
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .linalg import CSC
from .minimize_line import resolution

#: The force floor is this many times a one-ulp move's force change; the decrease a Newton
#: step from a point below it may predict, this factor squared times a one-ulp move's.
RESOLUTION_FACTOR = 10.0


def _force_resolution(h, x) -> float:
    """``RESOLUTION_FACTOR`` × max_i Σ_j |H_ij| ulp(x_j): how much the force on a row can change
    when the coordinates move by one unit in the last place. Below it the force is noise: a
    stiff wire of 10⁴ nodes at |x| ~ 0.5 cannot be brought below ~2e-5 (measured, B = 0.05)."""
    if isinstance(h, CSC):
        return RESOLUTION_FACTOR * h.abs_row_max_ulp(x) if h.nnz else 0.0
    u = np.spacing(np.abs(x)).ravel()
    if sp.issparse(h) and h.format == "csc" and h.shape[0] == h.shape[1] and h.nnz:
        # column sums of |H| u[row], = row sums by symmetry: no new sparse matrix
        r = np.bincount(
            np.repeat(np.arange(h.shape[1]), np.diff(h.indptr)),
            weights=np.abs(h.data) * u[h.indices], minlength=h.shape[1],
        )  # fmt: skip
    else:
        r = (abs(h) if sp.issparse(h) else np.abs(np.asarray(h))) @ u
    return RESOLUTION_FACTOR * float(np.max(r)) if r.size else 0.0


def _resolved(st, h, f, modes) -> tuple[bool, str]:
    """Whether a point below the force floor is a minimum (it passed the stability test; ``f``
    the factor of H + τM), and the message's note either way."""
    return _verdict(st, *_newton_decrease(st, h, f, modes))


def _verdict(st, decrease, noise, undecided="") -> tuple[bool, str]:
    """The decrease test's verdict and note: a minimum if the predicted ``decrease`` is within
    max(16 ε|E|, 10² × ``noise``, that of a one-ulp move). ``undecided`` (why the decrease is
    only a lower bound that did not settle) refuses the point whatever the numbers."""
    bound = _bound(st, noise)
    if decrease <= bound and not undecided:
        return True, (
            f"; a Newton step predicts a decrease of {decrease:.3g} <= {bound:.3g} "
            f"({RESOLUTION_FACTOR:g}² × that of a one-ulp move)"
        )
    what = undecided or f"above {bound:.3g} ({RESOLUTION_FACTOR:g}² × that of a one-ulp move)"
    return False, (
        f"had max force {st.fmax:.3g} <= its resolution {st.fres:.3g}, but a Newton step "
        f"predicted a decrease of {decrease:.3g}, {what}: not a minimum"
    )


def _bound(st, noise) -> float:
    """The largest decrease a minimum's Newton step may predict: max(16 ε|E|, 10² × ``noise``)."""
    return max(resolution(st.e), RESOLUTION_FACTOR**2 * noise)


def _ulp_moves(st) -> list[np.ndarray]:
    """Two one-ulp moves of the coordinates, δ_j = ±ulp(x_j) with random signs (fixed seed),
    zero on the fixed rows (``st.mask``): what the force resolution is the change of."""
    u = np.spacing(np.abs(np.asarray(st.x, dtype=np.float64))).ravel()
    if st.mask is not None:
        u[st.mask] = 0.0
    rng = np.random.default_rng(0)
    return [u * rng.choice((-1.0, 1.0), size=u.size) for _ in range(2)]


def _newton_decrease(st, h, f, modes) -> tuple[float, float]:
    """(the decrease a Newton step from ``st.x`` predicts, the same for round-off alone).

    ½ vᵀA⁻¹v in the complement of the zero modes W, A = H + τM factored as ``f``: by the limit
    of (A + βWWᵀ)⁻¹, ½ [vᵀy - (Wᵀy)ᵀ(WᵀA⁻¹W)⁻¹(Wᵀy)] with y = A⁻¹v, the complement the
    inertia test counts in (A itself can have a negative pivot along W there). v = g for the
    first; for the second, v = H δ with δ_j = ±ulp(x_j), random signs (the mean of two draws,
    fixed seed), the force change of a one-ulp move of the coordinates: the model of the force
    resolution itself, so that its decrease, about ½ δᵀHδ, is that of moving to the nearest
    representable point. Fixed rows (``st.mask``) do not move: δ = 0 there.

    They tell a point where the forces are below their floating-point resolution because they
    are noise from one where they are small but coherent. Measured on the continuum wire
    (B = 0.05, S = 5000) with `Ramp(lambdas=geomspace(1, 30, 12))`, before this test: with
    curved steps at N = 10⁴ two stages were accepted after one step, predicting 8·10⁻³ and
    9·10⁻³, their energies 0.0039 and 0.0082 above the minimum, while the true minima of the
    ramp predicted 10⁻²² … 2·10⁻¹²; docs/performance.md, "True minima below the force
    resolution"."""
    g = np.asarray(st.g, dtype=np.float64).ravel()
    vs = [g] + [np.asarray(h @ delta).ravel() for delta in _ulp_moves(st)]
    if modes is not None:
        aw = np.column_stack([f.solve(w) for w in modes.T])
        waw = modes.T @ aw
    out = []
    for v in vs:
        y = f.solve(v)
        d = float(v @ y)
        if modes is not None:
            wy = modes.T @ y
            d -= float(wy @ np.linalg.lstsq(0.5 * (waw + waw.T), wy, rcond=None)[0])
        out.append(0.5 * d)
    return out[0], 0.5 * (out[1] + out[2])
