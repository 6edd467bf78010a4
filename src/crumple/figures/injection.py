"""Figures of an injection: the cavity, the channel and the wire at chosen injected lengths."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

__all__ = ["plot_injection"]


def plot_injection(
    configurations: Sequence[np.ndarray],
    injected_lengths: Sequence[float],
    radius: float,
    *,
    free: Sequence[np.ndarray] | None = None,
    forces: Sequence[float] | None = None,
    title: str | None = None,
    ncols: int | None = None,
) -> Figure:
    """Wire configurations in their cavity, one panel per injected length.

    The cavity's wall (radius ``radius``, centred at the origin) is a black circle; the wire
    is blue where free and grey where held by the channel (``free`` masks); its tip (node 0)
    is a dot. Axes are x and y in units of L0, every panel on the cavity's scale with a
    little of the channel outside.

    Parameters
    ----------
    configurations : sequence of ndarray, each (n_nodes, 2)
        Positions ``[length]``.
    injected_lengths : sequence of float
        L_in of each panel ``[length]``, for its title.
    radius : float
        Cavity radius R_c ``[length]``.
    free : sequence of bool ndarray (n_nodes,), optional
        Nodes not held by the channel (default: all).
    forces : sequence of float, optional
        Feed force of each panel ``[energy/length]``, for its title.
    title : str, optional
    ncols : int, optional
        Panels per row (default: all in one row, up to 4).
    """
    n = len(configurations)
    if n == 0 or len(injected_lengths) != n:
        raise ValueError("need one injected length per configuration, and at least one")
    ncols = min(n, 4) if ncols is None else int(ncols)
    nrows = -(-n // ncols)
    fig = Figure(figsize=(3.2 * ncols, 3.2 * nrows + (0.4 if title else 0)))
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    t = np.linspace(0.0, 2.0 * np.pi, 721)
    lim = 1.3 * radius
    for k, ax in enumerate(axes):
        if k >= n:
            ax.set_axis_off()
            continue
        x = np.asarray(configurations[k], dtype=float)
        f = np.ones(len(x), dtype=bool) if free is None else np.asarray(free[k], dtype=bool)
        ax.plot(radius * np.cos(t), radius * np.sin(t), color="k", lw=1.2)
        ax.plot(x[:, 0], x[:, 1], color="0.6", lw=1.0)  # the whole wire, grey under
        m = np.flatnonzero(f)
        if m.size:
            j = min(m[-1] + 2, len(x))  # the free part and its joint to the channel
            ax.plot(x[:j, 0], x[:j, 1], color="tab:blue", lw=1.0)
        ax.plot(x[0, 0], x[0, 1], "o", color="tab:blue", ms=3)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        label = f"L_in = {injected_lengths[k]:.3g}"
        if forces is not None:
            label += f", F = {forces[k]:.3g}"
        ax.set_title(label, fontsize=9)
        ax.tick_params(labelsize=7)
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig
