"""The energy terms of the paper's Eq. (1), each with its analytic gradient and Hessian.

Every term is a plain function of positions ``(n_nodes, 2)`` ``[length]`` returning
``(energy, gradient)`` with the gradient of the same shape ``[energy/length]``; the total is
their explicit sum (:func:`total_energy`). The Numba kernels below are compiled once
(``cache=True``) and also fill the Hessian triplets used by the Newton minimiser.

Terms (see ``docs/model.md`` for every modelling decision):

.. math::

    E_b = \\sum_{i=1}^{N-1} f(θ_i), \\quad f(θ) = \\tfrac{k_b}{2} θ^2
          \\text{ (or the softening law of Sec. III.C)}

    E_s = \\sum_{i=0}^{N-1} \\tfrac{k_s}{2} (|x_{i+1} - x_i| - L_0/N)^2

    E_{ext} = λ \\sum_{i=0}^{N} w_i |x_i - c|^2

    E_{hc} = ε \\sum_{(k, j)} b(D_{kj} / d), \\quad b(u) = (1 - u)^2 / u \\ (u < 1),
             \\ 0 \\ (u \\ge 1)

    E_{wall} = ε \\sum_{i=0}^{N} b(δ_i / d), \\quad δ_i = R_c - |x_i|
             \\ \\text{(only with a cavity of radius } R_c\\text{)}

where D_kj is the distance from node k to segment j over the pairs of
:func:`crumple.geometry.node_segment_pairs` (non-adjacent segments), d the hard-core width and
ε its energy scale. b is zero with zero slope at D = d (so the energy is C1), stiff there
(b''(1) = 2: a contact force F sits at a depth 1 - u ≈ F d / (2 ε), so the core is hard) and
diverges as D → 0. A barrier that is C2 at the cutoff, such as IPC's -(1 - u)² ln u, has a
vanishing stiffness there, and Newton's method then converges only linearly on every contact
(measured: ratio 1/2 per iteration); see ``docs/model.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit

from .geometry import _as_positions, _node_segment_pairs, _point_segment
from .model import Plasticity, Wire

__all__ = [
    "EnergyTerms",
    "WireEnergy",
    "bending_energy",
    "cavity_energy",
    "confinement_energy",
    "confinement_weights",
    "energy_terms",
    "hard_core_energy",
    "hessian",
    "stretching_energy",
    "total_energy",
]

# Systems with at most this many degrees of freedom get a dense Hessian (LAPACK Cholesky is
# faster than sparse LU there); larger ones a sparse one.
DENSE_LIMIT = 800


# --------------------------------------------------------------------------------------------
# Kernels: energy and gradient
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _bend_law(theta, k_b, s, theta_p):
    """f(θ), f'(θ), f''(θ) of the bending law (elastic when θ_p is infinite)."""
    a = abs(theta)
    if a <= theta_p:
        return 0.5 * k_b * theta * theta, k_b * theta, k_b
    sign = 1.0 if theta > 0.0 else -1.0
    e = (
        0.5 * k_b * theta_p * theta_p
        + 0.5 * s * k_b * (theta * theta - theta_p * theta_p)
        + k_b * theta_p * (1.0 - s) * (a - theta_p)
    )
    return e, s * k_b * theta + k_b * theta_p * (1.0 - s) * sign, s * k_b


@njit(cache=True)
def _elastic_eg(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, cx, cy, grad, terms):
    """Bending, stretching and confinement in one pass; energies by term into ``terms[:3]``.

    Each segment vector is computed once and reused by the two joints that share it.
    ``rest`` holds the rest turning angle of every joint (zeros for a straight wire).
    """
    n = pos.shape[0]
    eb = 0.0
    es = 0.0
    ec = 0.0
    ax = ay = la2 = 0.0
    for i in range(n - 1):
        bx, by = pos[i + 1, 0] - pos[i, 0], pos[i + 1, 1] - pos[i, 1]
        lb2 = bx * bx + by * by
        length = math.sqrt(lb2)
        dl = length - l0
        es += 0.5 * k_s * dl * dl
        c = k_s * dl / length
        grad[i, 0] -= c * bx
        grad[i, 1] -= c * by
        grad[i + 1, 0] += c * bx
        grad[i + 1, 1] += c * by
        if i >= 1 and k_b != 0.0:  # joint i between segment a = i - 1 and b = i
            theta = math.atan2(ax * by - ay * bx, ax * bx + ay * by)
            f, df, _ = _bend_law(theta - rest[i - 1], k_b, s, theta_p)
            eb += f
            gax, gay = ay / la2, -ax / la2  # dθ/da
            gbx, gby = -by / lb2, bx / lb2  # dθ/db
            grad[i - 1, 0] -= df * gax
            grad[i - 1, 1] -= df * gay
            grad[i, 0] += df * (gax - gbx)
            grad[i, 1] += df * (gay - gby)
            grad[i + 1, 0] += df * gbx
            grad[i + 1, 1] += df * gby
        ax, ay, la2 = bx, by, lb2
    if lam != 0.0:
        for i in range(n):
            rx, ry = pos[i, 0] - cx, pos[i, 1] - cy
            w = lam * weights[i]
            ec += w * (rx * rx + ry * ry)
            grad[i, 0] += 2.0 * w * rx
            grad[i, 1] += 2.0 * w * ry
    terms[0] = eb
    terms[1] = es
    terms[2] = ec


