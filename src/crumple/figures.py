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
    "ramp_animation",
]


def _scale_bar(ax, span: float) -> None:
    """A bar of a round length (1, 2 or 5 × 10^k, about a fifth of ``span``) in the lower
    right corner, labelled in units of L0."""
    from matplotlib.offsetbox import AnchoredOffsetbox, AuxTransformBox, TextArea, VPacker
    from matplotlib.patches import Rectangle

    target = span / 5.0
    k = np.floor(np.log10(target))
    length = min((m * 10.0**k for m in (1.0, 2.0, 5.0, 10.0)), key=lambda v: abs(v - target))
    bar = AuxTransformBox(ax.transData)
    bar.add_artist(Rectangle((0, 0), length, 0, ec="0.2", lw=1.5))
    box = VPacker(children=[bar, TextArea(f"{length:g} L0", textprops={"fontsize": 7})],
                  align="center", pad=0, sep=2)  # fmt: skip
    ax.add_artist(AnchoredOffsetbox("lower right", child=box, frameon=False, pad=0.3))


def plot_configurations(
    configurations: Sequence[np.ndarray],
    lambdas: Sequence[float],
    *,
    title: str | None = None,
    trap_center=(0.0, 0.0),
    ncols: int | None = None,
    contacts: Sequence[np.ndarray] | None = None,
    contact_distance: float | None = None,
    common_scale: bool = True,
) -> Figure:
    """Wire configurations side by side, one panel per trap strength (the paper's Fig. 2).

    Axes are x and y in units of the rest length L0. The first node (end 0) is a blue
    dot, the last (end N) a hollow red square, the trap centre a grey cross; segments in
    contact are drawn in orange, and each panel's title gives the number of contact pairs.
    With ``common_scale`` every panel spans the same range (the shrinking with λ shows);
    otherwise each panel is zoomed on its wire and carries a scale bar.

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
    contacts : sequence of ndarray, each (n_pairs, 2) of int, optional
        Per panel, the pairs of segments in contact (as returned by
        :func:`crumple.geometry.close_segment_pairs`), highlighted. Computed by the caller:
        a figure computes no physics.
    contact_distance : float, optional
        The distance ``[length]`` that defined the contacts, for the legend.
    common_scale : bool
        One range for all panels (default), or one per panel with a scale bar.

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
    if contacts is not None and len(contacts) != len(configurations):
        raise ValueError(f"got {len(contacts)} contact lists for {len(configurations)} panels")
    n = len(configurations)
    ncols = min(n, 4) if ncols is None else max(1, int(ncols))
    nrows = -(-n // ncols)
    fig = Figure(figsize=(3.2 * ncols, 3.3 * nrows + 0.9), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, sharex=common_scale, sharey=common_scale)
    axes = axes.ravel()
    letters = "abcdefghijklmnopqrstuvwxyz"
    xs = [np.asarray(x, dtype=float) for x in configurations]
    c = np.asarray(trap_center, dtype=float)
    if common_scale:
        half = max(float(np.max(np.abs(x - c))) for x in xs) * 1.08
    n_contacts = []
    for k, (ax, x, lam) in enumerate(zip(axes[:n], xs, lambdas, strict=True)):
        ax.plot(x[:, 0], x[:, 1], "-", color="0.15", lw=1.0, label="wire")
        pairs = np.zeros((0, 2), int) if contacts is None else np.asarray(contacts[k], int)
        n_contacts.append(len(pairs))
        if len(pairs):
            segs = np.unique(pairs.ravel())
            for i in segs:
                ax.plot(x[i : i + 2, 0], x[i : i + 2, 1], "-", color="tab:orange", lw=2.6,
                        solid_capstyle="round", zorder=1.5)  # fmt: skip
        # end N hollow and larger, end 0 on top: both stay visible when the ends touch
        ax.plot(*x[-1], "s", ms=7, mfc="none", mec="tab:red", mew=1.5, zorder=3,
                label=f"end N = {len(x) - 1} (last node)")  # fmt: skip
        ax.plot(*x[0], "o", ms=4, color="tab:blue", zorder=4, label="end 0 (first node)")
        ax.plot(*c, "+", ms=7, color="tab:gray", label="trap centre")
        ax.set_aspect("equal", adjustable="datalim" if not common_scale else "box")
        if common_scale:
            ax.set_xlim(c[0] - half, c[0] + half)
            ax.set_ylim(c[1] - half, c[1] + half)
        else:
            span = float(np.ptp(x, axis=0).max()) or 1.0
            _scale_bar(ax, span)
        label = f"({letters[k % 26]})  " if n > 1 else ""
        extra = f", {len(pairs)} contact pair(s)" if contacts is not None else ""
        ax.set_title(f"{label}λ = {lam:g}{extra}", fontsize=10)
        ax.tick_params(labelsize=7)
        if k % ncols == 0 or not common_scale:
            ax.set_ylabel("y / L0", fontsize=8)
        if k >= n - ncols or not common_scale:
            ax.set_xlabel("x / L0", fontsize=8)
    for ax in axes[n:]:
        ax.set_visible(False)
    handles, labels = axes[0].get_legend_handles_labels()
    if contacts is not None:
        from matplotlib.lines import Line2D

        d = "" if contact_distance is None else f" (segments closer than {contact_distance:g} L0)"
        handles.append(Line2D([], [], color="tab:orange", lw=2.6))
        labels.append(f"in contact{d}")
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 3),
               fontsize=7, frameon=False)  # fmt: skip
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


def ramp_animation(
    positions,
    lambdas,
    energies: dict,
    *,
    converged=None,
    title: str | None = None,
    trap_center=(0.0, 0.0),
):
    """A ramp as an animation, one frame per stage, λ and the energies on screen.

    Parameters
    ----------
    positions : array_like, shape (n_stages, n_nodes, 2)
        ``[length]``.
    lambdas : array_like, shape (n_stages,)
    energies : dict of str to array_like, shape (n_stages,)
        Energy by term ``[energy]`` (``bending``, ``stretching``, ``confinement``,
        ``hard_core``, ``total``; any subset).
    converged : array_like of bool, shape (n_stages,), optional
        Stages that did not reach equilibrium are marked on screen.
    title : str, optional
    trap_center : tuple of float

    Returns
    -------
    matplotlib.animation.FuncAnimation
        Save it with ``anim.save("ramp.gif", writer=matplotlib.animation.PillowWriter())``.
    """
    from matplotlib.animation import FuncAnimation
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    pos = np.asarray(positions, dtype=float)
    lams = np.asarray(lambdas, dtype=float)
    if pos.ndim != 3 or pos.shape[2] != 2 or len(lams) != pos.shape[0] or not len(lams):
        raise ValueError(f"positions {pos.shape} and lambdas {lams.shape} do not match")
    conv = np.ones(len(lams), bool) if converged is None else np.asarray(converged, bool)
    fig = Figure(figsize=(9.0, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    ax, ax_e = fig.subplots(1, 2, width_ratios=[1.1, 1])
    c = np.asarray(trap_center, dtype=float)
    half = float(np.nanmax(np.abs(pos - c))) * 1.08
    ax.set_xlim(c[0] - half, c[0] + half)
    ax.set_ylim(c[1] - half, c[1] + half)
    ax.set_aspect("equal")
    ax.set_xlabel("x / L0")
    ax.set_ylabel("y / L0")
    ax.plot(*c, "+", ms=7, color="tab:gray")
    (wire,) = ax.plot([], [], "-", color="0.15", lw=1.0)
    (end1,) = ax.plot([], [], "s", ms=7, mfc="none", mec="tab:red", mew=1.5, label="end N")
    (end0,) = ax.plot([], [], "o", ms=4, color="tab:blue", label="end 0")
    ax.legend(loc="upper right", fontsize=7, frameon=False)
    text = ax.text(0.02, 0.02, "", transform=ax.transAxes, fontsize=8, family="monospace",
                   va="bottom")  # fmt: skip
    markers = []
    for name, values in energies.items():
        e = np.asarray(values, dtype=float)
        ok = np.isfinite(e) & (e > 0)
        line = ax_e.plot(lams[ok], e[ok], lw=1, label=name.replace("_", " "))[0]
        markers.append((ax_e.plot([], [], "o", ms=4, color=line.get_color())[0], e))
    ax_e.set_xscale("log")
    ax_e.set_yscale("log")
    top = max((float(np.nanmax(e)) for _, e in markers if np.any(e > 0)), default=1.0)
    # 8 decades: below, a straight wire's bending energy is round-off (~1e-30), not physics
    ax_e.set_ylim(bottom=top * 1e-8, top=top * 3)
    ax_e.set_xlabel("trap strength λ")
    ax_e.set_ylabel("energy")
    ax_e.legend(fontsize=7, frameon=False, loc="center left", bbox_to_anchor=(1.0, 0.5))
    cursor = ax_e.axvline(lams[0], color="0.6", lw=0.8)
    if title:
        fig.suptitle(title, fontsize=10)

    def frame(s):
        x = pos[s]
        wire.set_data(x[:, 0], x[:, 1])
        end0.set_data([x[0, 0]], [x[0, 1]])
        end1.set_data([x[-1, 0]], [x[-1, 1]])
        lines = [f"stage {s + 1}/{len(lams)}  λ = {lams[s]:.4g}"]
        for name, e in energies.items():
            lines.append(f"{name + ':':12s} {float(np.asarray(e)[s]):.4g}")
        if not conv[s]:
            lines.append("NOT at equilibrium")
        text.set_text("\n".join(lines))
        cursor.set_xdata([lams[s], lams[s]])
        for m, e in markers:
            m.set_data([lams[s]], [e[s]] if np.isfinite(e[s]) and e[s] > 0 else [np.nan])
        return [wire, end0, end1, text, cursor, *(m for m, _ in markers)]

    return FuncAnimation(fig, frame, frames=len(lams), blit=False, repeat=False)


# --------------------------------------------------------------------------------------------
# The reproduction report's figures (crumple.reproduce prepares the data; nothing is computed)
# --------------------------------------------------------------------------------------------

_PAPER_STYLE = {"color": "tab:red", "ls": ":", "lw": 1.2}


def _guides(ax, curves, x_range, slopes) -> None:
    """Straight lines of the given log-log ``slopes`` over ``x_range``, all through one anchor:
    the geometric mean of the curves' points inside the range (where the eye compares
    slopes). ``slopes = [(label, exponent, style dict)]``."""
    xs, ys = [], []
    for x, y in curves.values():
        x, y = np.asarray(x, float), np.asarray(y, float)
        ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
        ok &= (x >= x_range[0]) & (x <= x_range[1])
        xs.append(x[ok])
        ys.append(y[ok])
    x, y = np.concatenate(xs), np.concatenate(ys)
    if x.size == 0:
        return
    x0, y0 = np.exp(np.mean(np.log(x))), np.exp(np.mean(np.log(y)))
    xg = np.geomspace(*x_range, 20)
    for label, exponent, style in slopes:
        if exponent is not None and np.isfinite(exponent):
            ax.plot(xg, y0 * (xg / x0) ** exponent, label=label, **style)


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


def plot_configuration_rows(rows, *, title: str | None = None, contact_label=None) -> Figure:
    """Rows of configurations: ``{row label: [(positions (n, 2), λ[, contacts]), ...]}``
    (Fig. 2 and its alternatives, one row each); ``contacts`` an (n_pairs, 2) int array of
    segment pairs in contact, computed by the caller, drawn in orange.

    Axes are x and y in units of L0; the panels of a row share one scale, so the shrinking
    with λ shows, and carry a scale bar. End 0 is a blue dot, end N a hollow red square, the
    trap centre (the origin) a grey cross (legend below the panels, with ``contact_label``)."""
    rows = {k: v for k, v in rows.items() if v}
    if not rows:
        raise ValueError("nothing to plot")
    ncols = max(len(v) for v in rows.values())
    fig = Figure(figsize=(2.7 * ncols, 2.8 * len(rows) + 0.8), layout="constrained")
    axes = fig.subplots(len(rows), ncols, squeeze=False)
    for i, (label, panels) in enumerate(rows.items()):
        half = 1.08 * max(float(np.max(np.abs(np.asarray(x)))) for x, *_ in panels)
        for k in range(ncols):
            ax = axes[i, k]
            if k >= len(panels):
                ax.set_visible(False)
                continue
            x, lam, *rest = panels[k]
            x = np.asarray(x)
            ax.plot(x[:, 0], x[:, 1], "-", color="0.15", lw=0.9)
            pairs = np.asarray(rest[0], int).reshape(-1, 2) if rest else np.zeros((0, 2), int)
            for seg in np.unique(pairs.ravel()):
                ax.plot(x[seg : seg + 2, 0], x[seg : seg + 2, 1], "-", color="tab:orange",
                        lw=2.4, solid_capstyle="round", zorder=1.5)  # fmt: skip
            ax.plot(*x[-1], "s", ms=5, mfc="none", mec="tab:red", mew=1.2, zorder=3,
                    label="end N (last node)")  # fmt: skip
            ax.plot(*x[0], "o", ms=2.5, color="tab:blue", zorder=4, label="end 0 (first node)")
            ax.plot(0, 0, "+", ms=6, color="tab:gray", label="trap centre")
            ax.set_xlim(-half, half)
            ax.set_ylim(-half, half)
            ax.set_aspect("equal", adjustable="box")
            extra = f", {len(pairs)} contact(s)" if rest else ""
            ax.set_title(f"λ = {lam:g}{extra}", fontsize=9)
            ax.tick_params(labelsize=6)
            ax.set_xlabel("x / L0", fontsize=7, labelpad=1)
            _scale_bar(ax, 2 * half)
        axes[i, 0].set_ylabel(f"{label}\ny / L0", fontsize=9)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if contact_label:
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], color="tab:orange", lw=2.4))
        labels.append(contact_label)
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), fontsize=7,
               frameon=False)  # fmt: skip
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_mass_size(curves, dm_lambda, *, fit_range, paper_value=None) -> Figure:
    """Fig. 3. ``curves = {label: (R/R_G, M/M_total, (prefactor, D_M))}``;
    ``dm_lambda = {label: (λ, mean D_M, σ)}``, drawn with a ±2σ band."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    a, b = fig.subplots(1, 2)
    for label, (x, m, (pre, dm)) in curves.items():
        line = a.plot(x, m, lw=1, label=f"{label}: D_M = {dm:.2f}")[0]
        xf = np.geomspace(*fit_range, 20)
        a.plot(xf, pre * xf**dm, "--", color=line.get_color(), lw=1.5)
    a.axvspan(*fit_range, color="0.9", zorder=0, label=f"fit window R/R_G ∈ [{fit_range[0]:g}, "
              f"{fit_range[1]:g}]; dashed: the fits")  # fmt: skip
    a.set_xscale("log")
    a.set_yscale("log")
    a.set_xlabel("R / R_G  (R_G = r_max)")
    a.set_ylabel("mass fraction M(R) / M")
    a.legend(fontsize=6, loc="upper left")
    _panel_letter(a, 0)
    for label, (lam, mean, sd) in dm_lambda.items():
        line = b.plot(lam, mean, "o-", ms=2.5, lw=1, label=label)[0]
        b.fill_between(lam, mean - 2 * sd, mean + 2 * sd, color=line.get_color(), alpha=0.2,
                       lw=0)  # fmt: skip
    if paper_value is not None:
        b.axhline(paper_value, label=f"paper: {paper_value}", **_PAPER_STYLE)
    b.set_xscale("log")
    b.set_xlabel("λ")
    b.set_ylabel(f"D_M (fit on R/R_G in [{fit_range[0]:g}, {fit_range[1]:g}])")
    b.legend(fontsize=6)
    _panel_letter(b, 1)
    return fig


