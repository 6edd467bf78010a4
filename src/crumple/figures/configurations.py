"""Figures of configurations: the paper's Fig. 2 panels, their rows, a ramp's animation."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from .common import _scale_bar

__all__ = ["plot_configuration_rows", "plot_configurations", "ramp_animation"]


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
    half = max(float(np.max(np.abs(x - c))) for x in xs) * 1.08
    for k, (ax, x, lam) in enumerate(zip(axes[:n], xs, lambdas, strict=True)):
        pairs = np.zeros((0, 2), int) if contacts is None else np.asarray(contacts[k], int)
        _draw_panel(ax, x, pairs, c, half if common_scale else None)
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
    _legend(fig, axes[0], contacts is not None, contact_distance)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


def _draw_panel(ax, x, pairs, c, half) -> None:
    """One configuration: the wire, its segments in contact (orange), its ends and the trap
    centre; on ``[c - half, c + half]`` (common scale) or zoomed with a scale bar (None)."""
    ax.plot(x[:, 0], x[:, 1], "-", color="0.15", lw=1.0, label="wire")
    for i in np.unique(pairs.ravel()):
        ax.plot(x[i : i + 2, 0], x[i : i + 2, 1], "-", color="tab:orange", lw=2.6,
                solid_capstyle="round", zorder=1.5)  # fmt: skip
    # end N hollow and larger, end 0 on top: both stay visible when the ends touch
    ax.plot(*x[-1], "s", ms=7, mfc="none", mec="tab:red", mew=1.5, zorder=3,
            label=f"end N = {len(x) - 1} (last node)")  # fmt: skip
    ax.plot(*x[0], "o", ms=4, color="tab:blue", zorder=4, label="end 0 (first node)")
    ax.plot(*c, "+", ms=7, color="tab:gray", label="trap centre")
    ax.set_aspect("equal", adjustable="datalim" if half is None else "box")
    if half is not None:
        ax.set_xlim(c[0] - half, c[0] + half)
        ax.set_ylim(c[1] - half, c[1] + half)
    else:
        _scale_bar(ax, float(np.ptp(x, axis=0).max()) or 1.0)


def _legend(fig, ax, with_contacts: bool, contact_distance) -> None:
    """One legend for all panels, below them."""
    handles, labels = ax.get_legend_handles_labels()
    if with_contacts:
        from matplotlib.lines import Line2D

        d = "" if contact_distance is None else f" (segments closer than {contact_distance:g} L0)"
        handles.append(Line2D([], [], color="tab:orange", lw=2.6))
        labels.append(f"in contact{d}")
    fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 3),
               fontsize=7, frameon=False)  # fmt: skip


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
