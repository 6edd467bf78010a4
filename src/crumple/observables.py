"""Measurements on a wire: centre of mass, radii, contacts, the mass-size function and D_M.

Everything here is a pure function of node positions (and, for :func:`energy_ratio`, of
energies already computed); nothing runs a simulation, so the functions apply equally to a
digitised experimental wire.

Conventions
-----------
* ``positions`` has shape ``(n_nodes, 2)`` ``[length]``; segment ``i`` joins nodes ``i`` and
  ``i + 1``. Lengths are in units of the rest length ``L0`` of the wire (normally 1); nothing
  here depends on that choice.
* The wire is a *uniform* polygonal curve: its mass is spread evenly along its length
  (``weighting="length"``, the default everywhere). For a stretched discrete wire the paper's
  Eq. (3) instead gives every segment the same mass ``1/N``; ``weighting="segments"``
  reproduces that (the two agree for an unstretched wire).
* The centre defaults to the centre of mass of that uniform wire (the paper's choice for
  M(R), Sec. III.A); every function accepts an explicit ``center`` ``[length]``, shape (2,).

See ``docs/observables.md`` for the derivations.
"""

from __future__ import annotations

import math

import numpy as np

from crumple.fit import MeanEstimate, PowerLawFit, fit_power_law, mean_confidence_interval
from crumple.geometry import as_positions, close_segment_pairs, find_crossings
from crumple.loops import LoopStats, loops, positive_length

__all__ = [
    "LoopStats",
    "center_of_mass",
    "count_contacts",
    "energy_ratio",
    "ensemble_mass_size_exponent",
    "loops",
    "mass_size_exponent",
    "mass_within",
    "measure",
    "r_max",
    "radius_of_gyration",
]

#: Number of radii, log-spaced over the fit range, on which D_M is fitted by default.
DEFAULT_N_RADII = 50
#: Number of radii in the default ``mass_within`` table of :func:`measure`.
DEFAULT_N_TABLE = 25
#: Smallest radius of that table, as a fraction of ``r_max`` (two decades below the size).
DEFAULT_TABLE_MIN = 1e-2
# Work on at most this many (radius, segment) pairs at once in mass_within (memory ~ 8 x this).
_BLOCK = 2_000_000

_WEIGHTINGS = ("length", "segments")
_RG_CHOICES = ("r_max", "rms")


# --------------------------------------------------------------------------------------------
# Input checks (positions: crumple.geometry.as_positions)
# --------------------------------------------------------------------------------------------


def _segments(pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.diff(pos, axis=0)
    lengths = np.hypot(d[:, 0], d[:, 1])
    if not lengths.sum() > 0:
        raise ValueError("the wire has zero length (all nodes coincide)")
    return d, lengths


def _weights(lengths: np.ndarray, weighting: str) -> np.ndarray:
    """Mass of each segment, summing to 1."""
    if weighting == "length":
        return lengths / lengths.sum()
    if weighting == "segments":
        return np.full(lengths.shape, 1.0 / lengths.shape[0])
    raise ValueError(f"weighting must be one of {_WEIGHTINGS}, got {weighting!r}")


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


def _rg_choice(rg: str) -> str:
    if rg not in _RG_CHOICES:
        raise ValueError(f"rg must be 'r_max' (the paper's R_G) or 'rms', got {rg!r}")
    return rg


def _fit_range(fit_range) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in fit_range)
    except (TypeError, ValueError) as err:
        raise ValueError(
            f"fit_range must be a pair (low, high) of R/R_G values, got {fit_range!r}"
        ) from err
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo < hi):
        raise ValueError(f"fit_range must satisfy 0 < low < high, got {fit_range!r}")
    return lo, hi


# --------------------------------------------------------------------------------------------
# Centre and radii
# --------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------
# Energy allocation, Sec. III.B
# --------------------------------------------------------------------------------------------


def energy_ratio(E_s, E_b, *, on_zero: str = "nan"):
    """Energy allocation γ = E_s / E_b (Sec. III.B, Eq. 4), element-wise.

    Works on scalars or arrays of any broadcastable shape: one value per stage of a ramp,
    per replica, or both (e.g. shape ``(n_replicas, n_stages)``). For an ensemble value per
    stage, pass each stage's ratios to :func:`crumple.fit.mean_confidence_interval` (mean of
    ratios) or take ``energy_ratio(E_s.mean(0), E_b.mean(0))`` (ratio of means); the two
    differ at second order in the replica-to-replica scatter.

    Policy for ``E_b = 0`` (a straight wire: γ is undefined, or infinite if ``E_s > 0``):
    ``on_zero="nan"`` (default) returns NaN there, so a ramp's early straight stages do not
    stop a whole table; ``on_zero="raise"`` raises ``ValueError``. Energies must be
    non-negative (both terms of Eq. 1 are); NaN inputs propagate.

    Parameters
    ----------
    E_s, E_b : float or array_like
        Stretching and bending energies ``[energy]`` (the paper's units), >= 0.
    on_zero : {"nan", "raise"}

    Returns
    -------
    float or ndarray
        γ (dimensionless), of the broadcast shape.

    Examples
    --------
    >>> energy_ratio(2.0, 8.0)
    0.25
    >>> energy_ratio([1.0, 0.0, 3.0], [2.0, 0.0, 1.5]).tolist()
    [0.5, nan, 2.0]
    """
    if on_zero not in ("nan", "raise"):
        raise ValueError(f"on_zero must be 'nan' or 'raise', got {on_zero!r}")
    try:
        es = np.asarray(E_s, dtype=float)
        eb = np.asarray(E_b, dtype=float)
        es, eb = np.broadcast_arrays(es, eb)
    except (TypeError, ValueError) as err:
        raise ValueError(
            f"E_s and E_b must be numbers or arrays of matching shape, got {E_s!r}, {E_b!r}"
        ) from err
    if np.any(es < 0) or np.any(eb < 0):
        raise ValueError("energies must be non-negative: E_s and E_b are sums of squares (Eq. 1)")
    zero = eb == 0
    if on_zero == "raise" and np.any(zero):
        where = np.argwhere(zero).tolist() if eb.ndim else []
        raise ValueError(f"E_b = 0 (straight wire): gamma = E_s/E_b is undefined at {where}")
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma = np.where(zero, np.nan, es / np.where(zero, 1.0, eb))
    if gamma.ndim == 0:
        return float(gamma)
    return gamma


