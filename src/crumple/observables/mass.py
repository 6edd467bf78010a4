"""The mass-size function M(R) (the paper's Eq. 3) and the mass-size exponent D_M."""

from __future__ import annotations

import numpy as np

from crumple.fit import MeanEstimate, PowerLawFit, fit_power_law, mean_confidence_interval
from crumple.geometry import as_positions

from ._common import (
    DEFAULT_N_RADII,
    _fit_range,
    _rg_choice,
    _segments,
    _weights,
)
from .shape import _center, r_max, radius_of_gyration

__all__ = ["ensemble_mass_size_exponent", "mass_size_exponent", "mass_within"]

# Work on at most this many (radius, segment) pairs at once in mass_within (memory ~ 8 x this).
_BLOCK = 2_000_000


# --------------------------------------------------------------------------------------------
# Mass-size function M(R), Eq. (3)
# --------------------------------------------------------------------------------------------


def _inside_lengths_exact(a, d, lengths, ra, rb, radii):
    """Length of each segment inside each disc: shape (n_radii, n_segments).

    Along segment ``a + s u`` (``|u| = 1``, ``0 <= s <= l``) the distance to the centre is
    ``|r|^2 = h^2 + (s - s0)^2`` with ``s0 = -a·u`` the foot of the perpendicular and
    ``h = |a x u|`` its length; inside the disc is ``|s - s0| <= w = sqrt(R^2 - h^2)``.
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        ux = np.where(lengths > 0, d[:, 0] / lengths, 0.0)
        uy = np.where(lengths > 0, d[:, 1] / lengths, 0.0)
    s0 = -(a[:, 0] * ux + a[:, 1] * uy)
    h = np.abs(a[:, 0] * uy - a[:, 1] * ux)
    h = np.where(lengths > 0, h, ra)
    r_far = np.maximum(ra, rb)
    out = np.empty((radii.shape[0], lengths.shape[0]))
    for k, big_r in enumerate(radii):
        w = np.sqrt(np.maximum(big_r * big_r - h * h, 0.0))
        chord = np.minimum(lengths, s0 + w) - np.maximum(0.0, s0 - w)
        chord = np.maximum(chord, 0.0)
        # A segment with both ends in the (convex) disc lies wholly inside: count it exactly.
        out[k] = np.where(r_far <= big_r, lengths, np.where(big_r >= h, chord, 0.0))
    return out


def mass_within(
    positions,
    radii,
    *,
    center=None,
    method: str = "exact",
    weighting: str = "length",
):
    """The mass-size function M(R): fraction of the wire's mass within distance R (Eq. 3).

    .. math::

        M(R) = \\sum_i m_i \\, \\frac{\\ell_i(R)}{l_i}, \\qquad \\sum_i m_i = 1,

    where ``ℓ_i(R)`` is the length of segment ``i`` inside the closed disc of radius ``R``
    about the centre and ``m_i = l_i / L`` (``weighting="length"``, the uniform wire: M is the
    fraction of the total length ``L`` inside the disc) or ``m_i = 1/N`` (``"segments"``, the
    paper's ``1/N`` per segment). For an unstretched wire the two coincide.

    ``method="exact"`` (default) counts the exact length of every segment inside the disc:
    the chord of the segment's line inside the circle is clipped to the segment, so a segment
    with both ends outside that passes through the disc is counted, and a segment may be cut
    twice. ``method="eq3"`` is the paper's Eq. (3) as printed: a whole segment when both ends
    are inside, the exact inside part ``f(r_i, r_{i+1})`` when exactly one end is inside, and
    nothing when both ends are outside, even if the segment passes through the disc. The two
    differ only when a circle of radius R passes between the nodes of a segment that cuts it
    twice (e.g. R smaller than the distance from the centre to the nearest node); ``"eq3"``
    then undercounts and is not continuous in R.

    The paper's ``1/N`` with ``N`` monomers and ``N - 1`` segments would make
    ``M(∞) = (N - 1)/N``; here ``M(R) = 1`` for ``R >= r_max`` exactly, as the paper's Fig. 3
    states ("all mass will already be included in the circle when R = 1").

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``.
    radii : float or array_like, shape (n_radii,)
        Radii ``R >= 0`` ``[length]``, in any order.
    center : array_like, shape (2,), optional
        Default: the centre of mass with the same ``weighting``.
    method : {"exact", "eq3"}
    weighting : {"length", "segments"}

    Returns
    -------
    float or ndarray, shape (n_radii,)
        M(R) in [0, 1] (dimensionless), non-decreasing in R (both methods).

    Examples
    --------
    A straight wire of length 1 through the centre holds ``M = 2R`` for ``R < 1/2``:

    >>> import numpy as np
    >>> wire = np.c_[np.linspace(-0.5, 0.5, 11), np.zeros(11)]
    >>> mass_within(wire, [0.0, 0.123, 0.25, 0.5, 2.0]).round(12).tolist()
    [0.0, 0.246, 0.5, 1.0, 1.0]

    One segment cut twice by the circle: both ends outside, yet 0.8 of its length inside.

    >>> seg = [[-1.0, 0.3], [1.0, 0.3]]
    >>> round(mass_within(seg, 0.5, center=[0, 0]), 12), mass_within(seg, 0.5, center=[0, 0],
    ...     method="eq3")
    (0.4, 0.0)
    """
    pos = as_positions(positions)
    if method not in ("exact", "eq3"):
        raise ValueError(f"method must be 'exact' or 'eq3', got {method!r}")
    d, lengths = _segments(pos)
    w = _weights(lengths, weighting)
    c = _center(pos, center, weighting)
    try:
        r = np.asarray(radii, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"radii must be numbers, got {radii!r}") from err
    scalar = r.ndim == 0
    r = np.atleast_1d(r)
    if r.ndim != 1:
        raise ValueError(f"radii must be a number or a 1-D array, got shape {r.shape}")
    if not np.all(np.isfinite(r)) or np.any(r < 0):
        raise ValueError(f"radii must be finite and >= 0, got {radii!r}")
    rel = pos - c
    dist = np.hypot(rel[:, 0], rel[:, 1])
    a = rel[:-1]
    ra, rb = dist[:-1], dist[1:]
    # fraction of each segment's mass per unit length inside; zero-length segments carry no mass
    # under "length" and their node decides under "segments".
    with np.errstate(invalid="ignore", divide="ignore"):
        density = np.where(lengths > 0, w / lengths, 0.0)
    point_mass = np.where(lengths > 0, 0.0, w)
    out = np.empty(r.shape[0])
    block = max(1, _BLOCK // max(1, lengths.shape[0]))
    for start in range(0, r.shape[0], block):
        rr = r[start : start + block]
        inside = _inside_lengths_exact(a, d, lengths, ra, rb, rr)
        if method == "eq3":
            both_out = (ra[None, :] > rr[:, None]) & (rb[None, :] > rr[:, None])
            inside = np.where(both_out, 0.0, inside)
        # Row sums with numpy's pairwise summation (not BLAS): every radius is summed in the
        # same order, so M is non-decreasing in R to the last bit, whatever the block size.
        m = np.sum(inside * density, axis=1)
        if np.any(point_mass):
            m += np.sum((ra[None, :] <= rr[:, None]) * point_mass, axis=1)
        out[start : start + block] = m
    out = np.clip(out, 0.0, 1.0)
    out[r >= dist.max()] = 1.0
    if scalar:
        return float(out[0])
    return out


# --------------------------------------------------------------------------------------------
# Mass-size exponent D_M
# --------------------------------------------------------------------------------------------


def _size(pos: np.ndarray, c: np.ndarray, rg: str, weighting: str) -> float:
    size = r_max(pos, c) if rg == "r_max" else radius_of_gyration(pos, c, weighting=weighting)
    if not size > 0:
        raise ValueError("the wire has zero size about the centre; R_G = 0")
    return size


def mass_size_exponent(
    positions,
    *,
    rg: str = "r_max",
    fit_range=(0.5, 1.0),
    n_radii: int = DEFAULT_N_RADII,
    center=None,
    method: str = "exact",
    weighting: str = "length",
    confidence: float = 0.95,
) -> PowerLawFit:
    """Mass-size exponent D_M: slope of ln M(R) against ln(R / R_G) (Sec. III.A, Fig. 3).

    .. math::

        M(R) \\propto (R / R_G)^{D_M}, \\qquad \\text{fitted on } R/R_G \\in
        [\\text{fit\\_range}]

    ``R_G`` is ``r_max`` (``rg="r_max"``, the paper's reading, Sec. III.C) or the RMS radius
    (``rg="rms"``, :func:`radius_of_gyration`). M(R) (:func:`mass_within`) is evaluated on
    ``n_radii`` radii log-spaced (equally spaced in ``ln R``, both ends included) over
    ``fit_range * R_G``, and fitted by least squares in log-log space
    (:func:`crumple.fit.fit_power_law`). The paper fits R/R_G in [0.5, 1] to avoid the bias
    of small circles about the centre of mass. The rescaling by R_G only shifts ``ln R`` and
    does not change the exponent.

    The ``stderr`` is that of the regression: M(R) is cumulative, so successive points are
    not independent and it measures how far ln M departs from a straight line over the
    range, not a sampling error; for a statistical error use an ensemble of replicas
    (:func:`ensemble_mass_size_exponent`).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``.
    rg : {"r_max", "rms"}
        Which radius rescales R.
    fit_range : (float, float)
        Range of ``R / R_G`` fitted, ``0 < low < high``.
    n_radii : int
        Number of log-spaced radii, >= 3.
    center : array_like, shape (2,), optional
        Default: the centre of mass.
    method, weighting : str
        As in :func:`mass_within`.
    confidence : float
        Level of the reported interval.

    Returns
    -------
    PowerLawFit
        ``exponent`` is D_M; ``fit_range`` is in units of R_G.

    Examples
    --------
    >>> import numpy as np
    >>> straight = np.c_[np.linspace(0, 1, 101), np.zeros(101)]
    >>> fit = mass_size_exponent(straight)
    >>> round(fit.exponent, 10), fit.fit_range, fit.n_points
    (1.0, (0.5, 1.0), 50)
    """
    pos = as_positions(positions)
    rg = _rg_choice(rg)
    lo, hi = _fit_range(fit_range)
    if not isinstance(n_radii, int | np.integer) or n_radii < 3:
        raise ValueError(f"n_radii must be an integer >= 3, got {n_radii!r}")
    _segments(pos)
    c = _center(pos, center, weighting)
    size = _size(pos, c, rg, weighting)
    scaled = np.geomspace(lo, hi, int(n_radii))
    m = mass_within(pos, scaled * size, center=c, method=method, weighting=weighting)
    if np.any(m <= 0):
        raise ValueError(
            f"M(R) = 0 for some R/R_G in fit_range={fit_range}: no wire within"
            f" R = {lo * size:.3g} of the centre; raise the lower end of fit_range"
        )
    return fit_power_law(scaled, m, confidence=confidence)


def ensemble_mass_size_exponent(
    replicas,
    *,
    rg: str = "r_max",
    fit_range=(0.5, 1.0),
    n_radii: int = DEFAULT_N_RADII,
    method: str = "exact",
    weighting: str = "length",
    confidence: float = 0.95,
    ci: str = "t",
    n_boot: int = 2000,
    rng=None,
) -> MeanEstimate:
    """Mean mass-size exponent over replicas, with a confidence interval.

    Each replica's D_M is measured by :func:`mass_size_exponent` about its own centre of
    mass; the replicas are independent, so the mean's interval is the Student-t one
    (``ci="t"``, default) or a percentile bootstrap over replicas (``ci="bootstrap"``), see
    :func:`crumple.fit.mean_confidence_interval`. The paper averages ten replicas per point
    (Sec. II) and reports D_M = 1.33 (Sec. III.A).

    Parameters
    ----------
    replicas : sequence of array_like, each of shape (n_nodes_k, 2)
        At least two wires ``[length]``.
    rg, fit_range, n_radii, method, weighting : see :func:`mass_size_exponent`.
    confidence : float
        Level of the interval.
    ci : {"t", "bootstrap"}
    n_boot : int
        Bootstrap resamples (``ci="bootstrap"``).
    rng : numpy.random.Generator or int or None
        Randomness of the bootstrap.

    Returns
    -------
    MeanEstimate
        ``value`` is the mean D_M, ``samples`` the per-replica exponents.

    Examples
    --------
    >>> import numpy as np
    >>> s = np.linspace(0, 1, 201)
    >>> waves = [np.c_[s, a * np.sin(6 * np.pi * s)] for a in (0.05, 0.1, 0.15)]
    >>> est = ensemble_mass_size_exponent(waves)
    >>> est.n_samples, est.ci[0] < est.value < est.ci[1]
    (3, True)
    """
    if isinstance(replicas, np.ndarray) and replicas.ndim == 2:
        raise ValueError("replicas must be a sequence of wires, got a single (n_nodes, 2) array")
    try:
        wires = list(replicas)
    except TypeError as err:
        raise ValueError("replicas must be a sequence of (n_nodes, 2) arrays") from err
    if len(wires) < 2:
        raise ValueError(f"an ensemble needs at least 2 replicas, got {len(wires)}")
    exps = [
        mass_size_exponent(
            w, rg=rg, fit_range=fit_range, n_radii=n_radii, method=method, weighting=weighting
        ).exponent
        for w in wires
    ]
    return mean_confidence_interval(exps, confidence=confidence, method=ci, n_boot=n_boot, rng=rng)
