"""The feeding channel of the injection protocol: its geometry and the energy of a fed wire.

The cavity (radius R_c, centred at the origin) has its mouth at ``P = (R_c, 0)``. The channel
is the straight line through P along the unit vector ``u`` (pointing into the cavity), at an
angle α from the inward radial ``-P/R_c``. A point at channel coordinate ``t`` sits at
``P + t u``: outside for ``t < 0``, inside the cavity for ``0 < t < 2 R_c cos α``.

The wire is numbered from its tip (node 0, the first in) to its tail. Node i sits at material
coordinate ``σ_i = i L0/N``; with a length ``L_in`` pushed in, a node still held by the
channel sits at ``t = L_in - σ_i``. The nodes held by the channel are *prescribed* (the
minimiser's fixed mask); the others are *free*. A prescribed node becomes free once its
channel position lies at least the wall's barrier width d inside the wall (where the barrier
is zero, so freeing it changes no energy); a free node never goes back.

Energy of a fed wire (:class:`FedWireEnergy`): the wire's own terms (bending, stretching,
hard core; no trap) over every node, and the cavity wall's barrier over the free nodes
only. The prescribed nodes are the channel's business: they sit on or outside the wall, so
the barrier would be infinite there. The joint at the last prescribed node carries the
bending energy of the clamped feed (the angle between the channel and the first free
segment). See ``docs/injection.md``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .energy import DENSE_LIMIT, EnergyTerms, WireEnergy
from .energy_kernels import _barrier
from .linalg import CSC, pin_rows
from .linalg_csc import _position
from .model import Wire

__all__ = ["Channel", "FedWireEnergy"]


class Channel:
    """The straight feeding channel of a cavity: mouth, direction and the node positions it
    prescribes.

    Parameters
    ----------
    radius : float
        Cavity radius R_c ``[length]``.
    angle : float
        Entry angle α ``[rad]`` from the inward radial, ``|α| < π/2`` (0: radial).

    Examples
    --------
    >>> c = Channel(1.0, 0.0)
    >>> c.mouth.tolist(), c.direction.tolist()
    ([1.0, 0.0], [-1.0, 0.0])
    >>> c.positions(np.array([0.0, 0.5, 2.0]), injected=1.0).tolist()
    [[0.0, 0.0], [0.5, 0.0], [2.0, 0.0]]
    """

    def __init__(self, radius: float, angle: float = 0.0):
        self.radius = float(radius)
        self.angle = float(angle)
        if not (math.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"cavity radius must be positive, got {radius!r}")
        if not (math.isfinite(self.angle) and abs(self.angle) < 0.5 * math.pi):
            raise ValueError(f"entry angle must lie in (-pi/2, pi/2) rad, got {angle!r}")
        #: P, shape (2,) ``[length]``
        self.mouth = np.array([self.radius, 0.0])
        #: u, the inward radial (-1, 0) turned by α, shape (2,) (+ 0.0: no negative zeros)
        self.direction = np.array([-math.cos(self.angle), -math.sin(self.angle)]) + 0.0

    def positions(self, sigma, injected: float) -> np.ndarray:
        """Channel positions ``P + (L_in - σ) u`` of material coordinates ``sigma``, shape
        (len(sigma), 2) ``[length]``."""
        t = float(injected) - np.asarray(sigma, dtype=float)
        return self.mouth[None, :] + t[:, None] * self.direction[None, :]

    def chord(self) -> float:
        """Length ``2 R_c cos α`` of the channel line inside the cavity ``[length]``."""
        return 2.0 * self.radius * math.cos(self.angle)

    def release_depth(self, width: float) -> float:
        """The channel coordinate t at which the wall is ``width`` away: a prescribed node
        with ``t`` at least this is released. Smallest root of ``|P + t u| = R_c - width``.

        >>> round(Channel(1.0, 0.0).release_depth(0.01), 12)
        0.01
        """
        r, w = self.radius, float(width)
        if not 0 < w < r:
            raise ValueError(f"width must lie in (0, R_c), got {width!r}")
        c = math.cos(self.angle)
        # t² - 2 R t cos α + R² - (R - w)² = 0
        disc = (r * c) ** 2 - (r * r - (r - w) ** 2)
        if disc < 0:
            raise ValueError(
                f"the channel at angle {self.angle} rad never lies {w} inside a cavity of "
                f"radius {r}: entry too close to tangential"
            )
        return r * c - math.sqrt(disc)


def wall_blocks(x, radius: float, width: float, strength: float):
    """Energy, gradient and 2 × 2 Hessian blocks of the wall barrier ε Σ b((R_c - |x_i|)/d)
    on the rows of ``x`` (shape (m, 2)); the same law as :func:`crumple.energy.cavity_energy`.

    Returns ``(energy, grad (m, 2), near (k,) row indices, blocks (k, 2, 2))``; ``energy`` is
    inf when a row is on or outside the wall.

    >>> e, g, near, b = wall_blocks(np.array([[0.0, 0.0], [0.95, 0.0]]), 1.0, 0.1, 1.0)
    >>> round(e, 12), near.tolist(), g[1].tolist(), b[0].round(6).tolist()
    (0.5, [1], [30.0, 0.0], [[1600.0, 0.0], [0.0, 31.578947]])
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    # d² squared here, not in the kernel: Python's float power and Numba's multiplication
    # differ in the last bit for some d, and the blocks are bit for bit those of before
    e, grad, near, blocks = _wall_kernel(x, float(radius), float(width), float(width) ** 2,
                                         float(strength), True)  # fmt: skip
    return float(e), grad, near, blocks


