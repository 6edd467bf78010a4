"""The energy allocation γ (Sec. III.B) and everything at once, for the command line."""

from __future__ import annotations

import numpy as np

from crumple.geometry import as_positions, find_crossings
from crumple.loops import loops, positive_length

from ._common import (
    DEFAULT_N_TABLE,
    DEFAULT_TABLE_MIN,
    _fit_range,
    _rg_choice,
    _segments,
)
from .mass import mass_size_exponent, mass_within
from .shape import _center, count_contacts, r_max, radius_of_gyration

__all__ = ["energy_ratio", "measure"]


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