def plot_gamma(
    a_curves,
    b_curves,
    c_curves,
    d_curves,
    *,
    a_theory=None,
    b_theory=None,
    fit_range=None,
    titles=("", "", "", ""),
    slopes=None,
    theory_label="paper's closed form",
    notes=("", "", "", ""),
) -> Figure:
    """Fig. 4: γ against λ at fixed k_s (a) and fixed k_b (b), against k_b (c) and k_s (d);
    each argument ``{label: (x, γ)}``; ``*_theory`` the closed form, dashed. ``titles``: what
    each panel holds fixed; ``slopes``: per panel ``(x_range, ours (exponent, σ), paper
    exponent)`` drawn as straight lines through the data in the range; ``notes``: a line of
    text in each panel."""
    fig = Figure(figsize=(11, 8.5), layout="constrained")
    axes = fig.subplots(2, 2).ravel()
    slopes = slopes or (None,) * 4
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
                ax.plot(x, y, "--", color=f"C{i}", lw=0.8,
                        label=theory_label if i == 0 else None)  # fmt: skip
        if slopes[k] is not None:
            rng, (ours, sig), theirs = slopes[k]
            _guides(ax, curves, rng, [
                (f"ours: slope {ours:.2f} ± {sig:.2f} (pooled fit)", ours,
                 {"color": "k", "lw": 2.0, "alpha": 0.7}),
                (f"paper: slope {theirs:g}", theirs, _PAPER_STYLE | {"lw": 2.0}),
            ])  # fmt: skip
        if fit_range is not None and xl == "λ":
            ax.axvspan(*fit_range, color="0.92", zorder=0)
        ax.set_xlabel(xl)
        ax.set_ylabel("γ = E_s / E_b")
        ax.set_title(titles[k], fontsize=9)
        if notes[k]:
            ax.text(0.98, 0.02, notes[k], transform=ax.transAxes, fontsize=7, va="bottom",
                    ha="right", color="tab:red")  # fmt: skip
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi * (hi / lo) ** 0.5)  # room above the data for the legend
        ax.legend(fontsize=6, ncol=2, loc="upper left")
        _panel_letter(ax, k)
    return fig


