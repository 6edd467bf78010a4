"""The stability test where an assembled Hessian cannot decide it. Private, model-blind.

:func:`crumple.minimize.newton` counts the negative eigenvalues of H + τM by the inertia of
one LDLᵀ of the assembled H. The entries of an assembled H are exact only to ε_mach times
the largest of them, and when that, per unit of the metric M, exceeds τ the count can see
negative curvature that is round-off (a stiff wire of 10⁵ segments: docs/performance.md,
"N = 10⁵ fails"). There, and only there, a caller's accurate product ``hess_action(x, v)``
decides instead: the lowest eigenvalue of (H, M) by LOBPCG on that product.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .linalg import CSC
from .minimize_resolution import _bound, _ulp_moves, _verdict

#: How many ε_mach × max_j |H_jj| the round-off of an assembled Hessian's entries is taken to
#: be (:func:`_assembly_resolution`). A diagonal entry of a chain sums the blocks of up to three
#: joints and two segments, each exact to a few ε of itself, and the factorisation adds its own
#: round-off of the same order: 4 is that count, not a proven bound. It only decides when an
#: inertia count that found negative curvature is checked again with the caller's accurate
#: product (``hess_action``), never that a point is stable: too large a value costs an
#: eigensolve, too small one leaves the count to decide where it cannot.
ASSEMBLY_ROUNDOFF = 4.0
#: LOBPCG on the accurate product: the shift of the preconditioner's factor, H + σM with σ this
#: fraction of the assembled resolution. Measured at N = 10⁵ (straight wire, λ = 2, two
#: spurious negative pivots): with the modified factor of H alone (no shift) the lowest Ritz
#: value stalled at 4.009 (true 4) and the second at 8.04 (true 4); with σ = 0.1 and 1 ×
#: the resolution it reached 4.0000 in 12 and 21 iterations. Below the resolution the factor
#: is the noise of the assembled low modes, above it a smooth (H + σM)⁻¹ of all of them.
PRECONDITIONER_SHIFT = 0.1
#: Iterations at most, and the convergence test: the lowest Ritz value moved by less than
#: ACCURATE_RTOL × (|μ| + τ) over the last ACCURATE_WINDOW iterations. Not a residual: at
#: N = 10⁵ the residual of an M-normalised vector is floored at ~10³ per unit length by the
#: round-off of its stiff components alone (ε_mach × the top eigenvalue, ~10¹⁹), while the
#: Ritz values, a quadratic form, are exact to ~10⁻⁵ relative (measured).
ACCURATE_MAXITER = 100
ACCURATE_RTOL = 1e-4
ACCURATE_WINDOW = 5
#: Opt-in (off: the escape first tries the assembled H's lowest mode, as without an accurate
#: product): where the accurate eigensolve found a negative eigenvalue, step along *its* mode
#: first. Off or on, where the assembled mode's escape finds no step that lowers the energy
#: (at N ≳ 2 × 10⁴ it is a round-off direction: measured, the straight continuum wire at its
#: buckling stage λ = 6.39, N = 2 × 10⁴, stopped with "negative curvature that no step
#: lowers"), the escape then takes the accurate mode (:func:`_equilibrium`'s rescue): a stage
#: that escaped before escapes as before, bit for bit.
ACCURATE_ESCAPE = False
#: Opt-in (off: the count decides when it finds no negative pivot): run the accurate
#: eigensolve also where the count of an unresolved H found none. At N = 10⁵ the count can
#: miss true negative curvature as well as invent it (measured: after one accurate escape
#: from the straight wire at λ = 7.02, μ = -3.80, the count found no negative pivot at a
#: point of bending energy 3 × 10⁻⁶ and the stage was accepted).
ACCURATE_WHEN_POSITIVE = False
#: Points the accurate product finds stable but the decrease test refuses (forces below their
#: resolution, yet coherent) before a stage stops, unconverged: each costs an eigensolve and a
#: conjugate-gradient solve on the accurate product (~14 s at N = 10⁵), and Newton, stepping
#: with the assembled H, moves along the soft modes that made the forces coherent only as
#: fast as their round-off curvature lets it.
ACCURATE_REFUSALS = 20


def _assembly_resolution(h, m) -> float:
    """The eigenvalue resolution of an assembled H in the metric M (per unit of M):
    ``ASSEMBLY_ROUNDOFF`` × ε_mach × max_j |H_jj| / min_j M_jj. Below it the pencil's
    eigenvalues of the assembled matrix are round-off: its inertia cannot tell the sign of a
    curvature smaller than this."""
    hs = h.tocsc() if isinstance(h, CSC) else (h if sp.issparse(h) else sp.csc_matrix(h))
    diag = np.abs(hs.diagonal())
    top = float(np.max(diag)) if diag.size else 0.0
    return ASSEMBLY_ROUNDOFF * float(np.finfo(float).eps) * top / float(np.min(m))


def _recheck(st, h, m, floor) -> bool:
    """Whether a count with no negative pivot is to be checked by the accurate product: a
    product given, H unresolved, and :data:`ACCURATE_WHEN_POSITIVE` or the accurate steps on
    (``newton(accurate_steps=True)``: where the product makes the steps it also checks every
    minimum the count accepts; measured at N = 10⁵, the straight wire above its Euler load,
    λ = 6.39 … 11.9, had no negative pivot and was accepted as a minimum without it)."""
    return (
        (ACCURATE_WHEN_POSITIVE or st.accurate_steps)
        and st.hess_action is not None
        and _assembly_resolution(h, m) > float(floor[0] / m[0])
    )


def _m_orthonormal(s, m, modes=None, drop=1e-8):
    """An M-orthonormal basis of the span of s's columns in the M-complement of ``modes``,
    directions of relative weight below ``drop`` left out (they are round-off)."""
    if modes is not None:
        mw = m[:, None] * modes
        s = s - modes @ np.linalg.solve(modes.T @ mw, mw.T @ s)
    norm = np.sqrt(np.sum(m[:, None] * s * s, axis=0))
    s = s[:, (norm > 0) & np.isfinite(norm)] / norm[(norm > 0) & np.isfinite(norm)]
    if s.shape[1] == 0:
        return s
    g = s.T @ (m[:, None] * s)
    w, u = np.linalg.eigh(0.5 * (g + g.T))
    keep = w > drop * w[-1]
    return s @ (u[:, keep] / np.sqrt(w[keep]))


def _lobpcg(action, m, x, precondition, modes, tau, history):
    """The lowest Ritz pairs of (H, M) from the block x, H applied by ``action`` (LOBPCG,
    Knyazev 2001). Unlike SciPy's, the block X is kept exactly in every Rayleigh–Ritz basis
    (the other directions orthogonalised against it): an X re-orthonormalised with them loses
    round-off that the stiff modes (eigenvalues ~10¹⁹ at N = 10⁵) weight enormously, and its
    Ritz values then jump up (measured: -7.906 to -4.6). The lowest Ritz value of every
    iteration goes to ``history``. Returns (values, vectors, settled)."""
    ax = lambda b: np.column_stack([action(c) for c in b.T])  # noqa: E731
    x = _m_orthonormal(x, m, modes)
    k = x.shape[1]
    mu, c = np.linalg.eigh(_sym(x.T @ ax(x)))
    x, p = x @ c, None
    for _ in range(ACCURATE_MAXITER):
        r = ax(x) - (m[:, None] * x) * mu
        z = np.column_stack([precondition(col) for col in r.T] + ([] if p is None else [p]))
        for _ in range(2):
            z = _m_orthonormal(z - x @ (x.T @ (m[:, None] * z)), m, modes)
        if z.shape[1] == 0:  # x spans all there is (a small problem): its Ritz values are exact
            return mu, x, True
        basis = np.column_stack([x, z])
        vals, c = np.linalg.eigh(_sym(basis.T @ ax(basis)))
        xn = basis @ c[:, :k]
        p = xn - x @ (x.T @ (m[:, None] * xn))
        x, mu = xn, vals[:k]
        history.append(float(mu[0]))
        recent = history[-ACCURATE_WINDOW:]
        if len(recent) == ACCURATE_WINDOW and max(recent) - min(recent) <= ACCURATE_RTOL * (
            abs(mu[0]) + tau
        ):
            return mu, x, True
    return mu, x, False


def _sym(a):
    return 0.5 * (a + a.T)


def _accurate_lowest(h, m, ldl, floor, modes, action, check):
    """The lowest eigenpair of the pencil (H, M) with H applied by ``action`` (accurate where
    the assembled H is not): :func:`_lobpcg` preconditioned by the factor of the assembled
    H + σM (σ = ``PRECONDITIONER_SHIFT`` × its resolution, pivots floored), started from the
    factor's negative direction and two random vectors in the M-complement of the zero modes,
    as ``minimize_modes._lowest_mode``. Returns (μ, converged, v, iterations, (factor, X)): μ
    the lowest Ritz value, converged whether it settled (:data:`ACCURATE_RTOL`), factor the
    preconditioner's (positive definite), X the Ritz block (the lowest modes found)."""
    hs = h.tocsc() if isinstance(h, CSC) else (h if sp.issparse(h) else sp.csc_matrix(h))
    n = hs.shape[0]
    tau = float(floor[0] / m[0])
    sigma = PRECONDITIONER_SHIFT * _assembly_resolution(hs, m)
    pre = ldl.factorize(hs, shift=sigma * m, floor=floor)
    rng = np.random.default_rng(0)  # fixed: results reproducible
    v0 = check.negative_direction()
    start = [rng.standard_normal((n, 2))] + ([] if v0 is None else [v0[:, None]])
    history: list[float] = []
    with np.errstate(all="ignore"):
        mu, x, settled = _lobpcg(action, m, np.column_stack(start), pre.solve, modes, tau, history)
    converged = settled and bool(np.isfinite(mu[0]))
    return float(mu[0]), converged, x[:, 0], len(history), (pre, x)


