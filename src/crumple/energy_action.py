"""The Hessian of the wire's energy applied to a direction, in element form (Numba kernel).

Private: :meth:`crumple.energy.WireEnergy.hessian_action` is what is called. The product H v
is computed joint by joint and segment by segment from the *differences* of v along the wire,

    H v = Σ_i [f''(θ_i) ∇θ_i δθ_i + f'(θ_i) ∇²θ_i v]                      (bending)
        + Σ_j k_s [u_j δl_j + (1 - l0/l_j) (δe_j - u_j δl_j)]              (stretching)
        + 2 λ w v + (the cavity's wall and the hard core's blocks) v,

with δθ_i = ∇θ_i · v (from δa = v_i - v_{i-1} and δb = v_{i+1} - v_i) and δe_j = v_{j+1} - v_j,
δl_j = u_j · δe_j. It is the same matrix as the assembled one (:meth:`WireEnergy.hessian_csc`)
in exact arithmetic, not in floating point: an assembled node-coordinate entry of a bending
block is ~k_b/l², and for a smooth v (the modes that decide stability) H v is what is left
after those entries cancel to ~k_b l² v''''; at N = 10⁵ (6 k_b/l² ≈ 3 × 10¹⁴) the round-off of
the entries alone, ε_mach × 3 × 10¹⁴ ≈ 0.07 each, is ~10⁴ times the curvature of the wire per
unit length (docs/performance.md, "N = 10⁵ fails"). Here the cancellation happens on v's
differences, which are exact to their own round-off, so vᵀHv of a smooth mode keeps its
continuum value. The hard core and the wall are applied through their assembled blocks: they
are local (one block per contact or node) and do not cancel against the chain.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .energy_kernels import _contact_triplets, _joint, _wall_triplets


@njit(cache=True)
def _phi_hessian_times(vx, vy, dx, dy):
    """Hφ(v) d for φ = atan2(vy, vx) (the matrix of ``energy_kernels._phi_hessian``)."""
    r4 = (vx * vx + vy * vy) ** 2
    h00 = 2.0 * vx * vy / r4
    h01 = (vy * vy - vx * vx) / r4
    return h00 * dx + h01 * dy, h01 * dx - h00 * dy


@njit(cache=True)
def _bending_action(pos, k_b, s, theta_p, rest, v, out):
    """Σ_i [f'' ∇θ_i δθ_i + f' ∇²θ_i v] into out (n_nodes, 2); ∇²θ = -Hφ(a) on a, +Hφ(b) on b."""
    for i in range(1, pos.shape[0] - 1):
        ax, ay, bx, by, df, d2f, gax, gay, gbx, gby = _joint(pos, i, k_b, s, theta_p, rest)
        dax, day = v[i, 0] - v[i - 1, 0], v[i, 1] - v[i - 1, 1]
        dbx, dby = v[i + 1, 0] - v[i, 0], v[i + 1, 1] - v[i, 1]
        dtheta = (gax * dax + gay * day) + (gbx * dbx + gby * dby)
        hax, hay = _phi_hessian_times(ax, ay, dax, day)
        hbx, hby = _phi_hessian_times(bx, by, dbx, dby)
        # the product in (a, b), then onto the nodes: a = x_i - x_{i-1}, b = x_{i+1} - x_i
        rax = d2f * gax * dtheta - df * hax
        ray = d2f * gay * dtheta - df * hay
        rbx = d2f * gbx * dtheta + df * hbx
        rby = d2f * gby * dtheta + df * hby
        out[i - 1, 0] -= rax
        out[i - 1, 1] -= ray
        out[i, 0] += rax - rbx
        out[i, 1] += ray - rby
        out[i + 1, 0] += rbx
        out[i + 1, 1] += rby


@njit(cache=True)
def _stretching_action(pos, k_s, l0, v, out):
    """Σ_j k_s [u δl + (1 - l0/l)(δe - u δl)] on each segment e_j = x_{j+1} - x_j, into out."""
    for j in range(pos.shape[0] - 1):
        ex, ey = pos[j + 1, 0] - pos[j, 0], pos[j + 1, 1] - pos[j, 1]
        dex, dey = v[j + 1, 0] - v[j, 0], v[j + 1, 1] - v[j, 1]
        length = math.sqrt(ex * ex + ey * ey)
        ux, uy = ex / length, ey / length
        dl = ux * dex + uy * dey
        c = (length - l0) / length  # the tension over k_s l: exact to the round-off of l
        rx = k_s * (ux * dl + c * (dex - ux * dl))
        ry = k_s * (uy * dl + c * (dey - uy * dl))
        out[j, 0] -= rx
        out[j, 1] -= ry
        out[j + 1, 0] += rx
        out[j + 1, 1] += ry


@njit(cache=True)
def _local_blocks_action(pos, ks, js, width, strength, radius, v, out):
    """The hard core's blocks (every candidate pair) and the wall's (finite ``radius``) times v,
    through their triplets (local blocks: no cancellation along the chain)."""
    n = pos.shape[0]
    wall = math.isfinite(radius)
    size = 36 * ks.shape[0] + (4 * n if wall else 0)
    rows = np.empty(size, dtype=np.int64)
    cols = np.empty(size, dtype=np.int64)
    vals = np.empty(size)
    m = 0
    if wall:
        m = _wall_triplets(pos, radius, width, strength, rows, cols, vals, m)
    m = _contact_triplets(pos, ks, js, width, strength, False, rows, cols, vals, m)
    flat_v = v.reshape(-1)
    flat_out = out.reshape(-1)
    for e in range(m):
        flat_out[rows[e]] += vals[e] * flat_v[cols[e]]


@njit(cache=True)
def _hessian_action(pos, k_b, s, theta_p, rest, k_s, l0, lam, weights, ks, js, width, strength,
                    radius, v):  # fmt: skip
    """H v over the flattened coordinates 2 * node + axis (``v`` of shape (n_nodes, 2)),
    every term of :func:`crumple.energy_kernels._hessian_triplets` (unprojected)."""
    out = np.zeros_like(pos)
    if k_b != 0.0:
        _bending_action(pos, k_b, s, theta_p, rest, v, out)
    _stretching_action(pos, k_s, l0, v, out)
    for i in range(pos.shape[0]):
        c = 2.0 * lam * weights[i]
        out[i, 0] += c * v[i, 0]
        out[i, 1] += c * v[i, 1]
    _local_blocks_action(pos, ks, js, width, strength, radius, v, out)
    return out.reshape(-1)