# --------------------------------------------------------------------------------------------
# Everything at once, for the command line
# --------------------------------------------------------------------------------------------


def measure(
    positions,
    *,
    center=None,
    radii=None,
    rg: str = "r_max",
    fit_range=(0.5, 1.0),
    contact_distance: float = 2e-5,
    loop_distance: float | None = None,
) -> dict:
    """All observables of one wire as a JSON-able dict (what ``crumple measure`` prints).

    Keys:

    * ``center``: ``[x, y]`` used for every radius (the centre of mass unless given);
    * ``r_max``: :func:`r_max` (the paper's R_G);
    * ``radius_of_gyration``: RMS radius, :func:`radius_of_gyration`;
    * ``contacts``: :func:`count_contacts` at ``contact_distance`` (default ``2e-5``: twice
      the hard-core width of Table I, the distance of the contacts a sweep stores,
      ``crumple.stage_observables.CONTACT_DISTANCE``);
    * ``crossings``: number of intersecting segment pairs,
      ``len(crumple.geometry.find_crossings(positions))`` (0 for a physical wire);
    * ``mass_size_exponent``: ``{"value", "stderr", "fit_range", "n_points", "rg"}`` from
      :func:`mass_size_exponent` (``fit_range`` in units of R_G);
    * ``mass_within``: list of ``[R, M(R)]`` (Eq. 3, exact lengths) at ``radii``, or by default
      at 25 radii log-spaced from ``r_max / 100`` to ``r_max``;
    * ``loops``: :meth:`LoopStats.to_dict` of :func:`loops` at ``loop_distance`` (default
      ``contact_distance``, i.e. twice the hard-core width): ``count``,
      ``counts_by_depth``, ``area`` (the distribution's count, total, mean, min, quartiles,
      max), ``contact_distance``, ``min_width``; ``None`` for a wire that crosses itself.

    All values are plain Python floats, ints and lists.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        Node coordinates ``[length]``, at least 2 nodes, finite, non-zero total length.
    center : array_like, shape (2,), optional
    radii : array_like, shape (n_radii,), optional
        Radii ``>= 0`` ``[length]`` of the ``mass_within`` table.
    rg : {"r_max", "rms"}
    fit_range : (float, float)
        ``R / R_G`` range of the D_M fit.
    contact_distance : float
        ``[length]``, > 0.
    loop_distance : float, optional
        Contact distance of :func:`loops` ``[length]``, > 0. Default ``contact_distance``.

    Returns
    -------
    dict

    Examples
    --------
    >>> import json
    >>> out = measure([[-0.5, 0.0], [0.0, 0.0], [0.5, 0.0]], radii=[0.25])
    >>> out["center"], out["r_max"], out["crossings"], out["mass_within"]
    ([0.0, 0.0], 0.5, 0, [[0.25, 0.5]])
    >>> round(out["mass_size_exponent"]["value"], 10)
    1.0
    >>> out["loops"]["count"], out["loops"]["contact_distance"]
    (0, 2e-05)
    >>> json.loads(json.dumps(out)) == out
    True
    """
    pos = as_positions(positions)
    _segments(pos)
    rg = _rg_choice(rg)
    lo, hi = _fit_range(fit_range)
    c = _center(pos, center)
    size = r_max(pos, c)
    if not size > 0:
        raise ValueError("the wire has zero size about the centre; R_G = 0")
    if radii is None:
        table_r = np.geomspace(DEFAULT_TABLE_MIN * size, size, DEFAULT_N_TABLE)
    else:
        try:
            table_r = np.asarray(radii, dtype=float)
        except (TypeError, ValueError) as err:
            raise ValueError(f"radii must be a list of numbers, got {radii!r}") from err
        if table_r.ndim != 1 or table_r.shape[0] == 0:
            raise ValueError(f"radii must be a non-empty list of numbers, got {radii!r}")
        if not np.all(np.isfinite(table_r)) or np.any(table_r < 0):
            raise ValueError(f"radii must be finite and >= 0, got {radii!r}")
    dist = positive_length("contact_distance", contact_distance)
    loop_dist = dist if loop_distance is None else positive_length("loop_distance", loop_distance)
    fit = mass_size_exponent(pos, rg=rg, fit_range=(lo, hi), center=c)
    m = mass_within(pos, table_r, center=c)
    crossings = int(find_crossings(pos).shape[0])
    loop_stats = None if crossings else loops(pos, contact_distance=loop_dist).to_dict()
    return {
        "center": [float(c[0]), float(c[1])],
        "r_max": float(size),
        "radius_of_gyration": radius_of_gyration(pos, c),
        "contacts": count_contacts(pos, dist),
        "crossings": crossings,
        "mass_size_exponent": {
            "value": float(fit.exponent),
            "stderr": float(fit.stderr),
            "fit_range": [lo, hi],
            "n_points": int(fit.n_points),
            "rg": rg,
        },
        "mass_within": [[float(rr), float(mm)] for rr, mm in zip(table_r, m, strict=True)],
        "loops": loop_stats,
    }