def plot_radius(
    curves,
    slopes,
    collapsed,
    *,
    fit_range,
    master=None,
    paper_alpha=None,
    collapse_label="",
    alpha=None,
) -> Figure:
    """Fig. 5: R_g = r_max against λ (a), its local exponent d ln R_g / d ln λ (b), the
    collapsed curves (c). ``master = (prefactor, α)`` draws the fitted power law; ``alpha =
    (α, σ)`` the pooled fit in (a), beside the paper's ``paper_alpha``."""
    fig = Figure(figsize=(14, 4.4), layout="constrained")
    a, b, c = fig.subplots(1, 3)
    _loglog_curves(a, curves)
    guides = []
    if alpha is not None:
        guides.append((f"ours: λ^{alpha[0]:.3f} ± {alpha[1]:.3f} (pooled fit)", alpha[0],
                       {"color": "k", "lw": 2.0, "alpha": 0.7}))  # fmt: skip
    if paper_alpha is not None:
        guides.append((f"paper: λ^{paper_alpha:g}", paper_alpha, _PAPER_STYLE | {"lw": 2.0}))
    _guides(a, curves, fit_range, guides)
    a.set_xlabel("λ")
    a.set_ylabel("R_g = r_max  [L0]")
    a.legend(fontsize=6, loc="lower left")
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
    c.set_ylabel(collapse_label or "rescaled R_g", fontsize=8)
    c.legend(fontsize=6, loc="lower left")
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
    a.set_ylabel("R_g = r_max  [L0]")
    a.legend(fontsize=6, loc="lower left")
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
        fin = vals[np.isfinite(vals)]
        if fin.size and (fin > 0).all() and fin.max() / fin.min() > 30:
            ax.set_xscale("log")  # a ratio such as γ spans decades
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