def _accurate_check(st, h, m, ldl, floor, modes, check):
    """At an equilibrium the inertia count could not decide (it found negative curvature, or
    :data:`ACCURATE_WHEN_POSITIVE`): (suffix, mode, model). suffix is the converged message's
    addition when ``st.hess_action`` shows the point stable where the assembled H cannot
    resolve τ (its lowest eigenvalue >= -τ, LOBPCG settled), else None; mode is (μ, v), the
    accurate lowest mode for the escape, when μ < -τ, else None;
    model, with a suffix, the eigensolve's preconditioner (the factor of H + σM) and its Ritz
    block, which :func:`_accurate_resolved` uses in turn. The mode is returned whenever μ < -τ:
    the caller escapes along it first (:data:`ACCURATE_ESCAPE`) or where the assembled H's
    lowest mode offers no step down."""
    if st.hess_action is None:
        return None, None, None
    tau = float(floor[0] / m[0])
    res = _assembly_resolution(h, m)
    if not res > tau:
        return None, None, None
    mu, converged, v, its, model = _accurate_lowest(
        h, m, ldl, floor, modes, lambda v: st.hess_action(st.x, v), check
    )
    if mu >= -tau and converged:
        note = (
            f"; stable by the accurate Hessian product: lowest eigenvalue {mu:.6g} >= -{tau:.3g} "
            f"({its} LOBPCG iterations), below the assembled matrix's resolution {res:.3g}"
        )
        return note, None, model
    return None, ((mu, v) if mu < -tau else None), None


