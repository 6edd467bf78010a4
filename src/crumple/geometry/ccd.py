"""Continuous collision detection: how far every node may move along a direction."""

from __future__ import annotations

import numpy as np
from numba import njit

from ._input import _as_positions
from .cells import _build_hash, _cell, _cell_hash, _cell_size

# --------------------------------------------------------------------------------------------
# Continuous collision detection: how far may every node move along a direction
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


@njit(cache=True)
def _first_contact_collinear(e0x, e0y, dex, dey, q0x, q0y, dqx, dqy):
    """First contact of a point and a segment that stay on one common line.

    Along a unit vector u of that line, the point is at P(t) = q(t)·u and the segment spans
    [0, E(t)] with E(t) = e(t)·u (both linear in t, relative to the segment's start): contact
    when P lies between 0 and E, first at t = 0 or where P = 0 or P = E.
    """
    ux, uy = e0x, e0y
    for vx, vy in ((q0x, q0y), (dqx, dqy), (dex, dey)):
        if vx * vx + vy * vy > ux * ux + uy * uy:
            ux, uy = vx, vy
    norm = np.sqrt(ux * ux + uy * uy)
    if norm == 0.0:
        return 0.0  # everything at one point
    ux, uy = ux / norm, uy / norm
    p0, dp = q0x * ux + q0y * uy, dqx * ux + dqy * uy
    s0, ds = e0x * ux + e0y * uy, dex * ux + dey * uy
    best = 2.0
    cands = np.array([0.0, -p0 / dp if dp != 0.0 else 2.0,
                      (s0 - p0) / (dp - ds) if dp != ds else 2.0])  # fmt: skip
    for t in cands:
        if 0.0 <= t <= 1.0:
            pt, st = p0 + t * dp, s0 + t * ds
            tol = 1e-12 * (abs(pt) + abs(st))
            if min(0.0, st) - tol <= pt <= max(0.0, st) + tol:
                best = min(best, t)
    return best


@njit(cache=True)
def _first_contact(p0x, p0y, dpx, dpy, a0x, a0y, dax, day, b0x, b0y, dbx, dby):
    """Earliest t in [0, 1] at which point p(t) lies on segment a(t)b(t), or 2.0 if none.

    Collinearity of p - a with b - a is a quadratic in t; each root in [0, 1] is a contact when
    the projection parameter lies in [0, 1] (widened by 1e-9 to stay on the safe side).
    """
    e0x, e0y = b0x - a0x, b0y - a0y
    dex, dey = dbx - dax, dby - day
    q0x, q0y = p0x - a0x, p0y - a0y
    dqx, dqy = dpx - dax, dpy - day
    c = _cross(e0x, e0y, q0x, q0y)
    b = _cross(e0x, e0y, dqx, dqy) + _cross(dex, dey, q0x, q0y)
    a = _cross(dex, dey, dqx, dqy)
    roots = np.empty(2)
    nr = 0
    scale = abs(a) + abs(b) + abs(c)
    if scale == 0.0:
        return _first_contact_collinear(e0x, e0y, dex, dey, q0x, q0y, dqx, dqy)
    if abs(a) <= 1e-14 * scale:
        if b != 0.0:
            roots[0] = -c / b
            nr = 1
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            sq = np.sqrt(disc)
            q = -0.5 * (b + sq) if b >= 0.0 else -0.5 * (b - sq)
            r1 = q / a
            r2 = c / q if q != 0.0 else r1
            roots[0] = min(r1, r2)
            roots[1] = max(r1, r2)
            nr = 2
    for k in range(nr):
        t = roots[k]
        if t < 0.0 or t > 1.0:
            continue
        ex, ey = e0x + t * dex, e0y + t * dey
        qx, qy = q0x + t * dqx, q0y + t * dqy
        ee = ex * ex + ey * ey
        s = (qx * ex + qy * ey) / ee if ee > 0.0 else 0.0
        if -1e-9 <= s <= 1.0 + 1e-9:
            return t
    return 2.0


