"""A curved step of a chain: its segments turned and stretched instead of their ends moved.

Moving the nodes of a chain by ``α p`` along a straight line lengthens every segment that the
step turns: a segment of length l turned by δφ grows by about l δφ²/2. A stiff chain (a wire
whose stretching stiffness is 10⁵ times its bending's) then meets, at second order in α, a
stretching energy that the step's quadratic model did not see, and a Newton step along a large
rotation is cut back to a fraction of itself. :func:`curved_step` moves the chain along a curve
with the same tangent ``p`` at α = 0 that turns each segment by its linearised rotation
``δφ = (e × δe)/|e|²`` and stretches it by its linearised length change ``(e · δe)/|e|``: a
rigid rotation about the centroid is then exact at any angle, and a turn adds no stretch.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._input import as_positions

__all__ = ["curved_step"]


def curved_step(positions, step, alpha: float = 1.0) -> np.ndarray:
    """The chain after the step ``alpha * step`` taken along the curve of turned segments.

    Segment i, ``e = x[i+1] - x[i]``, becomes ``(1 + e·δe/|e|²) R(δφ) e``, with
    ``δe = α (p[i+1] - p[i])`` and ``δφ = (e × δe)/|e|²``; the chain is rebuilt along them
    and translated so that its centroid moves as that of ``positions + alpha * step``. To
    first order in α this is the straight step (its tangent at α = 0 is ``step``); a uniform
    translation is exact, and so is a rigid rotation about the centroid
    (``step = ω J (x - x̄)``, J the quarter turn) at any angle ω. The second-order part is
    added as a correction to the straight step, computed from small quantities, so
    rebuilding the chain adds no round-off of the size of the coordinates.

    >>> x = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    >>> p = np.array([[0.0, 1.0], [0.0, 0.0], [0.0, -1.0]])   # turning about the middle node
    >>> np.round(curved_step(x, p, np.pi / 2), 12).tolist()     # a quarter turn, clockwise
    [[1.0, 1.0], [1.0, 0.0], [1.0, -1.0]]
    >>> np.round(x + np.pi / 2 * p, 3).tolist()                 # the straight step stretches
    [[0.0, 1.571], [1.0, 0.0], [2.0, -1.571]]
    """
    x = as_positions(positions)
    p = np.ascontiguousarray(step, dtype=np.float64)
    if p.shape != x.shape:
        raise ValueError(f"step must have the shape of positions {x.shape}, got {p.shape}")
    if not (np.all(np.isfinite(p)) and math.isfinite(alpha)):
        raise ValueError("step and alpha must be finite")
    if np.any(np.all(x[1:] == x[:-1], axis=1)):
        raise ValueError("a segment of zero length has no direction to turn")
    return _curved_step(x, p, float(alpha))


@njit(cache=True)
def _curved_step(x, p, alpha):
    """:func:`curved_step` on checked arrays: x + αp + (C - mean C), C_i the sum over the
    segments before node i of r_j = s R(δφ) e_j - e_j - δe_j, written as
    -2 s sin²(δφ/2) e + ((s - 1) sin δφ + (sin δφ - δφ)) J e so that each term is formed
    from second-order quantities."""
    n = x.shape[0]
    corr = np.empty_like(x)
    corr[0, 0] = corr[0, 1] = 0.0
    cx = cy = 0.0
    sx = sy = 0.0
    for i in range(n - 1):
        ex, ey = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1]
        dx, dy = alpha * (p[i + 1, 0] - p[i, 0]), alpha * (p[i + 1, 1] - p[i, 1])
        l2 = ex * ex + ey * ey
        phi = (ex * dy - ey * dx) / l2
        s1 = (ex * dx + ey * dy) / l2  # s - 1
        sn = math.sin(phi)
        h = math.sin(0.5 * phi)
        a = -2.0 * (1.0 + s1) * h * h  # along e
        b = s1 * sn + (sn - phi)  # along J e = (-e_y, e_x)
        cx += a * ex - b * ey
        cy += a * ey + b * ex
        corr[i + 1, 0] = cx
        corr[i + 1, 1] = cy
        sx += cx
        sy += cy
    mx, my = sx / n, sy / n
    y = np.empty_like(x)
    for i in range(n):
        y[i, 0] = x[i, 0] + alpha * p[i, 0] + (corr[i, 0] - mx)
        y[i, 1] = x[i, 1] + alpha * p[i, 1] + (corr[i, 1] - my)
    return y


@njit(cache=True)
def _largest_turn(x, p, alpha):
    """The largest |δφ| = |e × δe|/|e|² over the segments of the step ``alpha * p``: the
    linearised rotation :func:`curved_step` gives a segment (radians)."""
    turn = 0.0
    for i in range(x.shape[0] - 1):
        ex, ey = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1]
        dx, dy = alpha * (p[i + 1, 0] - p[i, 0]), alpha * (p[i + 1, 1] - p[i, 1])
        turn = max(turn, abs(ex * dy - ey * dx) / (ex * ex + ey * ey))
    return turn