def _accurate_resolved(st, model, modes, floor) -> tuple[bool, str]:
    """The decrease test of a point below the force floor (``minimize_resolution._resolved``)
    where the accurate product decided that it is stable: (resolved, note).

    With A = H + τM applied by the accurate product, the decrease a Newton step predicts,
    ½ gᵀA⁻¹g in the complement of the zero modes, is :func:`_decrease_estimate`'s, from the
    eigensolve's ``model`` (its preconditioner and Ritz block); that of a one-ulp move δ is
    ½ δᵀAδ (= ½ vᵀA⁻¹v for v = Aδ, no solve; the product taken on δ/|δ|). No factor of the
    assembled H can stand in for A here: along its soft modes the assembled curvature is
    round-off, as large as the resolution (measured on the test's chain: the floored factor of
    H + σM predicted 2.0 × 10⁻⁴ where ½ gᵀH⁻¹g = 0.033)."""

    def action(v):
        return np.asarray(st.hess_action(st.x, v), dtype=np.float64).ravel() + floor * v

    noise = float(np.mean([0.5 * float(d @ d) * _rayleigh_unit(action, d) for d in _ulp_moves(st)]))
    g = np.asarray(st.g, dtype=np.float64).ravel()
    project = _complement(modes)
    bound = _bound(st, noise)
    pre, ritz = model
    steps: list = []
    quad, why = _decrease_estimate(action, project(g), pre.solve, project, ritz, 2.0 * bound,
                                   steps)  # fmt: skip
    if not why and 0.5 * quad > bound:  # stopped as soon as the lower bound passed the bound
        why = f"above {bound:.3g} (a lower bound: the solve stopped there)"
    resolved, note = _verdict(st, 0.5 * quad, noise, why)
    if not resolved and REFUSED_STEPS and steps and np.all(np.isfinite(steps[0])):
        st.pending = -steps[0].reshape(st.x.shape)  # the next direction (minimize._newton_step)
    return resolved, note


