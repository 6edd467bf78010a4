"""Numba kernels of the hard core's barriers a step may enter or leave, as the one-sided springs
of the Newton model (:meth:`crumple.energy.WireEnergy.barriers`). Private.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry.distance import _point_segment


@njit(cache=True)
def _step_reach(step, k, j):
    """|step_k| and max(|step_j|, |step_j+1|): together, the most a step can change the
    distance of node k to segment j."""
    sk = math.sqrt(step[k, 0] ** 2 + step[k, 1] ** 2)
    sa = math.sqrt(step[j, 0] ** 2 + step[j, 1] ** 2)
    sb = math.sqrt(step[j + 1, 0] ** 2 + step[j + 1, 1] ** 2)
    return sk, max(sa, sb)


@njit(cache=True)
def _linearised(dist, t, nx, ny, step, k, j):
    """The pair's distance after ``step``, linearised: D + ∇Dᵀ step."""
    lin = dist + nx * (step[k, 0] - (1.0 - t) * step[j, 0] - t * step[j + 1, 0])
    lin += ny * (step[k, 1] - (1.0 - t) * step[j, 1] - t * step[j + 1, 1])
    return lin


@njit(cache=True)
def _put_row(index, value, c, k, j, t, nx, ny, sign):
    """Row c: the coordinates of node k and segment j's ends, and sign × ∇D over them."""
    index[c, 0], index[c, 1] = 2 * k, 2 * k + 1
    index[c, 2], index[c, 3] = 2 * j, 2 * j + 1
    index[c, 4], index[c, 5] = 2 * j + 2, 2 * j + 3
    value[c, 0], value[c, 1] = sign * nx, sign * ny
    value[c, 2], value[c, 3] = sign * (-(1.0 - t) * nx), sign * (-(1.0 - t) * ny)
    value[c, 4], value[c, 5] = sign * (-t * nx), sign * (-t * ny)


@njit(cache=True)
def _barrier_rows(pos, step, ks, js, width, margin=-1.0):
    """Candidate pairs outside the core (D >= d) that ``step`` could bring inside it.

    A pair's distance falls by at most |step_k| + max(|step_j|, |step_j+1|); those that can
    reach d, and (with ``margin`` >= 0) whose linearised distance after the step is below
    d + margin (D - d), get a row a = ∇D (over the flattened coordinates 2 * node + axis: node
    k, segment ends j and j + 1) and an offset r = d - D <= 0, so that the linearised distance
    after a step s, D + aᵀs, is below d exactly when aᵀs < r.
    """
    m = ks.shape[0]
    index = np.empty((m, 6), dtype=np.int64)
    value = np.empty((m, 6))
    offset = np.empty(m)
    c = 0
    for q in range(m):
        k, j = ks[q], js[q]
        dist, t, vx, vy = _point_segment(
            pos[k, 0], pos[k, 1], pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1]
        )
        if dist < width:
            continue
        sk, sj = _step_reach(step, k, j)
        if dist - sk - sj >= width:
            continue
        nx, ny = vx / dist, vy / dist
        # keep only pairs the step itself drives most of the way in
        if margin >= 0.0 and _linearised(dist, t, nx, ny, step, k, j) >= width + margin * (
            dist - width
        ):
            continue
        _put_row(index, value, c, k, j, t, nx, ny, 1.0)
        offset[c] = width - dist
        c += 1
    return index[:c], value[:c], offset[:c]


@njit(cache=True)
def _release_rows(pos, step, ks, js, width, margin):
    """Candidate pairs inside the core (D < d) that ``step``, linearised, takes to beyond
    d - margin (d - D): the pairs the step may release. Each gets the row -a = -∇D, the offset
    -(d - D) < 0 and its u = D/d, so that the linearised distance after a step s is beyond d
    exactly when (-a)ᵀs < -(d - D): in the form of :func:`_barrier_rows`' springs, which the
    Newton model adds with a negative stiffness (:meth:`crumple.energy.WireEnergy.barriers`).
    """
    m = ks.shape[0]
    index = np.empty((m, 6), dtype=np.int64)
    value = np.empty((m, 6))
    offset = np.empty(m)
    u = np.empty(m)
    c = 0
    for q in range(m):
        k, j = ks[q], js[q]
        dist, t, vx, vy = _point_segment(
            pos[k, 0], pos[k, 1], pos[j, 0], pos[j, 1], pos[j + 1, 0], pos[j + 1, 1]
        )
        if dist >= width or dist <= 0.0:
            continue
        sk, sj = _step_reach(step, k, j)
        if dist + sk + sj < width:
            continue
        nx, ny = vx / dist, vy / dist
        if _linearised(dist, t, nx, ny, step, k, j) <= width - margin * (width - dist):
            continue
        _put_row(index, value, c, k, j, t, nx, ny, -1.0)
        offset[c] = dist - width
        u[c] = dist / width
        c += 1
    return index[:c], value[:c], offset[:c], u[:c]
