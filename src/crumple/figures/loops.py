"""Figures of the loops: the shape of a loop, and the number of loops against λ."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .common import _panel_letter

__all__ = ["plot_loop_count", "plot_loop_shape"]


def plot_loop_shape(loops, configuration=None, neck=None, title=None) -> Figure:
    """Sec. III.A: loops in the lobe's coordinates (r/r_max against θ) with
    ``sqrt(sin 2θ)``; ``loops = [(θ, r/r_max, label)]``; optionally the wire with its loop."""
    fig = Figure(figsize=(10, 4.2), layout="constrained")
    a, b = fig.subplots(1, 2)
    th = np.linspace(0, np.pi / 2, 200)
    for theta, rho, label in loops:
        a.plot(np.degrees(theta), rho, ".", ms=3, label=label)
    a.plot(np.degrees(th), np.sqrt(np.sin(2 * th)), "k-", lw=1.5, label="r = r_max √(sin 2θ)")
    a.plot(np.degrees(th), np.cos(th - np.pi / 4), "k:", lw=1, label="circle through the neck")
    a.set_xlabel("θ [degrees] about the neck's midpoint (loop bisector at 45°)")
    a.set_ylabel("r / r_max  (r from the neck's midpoint)")
    a.set_ylim(0, 1.45)
    a.legend(fontsize=6, loc="upper center", ncols=3)  # above the data (r/r_max <= 1)
    _panel_letter(a, 0)
    if configuration is not None:
        x = np.asarray(configuration)
        b.plot(x[:, 0], x[:, 1], "-", color="0.15", lw=1)
        if neck is not None:
            i, j = neck
            b.plot(
                x[i : j + 1, 0],
                x[i : j + 1, 1],
                "-",
                color="tab:orange",
                lw=2,
                alpha=0.6,
                label="the loop compared",
            )
            b.legend(fontsize=7)
        if neck is not None:
            mid = 0.5 * (x[neck[0]] + x[neck[1]])
            b.plot(*mid, "x", color="tab:orange", ms=6, label="neck midpoint (origin of r)")
            b.legend(fontsize=7)
        b.plot(0, 0, "+", color="tab:gray")
        b.set_xlabel("x / L0")
        b.set_ylabel("y / L0")
        b.set_aspect("equal", adjustable="datalim")
        if title:
            b.set_title(title, fontsize=9)
    else:
        b.set_visible(False)
    _panel_letter(b, 1)
    return fig


def plot_loop_count(lam, n_loops, *, brackets=None, picture=None) -> Figure:
    """The number of loops against λ (a) and a wire with its loops numbered (b).

    Parameters
    ----------
    lam : array_like, shape (S,)
        The stages.
    n_loops : array_like, shape (R, S)
        Loops per replica and stage (NaN where no stage).
    brackets : dict, optional
        label → (λ_lo, λ_hi) or None: onsets drawn as shaded bands ``(λ_lo, λ_hi]``.
    picture : dict, optional
        ``positions`` (n, 2), ``boundaries`` (loop polygons), ``depth``, ``centroid``,
        ``links`` (n_links, 2, 2), ``lam``: panel (b), each loop filled in its own colour
        (hatched when nested, depth >= 1) and numbered 1…n (largest first), every contact link
        marked by a red dot (the links are far shorter than the line width); with
        ``undefined: True`` (and only ``positions``, ``lam``), the wire titled "loops
        undefined"; without it, (b) is hidden.

    Examples
    --------
    >>> fig = plot_loop_count([1.0, 10.0, 100.0], [[0, 1, 3]])
    >>> len([ax for ax in fig.axes if ax.get_visible()])
    1
    """
    from matplotlib.ticker import MaxNLocator

    fig = Figure(figsize=(10.5, 4.6), layout="constrained")
    a, b = fig.subplots(1, 2, width_ratios=(1, 1.15))
    lam = np.asarray(lam, float)
    n = np.atleast_2d(np.asarray(n_loops, float))
    for r, nr in enumerate(n):
        ok = np.isfinite(nr)
        a.plot(lam[ok], nr[ok], "o-", ms=3, lw=1, alpha=0.5 if n.shape[0] > 1 else 1.0,
               color="tab:blue", label="replicas" if r == 0 else None)  # fmt: skip
    if n.shape[0] > 1:
        ok = np.isfinite(n)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(ok, n, 0.0).sum(axis=0) / ok.sum(axis=0)
        a.plot(lam, mean, "k-", lw=2, label="mean over replicas")
    for (label, br), color in zip((brackets or {}).items(), ("tab:red", "tab:gray"), strict=False):
        if br is not None:
            a.axvspan(
                br[0], br[1], color=color, alpha=0.2, label=f"{label}: ({br[0]:g}, {br[1]:g}]"
            )
        else:
            a.plot([], [], " ", label=f"{label}: none up to λ = {np.nanmax(lam):g}")
    a.axvline(1000.0, color="k", ls=":", lw=1, label="paper: contacts at λ ≥ 1000")
    a.set_xscale("log")
    a.set_xlabel("λ")
    a.set_ylabel("number of loops n")
    a.yaxis.set_major_locator(MaxNLocator(integer=True))
    a.legend(fontsize=7, loc="upper left")
    _panel_letter(a, 0)
    if picture is None:
        b.set_visible(False)
        return fig
    _draw_loops(b, picture)
    return fig


def _draw_loops(b, picture) -> None:
    """Panel (b) of :func:`plot_loop_count`: the wire, its loops numbered, its links."""
    from matplotlib.patches import Polygon

    x = np.asarray(picture["positions"])
    if picture.get("undefined"):
        b.plot(x[:, 0], x[:, 1], "-", color="0.1", lw=1)
        b.set_aspect("equal", adjustable="datalim")
        b.set_title(f"λ = {picture['lam']:g}: loops undefined (the wire crosses itself, or "
                    "its contact graph is not plane)", fontsize=9)  # fmt: skip
        _panel_letter(b, 1)
        return
    depth = np.asarray(picture["depth"])
    cycle = [f"C{k}" for k in range(10)]
    for k, (poly, d) in enumerate(zip(picture["boundaries"], depth, strict=True)):
        b.add_patch(Polygon(poly, closed=True, fc=cycle[k % 10], ec="none", alpha=0.4,
                            hatch="///" if d >= 1 else None))  # fmt: skip
        cx, cy = picture["centroid"][k]
        b.annotate(str(k + 1), (cx, cy), ha="center", va="center", fontsize=9, weight="bold")
    b.plot(x[:, 0], x[:, 1], "-", color="0.1", lw=1)
    links = np.asarray(picture["links"]).reshape(-1, 2, 2)
    if links.shape[0]:
        mid = links.mean(axis=1)
        b.plot(mid[:, 0], mid[:, 1], "o", color="red", ms=3, label="contacts (links)")
    b.plot(*x[0], "o", color="tab:blue", ms=4, label="wire ends")
    b.plot(*x[-1], "o", color="tab:blue", ms=4)
    b.set_aspect("equal", adjustable="datalim")
    b.set_xlabel("x [L0]")
    b.set_ylabel("y [L0]")
    nested = int(np.count_nonzero(depth >= 1))
    b.set_title(
        f"λ = {picture['lam']:g}: {len(depth)} loops, numbered ({nested} nested, hatched)",
        fontsize=9,
    )
    b.legend(fontsize=7, loc="lower right")
    _panel_letter(b, 1)
