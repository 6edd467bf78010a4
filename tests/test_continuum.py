"""The continuum limit (issue 12): the confinement number Λ, the collapse, the N-convergence
rule, and ``crumple study continuum`` (smoke profile) end to end.

The collapse test's tolerance comes from the discretisation error measured in the same test
(N against 2N at the same Λ), not from a number picked to pass: two wires with the same Λ but
different (k_b, λ, N) must agree within twice that error (docs/continuum.md).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from crumple import continuum as C
from crumple.cli import main
from crumple.model import Wire
from crumple.observables import r_max, radius_of_gyration
from crumple.protocol import Ramp, run_ramp
from crumple.reproduce import check_report
from crumple.reproduce.continuum import CONTINUUM, PROFILES
from crumple.reproduce.continuum_convergence import convergence_rule

# ---- the formulas ----------------------------------------------------------------------------


def test_confinement_number_round_trips_and_matches_the_wire():
    for kb, n, lam in ((5.0, 100, 1000.0), (0.3, 37, 2.5), (12.0, 1000, 1e6)):
        big = C.confinement_number(k_b=kb, lam=lam, n_segments=n)
        assert big == pytest.approx(lam * n / kb)
        assert C.lam_for(big, k_b=kb, n_segments=n) == pytest.approx(lam)
        w = Wire(k_b=kb, k_s=1e6, n_segments=n)
        assert C.bending_stiffness(kb, n) == pytest.approx(w.bending_stiffness)


def test_loop_length_and_segments_per_loop():
    assert C.loop_length(1e8) == pytest.approx(0.01)
    assert 1.0 / C.loop_length(1e4) ** 4 == pytest.approx(1e4)  # L/ℓ = Λ^1/4
    assert C.segments_per_loop(1e8, 1000) == pytest.approx(10.0)


def test_stiff_k_s_meets_the_strain_bound_over_the_whole_ramp():
    ks = C.stiff_k_s(1e6, k_b=2.0, strain=1e-3)
    for big in (1e2, 1e4, 1e6):
        assert C.strain_estimate(big, k_b=2.0, k_s=ks) <= 1e-3 * (1 + 1e-12)
    assert C.strain_estimate(1e6, k_b=2.0, k_s=ks) == pytest.approx(1e-3)


def test_wire_point_maps_lambda_to_the_same_confinement_numbers():
    grid = [1e2, 1e3, 1e4]
    for kb, n in ((1.0, 25), (3.0, 50)):
        p = C.wire_point(grid, n_segments=n, k_b=kb)
        got = [C.confinement_number(k_b=kb, lam=lam, n_segments=n) for lam in p["lambdas"]]
        assert got == pytest.approx(grid, rel=1e-11)
        assert p["k_s"] == pytest.approx(C.stiff_k_s(1e4, k_b=kb))


@pytest.mark.parametrize("bad", [0, -1, math.inf, "x"])
def test_formulas_reject_nonsense(bad):
    with pytest.raises(ValueError, match="positive"):
        C.loop_length(bad)


# ---- the collapse at equal Λ -------------------------------------------------------------------

GRID = (1e2, 1e3, 1e4)


def _continuum_observables(kb: float, n: int) -> dict[str, np.ndarray]:
    p = C.wire_point(GRID, n_segments=n, k_b=kb)
    w = Wire(k_b=p["k_b"], k_s=p["k_s"], n_segments=n)
    res = run_ramp(w, Ramp(lambdas=p["lambdas"]), seed=3)
    assert res.converged
    b = w.bending_stiffness
    return {
        "R_g/L": np.array([radius_of_gyration(s.positions) for s in res.stages]),
        "r_max/L": np.array([r_max(s.positions) for s in res.stages]),
        "E_b L/B": np.array([s.energy.bending / b for s in res.stages])[1:],  # stage 0 straight
    }


@pytest.fixture(scope="module")
def ramps():
    """Three ramps through Λ = 1e2, 1e3, 1e4: (k_b, N) = (1, 25), (1, 50), (3, 50) (λ and
    k_s follow from Λ: λ = Λ k_b/N, k_s stiff). About 2 s."""
    return {key: _continuum_observables(*key) for key in ((1.0, 25), (1.0, 50), (3.0, 50))}


def _rel(a, b):
    return np.max(np.abs(a - b) / np.abs(b))


def test_same_confinement_number_gives_the_same_continuum_observables(ramps):
    """(k_b, λ, N) = (1, Λ/25, 25) and (3, 3Λ/50, 50): same R_g/L, r_max/L, E_b L/B within
    twice the discretisation error, measured as (1, 25) against (1, 50)."""
    for q in ("R_g/L", "r_max/L", "E_b L/B"):
        disc = _rel(ramps[1.0, 25][q], ramps[1.0, 50][q])
        # at ℓ/Δs ≥ 2.5 segments per loop the discretisation error is small (measured:
        # docs/continuum.md); a larger one means the test no longer resolves ℓ
        assert disc < 0.05, (q, disc)
        assert _rel(ramps[1.0, 25][q], ramps[3.0, 50][q]) <= 2 * disc + 1e-6, q
        # at equal N, (k_b, λ, k_s) -> (a k_b, a λ, a k_s) rescales the energy: exact up to
        # the hard core (whose energy scale is fixed) and the force tolerance
        assert _rel(ramps[1.0, 50][q], ramps[3.0, 50][q]) < 1e-4, q


# ---- the N-convergence rule ---------------------------------------------------------------------


def test_convergence_rule_on_a_small_case(ramps):
    """R_g at N = 25 against N = 50: the error grows as ℓ/Δs = NΛ^-1/4 falls, and the rule
    (least ℓ/Δs for 1%) is the resolution at which it is met."""
    err = np.abs(ramps[1.0, 25]["R_g/L"] - ramps[1.0, 50]["R_g/L"]) / ramps[1.0, 50]["R_g/L"]
    spl = np.array([C.segments_per_loop(g, 25) for g in GRID])
    rule = convergence_rule(spl, err, 0.01)
    assert math.isfinite(rule)
    assert all(e < 0.01 for s, e in zip(spl, err, strict=True) if s >= rule)
    assert err[-1] > err[0]  # Λ = 1e4 (2.5 segments per ℓ) is the least resolved


def test_convergence_rule_edge_cases():
    assert convergence_rule([5.0, 10.0], [0.001, 0.0001], 0.01) == 5.0
    assert math.isnan(convergence_rule([5.0, 10.0], [0.1, 0.2], 0.01))
    assert math.isnan(convergence_rule([], [], 0.01))


# ---- the study: profiles and the smoke report ----------------------------------------------------


def test_profiles_build_and_full_is_declared_at_issue_sizes():
    from crumple.reproduce import registry

    for prof in PROFILES.values():
        for e in registry.experiments(CONTINUUM.sections()):
            assert len(e.build(prof)) > 0
    full = PROFILES["full"]
    assert max(full.sweep_confinements) >= 1e10
    assert full.sweep_n >= 1e4
    assert max(n for _, n in full.collapse_points) >= 1e4


def test_study_smoke_report_is_complete(tmp_path):
    out = tmp_path / "cont"
    rc = main(["study", "continuum", "--profile", "smoke", "--out", str(out), "--workers", "2",
               "--quiet"])  # fmt: skip
    assert rc == 0
    secs = CONTINUUM.sections()
    assert check_report(out, sections=secs) == []
    res = json.loads((out / "results.json").read_text())
    keys = {r["key"] for r in res["rows"]}
    assert keys == {"continuum_collapse", "continuum_alpha", "continuum_D_M", "continuum_eps_l"}
    for r in res["rows"]:
        assert r["verdict"] != "not measured", r
    conv = res["extra"]["continuum_convergence"]
    assert conv["N"] == [25, 50, 100]
    md = (out / "report.md").read_text()
    assert "SMOKE PROFILE" in md and "continuum limit" in md
    assert "N-convergence rule" in md
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64") == 6
    # a store of one profile is not reused for another
    assert main(["study", "continuum", "--quick", "--out", str(out), "--quiet"]) == 2