@njit(cache=True)
def _barrier(u):
    """b(u) = (1 - u)^2 / u and its first two derivatives, for 0 < u < 1."""
    v = 1.0 - u
    iu = 1.0 / u
    return v * v * iu, 1.0 - iu * iu, 2.0 * iu * iu * iu


@njit(cache=True)
def _hard_core_eg(pos, ks, js, width, strength, grad):
    """Barrier over candidate (node, segment) pairs; pairs at D >= width contribute nothing."""
    e = 0.0
    for m in range(ks.shape[0]):
        k, j = ks[m], js[m]
        dist, t, vx, vy = _point_segment(
            pos[k, 0], pos[k, 1], pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1]
        )
        if dist >= width:
            continue
        if dist <= 0.0:
            return math.inf
        b, db, _ = _barrier(dist / width)
        e += strength * b
        c = strength * db / (width * dist)  # dE/dD / D, times v gives dE/dx_k
        grad[k, 0] += c * vx
        grad[k, 1] += c * vy
        grad[j, 0] -= c * (1.0 - t) * vx
        grad[j, 1] -= c * (1.0 - t) * vy
        grad[j + 1, 0] -= c * t * vx
        grad[j + 1, 1] -= c * t * vy
    return e


@njit(cache=True)
def _wall_eg(pos, radius, width, strength, grad):
    """The cavity's barrier ε Σ b(δ_i/d), δ_i = R_c - |x_i|; nothing when R_c is infinite."""
    if not math.isfinite(radius):
        return 0.0
    e = 0.0
    for i in range(pos.shape[0]):
        r = math.sqrt(pos[i, 0] * pos[i, 0] + pos[i, 1] * pos[i, 1])
        delta = radius - r
        if delta >= width:
            continue
        if delta <= 0.0:
            return math.inf
        b, db, _ = _barrier(delta / width)
        e += strength * b
        c = -strength * db / (width * r)  # dE/dδ dδ/dx, dδ/dx = -x/r
        grad[i, 0] += c * pos[i, 0]
        grad[i, 1] += c * pos[i, 1]
    return e


@njit(cache=True)
def _max_displacement(x, ref):
    m = 0.0
    for i in range(x.shape[0]):
        dx, dy = x[i, 0] - ref[i, 0], x[i, 1] - ref[i, 1]
        m = max(m, dx * dx + dy * dy)
    return math.sqrt(m)


@njit(cache=True)
def _total_eg(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, cx, cy, ks, js, width, strength,
              radius, terms):  # fmt: skip
    grad = np.zeros_like(pos)
    _elastic_eg(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, cx, cy, grad, terms)
    terms[3] = _hard_core_eg(pos, ks, js, width, strength, grad)
    terms[4] = _wall_eg(pos, radius, width, strength, grad)
    return terms[0] + terms[1] + terms[2] + terms[3] + terms[4], grad


# --------------------------------------------------------------------------------------------
# Kernels: Hessian triplets (row, col, value) over the flattened coordinates 2 * node + axis
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _put_block(rows, cols, vals, m, nodes, block):
    """Scatter a (2p, 2p) block over nodes (p,) into the triplet arrays from index m."""
    p = nodes.shape[0]
    for a in range(p):
        for b in range(p):
            for u in range(2):
                for v in range(2):
                    rows[m] = 2 * nodes[a] + u
                    cols[m] = 2 * nodes[b] + v
                    vals[m] = block[2 * a + u, 2 * b + v]
                    m += 1
    return m