@njit(cache=True)
def _wall_kernel(x, radius, width, width2, strength, with_blocks):
    """:func:`wall_blocks` (``with_blocks`` False: no blocks, ``near`` empty): each node's
    terms in the order of the NumPy expressions they replace, so the sums are bit for bit."""
    m = x.shape[0]
    grad = np.zeros_like(x)
    r = np.empty(m)
    count = 0
    for i in range(m):
        r[i] = np.hypot(x[i, 0], x[i, 1])
        delta = radius - r[i]
        if delta <= 0.0:
            return math.inf, np.zeros_like(x), np.zeros(0, dtype=np.int64), np.zeros((0, 2, 2))
        count += delta < width
    near = np.empty(count if with_blocks else 0, dtype=np.int64)
    blocks = np.zeros((near.shape[0], 2, 2))
    e = 0.0
    k = 0
    for i in range(m):
        delta = radius - r[i]
        if not delta < width:
            continue
        b, db, d2b = _barrier(delta / width)
        e += strength * b
        nx, ny = x[i, 0] / r[i], x[i, 1] / r[i]
        c0 = -strength * db / width
        grad[i, 0] = c0 * nx
        grad[i, 1] = c0 * ny
        if with_blocks:
            c2 = strength * d2b / width2
            c1 = -strength * db / (width * r[i])
            nn = (nx * nx, nx * ny, ny * nx, ny * ny)
            for a in range(2):
                for c in range(2):
                    o = nn[2 * a + c]
                    blocks[k, a, c] = c2 * o + c1 * ((1.0 if a == c else 0.0) - o)
            near[k] = i
            k += 1
    return e, grad, near, blocks


