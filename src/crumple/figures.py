"""Figures drawn from stored configurations: no physics is computed here.

Every function returns a :class:`matplotlib.figure.Figure` built without pyplot (no global
state, no display needed); save it with ``fig.savefig(path)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

__all__ = [
    "plot_alternatives",
    "plot_configuration_rows",
    "plot_configurations",
    "plot_gamma",
    "plot_loop_shape",
    "plot_mass_size",
    "plot_minimizer",
    "plot_plasticity",
    "plot_radius",
]


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
    for k, (ax, x, lam) in enumerate(zip(axes[:n], configurations, lambdas, strict=True)):
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


# --------------------------------------------------------------------------------------------
# The reproduction report's figures (crumple.reproduce prepares the data; nothing is computed)
# --------------------------------------------------------------------------------------------

_PAPER_STYLE = {"color": "tab:red", "ls": ":", "lw": 1.2}


def _panel_letter(ax, k: int) -> None:
    # above the axes' top left corner: never on the data
    ax.text(0.0, 1.02, f"({'abcdefgh'[k]})", transform=ax.transAxes, va="bottom", fontsize=9)


def _loglog_curves(ax, curves, *, marker="o", errors=None):
    for label, (x, y) in curves.items():
        x, y = np.asarray(x, float), np.asarray(y, float)
        ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
        line = ax.plot(x[ok], y[ok], marker=marker, ms=3, lw=1, label=str(label))[0]
        if errors and label in errors:
            e = np.asarray(errors[label], float)[ok]
            ax.fill_between(x[ok], y[ok] - e, y[ok] + e, color=line.get_color(), alpha=0.2, lw=0)
    ax.set_xscale("log")
    ax.set_yscale("log")


def plot_configuration_rows(rows, *, title: str | None = None) -> Figure:
    """Rows of configurations: ``{row label: [(positions (n, 2), λ), ...]}`` (Fig. 2 and its
    alternatives, one row each)."""
    rows = {k: v for k, v in rows.items() if v}
    if not rows:
        raise ValueError("nothing to plot")
    ncols = max(len(v) for v in rows.values())
    fig = Figure(figsize=(2.7 * ncols, 2.8 * len(rows) + 0.4), layout="constrained")
    axes = fig.subplots(len(rows), ncols, squeeze=False)
    for i, (label, panels) in enumerate(rows.items()):
        for k in range(ncols):
            ax = axes[i, k]
            if k >= len(panels):
                ax.set_visible(False)
                continue
            x, lam = panels[k]
            x = np.asarray(x)
            ax.plot(x[:, 0], x[:, 1], "-", color="0.15", lw=0.9)
            ax.plot(*x[0], "o", ms=2.5, color="tab:blue")
            ax.plot(*x[-1], "s", ms=2.5, color="tab:red")
            ax.plot(0, 0, "+", ms=6, color="tab:gray")
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_title(f"λ = {lam:g}", fontsize=9)
            ax.tick_params(labelsize=6)
        axes[i, 0].set_ylabel(label, fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_mass_size(curves, dm_lambda, *, fit_range, paper_value=None) -> Figure:
    """Fig. 3. ``curves = {label: (R/R_G, M, (prefactor, D_M))}``;
    ``dm_lambda = {label: (λ, mean D_M, sd)}``."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    a, b = fig.subplots(1, 2)
    for label, (x, m, (pre, dm)) in curves.items():
        line = a.plot(x, m, lw=1, label=f"{label}: D_M = {dm:.2f}")[0]
        xf = np.geomspace(*fit_range, 20)
        a.plot(xf, pre * xf**dm, "--", color=line.get_color(), lw=1.5)
    a.axvspan(*fit_range, color="0.9", zorder=0)
    a.set_xscale("log")
    a.set_yscale("log")
    a.set_xlabel("R / R_G  (R_G = r_max)")
    a.set_ylabel("M(R)")
    a.legend(fontsize=6, loc="lower right")
    _panel_letter(a, 0)
    for label, (lam, mean, sd) in dm_lambda.items():
        line = b.plot(lam, mean, "o-", ms=2.5, lw=1, label=label)[0]
        b.fill_between(lam, mean - sd, mean + sd, color=line.get_color(), alpha=0.2, lw=0)
    if paper_value is not None:
        b.axhline(paper_value, label=f"paper: {paper_value}", **_PAPER_STYLE)
    b.set_xscale("log")
    b.set_xlabel("λ")
    b.set_ylabel(f"D_M (fit on R/R_G in [{fit_range[0]:g}, {fit_range[1]:g}])")
    b.legend(fontsize=6)
    _panel_letter(b, 1)
    return fig