@njit(cache=True)
def _phi_hessian(vx, vy):
    """Hessian of the polar angle atan2(vy, vx) with respect to (vx, vy)."""
    r4 = (vx * vx + vy * vy) ** 2
    h = np.empty((2, 2))
    h[0, 0] = 2.0 * vx * vy / r4
    h[0, 1] = (vy * vy - vx * vx) / r4
    h[1, 0] = h[0, 1]
    h[1, 1] = -h[0, 0]
    return h


@njit(cache=True)
def _project_psd(block):
    """Replace a symmetric block by its positive part, in place."""
    wv, vv = np.linalg.eigh(block)
    if wv[0] >= 0.0:
        return
    for a in range(wv.shape[0]):
        wv[a] = max(wv[a], 0.0)
    block[:, :] = (vv * wv) @ vv.T


@njit(cache=True)
def _hessian_triplets(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, ks, js, width, strength,
                      project, project_bending=False, radius=math.inf):  # fmt: skip
    n = pos.shape[0]
    wall = math.isfinite(radius)
    size = 36 * (n - 2) + 16 * (n - 1) + (6 if wall else 2) * n + 36 * ks.shape[0]
    rows = np.empty(size, dtype=np.int64)
    cols = np.empty(size, dtype=np.int64)
    vals = np.empty(size)
    m = 0
    nodes3 = np.empty(3, dtype=np.int64)
    nodes2 = np.empty(2, dtype=np.int64)
    block6 = np.empty((6, 6))
    block4 = np.empty((4, 4))
    g = np.empty(6)
    # bending: f'' ∇θ∇θᵀ + f' ∇²θ, with ∇²θ = -Hφ(a) on a = x_i - x_{i-1}, +Hφ(b) on b
    for i in range(1, n - 1):
        ax, ay = pos[i, 0] - pos[i - 1, 0], pos[i, 1] - pos[i - 1, 1]
        bx, by = pos[i + 1, 0] - pos[i, 0], pos[i + 1, 1] - pos[i, 1]
        la2 = ax * ax + ay * ay
        lb2 = bx * bx + by * by
        theta = math.atan2(ax * by - ay * bx, ax * bx + ay * by)
        _, df, d2f = _bend_law(theta - rest[i - 1], k_b, s, theta_p)
        gax, gay = ay / la2, -ax / la2
        gbx, gby = -by / lb2, bx / lb2
        g[0], g[1] = -gax, -gay
        g[2], g[3] = gax - gbx, gay - gby
        g[4], g[5] = gbx, gby
        for a in range(6):
            for b in range(6):
                block6[a, b] = d2f * g[a] * g[b]
        ha = _phi_hessian(ax, ay)
        hb = _phi_hessian(bx, by)
        for u in range(2):
            for v in range(2):
                ca = -df * ha[u, v]  # on a: pattern [[+, -], [-, +]] over nodes i-1, i
                cb = df * hb[u, v]  # on b: over nodes i, i+1
                block6[u, v] += ca
                block6[u, 2 + v] -= ca
                block6[2 + u, v] -= ca
                block6[2 + u, 2 + v] += ca + cb
                block6[2 + u, 4 + v] -= cb
                block6[4 + u, 2 + v] -= cb
                block6[4 + u, 4 + v] += cb
        if project_bending:
            _project_psd(block6)
        nodes3[0], nodes3[1], nodes3[2] = i - 1, i, i + 1
        m = _put_block(rows, cols, vals, m, nodes3, block6)
    # stretching: k_s [u uᵀ + (1 - l0/L)(I - u uᵀ)] on the segment vector
    for i in range(n - 1):
        ex, ey = pos[i + 1, 0] - pos[i, 0], pos[i + 1, 1] - pos[i, 1]
        length = math.sqrt(ex * ex + ey * ey)
        ux, uy = ex / length, ey / length
        c = 1.0 - l0 / length
        kxx = k_s * (ux * ux + c * (1.0 - ux * ux))
        kyy = k_s * (uy * uy + c * (1.0 - uy * uy))
        kxy = k_s * (1.0 - c) * ux * uy
        for a in range(2):
            for b in range(2):
                sgn = 1.0 if a == b else -1.0
                block4[2 * a, 2 * b] = sgn * kxx
                block4[2 * a + 1, 2 * b + 1] = sgn * kyy
                block4[2 * a, 2 * b + 1] = sgn * kxy
                block4[2 * a + 1, 2 * b] = sgn * kxy
        nodes2[0], nodes2[1] = i, i + 1
        m = _put_block(rows, cols, vals, m, nodes2, block4)
    # confinement: 2 λ w_i I
    for i in range(n):
        for u in range(2):
            rows[m] = 2 * i + u
            cols[m] = 2 * i + u
            vals[m] = 2.0 * lam * weights[i]
            m += 1
    # cavity: ε b''/d² n nᵀ + ε b'/d ∇²δ, with δ = R_c - r, ∇δ = -n, ∇²δ = -(I - n nᵀ)/r, on
    # each node's own 2 × 2 block (already in the pattern through the stretching blocks);
    # every node writes its block, zeros when away from the wall, so the pattern is fixed
    if wall:
        for i in range(n):
            r = math.sqrt(pos[i, 0] * pos[i, 0] + pos[i, 1] * pos[i, 1])
            delta = radius - r
            c2 = c1 = 0.0
            if 0.0 < delta < width:
                _, d1b, d2b = _barrier(delta / width)
                c2 = strength * d2b / (width * width)
                c1 = -strength * d1b / (width * r)  # ε b'/d × (-1/r)
            nx, ny = (pos[i, 0] / r, pos[i, 1] / r) if r > 0.0 else (0.0, 0.0)
            for u in range(2):
                nu = nx if u == 0 else ny
                for v in range(2):
                    nv = nx if v == 0 else ny
                    rows[m] = 2 * i + u
                    cols[m] = 2 * i + v
                    vals[m] = c2 * nu * nv + c1 * ((1.0 if u == v else 0.0) - nu * nv)
                    m += 1
    # hard core, exact: ε b''/d² ∇D∇Dᵀ + ε b'/d ∇²D. With n = (p - c)/D the unit normal and t the
    # closest-point parameter on segment (a, b), e = b - a:
    #   interior (0 < t < 1), by the envelope theorem on min_t |p - a - t e|:
    #     ∇²D = (τ rᵀ + r τᵀ)/|e| - (D/|e|²) r rᵀ,  τ = [ê, -(1-t)ê, -tê],  r = [0, n, -n]
    #     (sliding of the node along the segment couples to the segment's rotation);
    #   at an end (t = 0 or 1): ∇²D = (I - n nᵀ)/D on the node and that end.
    # The second term is the contact's geometric stiffness, of order (contact force)/|e|:
    # not negligible (docs/model.md).
    tau = np.empty(6)
    rr = np.empty(6)
    for p in range(ks.shape[0]):
        k, j = ks[p], js[p]
        dist, t, vx, vy = _point_segment(
            pos[k, 0], pos[k, 1], pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1]
        )
        nodes3[0], nodes3[1], nodes3[2] = k, j, j + 1
        if dist <= 0.0 or dist >= width:
            # a candidate outside the core: zeros, so that the pattern is that of the neighbour
            # list and does not change while the list holds (fixed-pattern assembly)
            block6[:, :] = 0.0
            m = _put_block(rows, cols, vals, m, nodes3, block6)
            continue
        _, d1b, d2b = _barrier(dist / width)
        c2 = strength * d2b / (width * width)
        c1 = strength * d1b / width
        nx, ny = vx / dist, vy / dist
        g[0], g[1] = nx, ny
        g[2], g[3] = -(1.0 - t) * nx, -(1.0 - t) * ny
        g[4], g[5] = -t * nx, -t * ny
        for a in range(6):
            for b in range(6):
                block6[a, b] = c2 * g[a] * g[b]
        if 0.0 < t < 1.0:
            ex, ey = pos[j + 1, 0] - pos[j, 0], pos[j + 1, 1] - pos[j, 1]
            le = math.sqrt(ex * ex + ey * ey)
            hx, hy = ex / le, ey / le
            tau[0], tau[1] = hx, hy
            tau[2], tau[3] = -(1.0 - t) * hx, -(1.0 - t) * hy
            tau[4], tau[5] = -t * hx, -t * hy
            rr[0], rr[1] = 0.0, 0.0
            rr[2], rr[3] = nx, ny
            rr[4], rr[5] = -nx, -ny
            for a in range(6):
                for b in range(6):
                    block6[a, b] += c1 * (
                        (tau[a] * rr[b] + rr[a] * tau[b]) / le - dist * rr[a] * rr[b] / (le * le)
                    )
        else:
            off = 2 if t <= 0.0 else 4  # the segment end that is the closest point
            for u in range(2):
                for v in range(2):
                    pu = (1.0 if u == v else 0.0) - g[u] * g[v]
                    val = c1 * pu / dist
                    block6[u, v] += val
                    block6[off + u, off + v] += val
                    block6[u, off + v] -= val
                    block6[off + u, v] -= val
        if project:
            # keep the positive part only: the negative curvature of a contact is a geometric
            # effect of its force, and left in it forces a large global shift that stalls
            # Newton on the wire's soft modes (docs/model.md)
            _project_psd(block6)
        m = _put_block(rows, cols, vals, m, nodes3, block6)
    return rows[:m], cols[:m], vals[:m]


