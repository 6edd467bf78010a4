"""Centre of mass, radii (r_max, R_G) and contacts of a wire."""

from __future__ import annotations

import math

import numpy as np

from crumple.geometry import as_positions, close_segment_pairs
from crumple.loops import positive_length

from ._common import (
    _segments,
    _weights,
)

__all__ = ["center_of_mass", "count_contacts", "r_max", "radius_of_gyration"]


def center_of_mass(positions, *, weighting: str = "length") -> np.ndarray:
    """Centre of mass of the wire ``[length]``.

    .. math::

        \\mathbf r_{cm} = \\sum_i m_i \\frac{\\mathbf r_i + \\mathbf r_{i+1}}{2},
        \\qquad m_i = l_i / L \\;(\\text{"length"}), \\; 1/N \\;(\\text{"segments"})

    ``"length"`` (default) is the exact centre of mass of a uniform polygonal wire: each
    straight segment's centre of mass is its midpoint, weighted by its length ``l_i`` (``L`` is
    the total length). ``"segments"`` gives every segment the mass ``1/N`` whatever its
    stretch, as the paper's Eq. (3) does; ``"nodes"`` is the plain mean of the nodes (the
    monomers of Eq. 1), which overweights the two end half-segments.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``, ``n_nodes >= 2``.
    weighting : {"length", "segments", "nodes"}

    Returns
    -------
    ndarray, shape (2,)

    Examples
    --------
    >>> center_of_mass([[0, 0], [1, 0], [1, 3]]).tolist()     # segment lengths 1 and 3
    [0.875, 1.125]
    >>> center_of_mass([[0, 0], [1, 0], [1, 3]], weighting="nodes").round(4).tolist()
    [0.6667, 1.0]
    """
    pos = as_positions(positions)
    if weighting == "nodes":
        return pos.mean(axis=0)
    _, lengths = _segments(pos)
    w = _weights(lengths, weighting)
    mid = 0.5 * (pos[:-1] + pos[1:])
    return w @ mid


def r_max(positions, center=None) -> float:
    """Largest distance of the wire from the centre ``[length]``: the paper's ``R_G = r_max``.

    Section III.C defines the size of the crumpled wire as ``R_g = r_max``. The farthest point
    of a straight segment from any point is one of its ends, so the maximum over the nodes is
    exact for the polygonal wire.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``.
    center : array_like, shape (2,), optional
        Default: the centre of mass (:func:`center_of_mass`, length-weighted).

    Returns
    -------
    float

    Examples
    --------
    >>> r_max([[-0.5, 0.0], [0.5, 0.0]])
    0.5
    >>> r_max([[0, 0], [3, 4]], center=[0, 0])
    5.0
    """
    pos = as_positions(positions)
    c = _center(pos, center)
    return float(np.max(np.hypot(*(pos - c).T)))


def radius_of_gyration(positions, center=None, *, weighting: str = "length") -> float:
    """Root-mean-square radius of the uniform wire about the centre ``[length]``.

    .. math::

        R_{rms}^2 = \\sum_i m_i \\frac{|\\mathbf a_i|^2 + \\mathbf a_i\\cdot\\mathbf b_i
                    + |\\mathbf b_i|^2}{3}

    where ``a_i``, ``b_i`` are the ends of segment ``i`` relative to the centre and
    ``(|a|^2 + a·b + |b|^2)/3`` is the exact mean of ``|r|^2`` along the straight segment (not a
    sample at the nodes). With the default centre (the centre of mass) this is the radius of
    gyration of the continuous wire; about any other centre it is the RMS distance from it.
    The paper's Sec. III.C uses ``r_max`` instead (:func:`r_max`).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``.
    center : array_like, shape (2,), optional
        Default: the centre of mass with the same ``weighting``.
    weighting : {"length", "segments"}
        Mass per segment: proportional to its length (uniform wire) or ``1/N`` (Eq. 3).

    Returns
    -------
    float

    Examples
    --------
    >>> round(radius_of_gyration([[-0.5, 0.0], [0.5, 0.0]]) ** 2, 12)     # L^2 / 12
    0.083333333333
    >>> import numpy as np
    >>> phi = np.linspace(0, 2 * np.pi, 2001)
    >>> round(radius_of_gyration(np.c_[np.cos(phi), np.sin(phi)]), 6)    # polygon ~ circle
    0.999999
    """
    pos = as_positions(positions)
    _, lengths = _segments(pos)
    w = _weights(lengths, weighting)
    rel = pos - _center(pos, center, weighting)
    a, b = rel[:-1], rel[1:]
    mean_sq = (np.einsum("ij,ij->i", a, a) + np.einsum("ij,ij->i", a, b)) / 3.0
    mean_sq += np.einsum("ij,ij->i", b, b) / 3.0
    return float(math.sqrt(max(0.0, float(w @ mean_sq))))


def count_contacts(positions, distance: float) -> int:
    """Number of pairs of non-adjacent segments closer than ``distance``.

    Non-adjacent means ``|i - j| >= 2`` (segments sharing a node are always in contact and
    are not counted); crossing pairs have distance 0 and are counted. Uses
    :func:`crumple.geometry.close_segment_pairs` (strict ``<``). A natural ``distance`` is the
    hard-core width of Eq. (1) (``1e-5`` in the paper's Table I), or slightly more. Keep it
    well below the segment length: segments ``i`` and ``i + 2`` are one segment apart along
    the wire and would otherwise count as contacts even on a straight stretch.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``.
    distance : float
        Contact distance ``[length]``, > 0.

    Returns
    -------
    int

    Examples
    --------
    >>> hairpin = [[0, 0], [1, 0], [1, 0.1], [0, 0.1]]
    >>> count_contacts(hairpin, 0.2), count_contacts(hairpin, 0.05)
    (1, 0)
    """
    pos = as_positions(positions)
    dist = positive_length("distance", distance)
    pairs, _ = close_segment_pairs(pos, dist)
    return int(pairs.shape[0])


def _center(pos: np.ndarray, center, weighting: str = "length") -> np.ndarray:
    if center is None:
        return center_of_mass(pos, weighting=weighting)
    try:
        c = np.asarray(center, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"center must be a point (x, y), got {center!r}") from err
    if c.shape != (2,) or not np.all(np.isfinite(c)):
        raise ValueError(f"center must be a finite point (x, y), got {center!r}")
    return c