def plot_gamma(
    a_curves, b_curves, c_curves, d_curves, *, a_theory=None, b_theory=None, fit_range=None
) -> Figure:
    """Fig. 4: γ against λ at fixed k_s (a) and fixed k_b (b), against k_b (c) and k_s (d);
    each argument ``{label: (x, γ)}``; ``*_theory`` the closed form, dashed."""
    fig = Figure(figsize=(10, 8), layout="constrained")
    axes = fig.subplots(2, 2).ravel()
    for k, (ax, curves, theory, xl) in enumerate(
        zip(
            axes,
            (a_curves, b_curves, c_curves, d_curves),
            (a_theory, b_theory, None, None),
            ("λ", "λ", "k_b", "k_s"),
            strict=True,
        )
    ):
        _loglog_curves(ax, curves)
        if theory:
            for i, (_, (x, y)) in enumerate(theory.items()):
                ax.plot(
                    x,
                    y,
                    "--",
                    color=f"C{i}",
                    lw=0.8,
                    label="paper's closed form" if i == 0 else None,
                )
        if fit_range is not None and xl == "λ":
            ax.axvspan(*fit_range, color="0.92", zorder=0)
        ax.set_xlabel(xl)
        ax.set_ylabel("γ = E_s / E_b")
        ax.legend(fontsize=6, ncol=2)
        _panel_letter(ax, k)
    return fig


def plot_radius(
    curves, slopes, collapsed, *, fit_range, master=None, paper_alpha=None, collapse_label=""
) -> Figure:
    """Fig. 5: R_g = r_max against λ (a), its local exponent d ln R_g / d ln λ (b), the
    collapsed curves (c). ``master = (prefactor, α)`` draws the fitted power law."""
    fig = Figure(figsize=(13, 4), layout="constrained")
    a, b, c = fig.subplots(1, 3)
    _loglog_curves(a, curves)
    a.set_xlabel("λ")
    a.set_ylabel("R_g = r_max")
    a.legend(fontsize=6)
    for label, (x, s) in slopes.items():
        b.plot(x, s, "o-", ms=2.5, lw=1, label=str(label))
    if paper_alpha is not None:
        b.axhline(paper_alpha, label=f"paper: α = {paper_alpha}", **_PAPER_STYLE)
    b.set_xscale("log")
    b.set_xlabel("λ")
    b.set_ylabel("local exponent d ln R_g / d ln λ")
    b.legend(fontsize=6)
    _loglog_curves(c, collapsed, marker=".")
    if master is not None:
        x = np.geomspace(*fit_range, 20)
        what = master[2] if len(master) > 2 else "fit"
        c.plot(x, master[0] * x ** master[1], "k--", lw=1.5, label=f"{what}: λ^{master[1]:.3f}")
    c.set_xlabel("λ")
    c.set_ylabel(collapse_label or "rescaled R_g")
    c.legend(fontsize=6)
    for k, ax in enumerate((a, b, c)):
        ax.axvspan(*fit_range, color="0.92", zorder=0)
        _panel_letter(ax, k)
    return fig


