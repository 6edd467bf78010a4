"""Numba kernels of the energy terms (:mod:`crumple.energy`): energies and gradients, fused
into one pass over the wire, and the exact Hessian as (row, col, value) triplets.

Private: the public functions, their equations and the modelling decisions are in
:mod:`crumple.energy` and ``docs/model.md``. Split from ``energy.py`` so that the kernels (what
is compiled) and the API (what is called) each stay one readable module.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry.distance import _point_segment

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
def _segment(pos, disp, i):
    """Segment i's vector x_{i+1} - x_i of x = pos (``disp`` None: this branch alone is
    compiled) or of x = pos + disp, as (pos_{i+1} - pos_i) + (disp_{i+1} - disp_i): its
    round-off is then ε |x_{i+1} - x_i| + ε |disp|, not ε |x| (the float64 rounding of pos + disp
    itself moves a segment of a wire of size |x| by ε |x|)."""
    if disp is None:
        return pos[i + 1, 0] - pos[i, 0], pos[i + 1, 1] - pos[i, 1]
    return ((pos[i + 1, 0] - pos[i, 0]) + (disp[i + 1, 0] - disp[i, 0]),
            (pos[i + 1, 1] - pos[i, 1]) + (disp[i + 1, 1] - disp[i, 1]))  # fmt: skip


@njit(cache=True)
def _node(pos, disp, i, cx, cy):
    """Node i's position relative to (cx, cy), of x = pos or x = pos + disp."""
    if disp is None:
        return pos[i, 0] - cx, pos[i, 1] - cy
    return (pos[i, 0] - cx) + disp[i, 0], (pos[i, 1] - cy) + disp[i, 1]


@njit(cache=True)
def _elastic_eg(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, cx, cy, grad, terms,
                disp=None):  # fmt: skip
    """Bending, stretching and confinement in one pass; energies by term into ``terms[:3]``.

    Each segment vector is computed once and reused by the two joints that share it.
    ``rest`` holds the rest turning angle of every joint (zeros for a straight wire). With
    ``disp``, of the positions pos + disp, each segment from :func:`_segment`'s sum.
    """
    n = pos.shape[0]
    eb = 0.0
    es = 0.0
    ec = 0.0
    ax = ay = la2 = 0.0
    for i in range(n - 1):
        bx, by = _segment(pos, disp, i)
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
            rx, ry = _node(pos, disp, i, cx, cy)
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
def _in_core(pos, ks, js, width):
    """Whether any candidate (node, segment) pair is inside the hard core (D < width)."""
    for m in range(ks.shape[0]):
        k, j = ks[m], js[m]
        dist, _, _, _ = _point_segment(
            pos[k, 0], pos[k, 1], pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1]
        )
        if dist < width:
            return True
    return False


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
              radius, terms, disp=None):  # fmt: skip
    """Every term at x = pos, or at x = pos + disp (the elastic ones from its segments' sums,
    :func:`_segment`; the hard core and the wall at the float64 sum)."""
    grad = np.zeros_like(pos)
    _elastic_eg(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, cx, cy, grad, terms, disp)
    x = pos if disp is None else pos + disp
    terms[3] = _hard_core_eg(x, ks, js, width, strength, grad)
    terms[4] = _wall_eg(x, radius, width, strength, grad)
    return terms[0] + terms[1] + terms[2] + terms[3] + terms[4], grad


# --------------------------------------------------------------------------------------------
# Kernels: Hessian triplets (row, col, value) over the flattened coordinates 2 * node + axis
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _put_block(rows, cols, vals, m, nodes, block):
    """Scatter a (2p, 2p) block over nodes (p,) from triplet index m: into the triplet arrays,
    or, in assembly mode (``cols`` empty), added straight into the CSC data ``vals`` at the
    entries ``rows[m]`` (the pattern's ``where``) names, in the same order."""
    p = nodes.shape[0]
    if cols.shape[0] == 0:
        for a in range(p):
            for b in range(p):
                for u in range(2):
                    for v in range(2):
                        vals[rows[m]] += block[2 * a + u, 2 * b + v]
                        m += 1
        return m
    _put_keys(rows, cols, m, nodes, p)
    for a in range(p):
        for b in range(p):
            for u in range(2):
                for v in range(2):
                    vals[m] = block[2 * a + u, 2 * b + v]
                    m += 1
    return m


@njit(cache=True)
def _put(rows, cols, vals, m, r, c, v):
    """One triplet (r, c, v) at index m, or in assembly mode (``cols`` empty) v added to the
    CSC data at ``rows[m]``; returns m + 1."""
    if cols.shape[0] == 0:
        vals[rows[m]] += v
    else:
        rows[m] = r
        cols[m] = c
        vals[m] = v
    return m + 1