# --------------------------------------------------------------------------------------------
# Public functions
# --------------------------------------------------------------------------------------------


def _one_term(pos, index, *, k_b=0.0, s=1.0, theta_p=math.inf, rest=None, k_s=0.0, l0=1.0,
              lam=0.0, weights=None, cx=0.0, cy=0.0):  # fmt: skip
    """One elastic term through the fused kernel, the other coefficients set to zero."""
    grad = np.zeros_like(pos)
    terms = np.zeros(4)
    w = np.zeros(pos.shape[0]) if weights is None else weights
    rest = _rest_angles(rest, pos.shape[0])
    _elastic_eg(pos, k_b, s, theta_p, rest, k_s, l0, lam, w, cx, cy, grad, terms)
    return float(terms[index]), grad


def _rest_angles(rest, n_nodes: int) -> np.ndarray:
    """Rest turning angles, shape (n_nodes - 2,): zeros when None."""
    if rest is None:
        return np.zeros(max(n_nodes - 2, 0))
    r = np.ascontiguousarray(rest, dtype=np.float64)
    if r.shape != (n_nodes - 2,):
        raise ValueError(f"rest_angles must have shape ({n_nodes - 2},), got {r.shape}")
    if not np.all(np.isfinite(r)):
        raise ValueError("rest_angles contain NaN or infinite values")
    return r


