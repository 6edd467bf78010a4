"""The Powell study's curves (``crumple reproduce --profile powell``): arrays in, a Figure out."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .common import _panel_letter

__all__ = ["plot_powell_study"]


def plot_powell_study(curves: dict, *, ftol: float = 1e-6) -> Figure:
    """Powell's ramps against Newton's, stage by stage, one line per minimiser.

    ``curves``: ``{label: {"lam", "excess", "force", "r_max", "sweeps"}}``, arrays over the
    stages (replica means, the force the replicas' largest; ``excess`` is E/E_Newton - 1 and
    absent for Newton; ``sweeps`` absent for Newton). Panels: (a) the energy above Newton's,
    (b) the largest node force, (c) r_max, (d) Powell sweeps used per stage.
    """
    if not curves:
        raise ValueError("nothing to plot")
    fig = Figure(figsize=(10, 7), layout="constrained")
    axes = fig.subplots(2, 2).ravel()
    for k, (label, c) in enumerate(curves.items()):
        style = {"color": f"C{k}", "ms": 3, "lw": 1.0, "label": label}
        lam = np.asarray(c["lam"], float)
        if c.get("excess") is not None:
            axes[0].plot(lam, np.asarray(c["excess"], float), "o-", **style)
        axes[1].plot(lam, np.asarray(c["force"], float), "o-", **style)
        axes[2].plot(lam, np.asarray(c["r_max"], float), "o-", **style)
        if c.get("sweeps") is not None:
            axes[3].plot(lam, np.asarray(c["sweeps"], float), "o-", **style)
    axes[0].set_yscale("symlog", linthresh=1e-4)
    axes[0].set_ylabel("E / E_Newton − 1 (replica means)")
    axes[1].axhline(ftol, color="0.4", ls=":", label=f"equilibrium: max force ≤ {ftol:g}")
    axes[1].set_yscale("log")
    axes[1].set_ylabel("largest node force (worst replica)")
    axes[2].set_yscale("log")
    axes[2].set_ylabel("r_max (replica mean) [L0]")
    axes[3].set_ylabel("Powell sweeps used per stage (mean)")
    for k, ax in enumerate(axes):
        ax.set_xscale("log")
        ax.set_xlabel("λ")
        ax.legend(fontsize=6)
        _panel_letter(ax, k)
    return fig
