"""Constants and input checks shared by the observables."""

from __future__ import annotations

import math

import numpy as np

#: Number of radii, log-spaced over the fit range, on which D_M is fitted by default.
DEFAULT_N_RADII = 50
#: Number of radii in the default ``mass_within`` table of :func:`measure`.
DEFAULT_N_TABLE = 25
#: Smallest radius of that table, as a fraction of ``r_max`` (two decades below the size).
DEFAULT_TABLE_MIN = 1e-2

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