def _complement(modes):
    """The Euclidean projection on the complement of the columns of ``modes`` (x.size, k), or
    the identity for None (:func:`crumple.minimize_modes._modes`)."""
    if modes is None:
        return lambda v: v
    q = np.linalg.qr(modes)[0]
    return lambda v: v - q @ (q.T @ v)


def _rayleigh_unit(action, d) -> float:
    """d̂ᵀA d̂ for d̂ = d/|d| (0 for d = 0): a caller's product need not be linear down to the
    ulp scale of d itself (one by finite differences would not be)."""
    norm = float(np.linalg.norm(d))
    if not norm > 0:
        return 0.0
    u = d / norm
    return float(u @ action(u))


#: A point the decrease test refuses (forces below their resolution, but a Newton step still
#: pays) hands the test's own step, the Galerkin solution of (H + τM) s = -g over the
#: eigensolve's Ritz block and the CG iterate (:func:`_decrease_estimate`), to the next Newton
#: iteration as its direction (``minimize._newton_step``): along the soft modes the factor's
#: preconditioner cannot see, that step is the one the test measured. False: the engine
#: before the twelfth stop (the next direction the factor's, or its CG refinement).
REFUSED_STEPS = True


#: The coarse correction of :func:`_decrease_estimate` keeps the directions of the Ritz block
#: Y along which |YᵀAY|'s eigenvalue exceeds this fraction of its largest: measured, an N = 10⁵
#: ramp (stage 38, λ = 754.8, eighteenth stop's engine) stopped with an exception where YᵀAY
#: was singular; the directions left out are those the block cannot correct anyway.
COARSE_RTOL = 1e-12


def _coarse_block(y, ay):
    """(Y, AY, YᵀAY) of the coarse correction, YᵀAY symmetrised; where it is singular (or
    nearly: an eigenvalue of modulus at most ``COARSE_RTOL`` × the largest) the block is
    rotated onto its eigenvectors and those directions dropped, and (None, None, None) where
    none is left. Where YᵀAY is regular the block is returned as it is (the same iterates as
    without the check)."""
    cy = _sym(y.T @ ay)
    w, u = np.linalg.eigh(cy)
    top = float(np.max(np.abs(w))) if w.size and np.all(np.isfinite(w)) else 0.0
    keep = np.abs(w) > COARSE_RTOL * top
    if top > 0 and keep.all():
        return y, ay, cy
    if not (top > 0 and keep.any()):
        return None, None, None
    return y @ u[:, keep], ay @ u[:, keep], np.diag(w[keep])