def plot_plasticity(curves, inset, *, fit_range, paper_inset=None) -> Figure:
    """Fig. 6: R_g against λ for several s (a); α against θ_p (b),
    ``inset = (θ_p, α, σ)``."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    a, b = fig.subplots(1, 2)
    _loglog_curves(a, curves)
    a.axvspan(*fit_range, color="0.92", zorder=0)
    a.set_xlabel("λ")
    a.set_ylabel("R_g = r_max")
    a.legend(fontsize=6)
    t, al, sg = (np.asarray(v, float) for v in inset)
    b.errorbar(t, np.abs(al), yerr=2 * sg, fmt="o-", ms=4, capsize=3, label="ours, ±2σ")
    if paper_inset is not None:
        b.axhline(paper_inset, label=f"paper's saturation {paper_inset}", **_PAPER_STYLE)
    b.set_xscale("log")
    b.set_xticks(t, [f"{v:g}" for v in t])
    b.minorticks_off()
    b.set_xlabel("θ_p [rad]  (s = 0.4)")
    b.set_ylabel("|α|")
    b.legend(fontsize=7)
    _panel_letter(a, 0)
    _panel_letter(b, 1)
    return fig


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
    a.set_xlabel("θ [degrees] (loop bisector at 45°)")
    a.set_ylabel("r / r_max")
    a.legend(fontsize=6)
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
        b.plot(0, 0, "+", color="tab:gray")
        b.set_aspect("equal", adjustable="datalim")
        if title:
            b.set_title(title, fontsize=9)
    else:
        b.set_visible(False)
    _panel_letter(b, 1)
    return fig


def plot_alternatives(groups) -> Figure:
    """One panel per quantity: ``{quantity: [(variant, value, σ, paper value or None)]}``,
    error bars ±2σ, the paper's value dotted."""
    groups = {k: v for k, v in groups.items() if v}
    n = len(groups)
    fig = Figure(figsize=(5.2 * min(n, 3), 3.2 * -(-n // 3)), layout="constrained")
    axes = fig.subplots(-(-n // 3), min(n, 3), squeeze=False).ravel()
    for k, (ax, (quantity, items)) in enumerate(zip(axes, groups.items(), strict=False)):
        y = np.arange(len(items))
        vals = np.array([np.nan if it[1] is None else it[1] for it in items], float)
        sig = np.array([0.0 if it[2] is None else it[2] for it in items], float)
        ax.errorbar(vals, y, xerr=2 * sig, fmt="o", capsize=3)
        pv = next((it[3] for it in items if it[3] is not None), None)
        if pv is not None:
            ax.axvline(pv, label=f"paper: {pv}", **_PAPER_STYLE)
            ax.legend(fontsize=6)
        ax.set_yticks(y, [it[0] for it in items], fontsize=6)
        ax.set_title(quantity, fontsize=8)
        ax.set_xlabel("value (bars: ±2σ)", fontsize=7)
        ax.tick_params(axis="x", labelsize=7)
        ax.invert_yaxis()
        _panel_letter(ax, k)
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig


def plot_minimizer(lam, energy_excess, force_powell, force_newton, *, ftol=1e-6) -> Figure:
    """Powell against Newton stage by stage: relative energy above Newton's (a), largest node
    force of each (b)."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    a, b = fig.subplots(1, 2)
    lam = np.asarray(lam, float)
    ex = np.asarray(energy_excess, float)
    a.plot(lam, np.abs(ex), "o-", ms=3, label="|E_Powell / E_Newton - 1|")
    a.set_xscale("log")
    a.set_yscale("log")
    a.set_xlabel("λ")
    a.set_ylabel("relative energy difference")
    a.legend(fontsize=7)
    b.plot(lam, force_powell, "o-", ms=3, label="Powell")
    b.plot(lam, force_newton, "s-", ms=3, label="Newton")
    b.axhline(ftol, color="0.5", ls="--", lw=1, label=f"equilibrium tolerance {ftol:g}")
    b.set_xscale("log")
    b.set_yscale("log")
    b.set_xlabel("λ")
    b.set_ylabel("largest node force")
    b.legend(fontsize=7)
    _panel_letter(a, 0)
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
        marked by a red dot (the links are far shorter than the line width); without it, (b)
        is hidden.

    Examples
    --------
    >>> fig = plot_loop_count([1.0, 10.0, 100.0], [[0, 1, 3]])
    >>> len([ax for ax in fig.axes if ax.get_visible()])
    1
    """
    from matplotlib.patches import Polygon
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
    x = np.asarray(picture["positions"])
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
    return fig