def _plastic_args(plasticity: Plasticity | None) -> tuple[float, float]:
    if plasticity is None:
        return 1.0, math.inf
    return plasticity.s, plasticity.theta_p


def bending_energy(positions, k_b: float, plasticity: Plasticity | None = None, rest_angles=None):
    """Bending energy Σ f(θ_i - θ⁰_i) over the N - 1 joints and its gradient (Eq. 1, Sec. III.C).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    k_b : float
        Bending rigidity ``[energy]``.
    plasticity : Plasticity, optional
        Elastic-softening law beyond θ_p (applied to θ - θ⁰).
    rest_angles : array_like, shape (n_nodes - 2,), optional
        Rest turning angles θ⁰ ``[rad]`` of an imperfect wire; zeros by default (the paper).

    Returns
    -------
    energy : float
        ``[energy]``
    gradient : ndarray, shape (n_nodes, 2)
        ``[energy/length]``

    Examples
    --------
    A regular polygon of n sides turns by 2π/n at every joint:

    >>> n = 6; t = 2 * np.pi * np.arange(n + 1) / n
    >>> e, g = bending_energy(np.c_[np.cos(t), np.sin(t)], k_b=2.0)
    >>> bool(np.isclose(e, (n - 1) * (2 * np.pi / n) ** 2))
    True
    """
    pos = _as_positions(positions)
    s, tp = _plastic_args(plasticity)
    return _one_term(pos, 0, k_b=float(k_b), s=s, theta_p=tp, rest=rest_angles)


def stretching_energy(positions, k_s: float, rest_length: float):
    """Stretching energy Σ k_s/2 (|segment| - rest_length)² and its gradient (Eq. 1).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    k_s : float
        Stretching modulus ``[energy/length²]``.
    rest_length : float
        Rest length of one segment, L0/N ``[length]``.

    Examples
    --------
    >>> e, g = stretching_energy([[0, 0], [1.1, 0], [2.2, 0]], k_s=10.0, rest_length=1.0)
    >>> round(e, 12)
    0.1
    """
    pos = _as_positions(positions)
    return _one_term(pos, 1, k_s=float(k_s), l0=float(rest_length))