class FedWireEnergy:
    """Energy of a wire fed through a channel: :class:`crumple.energy.WireEnergy` without its
    trap and wall, plus the wall over the ``free`` nodes only. A minimiser's callable, as
    ``WireEnergy``: ``energy(x) -> (E, grad)``, ``energy.hessian(x)``, ``energy.terms(x)``.

    Parameters
    ----------
    wire : Wire
        Must have a cavity (``cavity_radius``).
    free : array_like of bool, shape (wire.n_nodes,)
        The nodes the wall acts on (those inside, not held by the channel).
    rest_angles : array_like, optional
        As for ``WireEnergy``.
    """

    def __init__(self, wire: Wire, free, *, rest_angles=None):
        if wire.cavity_radius is None:
            raise ValueError("a fed wire needs a cavity (cavity_radius)")
        self.wire = wire
        self.free = np.asarray(free, dtype=bool)
        self._free_idx = np.flatnonzero(self.free)
        self.inner = WireEnergy(wire.replace(cavity_radius=None), 0.0, rest_angles=rest_angles)
        self._lookup = None

    def _wall(self, x, with_blocks=True):
        xf = x[self._free_idx]
        w = self.wire
        if with_blocks:
            return wall_blocks(xf, w.cavity_radius, w.hard_core, w.hard_core_energy)
        e, g, _, _ = _wall_kernel(xf, float(w.cavity_radius), float(w.hard_core), 0.0,
                                  float(w.hard_core_energy), False)  # fmt: skip
        return float(e), g

    def __call__(self, x):
        x = np.ascontiguousarray(x, dtype=np.float64)
        e, g = self.inner(x)
        ew, gw = self._wall(x, with_blocks=False)
        if not math.isfinite(ew):
            return math.inf, g
        g = g.copy()
        g[self._free_idx] += gw
        return e + ew, g

    def terms(self, x) -> EnergyTerms:
        t = self.inner.terms(x)
        ew = self._wall(np.ascontiguousarray(x, dtype=np.float64), with_blocks=False)[0]
        return EnergyTerms(t.bending, t.stretching, t.confinement, t.hard_core, wall=ew)

    def hessian(self, x, *, dense: bool | None = None, project_contacts: bool | str = False):
        """The Hessian of ``WireEnergy`` plus the wall's (positive semi-definite) blocks."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        if dense is None:
            dense = x.size <= DENSE_LIMIT
        if not dense:
            return self.hessian_csc(x, project_contacts=project_contacts).tocsc()
        h = self.inner.hessian(x, dense=True, project_contacts=project_contacts)
        _, _, near, blocks = self._wall(x)
        nodes = self._free_idx[near]
        if nodes.size == 0:
            return h
        rows = (2 * nodes[:, None, None] + np.arange(2)[None, :, None]).repeat(2, axis=2)
        cols = rows.transpose(0, 2, 1)
        np.add.at(h, (rows.ravel(), cols.ravel()), blocks.ravel())
        return h

    def hessian_csc(self, x, *, project_contacts: bool | str = False, pinned: bool = False) -> CSC:
        """The sparse :meth:`hessian` as a :class:`crumple.linalg.CSC` (the minimiser's hot
        path, as :meth:`crumple.energy.WireEnergy.hessian_csc`): the wall's blocks added
        into the data, each node's own 2 × 2 block being in the pattern (stretching).

        ``pinned``: the prescribed nodes' rows and columns made the identity's (as the
        minimiser's ``fixed`` makes them) and the zeros dropped: the entries, and the
        pattern, that the dense Hessian gives as SciPy CSC.
        """
        x = np.ascontiguousarray(x, dtype=np.float64)
        h = self.inner.hessian_csc(x, project_contacts=project_contacts)
        _, _, near, blocks = self._wall(x)
        if near.size:
            data, missing = _add_node_blocks(h.indptr, h.indices, h.data,
                                             self._free_idx[near], blocks)  # fmt: skip
            if missing >= 0:
                raise RuntimeError(f"row {missing} of a wall block is not in the pattern")
            h = CSC(data, h.indices, h.indptr)
        if pinned:
            h = pin_rows(h, np.repeat(~self.free, 2), drop_zeros=True)
            if h is None:
                raise RuntimeError("a prescribed node's diagonal is not in the Hessian's pattern")
        return h


@njit(cache=True)
def _add_node_blocks(indptr, indices, data, nodes, blocks):
    """A copy of the CSC ``data`` with ``blocks[k]`` added on node ``nodes[k]``'s 2 × 2
    diagonal block (rows sorted within each column); and -1, or the first row not stored."""
    out = data.copy()
    for k in range(nodes.shape[0]):
        for a in range(2):
            for c in range(2):
                r = 2 * nodes[k] + a
                at = _position(indptr, indices, r, 2 * nodes[k] + c)
                if at < 0:
                    return out, r
                out[at] += blocks[k, a, c]
    return out, -1
