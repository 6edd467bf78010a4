"""``crumple study cavity``: its profiles build, and the smoke report is complete (a row with a
verdict per compared observable and wire, the four figures, the published comparisons)."""

from __future__ import annotations

import json

import numpy as np

from crumple.cli import main
from crumple.reproduce.cavity import CAVITY, PROFILES, THICKNESS, schedule
from crumple.reproduce.cavity_compare import VALUES, _compare_row
from crumple.reproduce.common import Estimate
from crumple.reproduce.report import check_report


def test_profiles_build_the_same_wire_for_both_protocols():
    from crumple.reproduce import registry

    for prof in PROFILES.values():
        inj, ramp = (e.build(prof) for e in registry.experiments(CAVITY.sections()))
        assert inj.kind == "injection" and ramp.kind == "ramp"
        for a, b in zip(inj.runs(), ramp.runs(), strict=True):
            assert a.wire.replace(cavity_radius=None) == b.wire
            assert a.wire.hard_core == THICKNESS * prof.cavity_radius
        assert schedule(prof)[0] == 1.0 and np.isclose(schedule(prof)[-1], prof.lam_max)


def test_compare_row_verdicts():
    a, b = Estimate(1.0, 0.1, 3), Estimate(1.25, 0.1, 3)  # 2σ = 0.283
    assert _compare_row("k", "q", a, b, "", "3")["verdict"] == "same within 2σ"
    assert _compare_row("k", "q", a, Estimate(1.5, 0.1, 3), "", "3")["verdict"] == "differs"
    assert _compare_row("k", "q", Estimate(np.nan, np.nan, 0), b, "", "3")["verdict"] == (
        "not measured"
    )
    # no verdict without a σ: one replica, or integer counts equal in every replica
    one = Estimate(2.0, 0.0, 1)
    assert _compare_row("k", "q", one, Estimate(3.0, 0.0, 1), "", "1")["verdict"].startswith(
        "σ unknown (1 replica)"
    )
    same = Estimate(2.0, 0.0, 6)
    assert _compare_row("k", "q", same, Estimate(3.0, 0.0, 6), "", "6")["verdict"].startswith(
        "σ = 0 (identical replicas)"
    )
    assert _compare_row("k", "q", same, b, "", "6")["verdict"] == "differs"


def test_study_smoke_report_is_complete(tmp_path):
    out = tmp_path / "cav"
    rc = main(["study", "cavity", "--profile", "smoke", "--out", str(out), "--workers", "2",
               "--quiet"])  # fmt: skip
    assert rc == 0
    assert check_report(out, sections=CAVITY.sections()) == []
    res = json.loads((out / "results.json").read_text())
    assert {r["key"] for r in res["rows"]} == {v.key for v in VALUES}
    for r in res["rows"]:
        assert r["verdict"] != "not measured", r
    assert len(res["claims"]) == 6
    md = (out / "report.md").read_text()
    assert "SMOKE PROFILE" in md and "Donato & Gomes" in md and "PRL 101, 094101" in md