def confinement_weights(n_nodes: int, kind: str, length: float = 1.0) -> np.ndarray:
    """Weights w_i of the confinement λ Σ w_i r_i² for each normalisation.

    ``per-node``: w_i = 1 (Eq. 1 as printed). ``per-length``: each node's share of the rest
    length, L0/N inside and L0/(2N) at the two ends (trapezoidal rule for ∫ λ r² ds, Eq. 2).

    >>> confinement_weights(5, "per-length").tolist()
    [0.125, 0.25, 0.25, 0.25, 0.125]
    """
    if kind == "per-node":
        return np.ones(n_nodes)
    if kind == "per-length":
        w = np.full(n_nodes, length / (n_nodes - 1))
        w[[0, -1]] *= 0.5
        return w
    raise ValueError(f"confinement must be 'per-length' or 'per-node', got {kind!r}")


def confinement_energy(positions, lam: float, weights, center=(0.0, 0.0)):
    """Confinement energy λ Σ w_i |x_i - c|² and its gradient (Eqs. 1 and 2).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    lam : float
        Trap strength λ (>= 0).
    weights : array_like, shape (n_nodes,)
        w_i, see :func:`confinement_weights`.
    center : tuple of float
        Trap centre c ``[length]``.

    Examples
    --------
    A ring of radius R about the centre, per node: λ (n_nodes) R².

    >>> t = np.linspace(0, 2 * np.pi, 9)[:-1]
    >>> e, g = confinement_energy(0.5 * np.c_[np.cos(t), np.sin(t)], 3.0, np.ones(8))
    >>> round(e, 12)
    6.0
    """
    pos = _as_positions(positions)
    w = np.ascontiguousarray(weights, dtype=np.float64)
    if w.shape != (pos.shape[0],):
        raise ValueError(f"weights must have shape ({pos.shape[0]},), got {w.shape}")
    cx, cy = (float(c) for c in center)
    return _one_term(pos, 2, lam=float(lam), weights=w, cx=cx, cy=cy)


def hard_core_energy(positions, width: float, strength: float = 1.0):
    """Hard-core barrier ε Σ b(D/d) between non-adjacent segments and its gradient.

    b(u) = (1 - u)² / u for u < 1, else 0; D runs over node-segment distances
    (:func:`crumple.geometry.node_segment_pairs`). Infinite when a node touches a segment.
    It does not see crossings (a crossed wire may have all its nodes far from other
    segments): the minimisers forbid those by construction (``docs/model.md``).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    width : float
        Hard-core width d ``[length]``.
    strength : float
        Energy scale ε ``[energy]``.

    Examples
    --------
    >>> hairpin = np.array([[0, 0], [1, 0], [1, 0.5e-5], [0, 0.5e-5]])
    >>> e, g = hard_core_energy(hairpin, width=1e-5)
    >>> round(e, 12)                  # four node-segment pairs at D = d/2, b(1/2) = 1/2
    2.0
    """
    pos = _as_positions(positions)
    grad = np.zeros_like(pos)
    if pos.shape[0] < 4:
        return 0.0, grad
    ks, js = _node_segment_pairs(pos, float(width))
    return float(_hard_core_eg(pos, ks, js, float(width), float(strength), grad)), grad


def cavity_energy(positions, radius: float, width: float, strength: float = 1.0):
    """The wall of a rigid circular cavity centred at the origin, and its gradient.

    .. math::

        E_{wall} = ε \\sum_i b(δ_i / d), \\quad δ_i = R_c - |x_i|,
        \\quad b(u) = (1 - u)^2 / u \\ (u < 1), \\ 0 \\ (u \\ge 1)

    the hard core's barrier on each node's distance to the wall (``docs/model.md``, "The
    cavity"). Infinite when a node is on or outside the wall.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    radius : float
        Cavity radius R_c ``[length]``.
    width : float
        Barrier width d ``[length]`` (the wire's hard-core width).
    strength : float
        Energy scale ε ``[energy]``.

    Examples
    --------
    >>> e, g = cavity_energy([[0.0, 0.0], [0.5, 0.0], [0.0, 0.99995]], radius=1.0, width=1e-4)
    >>> round(e, 12)                  # one node at δ = d/2, b(1/2) = 1/2
    0.5
    """
    pos = _as_positions(positions)
    grad = np.zeros_like(pos)
    r = _check_radius(radius)
    return float(_wall_eg(pos, r, float(width), float(strength), grad)), grad


def _check_radius(radius) -> float:
    r = float(radius)
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"cavity radius must be a positive finite number, got {radius!r}")
    return r


