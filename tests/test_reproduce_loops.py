"""The report's loops section (crumple.reproduce.fig2_loops) on the smoke profile: n(λ) of the
Fig. 2 wire as the sweep stored it, and when loops first touch loops under both definitions."""

from __future__ import annotations

import json

import numpy as np

from crumple import paper
from crumple.reproduce import FIGURES
from crumple.reproduce.fig2_loops import FIGURES as LOOP_FIGURES
from crumple.sweep import load


def _fig2(ds):
    keys = [tuple(float(v) for v in t) for t in ds.indexes["point"]]
    return ds.isel(point=keys.index(paper.FIG2))


def test_the_section_is_in_the_report(smoke):
    out, _, _ = smoke
    assert set(LOOP_FIGURES) <= set(FIGURES)
    for stem in LOOP_FIGURES:
        assert (out / "figures" / f"{stem}.png").stat().st_size > 1000
    md = (out / "report.md").read_text()
    assert "loops start to touch loops" in md


def test_n_of_lambda_is_what_the_sweep_stored(smoke):
    out, _, _ = smoke
    res = json.loads((out / "results.json").read_text())
    got = res["extra"]["loops_fig2"]
    one = _fig2(load(out / "data" / "elastic"))
    np.testing.assert_array_equal(np.array(got["n_loops"], float), one["n_loops"].values)
    assert got["n_loops_at_1000"] == one["n_loops"].sel(lam=1000.0).values.tolist()
    # the loop definition's onset: the first stage with a contact between two loops
    lc = one["loop_contacts"].values[0]
    lam = one["lam"].values
    hit = np.flatnonzero(lc > 0)
    if hit.size:
        assert got["loop_contact_onset"][0] == [float(lam[hit[0] - 1]), float(lam[hit[0]])]
    else:
        assert got["loop_contact_bracket"] is None
    claim = next(c for c in res["claims"] if c["claim"].startswith("loops start to touch"))
    assert "loop definition" in claim["measured"] and "current definition" in claim["measured"]
    assert claim["verdict"] in ("consistent", "not consistent")


def test_a_stage_without_loops_draws_undefined_and_keeps_the_report(monkeypatch):
    """One bad stage at λ = 1000 (loops refuse its graph) must not abort the report."""
    from types import SimpleNamespace

    from crumple import stage_observables as so
    from crumple.figures import plot_loop_count
    from crumple.reproduce.fig2_loops import _picture

    def refuse(*a, **k):
        raise RuntimeError("the contact graph is not plane")

    monkeypatch.setattr(so, "loops", refuse)
    t = np.linspace(0, 2 * np.pi, 40)
    x = np.c_[np.cos(t), np.sin(t)] * 0.3
    lam = np.array([70.0, 1000.0])
    el = SimpleNamespace(
        lam=lam, hard_core=1e-5, positions=np.stack([x, x])[None, None],
        j=lambda v: int(np.argmin(abs(lam - v))), valid=lambda p, r, j: True,
    )  # fmt: skip
    pic = _picture(el, 0)
    assert pic["undefined"] and pic["lam"] == 1000.0
    fig = plot_loop_count(lam, [[1, np.nan]], picture=pic)
    assert "loops undefined" in fig.axes[1].get_title()
