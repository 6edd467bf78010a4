"""The paper under both readings of Eq. 1 (issue 14): the per-node twins, the hollow-ring D_M,
the normalisation of the closed form, and the summary generated from the table."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from crumple import paper
from crumple.reproduce.fig3_mass_size import _dm_hollow, _dm_slope, _inner_start, _is_rod
from crumple.reproduce.series import Series
from crumple.reproduce.summary import _state, tally


def _series(keys, *, confinement="per-length", positions=None, n_lam=3):
    n_nodes = 101 if positions is None else positions.shape[0]
    pos = np.zeros((len(keys), 1, n_lam, n_nodes, 2))
    if positions is not None:
        pos[:] = positions
    obs = {"r_max": np.arange(len(keys) * n_lam, dtype=float).reshape(len(keys), 1, n_lam)}
    return Series(
        keys=[tuple(map(float, k)) for k in keys],
        lam=np.geomspace(1.0, 1000.0, n_lam),
        positions=pos,
        energies={"total": np.ones((len(keys), 1, n_lam))},
        converged=np.ones((len(keys), 1, n_lam), bool),
        max_force=np.zeros((len(keys), 1, n_lam)),
        done=np.ones((len(keys), 1), bool),
        incomplete=[],
        hard_core=1e-5,
        obs=obs,
        confinement=confinement,
    )


def test_reindex_fills_the_points_not_run_with_nan():
    s = _series([(5, 5e5), (6, 1e5)], confinement="per-node")
    r = s.reindex([(1, 1e4), (6, 1e5), (5, 5e5)])
    assert r.keys == [(1.0, 1e4), (6.0, 1e5), (5.0, 5e5)]
    assert np.isnan(r.obs["r_max"][0]).all() and not r.done[0].any()
    assert not r.converged[0].any()
    np.testing.assert_array_equal(r.obs["r_max"][1], s.obs["r_max"][1])
    np.testing.assert_array_equal(r.obs["r_max"][2], s.obs["r_max"][0])
    assert not r.valid(0, 0, 0) and r.valid(2, 0, 0)
    assert r.confinement == "per-node"
    assert s.reindex(s.keys) is s


def test_the_closed_form_takes_lambda_in_discrete_moduli():
    """Per node the stage λ is already Eq. (1)'s λ; per length it is λ Δs (the trap energies
    of the two readings agree when λ_node = λ_length Δs)."""
    pl = _series([(5, 5e5)])
    pn = _series([(5, 5e5)], confinement="per-node")
    np.testing.assert_allclose(pl.lam_discrete, pl.lam * 0.01)
    np.testing.assert_array_equal(pn.lam_discrete, pn.lam)


def _ring(n=101, r=0.1):
    t = np.linspace(0, 2 * np.pi * (n - 1) / n, n)
    return np.c_[r * np.cos(t), r * np.sin(t)]


def test_a_ring_is_hollow_and_cannot_be_fitted_anywhere():
    """A circle: M(R) = 0 up to R = r_max, so D_M cannot be fitted on [0.5, 1], and no range
    where the wire has mass spans a factor 1.25."""
    s = _series([(5, 5e5)], positions=_ring())
    assert _inner_start(s.positions[0, 0, 0]) == pytest.approx(1.0, abs=0.02)
    hollow, total, inner = _dm_hollow(s, 0)
    assert (hollow, total) == (1, 1)
    assert inner.n == 0 and math.isnan(inner.value)


def test_a_straight_wire_through_the_centre_is_not_hollow():
    """A straight wire about its centre: M(R) = R / r_max, D_M = 1 on every range."""
    x = np.c_[np.linspace(-0.5, 0.5, 101), np.zeros(101)]
    s = _series([(5, 5e5)], positions=x)
    hollow, total, inner = _dm_hollow(s, 0)
    assert (hollow, total) == (0, 1)
    assert inner.value == pytest.approx(1.0, abs=1e-6)
    assert inner.fit_range == (0.5, 1.0)


def test_a_thick_annulus_is_fitted_where_it_has_mass():
    """Two concentric rings, about 0.6 and 1 of r_max (joined, so the centre of mass moves a
    little): hollow on [0.5, 1], fitted from 1.1 × where the mass starts (≈ 0.66) to 1."""
    x = np.r_[_ring(60, 0.06), _ring(41, 0.1)]
    s = _series([(5, 5e5)], positions=x)
    hollow, _, inner = _dm_hollow(s, 0)
    assert hollow == 1
    assert 0.55 < _inner_start(x) < 0.61
    assert inner.fit_range[0] == pytest.approx(1.1 * _inner_start(x))
    assert math.isfinite(inner.value) and inner.n == 1


# ---- the report (the smoke profile, tests/conftest.py) ----------------------------------------


def _summary_table(md: str) -> list[list[str]]:
    part = md.split("## Summary", 1)[1].split("\n## ", 1)[0]
    lines = [ln for ln in part.splitlines() if ln.startswith("| ")][1:]
    return [[c.strip() for c in re.split(r"(?<!\\)\|", ln)[1:-1]] for ln in lines]


def test_every_row_has_a_per_node_verdict_and_the_summary_follows_it(smoke):
    out, _, _ = smoke
    res = json.loads((out / "results.json").read_text())
    md = (out / "report.md").read_text()
    assert md.index("## Summary") < md.index("## Runs") < md.index("## The paper's numbers")
    rows = res["rows"]
    assert {r["key"] for r in rows} == set(paper.PAPER_VALUES)
    for r in rows:  # every row measured under both readings
        assert r["per_node"]["verdict"] and r["per_node"]["replicas"]
    table = _summary_table(md)
    assert len(table) == len(rows)
    for r, line in zip(rows, table, strict=True):
        for reading, cell in ((r, line[1]), (r["per_node"], line[2])):
            assert cell.startswith(_state(reading))  # the summary's verdict is the row's
        both_agree = _state(r) == _state(r["per_node"]) == "agrees"
        assert (line[3] == "—") == both_agree  # a reason exactly where one reading differs
    g = tally(rows)
    assert (
        f"Of the paper's {len(rows)} numbers, {len(g['both'])} " in md
        and f"{len(g['per-length'])} only per length" in md
        and f"{len(g['per-node'])} only per node" in md
        and f"and {len(g['neither'])} under neither" in md
    )


def _r(pl: str, pn: str | None) -> dict:
    row = {"key": "x", "quantity": "x", "verdict": pl, "ours": 1.0, "sigma": 0.1}
    return row if pn is None else {**row, "per_node": {**row, "verdict": pn}}


def test_the_tally_puts_every_row_in_exactly_one_group():
    """Every combination of the two readings' states, "not measured" and "not run" included:
    the four groups partition the rows (B3 of issue 14's review)."""
    states = ["agrees (within 2σ)", "differs", "not measured", "cannot be fitted (hollow ring)"]
    rows = [_r(a, b) for a in states for b in [*states, None]]
    g = tally(rows)
    assert sum(len(v) for v in g.values()) == len(rows)
    ids = [id(r) for v in g.values() for r in v]
    assert len(set(ids)) == len(rows)
    assert len(g["both"]) == 1 and len(g["per-length"]) == 4 and len(g["per-node"]) == 3
    assert len(g["neither"]) == len(rows) - 8


def test_the_html_report_opens_with_the_summary(smoke):
    out, _, _ = smoke
    html = (out / "report.html").read_text()
    assert html.index("<h2>Summary</h2>") < html.index("<h2>Runs</h2>")


def test_per_node_figures_are_drawn(smoke):
    out, _, _ = smoke
    for stem in ("fig3_mass_size", "fig4_gamma", "fig5_radius", "fig6_plasticity"):
        assert (out / "figures" / f"{stem}_per_node.png").stat().st_size > 1000


def test_claims_are_judged_under_both_readings(smoke):
    out, _, _ = smoke
    res = json.loads((out / "results.json").read_text())
    twins = [c for c in res["claims"] if "per_node" in c]
    assert len(twins) >= 6  # α independence, the two plasticity trends, Fig. 2's three
    for c in twins:
        assert c["per_node"]["verdict"]


def test_a_reproduction_without_the_per_node_runs_says_how_to_add_them(smoke, tmp_path):
    """A store made before the per-node twins existed: a clear error, not a traceback."""
    import shutil

    from crumple.reproduce import analyse

    out, _, _ = smoke
    old = tmp_path / "old"
    shutil.copytree(out / "data", old / "data", ignore=shutil.ignore_patterns("*_per_node"))
    prof = json.loads((out / "profile.json").read_text())
    for k in ("per_node_points", "per_node_plastic"):  # fields added with a default
        prof["profile"].pop(k)
    (old / "profile.json").write_text(json.dumps(prof))
    with pytest.raises(ValueError, match=r"holds no 'elastic_per_node' runs.*crumple reproduce"):
        analyse(old)


def test_a_straight_or_folded_flat_wire_is_a_rod_and_a_ring_is_not():
    line = np.c_[np.linspace(-0.5, 0.5, 101), np.zeros(101)]
    hairpin = np.r_[line[:51], line[50:][::-1][1:] + np.array([0.0, 0.01])]  # folded back
    assert _is_rod(line) and _is_rod(hairpin)
    assert not _is_rod(_ring())


def test_the_saturation_slope_is_fitted_per_point_not_on_a_mean_over_changing_points():
    """Two points with D_M = c + 0.1 log10 λ, c = 1.5 and 3: the second cannot be fitted at
    the first half of the stages. A stage-by-stage mean over the points that can be fitted
    jumps from 1.5 to 2.25 (a slope near 1); per point, then pooled, the slope is 0.1."""
    lam_n = 8
    s = _series([(1, 1e4), (5, 5e5)], positions=_ring(), n_lam=lam_n)
    s.lam[:] = np.geomspace(150.0, 2000.0, lam_n)
    x = np.log10(s.lam)
    dm = np.stack([1.5 + 0.1 * x, 3.0 + 0.1 * x])[:, None, :]
    dm[1, 0, : lam_n // 2] = np.nan
    est, info = _dm_slope(s, [0, 1], dm)
    assert est.value == pytest.approx(0.1, abs=1e-9)
    assert info["points_fitted"] == 2 and info["rod_wires"] == 0
    naive = np.polyfit(x, np.nanmean(dm[:, 0, :], axis=0), 1)[0]
    assert naive > 0.5  # the artefact the per-point fit removes


def test_a_rod_at_lambda_1000_is_left_out_of_the_saturation_slope():
    line = np.c_[np.linspace(-0.5, 0.5, 101), np.zeros(101)]
    s = _series([(1, 1e4)], positions=line, n_lam=5)
    s.lam[:] = np.geomspace(150.0, 2000.0, 5)
    dm = np.ones((1, 1, 5))
    est, info = _dm_slope(s, [0], dm)
    assert info == {**info, "points_fitted": 0, "rod_wires": 1}
    assert math.isnan(est.value)


def test_the_reason_says_fit_range_only_when_an_alternative_range_agrees():
    from crumple.reproduce.common import _alt_reason

    def alt(variant, value):
        return {"variant": variant, "value": value, "sigma": 0.1}

    far = [alt("fit on [0.1, 0.5]", 2.0), alt("R_G = RMS radius", 1.8)]
    assert _alt_reason(far, 1.33).startswith("no range tried reproduces it (best: R_G = RMS")
    assert _alt_reason([*far, alt("fit on [0.2, 1]", 1.4)], 1.33).startswith(
        "fit range: fit on [0.2, 1] gives"
    )
    assert _alt_reason([alt("R_G = RMS radius", 1.3)], 1.33).startswith("choice: R_G")
    assert _alt_reason([], 1.33) == "no range tried can be fitted"


def test_the_collapse_sentence_follows_the_scatter():
    from crumple.reproduce.fig5_radius import _collapse_says

    flat = {"scatter_uncollapsed": 0.30, "scatter": 0.25, "exponent": 0.04}
    assert "no power of k_b k_s collapses" in _collapse_says(flat)
    drop = {"scatter_uncollapsed": 0.30, "scatter": 0.10, "exponent": 0.04}
    assert "does collapse them" in _collapse_says(drop)
    assert "no power" not in _collapse_says(drop)


def test_the_fit_range_column_shows_the_per_node_range_where_it_differs():
    from crumple.reproduce.document import _fit_range_cell

    row = {"fit_range": [0.5, 1.0], "per_node": {"fit_range": [0.5, 1.0]}}
    assert _fit_range_cell(row) == "[0.5, 1]"
    row["per_node"]["fit_range"] = [0.56, 1.0]
    assert _fit_range_cell(row) == "[0.5, 1] (per node [0.56, 1])"
    row["per_node"]["fit_range"] = None
    assert _fit_range_cell(row) == "[0.5, 1]"