@dataclass(frozen=True, slots=True)
class EnergyTerms:
    """Energy of a configuration by term ``[energy]``; ``wall`` is the cavity's (0 without)."""

    bending: float
    stretching: float
    confinement: float
    hard_core: float
    wall: float = 0.0

    @property
    def total(self) -> float:
        return self.bending + self.stretching + self.confinement + self.hard_core + self.wall

    @property
    def gamma(self) -> float:
        """γ = E_s / E_b, the paper's energy allocation (NaN when E_b = 0)."""
        return self.stretching / self.bending if self.bending > 0 else math.nan

    def to_dict(self) -> dict[str, float]:
        return {
            "bending": self.bending,
            "stretching": self.stretching,
            "confinement": self.confinement,
            "hard_core": self.hard_core,
            "wall": self.wall,
            "total": self.total,
        }


class WireEnergy:
    """The total energy of a wire at one trap strength, as a minimiser's callable.

    ``energy(x) -> (E, grad)`` for positions ``x`` of shape (n_nodes, 2); ``energy.hessian(x)``
    gives the Hessian over the flattened coordinates (dense up to ``DENSE_LIMIT`` degrees of
    freedom, else sparse CSC); ``energy.terms(x)`` the :class:`EnergyTerms`.

    Examples
    --------
    >>> w = Wire(k_b=5, k_s=5e5, n_segments=10)
    >>> x = np.c_[np.linspace(-0.5, 0.5, 11), np.zeros(11)]
    >>> e, g = WireEnergy(w, lam=1.0)(x)
    >>> bool(np.isclose(e, WireEnergy(w, lam=1.0).terms(x).confinement))
    True
    """

    def __init__(self, wire: Wire, lam: float, *, rest_angles=None, skin: float | None = None):
        if not isinstance(wire, Wire):
            raise TypeError(f"wire must be a Wire, got {type(wire).__name__}")
        lam = float(lam)
        if not (math.isfinite(lam) and lam >= 0):
            raise ValueError(f"lambda must be a non-negative finite number, got {lam}")
        self.wire = wire
        self.lam = lam
        self.weights = confinement_weights(wire.n_nodes, wire.confinement, wire.length)
        self._s, self._tp = _plastic_args(wire.plasticity)
        self.rest_angles = _rest_angles(rest_angles, wire.n_nodes)
        self._terms = np.zeros(5)
        self._radius = math.inf if wire.cavity_radius is None else wire.cavity_radius
        # Verlet list: candidate pairs within d + skin of a reference configuration stay valid
        # while no node has moved more than skin / 2 from it (a pair's distance changes by at
        # most the sum of its nodes' displacements). Candidates come out in (node, segment)
        # order as from a fresh search, so the energy is the same function of x to the bit.
        self.skin = 0.1 * wire.rest_length if skin is None else float(skin)
        self._ref = None
        self._ks = self._js = None
        self._pattern = None
        self.rebuilds = 0

    def _pairs(self, x):
        if self._ref is None or _max_displacement(x, self._ref) > 0.5 * self.skin:
            self._ks, self._js = _node_segment_pairs(x, self.wire.hard_core + self.skin)
            self._ref = x.copy()
            self.rebuilds += 1
        return self._ks, self._js

    def _eg(self, x):
        w = self.wire
        ks, js = self._pairs(x)
        return _total_eg(
            x, w.k_b, self._s, self._tp, self.rest_angles, w.k_s, w.rest_length, self.lam,
            self.weights,
            w.trap_center[0], w.trap_center[1], ks, js, w.hard_core, w.hard_core_energy,
            self._radius, self._terms,
        )  # fmt: skip

    def __call__(self, x):
        x = np.ascontiguousarray(x, dtype=np.float64)
        e, g = self._eg(x)
        return float(e), g

    def terms(self, x) -> EnergyTerms:
        x = _as_positions(x)
        if x.shape[0] != self.wire.n_nodes:
            raise ValueError(f"positions must have {self.wire.n_nodes} nodes, got {x.shape[0]}")
        self._eg(x)
        return EnergyTerms(*(float(v) for v in self._terms))

    def hessian(self, x, *, dense: bool | None = None, project_contacts: bool = False,
                project_bending: bool = False):  # fmt: skip
        """Hessian over ``x.ravel()``: dense (2n, 2n) or sparse CSC holding both triangles.

        The sparse one is assembled into a fixed pattern (chain + every candidate pair of the
        neighbour list, inactive pairs as explicit zeros), rebuilt only with the list: no
        COO to CSC conversion per call, and its index arrays are equal from call to call, so a
        factorisation can reuse its symbolic analysis (:class:`crumple.linalg.LDLT`).

        ``project_contacts`` / ``project_bending`` replace every contact's / every joint's block
        by its positive part: the Newton minimiser's fallback where the exact Hessian is
        indefinite. The stretching blocks stay exact: their negative transverse stiffness
        under compression is what makes a straight wire buckle, and the fallback must keep it.
        """
        w = self.wire
        x = np.ascontiguousarray(x, dtype=np.float64)
        ks, js = self._pairs(x)
        rows, cols, vals = _hessian_triplets(
            x, w.k_b, self._s, self._tp, self.rest_angles, w.k_s, w.rest_length, self.lam,
            self.weights, ks, js, w.hard_core, w.hard_core_energy, project_contacts,
            project_bending, self._radius,
        )  # fmt: skip
        ndof = x.size
        if dense is None:
            dense = ndof <= DENSE_LIMIT
        if dense:
            h = np.bincount(rows * ndof + cols, weights=vals, minlength=ndof * ndof)
            return h.reshape(ndof, ndof)
        if self._pattern is None or not (
            self._pattern[0] is ks
            or (np.array_equal(self._pattern[0], ks) and np.array_equal(self._pattern[1], js))
        ):  # a rebuilt neighbour list often holds the same pairs: keep the pattern then
            self._pattern = (ks, js, *_csc_pattern(rows, cols, ndof))
        _, _, indptr, indices, where = self._pattern
        data = np.bincount(where, weights=vals, minlength=indices.shape[0])
        return sp.csc_matrix((data, indices, indptr), shape=(ndof, ndof), copy=False)


