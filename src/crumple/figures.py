"""Figures drawn from stored configurations: no physics is computed here.

Every function returns a :class:`matplotlib.figure.Figure` built without pyplot (no global
state, no display needed); save it with ``fig.savefig(path)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

__all__ = ["plot_configurations"]


def plot_configurations(
    configurations: Sequence[np.ndarray],
    lambdas: Sequence[float],
    *,
    title: str | None = None,
    trap_center=(0.0, 0.0),
    ncols: int | None = None,
) -> Figure:
    """Wire configurations side by side, one panel per trap strength (the paper's Fig. 2).

    Parameters
    ----------
    configurations : sequence of ndarray, each (n_nodes, 2)
        Positions ``[length]``.
    lambdas : sequence of float
        The trap strength of each configuration, for the panel titles.
    title : str, optional
        Figure title.
    trap_center : tuple of float
        Marked with a cross.
    ncols : int, optional
        Panels per row (default: all in one row, up to 4).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 50)
    >>> fig = plot_configurations([np.c_[np.cos(t), np.sin(t)]], [1.0])
    >>> len(fig.axes)
    1
    """
    if len(configurations) != len(lambdas):
        raise ValueError(
            f"got {len(configurations)} configurations but {len(lambdas)} lambda values"
        )
    if not configurations:
        raise ValueError("nothing to plot")
    n = len(configurations)
    ncols = min(n, 4) if ncols is None else max(1, int(ncols))
    nrows = -(-n // ncols)
    fig = Figure(figsize=(3.2 * ncols, 3.3 * nrows + (0.4 if title else 0.0)), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    letters = "abcdefghijklmnopqrstuvwxyz"
    for k, (ax, x, lam) in enumerate(zip(axes, configurations, lambdas, strict=True)):
        x = np.asarray(x)
        ax.plot(x[:, 0], x[:, 1], "-", color="0.15", lw=1.0)
        ax.plot(*x[0], "o", ms=3, color="tab:blue", label="start")
        ax.plot(*x[-1], "s", ms=3, color="tab:red", label="end")
        ax.plot(*trap_center, "+", ms=6, color="tab:gray")
        ax.set_aspect("equal", adjustable="datalim")
        label = f"({letters[k % 26]})  " if n > 1 else ""
        ax.set_title(f"{label}λ = {lam:g}", fontsize=10)
        ax.tick_params(labelsize=7)
    for ax in axes[n:]:
        ax.set_visible(False)
    axes[0].legend(fontsize=7, loc="upper right", frameon=False)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig
