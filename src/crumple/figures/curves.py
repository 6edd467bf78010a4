"""Figures of the report's curves: M(R), γ, R_G, plasticity, alternatives, the minimiser."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .common import _PAPER_STYLE, _guides, _loglog_curves, _panel_letter

__all__ = [
    "plot_alternatives",
    "plot_gamma",
    "plot_mass_size",
    "plot_minimizer",
    "plot_plasticity",
    "plot_radius",
]


def plot_mass_size(curves, dm_lambda, *, fit_range, paper_value=None) -> Figure:
    """Fig. 3. ``curves = {label: (R/R_G, M/M_total, (prefactor, D_M))}``;
    ``dm_lambda = {label: (λ, mean D_M, σ)}``, drawn with a ±2σ band."""
    fig = Figure(figsize=(10, 4), layout="constrained")
    a, b = fig.subplots(1, 2)
    for label, (x, m, (pre, dm)) in curves.items():
        if not np.isfinite(dm):  # M(R) = 0 in the window: a hollow ring, no fit
            a.plot(x, m, lw=1, label=f"{label}: D_M cannot be fitted (hollow)")
            continue
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
            rng, (ours, sig, *ln_a), theirs = slopes[k]
            _guides(ax, curves, rng, [
                (f"ours: slope {ours:.2f} ± {sig:.2f} (pooled fit)", ours,
                 {"color": "k", "lw": 2.0, "alpha": 0.7}, *ln_a),
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
        if 0 < lo < hi and np.isfinite(hi):  # a panel without data keeps its default limits
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
                       {"color": "k", "lw": 2.0, "alpha": 0.7}, *alpha[2:]))  # fmt: skip
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