def _csc_pattern(rows, cols, ndof):
    """CSC pattern (indptr, indices) of the triplets, and the entry each triplet adds to."""
    key = cols * ndof + rows
    uniq, where = np.unique(key, return_inverse=True)
    index = np.int32 if uniq.shape[0] < 2**31 - 1 else np.int64
    indices = (uniq % ndof).astype(index)
    indptr = np.zeros(ndof + 1, dtype=index)
    np.cumsum(np.bincount(uniq // ndof, minlength=ndof), out=indptr[1:])
    return indptr, indices, where


def energy_terms(wire: Wire, positions, lam: float, *, rest_angles=None) -> EnergyTerms:
    """Energy of a configuration by term (paper's Eq. 1).

    Parameters
    ----------
    wire : Wire
    positions : array_like, shape (wire.n_nodes, 2)
        ``[length]``
    lam : float
        Trap strength λ.

    Examples
    --------
    >>> w = Wire(k_b=5, k_s=5e5, n_segments=4, confinement="per-node")
    >>> x = np.c_[np.linspace(-0.5, 0.5, 5), np.zeros(5)]     # straight, unstretched
    >>> energy_terms(w, x, lam=2.0).to_dict()["confinement"]   # 2 (2 * 0.25 + 2 * 0.0625)
    1.25
    """
    return WireEnergy(wire, lam, rest_angles=rest_angles).terms(positions)


def total_energy(wire: Wire, positions, lam: float):
    """Total energy ``[energy]`` and its gradient ``(n_nodes, 2)`` ``[energy/length]``.

    >>> w = Wire(k_b=5, k_s=5e5, n_segments=4)
    >>> e, g = total_energy(w, np.c_[np.linspace(-0.5, 0.5, 5), np.zeros(5)], lam=2.0)
    >>> e, g.shape
    (0.1875, (5, 2))
    """
    pos = _as_positions(positions)
    if pos.shape[0] != wire.n_nodes:
        raise ValueError(f"positions must have {wire.n_nodes} nodes, got {pos.shape[0]}")
    return WireEnergy(wire, lam)(pos)


def hessian(wire: Wire, positions, lam: float, *, dense: bool | None = None):
    """Hessian of the total energy over the flattened coordinates ``2 * node + axis``.

    Exact for every term (the hard core's includes the geometric stiffness ε b'/d ∇²D of each
    contact; it is C1 only, so its Hessian jumps where a pair enters the hard core). Dense
    ``(2n, 2n)`` ndarray up to ``DENSE_LIMIT`` degrees of freedom, else sparse CSC.

    >>> w = Wire(k_b=5, k_s=5e5, n_segments=4)
    >>> hessian(w, np.c_[np.linspace(-0.5, 0.5, 5), np.zeros(5)], lam=1.0).shape
    (10, 10)
    """
    pos = _as_positions(positions)
    return WireEnergy(wire, lam).hessian(pos, dense=dense)
