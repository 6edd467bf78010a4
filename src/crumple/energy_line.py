"""Numba kernels of the energy along a line, for Powell's line searches (:mod:`crumple.powell`,
through :meth:`crumple.energy.WireEnergy.line_kernels`). Private; split from
:mod:`crumple.energy_kernels` by concept.

params = (k_b, s, theta_p, rest, k_s, l0, lam, weights, cx, cy, width, strength, reach); x and
d are flat (2 n_nodes,). No cavity: a wire with one goes through the Python path.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .energy_kernels import _elastic_eg, _hard_core_eg
from .geometry.ccd import _max_safe_fraction
from .geometry.crossings import _crossing_candidates
from .geometry.distance import _node_segment_pairs


@njit(cache=True)
def _line_prepare(x, d, params):
    """The admissible steps t in [lo, hi] along d from x, and the hard core's pairs over them.

    [lo, hi]: no node moves further than ``reach`` and, by continuous collision detection,
    no node touches a segment on the way (so no two segments cross: the path is admissible,
    not only its points). The pairs: every (node, segment) within ``width + 2 reach`` at x,
    which holds every pair within ``width`` anywhere on the interval (a node-segment distance
    changes by at most the displacement of the node plus that of the segment).
    """
    width, reach = params[10], params[12]
    n = x.shape[0] // 2
    pos = x.reshape((n, 2))
    dd = d.reshape((n, 2))
    dmax = 0.0
    for i in range(n):
        dmax = max(dmax, dd[i, 0] * dd[i, 0] + dd[i, 1] * dd[i, 1])
    dmax = math.sqrt(dmax)
    if dmax == 0.0:
        empty = np.empty(0, dtype=np.int64)
        return 0.0, 0.0, (empty, empty)
    span = reach / dmax
    step = dd * span
    hi = _max_safe_fraction(pos, step) * span
    lo = -_max_safe_fraction(pos, -step) * span
    ks, js = _node_segment_pairs(pos, width + 2.0 * reach)
    return lo, hi, (ks, js)


@njit(cache=True)
def _line_energy(x, d, t, params, aux):
    """E(x + t d): the terms of ``_total_eg`` (no wall) summed in its order; +inf at a contact."""
    k_b, s, theta_p, rest, k_s, l0, lam, weights, cx, cy, width, strength, _ = params
    ks, js = aux
    n = x.shape[0] // 2
    y = (x + t * d).reshape((n, 2))
    grad = np.zeros((n, 2))
    terms = np.zeros(5)
    _elastic_eg(y, k_b, s, theta_p, rest, k_s, l0, lam, weights, cx, cy, grad, terms)
    terms[3] = _hard_core_eg(y, ks, js, width, strength, grad)
    e = terms[0] + terms[1] + terms[2] + terms[3] + terms[4]
    return e if math.isfinite(e) else math.inf


@njit(cache=True)
def _line_admissible(y, params):
    """No two segments of the flat configuration y intersect. Conservative: a pair whose
    floating-point orientation test is uncertain (decided exactly in
    :func:`crumple.geometry.has_crossings`) counts as crossing, so such a point is refused."""
    n = y.shape[0] // 2
    hits, unsure = _crossing_candidates(y.reshape((n, 2)), True)
    return hits.shape[0] == 0 and unsure.shape[0] == 0
