"""The report's figures carry what a referee asks for (issue 15, "the figures a referee would
send back"), and its table states |ours − paper|/σ, the contact bracket and one α range.

Drawn from the session's smoke reproduction (the ``smoke`` fixture, tests/conftest.py)."""

from __future__ import annotations

import re

import pytest

from crumple import paper


@pytest.fixture(scope="module")
def figs(smoke):
    from crumple.reproduce.analysis import analyse
    from crumple.reproduce.report import make_figures

    out, _, _ = smoke
    return make_figures(analyse(out))


def _legend(ax) -> str:
    leg = ax.get_legend()
    return "" if leg is None else " | ".join(t.get_text() for t in leg.get_texts())


def _fig_legend(fig) -> str:
    return " | ".join(t.get_text() for leg in fig.legends for t in leg.get_texts())


def _captions():
    from crumple.reproduce import registry

    return registry.figures(registry.sections())


def test_fig2_contacts_scale_and_ends(figs):
    fig = figs["fig2_configurations"]
    legend = _fig_legend(fig)
    assert "in contact" in legend and "end 0" in legend and "end N" in legend
    ax = fig.axes[0]
    assert ax.get_xlabel() == "x / L0" and "y / L0" in ax.get_ylabel()
    assert "contact(s)" in ax.get_title()
    assert any("L0" in getattr(c, "get_text", lambda: "")() for c in ax.findobj())  # scale bar
    cap = _captions()["fig2_configurations"]
    assert "share one scale" in cap and "orange" in cap and "first and last node" in cap


def test_fig3_mass_fraction_fit_window_and_gaps(figs):
    a = figs["fig3_mass_size"].axes[0]
    assert a.get_ylabel() == "mass fraction M(R) / M"
    assert "fit window" in _legend(a) and "dashed: the fits" in _legend(a)
    cap = _captions()["fig3_mass_size"]
    assert "Gaps in (b)" in cap and "±2σ" in cap


def test_fig4_fixed_moduli_slopes_every_lambda_and_prefactor(figs):
    axes = figs["fig4_gamma"].axes
    ks, kb = paper.FIG4A_POINTS[0][1], paper.FIG4B_POINTS[0][0]
    assert axes[0].get_title() == f"k_s = {ks:g} fixed"
    assert axes[1].get_title() == f"k_b = {kb:g} fixed"
    for ax, theirs in zip(axes, (0.55, 0.55, 2.6, -3.3), strict=True):
        assert f"paper: slope {theirs:g}" in _legend(ax) and "ours: slope" in _legend(ax)
    assert "C fitted per curve" in _legend(axes[0])
    # (c) shows every λ that enters ε_b: the stages in the γ fit window
    shown = re.findall(r"λ=([\d.e+]+)", _legend(axes[2]))
    assert len(shown) >= 2
    assert all(paper.GAMMA_RANGE[0] <= float(v) <= paper.GAMMA_RANGE[1] for v in shown)


def test_fig5_alpha_fit_paper_slope_and_g_ref(figs):
    a, _, c = figs["fig5_radius"].axes[:3]
    assert "paper: λ^-0.25" in _legend(a) and "ours: λ^" in _legend(a)
    assert "g_ref = " in c.get_ylabel()
    cap = _captions()["fig5_radius"]
    assert "g_ref = k_b k_s of the paper's reference point" in cap
    assert "fitted to that reference curve" in cap


def test_fig6_caption_and_alpha_per_s(figs):
    a = figs["fig6_plasticity"].axes[0]
    assert all("α = " in t for t in _legend(a).split(" | "))
    cap = _captions()["fig6_plasticity"]
    assert f"θ_p = {paper.PLASTIC_THETA_P:g} rad" in cap
    assert f"(k_b, k_s) = ({paper.FIG2[0]:g}, {paper.FIG2[1]:g})" in cap


def test_loop_shape_origin_legend_and_axes(figs):
    a, b = figs["fig_loop_shape"].axes[:2]
    assert "neck's midpoint" in a.get_ylabel()
    assert a.get_ylim()[1] > 1.3  # the legend sits above the data (r/r_max <= 1)
    assert b.get_xlabel() == "x / L0" and b.get_ylabel() == "y / L0"
    assert "origin of r" in _legend(b)


def test_alternatives_log_gamma_and_one_error_bar_convention(figs):
    axes = [ax for ax in figs["fig_alternatives"].axes if ax.get_visible()]
    gamma = [ax for ax in axes if ax.get_title().startswith("γ")]
    assert gamma and all(ax.get_xscale() == "log" for ax in gamma)
    caps = _captions()
    for stem in ("fig_alternatives", "fig3_mass_size", "fig6_plasticity"):
        assert "±2σ" in caps[stem], stem
    assert "±sd" not in " ".join(caps.values()) and "± sd" not in " ".join(caps.values())


def test_minimizer_plots_every_powell_stage(smoke, figs):
    import json

    out, _, _ = smoke
    res = json.loads((out / "results.json").read_text())
    n_powell = len(res["extra"]["powell_stages"]["lam"])
    b = figs["fig_minimizer"].axes[1]
    line = next(ln for ln in b.get_lines() if ln.get_label() == "Powell, every stage")
    assert len(line.get_xdata()) == n_powell
    assert "only at the stages both ramps ran" in _captions()["fig_minimizer"]


def test_table_deviation_bracket_and_one_alpha_range(smoke):
    out, _, _ = smoke
    md = (out / "report.md").read_text()
    assert "| \\|ours − paper\\|/σ |" in md  # escaped: a pipe would split the column
    contact = next(ln for ln in md.splitlines() if "λ of the first interior contact" in ln)
    assert "(a bracket, no σ)" in contact or "no contact" in contact
    lo, hi = paper.ALPHA_RANGE
    starts = ("| α ", "| \\|α\\| ", "| collapse exponent")
    table = md.split("## The paper's numbers", 1)[1].split("###", 1)[0]
    alpha_rows = [ln for ln in table.splitlines() if ln.startswith(starts)]
    assert len(alpha_rows) >= 5
    assert all(f"[{lo:g}, {hi:g}]" in ln for ln in alpha_rows), alpha_rows
    alts = [ln for ln in md.splitlines() if ln.startswith(("| α, six points", "| α at"))]
    assert len(alts) >= 2
    assert all(f"| [{lo:g}, {hi:g}] |" in ln for ln in alts), alts
    assert f"α is fitted over λ ∈ [{lo:g}, {hi:g}] everywhere" in md