def plot_minimizer(
    lam, energy_excess, force_powell, force_newton, *, ftol=1e-6, powell_all=None
) -> Figure:
    """Powell against Newton stage by stage: relative energy above Newton's (a) at the stages
    both ran, largest node force of each (b); ``powell_all = (λ, force)`` every Powell stage,
    also those Newton's schedule does not have."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    a, b = fig.subplots(1, 2)
    lam = np.asarray(lam, float)
    ex = np.asarray(energy_excess, float)
    a.plot(lam, np.abs(ex), "o-", ms=3,
           label="|E_Powell / E_Newton - 1| (stages both ramps ran)")  # fmt: skip
    a.set_xscale("log")
    a.set_yscale("log")
    a.set_xlabel("λ")
    a.set_ylabel("relative energy difference")
    a.legend(fontsize=7)
    if powell_all is not None:
        b.plot(*powell_all, "o-", ms=3, label="Powell, every stage")
    else:
        b.plot(lam, force_powell, "o-", ms=3, label="Powell")
    b.plot(lam, force_newton, "s-", ms=3, label="Newton")
    b.axhline(ftol, color="0.5", ls="--", lw=1, label=f"equilibrium tolerance {ftol:g}")
    b.set_xscale("log")
    b.set_yscale("log")
    b.set_xlabel("λ")
    b.set_ylabel("largest node force  [energy/length]")
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
        marked by a red dot (the links are far shorter than the line width); with
        ``undefined: True`` (and only ``positions``, ``lam``), the wire titled "loops
        undefined"; without it, (b) is hidden.

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
    if picture.get("undefined"):
        b.plot(x[:, 0], x[:, 1], "-", color="0.1", lw=1)
        b.set_aspect("equal", adjustable="datalim")
        b.set_title(f"λ = {picture['lam']:g}: loops undefined (the wire crosses itself, or "
                    "its contact graph is not plane)", fontsize=9)  # fmt: skip
        _panel_letter(b, 1)
        return fig
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
