"""The one input check of every function of positions."""

from __future__ import annotations

import numpy as np


def as_positions(positions, *, min_nodes: int = 2) -> np.ndarray:
    """``positions`` as a finite float array of shape (n_nodes, 2), ``n_nodes >= min_nodes``.

    Raises ValueError with a message naming what is wrong (not numbers, wrong shape, too few
    nodes, NaN or infinite values): the one input check of every function of positions.
    """
    try:
        pos = np.asarray(positions, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"positions must be an array of numbers, got {positions!r}") from err
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions must have shape (n_nodes, 2), got {pos.shape}")
    if pos.shape[0] < min_nodes:
        raise ValueError(f"a wire needs at least {min_nodes} nodes, got {pos.shape[0]}")
    if not np.all(np.isfinite(pos)):
        raise ValueError("positions contain NaN or infinite values")
    return pos


def _as_positions(positions) -> np.ndarray:
    """:func:`as_positions` (any number of nodes), C-contiguous for the Numba kernels."""
    return np.ascontiguousarray(as_positions(positions, min_nodes=0))