@njit(cache=True)
def _phi_hessian(vx, vy, h):
    """Hessian of the polar angle atan2(vy, vx) with respect to (vx, vy), into h (2, 2)."""
    r4 = (vx * vx + vy * vy) ** 2
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
def _joint(pos, i, k_b, s, theta_p, rest):
    """Joint i's segment vectors a = x_i - x_{i-1}, b = x_{i+1} - x_i, the bending law's f'
    and f'' at its angle, and dθ/da, dθ/db: (ax, ay, bx, by, f', f'', ∂θ/∂a, ∂θ/∂b). Called by
    cached kernels here and in :mod:`crumple.energy_action`: Numba's cache does not see a
    change to a callee, so after editing this function clear ``__pycache__``."""
    ax, ay = pos[i, 0] - pos[i - 1, 0], pos[i, 1] - pos[i - 1, 1]
    bx, by = pos[i + 1, 0] - pos[i, 0], pos[i + 1, 1] - pos[i, 1]
    la2 = ax * ax + ay * ay
    lb2 = bx * bx + by * by
    theta = math.atan2(ax * by - ay * bx, ax * bx + ay * by)
    _, df, d2f = _bend_law(theta - rest[i - 1], k_b, s, theta_p)
    return ax, ay, bx, by, df, d2f, ay / la2, -ax / la2, -by / lb2, bx / lb2


@njit(cache=True)
def _hessian_triplets(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, ks, js, width, strength,
                      project, project_bending=False, radius=math.inf):  # fmt: skip
    """The exact Hessian's triplets, term by term in a fixed order (bending, stretching,
    confinement, the cavity's wall when ``radius`` is finite, the hard core's pairs)."""
    n = pos.shape[0]
    size = 36 * (n - 2) + 16 * (n - 1) + (6 if math.isfinite(radius) else 2) * n
    size += 36 * ks.shape[0]
    rows = np.empty(size, dtype=np.int64)
    cols = np.empty(size, dtype=np.int64)
    vals = np.empty(size)
    m = _hessian_terms(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, ks, js, width,
                       strength, project, project_bending, radius, rows, cols, vals)  # fmt: skip
    return rows[:m], cols[:m], vals[:m]


@njit(cache=True)
def _triplet_keys(n, ks, js, wall):
    """The rows and columns of :func:`_hessian_triplets` for ``n`` nodes, the candidate pairs
    (ks, js) and, with ``wall``, the cavity's wall, without their values: the same triplets in
    the same order (bending, stretching, confinement, the wall, the pairs), all that a new
    pattern needs (``_put_block``'s and ``_put``'s orders)."""
    size = 36 * max(n - 2, 0) + 16 * max(n - 1, 0) + (6 if wall else 2) * n + 36 * ks.shape[0]
    rows = np.empty(size, dtype=np.int64)
    cols = np.empty(size, dtype=np.int64)
    nodes = np.empty(3, dtype=np.int64)
    m = 0
    for i in range(1, n - 1):
        nodes[0], nodes[1], nodes[2] = i - 1, i, i + 1
        m = _put_keys(rows, cols, m, nodes, 3)
    for i in range(n - 1):
        nodes[0], nodes[1] = i, i + 1
        m = _put_keys(rows, cols, m, nodes, 2)
    for i in range(n):
        for u in range(2):
            rows[m] = cols[m] = 2 * i + u
            m += 1
    if wall:
        for i in range(n):
            for u in range(2):
                for v in range(2):
                    rows[m], cols[m] = 2 * i + u, 2 * i + v
                    m += 1
    for p in range(ks.shape[0]):
        nodes[0], nodes[1], nodes[2] = ks[p], js[p], js[p] + 1
        m = _put_keys(rows, cols, m, nodes, 3)
    return rows, cols


@njit(cache=True)
def _put_keys(rows, cols, m, nodes, p):
    """The keys of a (2p, 2p) block over ``nodes[:p]`` from index m, in ``_put_block``'s
    order; returns the next index."""
    for a in range(p):
        for b in range(p):
            for u in range(2):
                for v in range(2):
                    rows[m] = 2 * nodes[a] + u
                    cols[m] = 2 * nodes[b] + v
                    m += 1
    return m


@njit(cache=True)
def _hessian_values(where, nnz, pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, ks, js,
                    width, strength, project, project_bending=False, radius=math.inf):  # fmt: skip
    """The CSC data of the exact Hessian in a known pattern, ``where[e]`` the entry triplet e
    of :func:`_hessian_triplets` adds to: the same sums in the same order (bit for bit its
    triplets scattered), without the triplet arrays. A candidate pair outside the core adds
    nothing (its zeros change no sum: the data start at +0.0 and a sum in round-to-nearest
    never becomes -0.0)."""
    data = np.zeros(nnz)
    _hessian_terms(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, ks, js, width, strength,
                   project, project_bending, radius, where, np.empty(0, dtype=np.int64),
                   data)  # fmt: skip
    return data