def _decrease_estimate(action, b, solve, project, ritz, above=np.inf, steps=None):
    """bᵀA⁻¹b in the subspace ``project`` keeps (b already in it), as a lower bound: (value, why).

    Conjugate gradients (:func:`_cg_quadratic`) preconditioned by ``solve`` (the factor of the
    assembled H + σM, exact enough on the stiff modes) plus a coarse correction on Y, the
    projected Ritz block ``ritz`` of the accurate eigensolve: z = P solve(P r) + Y(YᵀAY)⁻¹Yᵀr.
    The factor's curvature along the soft modes is round-off, so without the correction their
    share of bᵀA⁻¹b (nearly all of it where the forces are coherent) hides behind a plateau of
    the estimate until the rest of the residual has fallen to its level. The value is then the
    Galerkin quadratic bᵀV(VᵀAV)⁻¹Vᵀb over V = [Y, s], s the CG solution: at least the CG
    estimate (s ∈ V) and that of Y alone, and still at most bᵀA⁻¹b. With ``steps`` (a list),
    the Galerkin solution V(VᵀAV)⁻¹Vᵀb ≈ A⁻¹b is appended to it (the CG solution where
    there is no Ritz block, or VᵀAV is not positive), whichever way the estimate ends."""
    y, ay = None, None
    if ritz is not None:
        ritz = np.column_stack([project(c) for c in np.asarray(ritz, float).T])
        y = _m_orthonormal(ritz, np.ones(ritz.shape[0]), drop=1e-16)
        y = y if y.shape[1] else None
    if y is not None:
        ay = np.column_stack([project(action(c)) for c in y.T])
        y, ay, cy = _coarse_block(y, ay)

    def precondition(r):
        z = project(solve(project(r)))
        return z if y is None else z + y @ np.linalg.solve(cy, y.T @ r)

    est, s, why = _cg_quadratic(action, b, precondition, project, above)
    early = bool(why) or est > above
    if y is None or (early and steps is None):
        if steps is not None:
            steps.append(s)
        return est, why
    cg = s
    s = s - y @ (y.T @ s)  # V = [Y, the part of s outside Y], orthonormal
    norm = float(np.linalg.norm(s))
    v, av = y, ay
    if norm > 0:
        v = np.column_stack([y, s / norm])
        av = np.column_stack([ay, project(action(s / norm))])
    w, u = np.linalg.eigh(_sym(v.T @ av))
    if not w[0] > 0:
        if steps is not None:
            steps.append(cg)
        return est, why or "a lower bound: the accurate H + τM is not positive on the Ritz block"
    c = u.T @ (v.T @ b)
    if steps is not None:
        steps.append(v @ (u @ (c / w)))
    if early:
        return est, why
    return max(est, float(np.sum(c**2 / w))), ""


def _cg_quadratic(action, b, precondition, project, above=np.inf):
    """bᵀA⁻¹b by preconditioned conjugate gradients from 0, in the subspace ``project`` keeps:
    (estimate, s, why), s the last iterate. The estimate bᵀs_k grows monotonically to bᵀA⁻¹b
    (each step adds (rᵀz)²/pᵀAp, a Gauss-quadrature lower bound), so it stops as soon as it
    exceeds ``above``; else it has settled when it moved by less than :data:`ACCURATE_RTOL` of
    itself over :data:`ACCURATE_WINDOW` iterations (the residual is floored by the stiff modes'
    round-off, as in :func:`_lobpcg`, the estimate is not). why is "" when the estimate settled
    or passed ``above``, else what it is: a lower bound that did not settle within
    :data:`ACCURATE_MAXITER` iterations, or one where A, or the preconditioned residual, is not
    positive (round-off)."""
    r = b.copy()
    s = np.zeros_like(b)
    if not np.any(r):
        return 0.0, s, ""
    z = precondition(r)
    p = z.copy()
    rz = float(r @ z)
    est, history = 0.0, [0.0]
    for _ in range(ACCURATE_MAXITER):
        if not rz > 0:
            return est, s, "a lower bound: the preconditioned residual lost its sign (round-off)"
        ap = project(action(p))
        pap = float(p @ ap)
        if not (pap > 0 and np.isfinite(pap)):
            return est, s, "a lower bound: the accurate H + τM is not positive along its direction"
        alpha = rz / pap
        est += alpha * rz
        s = s + alpha * p
        if est > above:
            return est, s, ""
        history.append(est)
        recent = history[-ACCURATE_WINDOW - 1 :]
        if len(recent) > ACCURATE_WINDOW and recent[-1] - recent[0] <= ACCURATE_RTOL * est:
            return est, s, ""
        r = project(r - alpha * ap)
        z = precondition(r)
        rz_new = float(r @ z)
        p = z + (rz_new / rz) * p
        rz = rz_new
    return est, s, f"a lower bound, not settled in {ACCURATE_MAXITER} conjugate-gradient iterations"