@njit(cache=True)
def _max_safe_fraction(pos, step):
    """Largest t in (0, 1] such that moving pos by t * step causes no node-segment contact."""
    n = pos.shape[0]
    ns = n - 1
    lox = np.empty(ns)
    loy = np.empty(ns)
    hix = np.empty(ns)
    hiy = np.empty(ns)
    for i in range(ns):
        lox[i] = min(
            pos[i, 0], pos[i + 1, 0], pos[i, 0] + step[i, 0], pos[i + 1, 0] + step[i + 1, 0]
        )
        hix[i] = max(
            pos[i, 0], pos[i + 1, 0], pos[i, 0] + step[i, 0], pos[i + 1, 0] + step[i + 1, 0]
        )
        loy[i] = min(
            pos[i, 1], pos[i + 1, 1], pos[i, 1] + step[i, 1], pos[i + 1, 1] + step[i + 1, 1]
        )
        hiy[i] = max(
            pos[i, 1], pos[i + 1, 1], pos[i, 1] + step[i, 1], pos[i + 1, 1] + step[i + 1, 1]
        )
    ox = lox.min()
    oy = loy.min()
    h = _cell_size(lox, loy, hix, hiy)
    start, item, cx, cy, mask = _build_hash(lox, loy, hix, hiy, ox, oy, h)
    tmin = 2.0
    for k in range(n):
        plx = min(pos[k, 0], pos[k, 0] + step[k, 0])
        phx = max(pos[k, 0], pos[k, 0] + step[k, 0])
        ply = min(pos[k, 1], pos[k, 1] + step[k, 1])
        phy = max(pos[k, 1], pos[k, 1] + step[k, 1])
        x0 = _cell(plx, ox, h)
        x1 = _cell(phx, ox, h)
        y0 = _cell(ply, oy, h)
        y1 = _cell(phy, oy, h)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                bkt = _cell_hash(ix, iy, mask)
                for e in range(start[bkt], start[bkt + 1]):
                    j = item[e]
                    if j == k or j + 1 == k or cx[e] != ix or cy[e] != iy:
                        continue
                    if lox[j] > phx or plx > hix[j] or loy[j] > phy or ply > hiy[j]:
                        continue
                    t = _first_contact(
                        pos[k, 0], pos[k, 1], step[k, 0], step[k, 1],
                        pos[j, 0], pos[j, 1], step[j, 0], step[j, 1],
                        pos[j + 1, 0], pos[j + 1, 1], step[j + 1, 0], step[j + 1, 1],
                    )  # fmt: skip
                    tmin = min(tmin, t)
    return min(tmin, 1.0)


def max_safe_fraction(positions, step) -> float:
    """Continuous collision detection along a straight path.

    The largest ``t`` in ``[0, 1]`` such that no node touches a segment it does not belong to
    while the wire moves from ``positions`` to ``positions + t' * step`` for every ``t' < t``.
    In the plane, two segments can begin to cross only through such a node-segment contact,
    so a crossing-free wire stays crossing-free along the whole path up to ``t``. Returns 1.0
    when the whole step is safe.

    Parameters
    ----------
    positions, step : array_like, shape (n_nodes, 2)
        Start configuration and displacement ``[length]``.

    Examples
    --------
    >>> pos = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.5, 1.0], [0.5, 0.5]])
    >>> step = np.zeros_like(pos); step[4] = [0.0, -1.0]          # last node dives through
    >>> round(max_safe_fraction(pos, step), 6)                     # segment 0 at y = 0
    0.5
    """
    pos = _as_positions(positions)
    stp = _as_positions(step)
    if stp.shape != pos.shape:
        raise ValueError(f"step has shape {stp.shape}, positions {pos.shape}")
    return _safe_fraction(pos, stp)


def _safe_fraction(pos: np.ndarray, step: np.ndarray) -> float:
    """:func:`max_safe_fraction` of checked float arrays of one shape (n_nodes, 2), without
    the checks: the minimiser's hot path, where both are its own finite arrays."""
    if pos.shape[0] < 3:
        return 1.0
    return float(_max_safe_fraction(pos, step))


def disc_exit_fraction(positions, step, radius: float) -> float:
    """Continuous collision detection against a circle: the largest ``t`` in ``[0, 1]`` such
    that every node stays strictly inside the disc ``|x| < radius`` (centred at the origin)
    while the wire moves from ``positions`` to ``positions + t' * step``, ``t' < t``.

    Node i leaves at the positive root of ``|x_i + t p_i|² = radius²`` (one positive root,
    since the start is inside). The disc is convex, so a segment whose two ends are inside
    lies inside: testing the nodes is enough. Returns 1.0 when the whole step stays inside.

    Parameters
    ----------
    positions, step : array_like, shape (n_nodes, 2)
        Start configuration (every node inside) and displacement ``[length]``.
    radius : float
        Radius of the disc ``[length]``.

    Examples
    --------
    >>> round(disc_exit_fraction([[0.5, 0.0]], [[1.0, 0.0]], 1.0), 12)   # reaches x = 1 at t = ½
    0.5
    >>> disc_exit_fraction([[0.5, 0.0]], [[-1.0, 0.0]], 1.0)              # inward: whole step
    1.0
    """
    pos = _as_positions(positions)
    stp = _as_positions(step)
    if stp.shape != pos.shape:
        raise ValueError(f"step has shape {stp.shape}, positions {pos.shape}")
    a = np.einsum("ij,ij->i", stp, stp)
    b = np.einsum("ij,ij->i", pos, stp)
    c = np.einsum("ij,ij->i", pos, pos) - float(radius) ** 2  # < 0 inside
    moving = a > 0
    if not np.any(moving):
        return 1.0
    a, b, c = a[moving], b[moving], c[moving]
    root = np.sqrt(np.maximum(b * b - a * c, 0.0))
    # the positive root of a t² + 2 b t + c, written without cancellation
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(b > 0, -c / (b + root), (root - b) / a)
    t = np.where(c < 0, t, 0.0)  # a node already on or outside the circle: no safe step
    return float(min(1.0, np.min(t)))