@njit(cache=True)
def _hessian_terms(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, ks, js, width, strength,
                   project, project_bending, radius, rows, cols, vals):  # fmt: skip
    """Every term's blocks from triplet index 0 (triplets, or assembly mode: ``_put_block``)."""
    m = _bending_triplets(pos, k_b, s, theta_p, rest, project_bending, rows, cols, vals, 0)
    m = _stretching_triplets(pos, k_s, l0, rows, cols, vals, m)
    m = _confinement_triplets(pos.shape[0], lam, weights, rows, cols, vals, m)
    if math.isfinite(radius):
        m = _wall_triplets(pos, radius, width, strength, rows, cols, vals, m)
    return _contact_triplets(pos, ks, js, width, strength, project, rows, cols, vals, m)


@njit(cache=True)
def _bending_triplets(pos, k_b, s, theta_p, rest, project_bending, rows, cols, vals, m):
    """Bending, one 6 × 6 block per joint from index m: f'' ∇θ∇θᵀ + f' ∇²θ, with
    ∇²θ = -Hφ(a) on a = x_i - x_{i-1}, +Hφ(b) on b. Returns the next index."""
    nodes3 = np.empty(3, dtype=np.int64)
    block6 = np.empty((6, 6))
    g = np.empty(6)
    ha = np.empty((2, 2))
    hb = np.empty((2, 2))
    for i in range(1, pos.shape[0] - 1):
        ax, ay, bx, by, df, d2f, gax, gay, gbx, gby = _joint(pos, i, k_b, s, theta_p, rest)
        g[0], g[1] = -gax, -gay
        g[2], g[3] = gax - gbx, gay - gby
        g[4], g[5] = gbx, gby
        for a in range(6):
            for b in range(6):
                block6[a, b] = d2f * g[a] * g[b]
        _phi_hessian(ax, ay, ha)
        _phi_hessian(bx, by, hb)
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
    return m


@njit(cache=True)
def _stretching_triplets(pos, k_s, l0, rows, cols, vals, m):
    """Stretching, one 4 × 4 block per segment from index m: k_s [u uᵀ + (1 - l0/L)(I - u uᵀ)]
    on the segment vector. Returns the next index."""
    nodes2 = np.empty(2, dtype=np.int64)
    block4 = np.empty((4, 4))
    for i in range(pos.shape[0] - 1):
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
    return m


@njit(cache=True)
def _confinement_triplets(n, lam, weights, rows, cols, vals, m):
    """Confinement, 2 λ w_i I: two diagonal entries per node from index m. Returns the next."""
    for i in range(n):
        for u in range(2):
            m = _put(rows, cols, vals, m, 2 * i + u, 2 * i + u, 2.0 * lam * weights[i])
    return m


@njit(cache=True)
def _wall_triplets(pos, radius, width, strength, rows, cols, vals, m):
    """The cavity, a 2 × 2 block per node from index m: ε b''/d² n nᵀ + ε b'/d ∇²δ, with
    δ = R_c - r, ∇δ = -n, ∇²δ = -(I - n nᵀ)/r, on each node's own block (already in the
    pattern through the stretching blocks); every node writes its block, zeros when away from
    the wall, so the pattern is fixed. Returns the next index."""
    for i in range(pos.shape[0]):
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
                val = c2 * nu * nv + c1 * ((1.0 if u == v else 0.0) - nu * nv)
                m = _put(rows, cols, vals, m, 2 * i + u, 2 * i + v, val)
    return m


@njit(cache=True)
def _contact_triplets(pos, ks, js, width, strength, project, rows, cols, vals, m):
    """The hard core, one 6 × 6 block per candidate pair from index m (zeros outside the core).
    ``project``: 0 (or False) exact; 1 (or True) every block projected on its positive part;
    2 only the blocks of pairs whose closest point is a segment's end (a joint's cap).
    Returns the next index."""
    nodes3 = np.empty(3, dtype=np.int64)
    block6 = np.empty((6, 6))
    g = np.empty(6)
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
            if cols.shape[0] == 0:  # assembly: zeros add nothing
                m += 36
                continue
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
        if project == 1 or (project == 2 and not 0.0 < t < 1.0):
            # keep the positive part only: the negative curvature of a contact is a geometric
            # effect of its force, and left in it forces a large global shift that stalls
            # Newton on the wire's soft modes (docs/model.md); 2: only where the closest point
            # is a segment's end (a joint's cap), whose eigenvalue about -2F/D is the curvature
            # of the polyline's corner at the scale d
            _project_psd(block6)
        m = _put_block(rows, cols, vals, m, nodes3, block6)
    return m


@njit(cache=True)
def _same_pairs(ks, js, ks0, js0):
    """The pair lists (ks, js) and (ks0, js0) are equal."""
    if ks.shape[0] != ks0.shape[0]:
        return False
    for p in range(ks.shape[0]):
        if ks[p] != ks0[p] or js[p] != js0[p]:
            return False
    return True
