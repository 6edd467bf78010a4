"""The Newton step where the assembled Hessian cannot resolve the soft modes: a truncated
conjugate-gradient solve with the accurate product. Private, model-blind.

At large N the assembled H carries a round-off of about ε max|H_jj| per entry (the bending
blocks' k_b/l0² at N = 5 × 10⁴ is 6 × 10¹²: an absolute error of ~10⁻³ per entry), larger than
the curvature of the wire's soft modes (λ l0 per node, ~10⁻⁴). Its factor is then exact on the
stiff modes and wrong on the soft ones; at a saddle, the shift σM that makes it positive
definite is set by that round-off (measured: σ ≈ 10³ per unit length against the buckling
mode's μ = −1.26), so the step along the unstable mode is 10⁻³ of the one it should be and the
buckle grows by ~0.1 % per iteration.

:func:`_accurate_step` solves H p = −g with H applied by ``hess_action`` (the element-form
product, accurate to round-off of the elements themselves) by conjugate gradients
preconditioned by that factor: Steihaug's truncated CG (Steihaug, SIAM J. Numer. Anal. 20, 626
(1983); Nocedal & Wright, Numerical Optimization, Alg. 7.2). From 0, every iterate is a descent
direction; the solve stops once an iterate leaves the trust radius (that iterate is returned,
and the line search scales the whole step back to the radius), or where the accurate H has
negative curvature along the CG direction d: it then returns s + (Δ/|d|∞) d (the unstable mode
of a saddle), or d itself at the first iteration. Both are descent directions but differ from
Steihaug's boundary point (the root of |s + τd| = Δ), which would be up to 2× shorter; that
variant was not measured. The factor stays the preconditioner only: on the stiff modes it is
exact (CG converges in a few iterations), on the soft ones the product decides.
"""

from __future__ import annotations

import numpy as np

from .minimize_accurate import _assembly_resolution, _complement
from .minimize_modes import _modes
from .minimize_result import max_force

#: Take the truncated-CG step where the assembled H cannot resolve τ (its resolution
#: ``minimize_accurate._assembly_resolution`` above the stability tolerance) and a product is
#: given. False: the factor's step everywhere (the engine before the tenth stop).
ACCURATE_STEPS = True
#: Conjugate-gradient iterations per step at most (measured at N = 5 × 10⁴: 2–3 on average).
ACCURATE_STEP_MAXITER = 50
#: The solve has converged when rᵀz (the preconditioned residual's square) falls below this
#: fraction of its value at 0.
ACCURATE_STEP_RTOL = 1e-10


def _accurate_step(st, p, m, floor) -> np.ndarray:
    """The truncated-CG step of the accurate H, or p where it does not apply.

    It applies where ``st.hess_action`` is given (and ``newton(accurate_steps=True)``), the
    direction's factor is positive definite
    with its sparse matrix known (``st.model``), and the assembled H's resolution is above
    τ = floor/m. Counts the CG iterations in ``st.krylov``."""
    if not (ACCURATE_STEPS and st.accurate_steps) or st.hess_action is None or st.model is None:
        return p
    tau = float(floor[0] / m[0])
    if not _assembly_resolution(st.model[0], m) > tau:
        return p
    shape = p.shape
    f = st.factor

    def rows(v):  # the trust radius's measure: the largest row displacement
        return max_force(v.reshape(shape)) if len(shape) == 2 else float(np.max(np.abs(v)))

    # the zero modes' accurate curvature is zero to round-off: a CG that read its sign as
    # negative would step along a symmetry to the trust radius
    project = _complement(_modes(st.zero_modes, st.x, m))
    r = project(-np.asarray(st.g, dtype=np.float64).ravel())
    s = np.zeros_like(r)
    z = project(f.solve(r))
    d = z.copy()
    rz = rz0 = float(r @ z)
    if not rz > 0:
        return p
    for k in range(ACCURATE_STEP_MAXITER):
        ad = np.asarray(st.hess_action(st.x, d), dtype=np.float64).ravel()
        dad = float(d @ ad)
        st.krylov += 1
        if not dad > 0:  # negative curvature along d: along it, by the trust radius's length
            if k == 0:
                s = d  # the factor's step (scaled): the line search caps it at the radius
            elif np.isfinite(st.radius):
                s = s + (st.radius / rows(d)) * d
            break
        alpha = rz / dad
        s = s + alpha * d
        if rows(s) > st.radius:  # beyond the trust radius: the line search caps it there
            break
        r = project(r - alpha * ad)
        z = project(f.solve(r))
        rz_new = float(r @ z)
        if rz_new < ACCURATE_STEP_RTOL * rz0:
            break
        d = z + (rz_new / rz) * d
        rz = rz_new
    return s.reshape(shape) if np.all(np.isfinite(s)) and np.any(s) else p
